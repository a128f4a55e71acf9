//! Placement of a scene's particle sets: random non-overlapping gas, lattices, explicit lists;
//! size distributions; initial velocities. Deterministic for a given seed.

use std::collections::HashMap;

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::aggregate::{grow_ball, grow_disk};
use super::Particles;
use crate::error::EngineError;
use crate::geometry::Domain;
use crate::math::{Real, Vec3};
use crate::scene::{Aabb, Ball, DrumDef, InitialState, InitialVelocity, LatticeKind, ParticleSet, Placement, Scene, SizeDist};

/// Attempts per particle before random placement gives up.
const MAX_ATTEMPTS: usize = 20_000;

/// Places every particle set of `scene` in `domain` (Lees-Edwards offset zero).
pub fn place_particles(scene: &Scene, domain: &Domain) -> Result<Particles, EngineError> {
    if let Some(st) = &scene.initial {
        return Ok(restore_state(scene, st));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(scene.seed);
    let mut grid = OverlapGrid::new(largest_diameter(scene).max(1e-300));
    let mut out = Particles::default();
    let confine = Confinement { drum: scene.container.drum.as_ref(), ball: scene.container.granule.as_ref() };
    // Each set's grains in `out`: where they start.
    let mut starts = Vec::with_capacity(scene.sets.len() + 1);
    for (k, set) in scene.sets.iter().enumerate() {
        starts.push(out.len());
        let path = format!("particles[{k}]");
        let diameters = draw_diameters(set, &mut rng);
        let mat = &scene.materials[set.material];
        let wet = wet_flags(set, &mut rng);
        // A set placed within a ball of its own (an agglomerate) lies in it, besides the box.
        let confine = Confinement { ball: set.within.as_ref().or(confine.ball), ..confine };
        let positions: Vec<Vec3> = match &set.placement {
            Placement::Random(region) => random_positions(&diameters, region, domain, confine, &mut grid, &mut out, &mut rng, &path)?,
            Placement::Lattice { kind, region, spacing, random_select } => {
                let (s, dm) = lattice_spacing(*spacing, &diameters, &path)?;
                let mut sites = lattice_sites(*kind, region, s, dm / 2.0, domain);
                sites.retain(|p| confine.holds(p, dm / 2.0));
                if sites.len() < set.count {
                    return Err(EngineError::Build {
                        field: format!("{path}.count"),
                        reason: format!(
                            "the region holds only {} lattice sites at spacing {s} m, fewer than the {} particles asked for",
                            sites.len(),
                            set.count
                        ),
                    });
                }
                select_sites(&mut sites, set.count, *random_select, &mut rng);
                for (p, d) in sites.iter().zip(&diameters) {
                    // Sites of one lattice cannot overlap each other (spacing >= diameter).
                    check_free(&grid, &out, &[], &[], domain, p, d / 2.0, &path)?;
                    grid.insert_in(domain, p, out.len() + grid.pending());
                    grid.pending_push();
                }
                grid.flush();
                sites
            }
            Placement::List { positions, .. } => list_positions(positions, &diameters, domain, confine, &mut grid, &out, &path)?,
        };
        let listed_vel = match &set.placement {
            Placement::List { velocities: Some(v), .. } => Some(v.clone()),
            _ => None,
        };
        for (idx, (p, d)) in positions.iter().zip(&diameters).enumerate() {
            let v = match (&listed_vel, set.velocity) {
                (Some(v), _) => v[idx],
                (None, InitialVelocity::Uniform(v)) => v,
                (None, InitialVelocity::Gaussian(std)) => gaussian_velocity(scene.dim, std, &mut rng),
            };
            out.push(scene.dim, *p, v, d / 2.0, mat.density, set.material as u16, wet[idx]);
        }
    }
    starts.push(out.len());
    if scene.sets.iter().any(|s| s.aggregate.is_some()) {
        return fill_aggregates(scene, &out, &starts, &mut rng);
    }
    Ok(out)
}

/// The particles of a saved state, as they were (checked by the scene's validation).
fn restore_state(scene: &Scene, st: &InitialState) -> Particles {
    let mut out = Particles::default();
    for k in 0..st.pos.len() {
        let density = scene.materials.get(st.material[k]).map_or(1.0, |m| m.density);
        out.push(scene.dim, st.pos[k], st.vel[k], st.radius[k], density, st.material[k] as u16, st.wet[k]);
        if let Some(w) = out.omega.last_mut() {
            *w = st.omega[k];
        }
    }
    out.aggregate.clone_from(&st.aggregate);
    out.bondings.clone_from(&st.bondings);
    out
}

/// The largest diameter any set can draw (its listed diameters, or its size distribution's).
fn largest_diameter(scene: &Scene) -> Real {
    scene
        .sets
        .iter()
        .map(|s| match &s.placement {
            Placement::List { diameters: Some(d), .. } => d.iter().copied().fold(0.0, f64::max),
            _ => s.size.max_diameter(),
        })
        .fold(0.0, f64::max)
}

/// Which of the set's grains are wet: its wet fraction of them, at random.
fn wet_flags(set: &ParticleSet, rng: &mut ChaCha8Rng) -> Vec<bool> {
    let mut wet = vec![false; set.count];
    let n_wet = (set.wet_fraction * set.count as f64).round() as usize;
    wet.iter_mut().take(n_wet).for_each(|w| *w = true);
    wet.shuffle(rng);
    wet
}

/// A lattice's spacing (by default just over the largest diameter) and the largest diameter;
/// an error when the grains would overlap.
fn lattice_spacing(spacing: Option<Real>, diameters: &[Real], path: &str) -> Result<(Real, Real), EngineError> {
    let s = spacing.unwrap_or(1.01 * diameters.iter().copied().fold(0.0, f64::max));
    let dm = diameters.iter().copied().fold(0.0, f64::max);
    if s < (1.0 - LATTICE_OVERLAP) * dm {
        return Err(EngineError::Build {
            field: format!("{path}.placement.spacing"),
            reason: format!(
                "{s} m is smaller than {} of the largest diameter {dm} m: neighbours would overlap by more than {}% of it",
                1.0 - LATTICE_OVERLAP,
                100.0 * LATTICE_OVERLAP
            ),
        });
    }
    Ok((s, dm))
}

/// Largest overlap of lattice neighbours a spacing may ask for, as a fraction of the largest
/// diameter: wet grains placed overlapping start bridged (a packed agglomerate); beyond 1% the
/// first steps would throw them apart.
const LATTICE_OVERLAP: Real = 0.01;

/// Keeps `count` lattice sites: the first ones, or (`random_select`) a random choice in
/// lattice order.
fn select_sites(sites: &mut Vec<Vec3>, count: usize, random_select: bool, rng: &mut ChaCha8Rng) {
    if random_select {
        sites.shuffle(rng);
        sites.truncate(count);
        sites.sort_by(|a, b| a.z.total_cmp(&b.z).then(a.y.total_cmp(&b.y)).then(a.x.total_cmp(&b.x)));
    } else {
        sites.truncate(count);
    }
}

/// Checks listed positions (inside the confinement, free of the grains placed and of each
/// other) and registers them in the overlap grid.
fn list_positions(
    positions: &[Vec3],
    diameters: &[Real],
    domain: &Domain,
    confine: Confinement<'_>,
    grid: &mut OverlapGrid,
    placed: &Particles,
    path: &str,
) -> Result<Vec<Vec3>, EngineError> {
    let radii: Vec<Real> = diameters.iter().map(|d| d / 2.0).collect();
    for (idx, (p, d)) in positions.iter().zip(diameters).enumerate() {
        let field = format!("{path}.placement.positions[{idx}]");
        if !confine.holds(p, d / 2.0) {
            return Err(EngineError::Build { field, reason: format!("particle lies outside {}", confine.name()) });
        }
        check_free(grid, placed, &positions[..idx], &radii[..idx], domain, p, d / 2.0, &field)?;
        grid.insert_in(domain, p, placed.len() + grid.pending());
        grid.pending_push();
    }
    grid.flush();
    Ok(positions.to_vec())
}

/// A velocity with independent Gaussian components of standard deviation `std` in `dim`
/// dimensions.
fn gaussian_velocity(dim: usize, std: Real, rng: &mut ChaCha8Rng) -> Vec3 {
    let mut v = Vec3::zeros();
    for a in 0..dim {
        v[a] = std * standard_normal(rng);
    }
    v
}

/// The particles of `grains` (the placed grains, those of set `k` from `starts[k]` to
/// `starts[k + 1]`), with each grain of an aggregate set replaced by its primaries
/// ([`grow_disk`], [`grow_ball`] in 3D), which move with the grain's velocity.
fn fill_aggregates(scene: &Scene, grains: &Particles, starts: &[usize], rng: &mut ChaCha8Rng) -> Result<Particles, EngineError> {
    let mut out = Particles::default();
    for (k, set) in scene.sets.iter().enumerate() {
        let density = scene.materials[set.material].density;
        for i in starts[k]..starts[k + 1] {
            let (pos, vel, r, material, wet) = (grains.pos[i], grains.vel[i], grains.radius[i], grains.material[i], grains.wet[i]);
            let Some(model) = &set.aggregate else {
                out.push(scene.dim, pos, vel, r, density, material, wet);
                continue;
            };
            let primaries =
                if scene.dim == 3 { grow_ball(pos, r, &model.primaries, rng) } else { grow_disk(pos, r, &model.primaries, rng) };
            if primaries.len() < model.min_primaries {
                return Err(EngineError::Build {
                    field: format!("particles[{k}].model.primaries"),
                    reason: format!(
                        "grain {} of the set ({:.4e} m across) holds only {} primaries, fewer than min_primaries ({}): make the grains larger or the primaries smaller",
                        i - starts[k],
                        2.0 * r,
                        primaries.len(),
                        model.min_primaries
                    ),
                });
            }
            let id = out.bondings.len() as u32;
            out.bondings.push(model.bonding);
            let c = &scene.container;
            for (mut x, rp) in primaries {
                // A grain across a periodic boundary: its primaries beyond it at their images.
                for a in (0..scene.dim).filter(|&a| c.periodic[a]) {
                    x[a] = c.lo[a] + (x[a] - c.lo[a]).rem_euclid(c.hi[a] - c.lo[a]);
                }
                out.push(scene.dim, x, vel, rp, density, material, wet);
                if let Some(a) = out.aggregate.last_mut() {
                    *a = id;
                }
            }
        }
    }
    Ok(out)
}

fn draw_diameters(set: &ParticleSet, rng: &mut ChaCha8Rng) -> Vec<Real> {
    if let Placement::List { diameters: Some(d), .. } = &set.placement {
        return d.clone();
    }
    let mut d: Vec<Real> = match set.size {
        SizeDist::Monodisperse(d) => vec![d; set.count],
        SizeDist::Uniform { min, max } => (0..set.count).map(|_| if max > min { rng.gen_range(min..=max) } else { min }).collect(),
        SizeDist::Bidisperse { small, ratio, fraction_small } => {
            let n_small = (fraction_small * set.count as f64).round() as usize;
            let mut d: Vec<Real> = (0..set.count).map(|k| if k < n_small { small } else { small * ratio }).collect();
            d.shuffle(rng);
            d
        }
    };
    if matches!(set.placement, Placement::Random(_)) {
        // Largest first: random sequential addition packs better that way.
        d.sort_by(|a, b| b.total_cmp(a));
    }
    d
}

/// Standard normal deviate (Box-Muller).
fn standard_normal(rng: &mut ChaCha8Rng) -> Real {
    let u1: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Interval of admissible centre coordinates along axis `a` for a particle of radius r.
fn centre_bounds(region: &Aabb, domain: &Domain, a: usize, r: Real) -> (Real, Real) {
    let spans = domain.periodic[a] && region.lo[a] <= domain.lo[a] + 1e-12 && region.hi[a] >= domain.hi[a] - 1e-12;
    if spans {
        (domain.lo[a], domain.hi[a])
    } else {
        (region.lo[a] + r, region.hi[a] - r)
    }
}

/// Where the grains of a scene must be placed besides the box: inside its drum, or inside the
/// ball of its granule or of their set (`placement.within`).
#[derive(Clone, Copy)]
struct Confinement<'a> {
    drum: Option<&'a DrumDef>,
    ball: Option<&'a Ball>,
}

impl Confinement<'_> {
    /// True if a particle of radius `r` at `p` lies inside.
    fn holds(&self, p: &Vec3, r: Real) -> bool {
        let in_drum = self.drum.is_none_or(|d| {
            let mut x = p - d.center;
            x[d.axis] = 0.0;
            x.norm() + r <= d.radius
        });
        in_drum && self.ball.is_none_or(|b| (p - b.center).norm() + r <= b.radius)
    }

    /// Interval of centre coordinates along axis `a` that may hold a particle of radius `r`
    /// (the bounding box of the confinement), if it bounds that axis.
    fn bounds(&self, a: usize, r: Real) -> Option<(Real, Real)> {
        if let Some(b) = self.ball {
            return Some((b.center[a] - (b.radius - r), b.center[a] + (b.radius - r)));
        }
        self.drum.filter(|d| d.axis != a).map(|d| (d.center[a] - (d.radius - r), d.center[a] + (d.radius - r)))
    }

    /// Volume that may hold the grains (m³, m² in 2D) within `region`, for messages.
    fn volume(&self, dim: usize, region: &Aabb) -> Real {
        let extent = |a: usize| region.hi[a] - region.lo[a];
        match (self.ball, self.drum) {
            (Some(b), _) => Particles::volume_of(dim, b.radius),
            (None, Some(d)) => {
                let along = if dim == 3 { extent(d.axis) } else { 1.0 };
                std::f64::consts::PI * d.radius * d.radius * along
            }
            (None, None) => (0..dim).map(extent).product(),
        }
    }

    /// What the grain must lie inside, for messages.
    fn name(&self) -> &'static str {
        if self.ball.is_some() {
            "the granule's ball"
        } else {
            "the drum"
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn random_positions(
    diameters: &[Real],
    region: &Aabb,
    domain: &Domain,
    confine: Confinement<'_>,
    grid: &mut OverlapGrid,
    placed: &mut Particles,
    rng: &mut ChaCha8Rng,
    path: &str,
) -> Result<Vec<Vec3>, EngineError> {
    let mut out: Vec<Vec3> = Vec::with_capacity(diameters.len());
    let mut radii: Vec<Real> = Vec::with_capacity(diameters.len());
    for (k, d) in diameters.iter().enumerate() {
        let r = d / 2.0;
        let mut bounds = [(0.0, 0.0); 3];
        for (a, b) in bounds.iter_mut().enumerate().take(domain.dim) {
            *b = centre_bounds(region, domain, a, r);
            if let Some((lo, hi)) = confine.bounds(a, r) {
                *b = (b.0.max(lo), b.1.min(hi));
            }
            if b.1 < b.0 {
                return Err(EngineError::Build {
                    field: format!("{path}.placement.region"),
                    reason: format!("region is narrower than a particle of diameter {d} m along {}", crate::math::AXES[a]),
                });
            }
        }
        let mut found = None;
        for _ in 0..MAX_ATTEMPTS {
            let mut p = Vec3::zeros();
            for a in 0..domain.dim {
                let (l, h) = bounds[a];
                p[a] = if h > l { rng.gen_range(l..h) } else { l };
            }
            if confine.holds(&p, r) && grid.is_free(placed, &out, &radii, domain, &p, r) {
                found = Some(p);
                break;
            }
        }
        let Some(p) = found else {
            let vol = confine.volume(domain.dim, region);
            let solid: Real = diameters.iter().map(|d| Particles::volume_of(domain.dim, d / 2.0)).sum();
            return Err(EngineError::Build {
                field: format!("{path}.count"),
                reason: format!(
                    "placed only {k} of {} particles at random without overlap (requested packing fraction {:.3} of the space that may hold them); \
                     random placement jams near 0.55 in 2D and 0.38 in 3D: use a larger region, fewer particles, or a lattice",
                    diameters.len(),
                    solid / vol
                ),
            });
        };
        grid.insert_in(domain, &p, placed.len() + out.len());
        out.push(p);
        radii.push(r);
    }
    grid.pending_clear();
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn check_free(
    grid: &OverlapGrid,
    placed: &Particles,
    new_pos: &[Vec3],
    new_r: &[Real],
    domain: &Domain,
    p: &Vec3,
    r: Real,
    field: &str,
) -> Result<(), EngineError> {
    for a in 0..domain.dim {
        if !domain.periodic[a] && (p[a] - r < domain.lo[a] - 1e-12 || p[a] + r > domain.hi[a] + 1e-12) {
            return Err(EngineError::Build {
                field: field.to_string(),
                reason: format!("particle at {:?} crosses the container along {}", p.as_slice(), crate::math::AXES[a]),
            });
        }
    }
    if !grid.is_free(placed, new_pos, new_r, domain, p, r) {
        return Err(EngineError::Build { field: field.to_string(), reason: "particle overlaps one placed before it".to_string() });
    }
    Ok(())
}

/// Lattice sites inside `region` (centres at least `r` from non-periodic region faces).
fn lattice_sites(kind: LatticeKind, region: &Aabb, s: Real, r: Real, domain: &Domain) -> Vec<Vec3> {
    let (cell, basis): (Vec3, Vec<Vec3>) = match kind {
        LatticeKind::Square => (Vec3::new(s, s, 1.0), vec![Vec3::zeros()]),
        LatticeKind::Hexagonal => {
            let h = s * 3f64.sqrt();
            (Vec3::new(s, h, 1.0), vec![Vec3::zeros(), Vec3::new(0.5 * s, 0.5 * h, 0.0)])
        }
        LatticeKind::Cubic => (Vec3::repeat(s), vec![Vec3::zeros()]),
        LatticeKind::Fcc => {
            let a = s * 2f64.sqrt();
            let h = 0.5 * a;
            (Vec3::repeat(a), vec![Vec3::zeros(), Vec3::new(h, h, 0.0), Vec3::new(h, 0.0, h), Vec3::new(0.0, h, h)])
        }
    };
    let mut lo = Vec3::zeros();
    let mut hi = Vec3::zeros();
    let mut ncell = [1usize; 3];
    for a in 0..domain.dim {
        let spans = domain.periodic[a] && region.lo[a] <= domain.lo[a] + 1e-12 && region.hi[a] >= domain.hi[a] - 1e-12;
        // On a periodic axis the lattice starts a quarter cell in, so that its periodic image
        // continues it; elsewhere centres keep one radius from the faces.
        let m = if spans { 0.25 * cell[a] } else { r };
        lo[a] = region.lo[a] + m;
        hi[a] = region.hi[a] - m;
        ncell[a] = (((hi[a] - lo[a]) / cell[a]).floor().max(0.0) as usize) + 1;
    }
    let mut sites = Vec::new();
    let tol = 1e-9 * s;
    for k in 0..ncell[2] {
        for j in 0..ncell[1] {
            for i in 0..ncell[0] {
                for b in &basis {
                    let p = Vec3::new(
                        lo.x + i as f64 * cell.x + b.x,
                        lo.y + j as f64 * cell.y + b.y,
                        if domain.dim == 3 { lo.z + k as f64 * cell.z + b.z } else { 0.0 },
                    );
                    if (0..domain.dim).all(|a| p[a] <= hi[a] + tol) {
                        sites.push(p);
                    }
                }
            }
        }
    }
    sites.sort_by(|a, b| a.z.total_cmp(&b.z).then(a.y.total_cmp(&b.y)).then(a.x.total_cmp(&b.x)));
    sites
}

/// Hash grid of placed centres for overlap checks during placement. On periodic axes the cells
/// tile the box exactly and indices wrap, so periodic images are found.
struct OverlapGrid {
    size: Real,
    cells: HashMap<[i64; 3], Vec<usize>>,
    pending: usize,
}

impl OverlapGrid {
    fn new(size: Real) -> Self {
        Self { size, cells: HashMap::new(), pending: 0 }
    }
    fn layout(&self, domain: &Domain, a: usize) -> (Real, i64) {
        if domain.periodic[a] {
            let n = ((domain.length(a) / self.size).floor() as i64).max(1);
            (domain.length(a) / n as f64, n)
        } else {
            (self.size, 0)
        }
    }
    fn key_in(&self, domain: &Domain, p: &Vec3) -> [i64; 3] {
        let mut k = [0i64; 3];
        for (a, ka) in k.iter_mut().enumerate().take(domain.dim) {
            let (w, n) = self.layout(domain, a);
            let c = ((p[a] - domain.lo[a]) / w).floor() as i64;
            *ka = if n > 0 { c.rem_euclid(n) } else { c };
        }
        k
    }
    fn insert_in(&mut self, domain: &Domain, p: &Vec3, index: usize) {
        let k = self.key_in(domain, p);
        self.cells.entry(k).or_default().push(index);
    }
    fn pending(&self) -> usize {
        self.pending
    }
    fn pending_push(&mut self) {
        self.pending += 1;
    }
    fn pending_clear(&mut self) {
        self.pending = 0;
    }
    fn flush(&mut self) {
        self.pending = 0;
    }
    /// True if a particle at `p` with radius `r` overlaps neither the placed particles nor the
    /// new ones (`new_pos`, `new_r`, indexed after `placed`).
    fn is_free(&self, placed: &Particles, new_pos: &[Vec3], new_r: &[Real], domain: &Domain, p: &Vec3, r: Real) -> bool {
        let n0 = placed.len();
        let check = |j: usize| -> bool {
            let (q, rj) = if j < n0 {
                (placed.pos[j], placed.radius[j])
            } else {
                match (new_pos.get(j - n0), new_r.get(j - n0)) {
                    (Some(q), Some(rj)) => (*q, *rj),
                    _ => return true,
                }
            };
            let (d, _) = domain.separation(p, &q);
            d.norm() >= r + rj
        };
        let k = self.key_in(domain, p);
        let mut keys: Vec<[i64; 3]> = Vec::with_capacity(27);
        let dz = if domain.dim == 3 { -1..=1 } else { 0..=0 };
        for z in dz {
            for y in -1..=1i64 {
                for x in -1..=1i64 {
                    let mut c = [k[0] + x, k[1] + y, k[2] + z];
                    for (a, ca) in c.iter_mut().enumerate().take(domain.dim) {
                        let (_, n) = self.layout(domain, a);
                        if n > 0 {
                            *ca = ca.rem_euclid(n);
                        }
                    }
                    keys.push(c);
                }
            }
        }
        keys.sort_unstable();
        keys.dedup();
        keys.iter().all(|c| self.cells.get(c).is_none_or(|list| list.iter().all(|&j| check(j))))
    }
}
