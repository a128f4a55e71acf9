//! Computation of a [`Sample`] from a method-independent view of the system.

use super::contacts::{coordination, ContactRecord};
use super::drum::{measure_drum, DrumView};
use super::grains::{GrainSample, PrimarySample};
use super::sample::{DeformableSample, Sample, Stress, WallSample};
use crate::math::{Mat3, Real, Vec3};
use crate::particles::Particles;

/// A wall at sampling time.
#[derive(Debug, Clone, PartialEq)]
pub struct WallView {
    /// `x_min`, ...
    pub name: String,
    /// Coordinate along its axis, m.
    pub position: Real,
    /// Unit normal pointing into the box.
    pub normal: Vec3,
    /// Force exerted by the particles on the wall, N.
    pub force: Vec3,
    /// Area (length in 2D, per metre of thickness), m².
    pub area: Real,
}

/// A shear flow: rate and axes (flow along `flow`, gradient along `gradient`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShearGeometry {
    /// Shear rate, 1/s.
    pub rate: Real,
    /// Flow axis.
    pub flow: usize,
    /// Gradient axis.
    pub gradient: usize,
    /// Subtract the imposed streaming profile `rate (x_gradient - origin)` before computing
    /// fluctuations (Lees-Edwards); false when walls drive the flow.
    pub streaming: bool,
}

/// What a method shows of itself at sampling time.
#[derive(Debug, Clone, Copy)]
pub struct SystemView<'a> {
    /// 2 or 3.
    pub dim: usize,
    /// Step number.
    pub step: u64,
    /// Simulated time, s.
    pub time: Real,
    /// Particles.
    pub particles: &'a Particles,
    /// Container volume (area in 2D), m³.
    pub volume: Real,
    /// Interactions.
    pub contacts: &'a [ContactRecord],
    /// Walls.
    pub walls: &'a [WallView],
    /// Shear, where one is imposed.
    pub shear: Option<ShearGeometry>,
    /// Elastic energy stored in contacts, J.
    pub elastic_energy: Real,
    /// A particle with fewer force-bearing contacts than this is a rattler: D + 1 for
    /// frictionless grains (needed for force balance without friction), 2 with friction (one
    /// contact alone cannot balance any force). See [`super::contacts::rattler_threshold`].
    pub rattler_threshold: usize,
    /// The rotating drum, if there is one.
    pub drum: Option<DrumView>,
    /// What deformable grains add (methods `mpm` and `fem`; aggregates of the bonded particle
    /// method are rigid primaries here, their grains measured in `Sample::grains`): their
    /// kinetic energy with their internal motion, and their deformation. Their `particles`
    /// are the grains as disks of their *current* area (centroid, mean velocity), so that Φ,
    /// the coordination, the stress and p, q, μ are measured as for rigid grains.
    pub deformable: Option<DeformableView>,
    /// The box, for the periodic images of a grain of primaries that crosses a periodic
    /// boundary ([`super::grains`]).
    pub domain: &'a crate::geometry::Domain,
}

/// The part of a [`SystemView`] only deformable grains have.
#[derive(Debug, Clone, Copy)]
pub struct DeformableView {
    /// Kinetic energy of all the material, J (replaces the grains' rigid-body one).
    pub kinetic_energy: Real,
    /// Mean and largest aspect ratio of the grains (1 for a disk): the square root of the ratio
    /// of the principal second moments of each grain's area about its centroid.
    pub aspect_ratios: (Real, Real),
    /// Jacobian, dissipation and cost.
    pub sample: DeformableSample,
}

/// Computes every metric of a [`Sample`].
pub fn measure(v: &SystemView<'_>) -> Sample {
    let p = v.particles;
    let n = p.len();
    let dim = v.dim;
    let solid: Real = p.radius.iter().map(|&r| Particles::volume_of(dim, r)).sum();
    let phi = if v.volume > 0.0 { solid / v.volume } else { 0.0 };
    let (sigma, kinetic, total_mass) = love_weber_stress(v);
    let (stress, pressure, q) = stress_invariants(dim, &sigma);
    let zeta = if pressure > 0.0 { q / pressure } else { 0.0 };
    let (z, z_no_rattlers) = coordination(n, v.rattler_threshold, v.contacts);
    // Soft grains: the sample's Φ and Z are the grains'; an aggregate's primaries keep theirs.
    let (grains, primaries) = match v.deformable {
        Some(d) => (Some(super::grains::measure_whole_grains(p, dim, v.contacts, v.volume, d.aspect_ratios, z_no_rattlers)), None),
        None => match super::grains::measure_grains(p, dim, v.contacts, v.volume, v.domain) {
            Some(g) => (Some(g), Some(PrimarySample { phi, z, z_no_rattlers })),
            None => (None, None),
        },
    };
    let (phi, z, z_no_rattlers) = match (&grains, &primaries) {
        (Some(g), Some(_)) => (g.phi, g.z, g.z_no_rattlers),
        _ => (phi, z, z_no_rattlers),
    };
    let aggregates = grains.as_ref().filter(|_| primaries.is_some());
    let (mu, inertial_number) = shear_response(v, &sigma, aggregates, solid, total_mass);
    let walls = wall_samples(v);
    Sample {
        step: v.step,
        time: v.time,
        phi,
        z,
        z_no_rattlers,
        zeta,
        mu,
        p: pressure,
        q,
        stress,
        inertial_number,
        kinetic_energy: v.deformable.map_or(kinetic, |d| d.kinetic_energy),
        elastic_energy: v.elastic_energy,
        walls,
        stage: None,
        strain: None,
        drum: v.drum.as_ref().map(|d| Box::new(measure_drum(dim, p, v.contacts, d))),
        solver: None,
        deformable: v.deformable.map(|d| Box::new(d.sample)),
        grains: grains.map(Box::new),
        primaries,
        // Following a cluster carries a state from sample to sample: the rigid-grain world,
        // which has wet grains, measures it ([`crate::methods::rigid::RigidWorld::measure`]).
        cluster: None,
    }
}

/// The Love-Weber stress tensor (velocity fluctuations about the mean and the streaming
/// profile, and contact forces), the kinetic energy (of the fluctuations when the shear
/// streams) and the grains' total mass.
fn love_weber_stress(v: &SystemView<'_>) -> (Mat3, Real, Real) {
    let p = v.particles;
    let n = p.len();
    let total_mass: Real = p.mass.iter().sum();
    let streaming = |x: &Vec3| -> Vec3 {
        match v.shear {
            Some(s) if s.streaming => {
                let mut u = Vec3::zeros();
                u[s.flow] = s.rate * x[s.gradient];
                u
            }
            _ => Vec3::zeros(),
        }
    };
    let mut mean = Vec3::zeros();
    for k in 0..n {
        mean += (p.vel[k] - streaming(&p.pos[k])) * p.mass[k];
    }
    if total_mass > 0.0 {
        mean /= total_mass;
    }
    let mut sigma = Mat3::zeros();
    let mut kinetic = 0.0;
    for k in 0..n {
        let dv = p.vel[k] - streaming(&p.pos[k]) - mean;
        sigma += dv * dv.transpose() * p.mass[k];
        let vk = if v.shear.is_some_and(|s| s.streaming) { dv } else { p.vel[k] };
        kinetic += p.kinetic_energy_at(k, &vk);
    }
    for c in v.contacts {
        sigma += c.force * c.branch.transpose();
    }
    if v.volume > 0.0 {
        sigma /= v.volume;
    }
    (sigma, kinetic, total_mass)
}

/// The symmetric part of a tensor's `(a, b)` component.
fn sym(sigma: &Mat3, a: usize, b: usize) -> Real {
    0.5 * (sigma[(a, b)] + sigma[(b, a)])
}

/// The stress components of a stress tensor in `dim` dimensions, its mean stress `p` and its
/// deviatoric stress `q`.
fn stress_invariants(dim: usize, sigma: &Mat3) -> (Stress, Real, Real) {
    let stress = if dim == 2 {
        Stress { xx: sigma[(0, 0)], yy: sigma[(1, 1)], zz: None, xy: sym(sigma, 0, 1), xz: None, yz: None }
    } else {
        Stress {
            xx: sigma[(0, 0)],
            yy: sigma[(1, 1)],
            zz: Some(sigma[(2, 2)]),
            xy: sym(sigma, 0, 1),
            xz: Some(sym(sigma, 0, 2)),
            yz: Some(sym(sigma, 1, 2)),
        }
    };
    let pressure = (0..dim).map(|a| sigma[(a, a)]).sum::<Real>() / dim as Real;
    let q = if dim == 2 {
        (0.25 * (sigma[(0, 0)] - sigma[(1, 1)]).powi(2) + sym(sigma, 0, 1).powi(2)).sqrt()
    } else {
        let mut s = Mat3::zeros();
        for a in 0..3 {
            for b in 0..3 {
                s[(a, b)] = sym(sigma, a, b) - if a == b { pressure } else { 0.0 };
            }
        }
        (1.5 * s.component_mul(&s).sum()).sqrt()
    };
    (stress, pressure, q)
}

/// Effective friction and inertial number of a sheared system (none without shear); the
/// grains' size is that of the `aggregates` when the grains are aggregates, else the
/// number-mean diameter.
fn shear_response(
    v: &SystemView<'_>,
    sigma: &Mat3,
    aggregates: Option<&GrainSample>,
    solid: Real,
    total_mass: Real,
) -> (Option<Real>, Option<Real>) {
    let Some(s) = v.shear else { return (None, None) };
    let p = v.particles;
    let n = p.len();
    let sn = sigma[(s.gradient, s.gradient)];
    let tau = sym(sigma, s.flow, s.gradient).abs();
    let mu = if sn > 0.0 { tau / sn } else { 0.0 };
    // The grains' size: the number-mean diameter, or for aggregates their own.
    let mean_d = match aggregates {
        Some(g) => g.mean_diameter(v.dim),
        _ if n > 0 => 2.0 * p.radius.iter().sum::<Real>() / n as Real,
        _ => 0.0,
    };
    let rho = if solid > 0.0 { total_mass / solid } else { 0.0 };
    let i = (sn > 0.0).then(|| s.rate.abs() * mean_d * (rho / sn).sqrt());
    (Some(mu), i)
}

/// The load on each wall: its force and normal stress.
fn wall_samples(v: &SystemView<'_>) -> Vec<WallSample> {
    v.walls
        .iter()
        .map(|w| WallSample {
            name: w.name.clone(),
            position: w.position,
            force: w.force.as_slice()[..v.dim].to_vec(),
            normal_stress: if w.area > 0.0 { -w.force.dot(&w.normal) / w.area } else { 0.0 },
        })
        .collect()
}
