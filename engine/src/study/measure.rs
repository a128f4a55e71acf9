//! What a study measures on each of its runs: a sample field at the end, its mean over a
//! window (the steady state), its peak or its least value, or its value where another field
//! first reaches a level (the packing fraction at a wall stress); a field of the experiment's
//! results; or a derived quantity (the restitution of a collision).

use serde::{Deserialize, Serialize};

use crate::observe::Sample;

/// How a sample field is reduced to one number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reduce {
    /// The last sample's value.
    End,
    /// The mean over the window.
    Mean,
    /// The largest value in the window.
    Peak,
    /// The smallest value in the window.
    Min,
}

/// Derived quantities a study can measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Derived {
    /// Restitution of a collision, `sqrt(E_k(end) / E_k(start))`: the ratio of the relative
    /// speeds after and before a collision of bodies whose total momentum is zero (a binary
    /// collision in the centre-of-mass frame), taken once the bodies have parted
    /// (docs/physics.md §2.2).
    Restitution,
}

/// Which upward crossing of a level [`When`] reads at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Crossing {
    /// The first time the field reaches the level.
    #[default]
    First,
    /// The last time it rises through the level: past a transient peak (a column of grains
    /// that carries the wall, then buckles), the branch the run ends on.
    Last,
}

/// Where a sample field is read: where another sample field reaches a level from below.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct When {
    /// The other field, by path (`walls.y_max.normal_stress`).
    pub sample: String,
    /// The level, in that field's units.
    pub reaches: f64,
    /// The first (default) or the last upward crossing.
    #[serde(default)]
    pub crossing: Crossing,
}

/// The measured quantity, as a study file writes it: exactly one of `sample`, `result`,
/// `derived`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasureSpec {
    /// A sample field, by path (`zeta`, `mu`, `p`, `stress.xy`, `solver.iterations`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample: Option<String>,
    /// How the sample field is reduced. Default `end`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at: Option<Reduce>,
    /// Only the samples of this stage of the experiment (`preparation`, `loading`, `shear`, ...).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage: Option<String>,
    /// The window starts at this fraction of the (stage's) samples, in [0, 1). Default 0.5 for
    /// `mean` (the second half: the steady state), 0 for `peak` and `min`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<f64>,
    /// Instead of `at`: the sample field where another one first reaches a level, interpolated
    /// linearly between the two samples around the crossing (`phi` where
    /// `walls.y_max.normal_stress` reaches 1e5 Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub when: Option<When>,
    /// A field of the experiment's results, by path (`peak.zeta`, `steady.zeta`, `shear.mu`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub result: Option<String>,
    /// A derived quantity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub derived: Option<Derived>,
}

impl MeasureSpec {
    /// The rules the measure breaks, as (field below `measure`, rule).
    pub fn check(&self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        let given = [self.sample.is_some(), self.result.is_some(), self.derived.is_some()].iter().filter(|x| **x).count();
        if given != 1 {
            out.push((String::new(), "give exactly one of sample, result, derived".into()));
        }
        if self.sample.is_none() && (self.at.is_some() || self.stage.is_some() || self.from.is_some() || self.when.is_some()) {
            out.push(("at".into(), "at, when, stage and from apply to a sample field only".into()));
        }
        if let Some(w) = &self.when {
            if self.at.is_some() || self.from.is_some() {
                out.push(("when".into(), "give either when or at/from, not both".into()));
            }
            if !w.reaches.is_finite() {
                out.push(("when.reaches".into(), format!("must be a finite number, got {}", w.reaches)));
            }
            if w.sample.is_empty() {
                out.push(("when.sample".into(), "must name a sample field".into()));
            }
        }
        if let Some(f) = self.from {
            if !(f.is_finite() && (0.0..1.0).contains(&f)) {
                out.push(("from".into(), format!("must be in [0, 1), got {f}")));
            }
        }
        out
    }

    /// A short description for charts and reports (`mu (mean from 0.5, stage shear)`).
    pub fn describe(&self) -> String {
        if let (Some(f), Some(w)) = (&self.sample, &self.when) {
            let last = if w.crossing == Crossing::Last { " last" } else { "" };
            let mut s = format!("{f} where {}{last} reaches {}", w.sample, w.reaches);
            if let Some(st) = &self.stage {
                s.push_str(&format!(" ({st})"));
            }
            s
        } else if let Some(f) = &self.sample {
            let at = self.at.unwrap_or(Reduce::End);
            let mut s = match at {
                Reduce::End => format!("{f} at the end"),
                Reduce::Mean => format!("mean {f} from {:.0}% of the run", 100.0 * self.window_start(at)),
                Reduce::Peak => format!("peak {f}"),
                Reduce::Min => format!("least {f}"),
            };
            if let Some(st) = &self.stage {
                s.push_str(&format!(" ({st})"));
            }
            s
        } else if let Some(r) = &self.result {
            format!("result {r}")
        } else {
            match self.derived {
                Some(Derived::Restitution) => "restitution".into(),
                None => "nothing".into(),
            }
        }
    }

    fn window_start(&self, at: Reduce) -> f64 {
        self.from.unwrap_or(if at == Reduce::Mean { 0.5 } else { 0.0 })
    }

    /// The measured value of a run from its samples (in order) and its experiment's results
    /// (JSON); the error says what was missing.
    pub fn evaluate(&self, samples: &[Sample], result: Option<&serde_json::Value>) -> Result<f64, String> {
        if let Some(path) = &self.result {
            let r = result.ok_or("the run has no experiment results")?;
            return super::paths::get(r, path).and_then(|v| v.as_f64()).ok_or_else(|| format!("the results have no number at '{path}'"));
        }
        if let Some(Derived::Restitution) = self.derived {
            let (Some(first), Some(last)) = (samples.first(), samples.last()) else { return Err("the run has no samples".into()) };
            if first.kinetic_energy <= 0.0 {
                return Err("the first sample has no kinetic energy: nothing collides".into());
            }
            return Ok((last.kinetic_energy / first.kinetic_energy).sqrt());
        }
        let Some(field) = &self.sample else { return Err("nothing to measure".into()) };
        let chosen: Vec<&Sample> = samples.iter().filter(|s| self.stage.as_ref().is_none_or(|st| s.stage.as_ref() == Some(st))).collect();
        if chosen.is_empty() {
            return Err(match &self.stage {
                Some(st) => format!("no sample of stage '{st}'"),
                None => "the run has no samples".into(),
            });
        }
        let doc = |s: &Sample| serde_json::to_value(s).map_err(|e| e.to_string());
        let number = |doc: &serde_json::Value, path: &str| -> Result<f64, String> {
            super::paths::get(doc, path).and_then(|v| v.as_f64()).ok_or_else(|| format!("the samples have no number at '{path}'"))
        };
        if let Some(w) = &self.when {
            // Each upward crossing: a sample at or above the level after one below it (or the
            // first sample, already there), interpolated between the two.
            let mut found = None;
            let mut before: Option<(f64, f64)> = None;
            let mut most = f64::NEG_INFINITY;
            for s in &chosen {
                let d = doc(s)?;
                let (x, y) = (number(&d, &w.sample)?, number(&d, field)?);
                most = most.max(x);
                let below = before.is_none_or(|(x0, _)| x0 < w.reaches);
                if x >= w.reaches && below {
                    found = Some(match before {
                        Some((x0, y0)) => y0 + (y - y0) * (w.reaches - x0) / (x - x0),
                        None => y,
                    });
                    if w.crossing == Crossing::First {
                        break;
                    }
                }
                before = Some((x, y));
            }
            return found.ok_or_else(|| format!("'{}' never reaches {} (at most {most})", w.sample, w.reaches));
        }
        let at = self.at.unwrap_or(Reduce::End);
        let start = if at == Reduce::End {
            chosen.len() - 1
        } else {
            ((self.window_start(at) * chosen.len() as f64) as usize).min(chosen.len() - 1)
        };
        let mut values = Vec::with_capacity(chosen.len() - start);
        for s in &chosen[start..] {
            values.push(number(&doc(s)?, field)?);
        }
        let n = values.len() as f64;
        Ok(match at {
            Reduce::End => values[values.len() - 1],
            Reduce::Mean => values.iter().sum::<f64>() / n,
            Reduce::Peak => values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            Reduce::Min => values.iter().copied().fold(f64::INFINITY, f64::min),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::Stress;

    fn sample(step: u64, zeta: f64, ke: f64, stage: &str) -> Sample {
        Sample {
            step,
            time: step as f64,
            phi: 0.8,
            z: 4.0,
            z_no_rattlers: 4.0,
            zeta,
            p: 1.0,
            q: zeta,
            stress: Stress { xy: 2.0 * zeta, ..Default::default() },
            kinetic_energy: ke,
            stage: Some(stage.into()),
            ..Default::default()
        }
    }

    #[test]
    fn a_measure_reduces_the_samples_it_names() {
        let s: Vec<Sample> =
            (0..10).map(|k| sample(k, k as f64, 4.0 / (1.0 + k as f64), if k < 4 { "preparation" } else { "shear" })).collect();
        let m = |json: serde_json::Value| serde_json::from_value::<MeasureSpec>(json).expect("spec");
        let eval = |json: serde_json::Value| m(json).evaluate(&s, None);
        assert_eq!(eval(serde_json::json!({"sample": "zeta"})), Ok(9.0));
        // Stage shear is samples 4..10; the mean of its second half is that of 7, 8, 9.
        assert_eq!(eval(serde_json::json!({"sample": "zeta", "at": "mean", "stage": "shear"})), Ok(8.0));
        assert_eq!(eval(serde_json::json!({"sample": "stress.xy", "at": "peak", "stage": "preparation"})), Ok(6.0));
        assert_eq!(eval(serde_json::json!({"sample": "zeta", "at": "min", "from": 0.5})), Ok(5.0));
        assert_eq!(eval(serde_json::json!({"derived": "restitution"})), Ok((0.4f64 / 4.0).sqrt()));
        let r = serde_json::json!({"peak": {"zeta": 0.43}});
        assert_eq!(m(serde_json::json!({"result": "peak.zeta"})).evaluate(&s, Some(&r)), Ok(0.43));
        assert!(eval(serde_json::json!({"sample": "nothing"})).is_err());
        // μ = τ/σ_n is defined under shear only: these samples have none.
        assert!(eval(serde_json::json!({"sample": "mu"})).is_err());
        assert!(eval(serde_json::json!({"sample": "zeta", "stage": "loading"})).is_err_and(|e| e.contains("no sample of stage 'loading'")));
        assert!(m(serde_json::json!({"result": "peak.zeta"})).evaluate(&s, None).is_err());
        assert_eq!(m(serde_json::json!({"sample": "zeta", "derived": "restitution"})).check().len(), 1);
        assert_eq!(m(serde_json::json!({"result": "x", "at": "mean"})).check()[0].0, "at");
        // zeta = k, stress.xy = 2k: zeta is 3.5 where stress.xy first reaches 7 (between samples 3
        // and 4), and the first sample's where the level is already reached.
        assert_eq!(eval(serde_json::json!({"sample": "zeta", "when": {"sample": "stress.xy", "reaches": 7.0}})), Ok(3.5));
        assert_eq!(eval(serde_json::json!({"sample": "zeta", "when": {"sample": "stress.xy", "reaches": -1.0}})), Ok(0.0));
        assert!(eval(serde_json::json!({"sample": "zeta", "when": {"sample": "stress.xy", "reaches": 40.0}}))
            .is_err_and(|e| e.contains("never reaches 40 (at most 18)")));
        assert_eq!(m(serde_json::json!({"sample": "zeta", "at": "end", "when": {"sample": "p", "reaches": 1.0}})).check()[0].0, "when");
        // A level crossed upwards twice: stress.xy = 2k except a drop to 1 at sample 5.
        let mut t = s.clone();
        t[5].stress.xy = 1.0;
        let at = |which: &str| {
            m(serde_json::json!({"sample": "zeta", "when": {"sample": "stress.xy", "reaches": 7.0, "crossing": which}})).evaluate(&t, None)
        };
        assert_eq!(at("first"), Ok(3.5));
        // From sample 5 (xy 1) to 6 (xy 12): 7 is 6/11 of the way, zeta 5 + 6/11.
        assert_eq!(at("last"), Ok(5.0 + 6.0 / 11.0));
    }
}
