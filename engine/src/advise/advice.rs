//! The advice on a scene ([`Advice`]): the method chosen and why, the regime, the scene's
//! dimensionless numbers ([`Numbers`]), and the costs learnt from stored studies.

use serde::{Deserialize, Serialize};

use super::LEARNED_ACCURACY;
use crate::math::Real;

/// A scene's scales and dimensionless numbers, as estimated before running.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Numbers {
    /// Number-mean diameter, m.
    pub mean_diameter: Real,
    /// Density of the grains, kg/m³.
    pub density: Real,
    /// Confining stress of the loading, Pa (none when nothing confines the grains).
    pub pressure: Option<Real>,
    /// Where the stress comes from.
    pub pressure_source: Option<String>,
    /// Strain rate of the loading, 1/s (none when nothing is imposed).
    pub strain_rate: Option<Real>,
    /// Where the rate comes from.
    pub strain_rate_source: Option<String>,
    /// Solid fraction of the grains in the box at the start.
    pub initial_solid_fraction: Real,
    /// Inertial number `I = ε̇ d sqrt(ρ/p)`.
    pub inertial_number: Option<Real>,
    /// Stiffness number κ (Roux & Chevoir 2005, §2.3.4).
    pub stiffness_number: Option<Real>,
    /// Contact deflection over the diameter, `1/κ` (for Hertz contacts `((1 − ν²) p/E)^(2/3)`).
    pub deflection: Option<Real>,
    /// Cohesion index `ξ = f_c/(p d^(D-1))`.
    pub cohesion_index: Option<Real>,
    /// Stokes number `ρ d² ε̇ / η`.
    pub stokes_number: Option<Real>,
}

/// What the scene's loading is, for the choice.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Regime {
    /// Grains in free flight and binary collisions (a gas, a fall, a drum's surface flow).
    Collisional,
    /// A dense flow with `I` above the quasi-static bound.
    DenseFlow,
    /// A slow loading of a packing.
    QuasiStatic,
    /// An imposed motion squeezes or shears a closed box with no stress-controlled boundary.
    KinematicSqueeze,
    /// Nothing loads the grains.
    Unloaded,
}

impl Regime {
    /// The name used in the advice.
    pub fn name(self) -> &'static str {
        match self {
            Self::Collisional => "collisional",
            Self::DenseFlow => "dense_flow",
            Self::QuasiStatic => "quasi_static",
            Self::KinematicSqueeze => "kinematic_squeeze",
            Self::Unloaded => "unloaded",
        }
    }
}

/// The advisor's answer for a scene.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Advice {
    /// The method chosen (`dem`, `cd`, `mpm` or `fem`).
    pub method: String,
    /// The method the scene asked for (`auto`, or a name).
    pub requested: String,
    /// The regime the loading puts the grains in.
    pub regime: Regime,
    /// The scene's numbers.
    pub numbers: Numbers,
    /// Why this method, one sentence each, in order of weight.
    pub reasons: Vec<String>,
    /// What the scene does not need and the engine leaves out.
    pub dropped: Vec<String>,
    /// A method the scene needs that this version does not have.
    pub needs: Option<String>,
    /// Changes to the scene that would model it more cheaply, which the advisor cannot make.
    pub suggestions: Vec<String>,
    /// What runs of this scene cost in the studies stored by the service (filled by the
    /// service; empty when none studied it): every run that succeeded, those on their study's
    /// Pareto front marked.
    #[serde(default)]
    pub expected_cost: Vec<ExpectedCost>,
}

/// The cost and error of one stored run of the same scene (a study's run that succeeded).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ExpectedCost {
    /// The study.
    pub study_id: i64,
    /// The run's job (its scene holds the method and parameters).
    #[serde(default)]
    pub job_id: i64,
    /// Its series and the run's swept values.
    pub series: String,
    /// The swept values.
    pub label: String,
    /// The method the run used.
    pub method: String,
    /// CPU seconds of the run.
    pub cpu_seconds: f64,
    /// Wall-clock seconds of the run.
    pub wall_seconds: f64,
    /// Its relative error against the study's reference (absolute when the reference is 0).
    pub error: Option<f64>,
    /// On its study's Pareto front of cost against error: no run of the study is both cheaper
    /// and closer.
    #[serde(default)]
    pub pareto: bool,
}

impl Advice {
    /// The cheapest of [`Advice::expected_cost`]'s runs whose error is within `accuracy`
    /// (relative to its study's reference), if one is.
    pub fn cheapest_within(&self, accuracy: Real) -> Option<&ExpectedCost> {
        self.expected_cost
            .iter()
            .filter(|c| c.error.is_some_and(|e| e <= accuracy) && !c.method.is_empty())
            .min_by(|a, b| a.cpu_seconds.total_cmp(&b.cpu_seconds))
    }

    /// Learns from the stored studies of the scene ([`Advice::expected_cost`]): takes the
    /// method of the cheapest run within [`LEARNED_ACCURACY`], with the reason first, and
    /// returns that run (its job's scene holds the parameters to run with). Nothing changes
    /// when no run is that accurate.
    pub fn learn(&mut self) -> Option<ExpectedCost> {
        let run = self.cheapest_within(LEARNED_ACCURACY)?.clone();
        let others: Vec<String> = {
            let mut methods: Vec<&str> = self.expected_cost.iter().map(|c| c.method.as_str()).filter(|m| *m != run.method).collect();
            methods.sort_unstable();
            methods.dedup();
            methods
                .iter()
                .map(|m| {
                    let best = self
                        .expected_cost
                        .iter()
                        .filter(|c| c.method == *m && c.error.is_some_and(|e| e <= LEARNED_ACCURACY))
                        .map(|c| c.cpu_seconds)
                        .fold(Real::INFINITY, Real::min);
                    if best.is_finite() {
                        format!("{m} needed {best:.1} s")
                    } else {
                        format!("no {m} run was that close")
                    }
                })
                .collect()
        };
        let mut why = format!(
            "study {} measured {} ({} {}) within {:.2}% of its reference in {:.1} s of CPU: the cheapest run within {}%",
            run.study_id,
            run.method,
            run.series,
            run.label,
            100.0 * run.error.unwrap_or(0.0),
            run.cpu_seconds,
            100.0 * LEARNED_ACCURACY
        );
        if !others.is_empty() {
            why.push_str(&format!(" ({})", others.join(", ")));
        }
        self.reasons.insert(0, why);
        self.method = run.method.clone();
        Some(run)
    }

    /// One line for a job's `method_reason`: the choice, each reason, what was dropped.
    pub fn summary(&self) -> String {
        let mut s = format!("auto chose {}: {}", self.method, self.reasons.join("; "));
        if let Some(n) = &self.needs {
            s.push_str(&format!("; needs {n}"));
        }
        if !self.dropped.is_empty() {
            s.push_str(&format!("; left out: {}", self.dropped.join("; ")));
        }
        s
    }
}
