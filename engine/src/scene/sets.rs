//! The checks of a scene's particle sets: counts, sizes, placement regions, velocities, wetness,
//! the grain model of aggregates, and the count a drum's fill sets.

use super::model::*;
use super::spec::*;
use super::violation::Checker;
use crate::contact::attraction_lj::AttractionLj;
use crate::math::{vec_from_slice, Real, Vec3, AXES};
use crate::particles::aggregate::Bonding;

/// Packing fraction of a drum's bed used to turn `experiment.fill` into a grain count: that of
/// frictional grains poured and turned (measured: 0.815 with 300 disks, 0.558 with 5,000
/// spheres).
pub const DRUM_BED_PHI: [Real; 2] = [0.82, 0.58];

/// Sets the count of the one particle set of a drum from the fill asked for: the grains'
/// volume is `fill × Φ_bed × the drum's volume` ([`DRUM_BED_PHI`]).
pub(super) fn fill_drum(
    c: &mut Checker,
    sets: &mut [ParticleSet],
    specs: &[ParticleSetSpec],
    fill: Real,
    drum: &DrumDef,
    container: &Container,
    dim: usize,
) {
    if !(fill > 0.0 && fill < 1.0) {
        c.fail("experiment.fill", format!("must be in (0, 1), got {fill}"));
        return;
    }
    let [set] = sets else {
        c.fail("experiment.fill", "needs exactly one particle set (placed at random, without count)");
        return;
    };
    if specs.first().is_some_and(|s| s.count.is_some()) || !matches!(set.placement, Placement::Random(_)) {
        c.fail("experiment.fill", "give particles[0].count or experiment.fill, not both (fill needs random placement)");
        return;
    }
    let length = if dim == 3 { container.hi[drum.axis] - container.lo[drum.axis] } else { 1.0 };
    let volume = std::f64::consts::PI * drum.radius * drum.radius * length;
    let grain = crate::particles::Particles::volume_of(dim, 1.0) * set.size.mean_power(dim as Real) / (2.0_f64).powi(dim as i32);
    let count = (fill * DRUM_BED_PHI[dim - 2] * volume / grain).round();
    if !(1.0..=1e8).contains(&count) {
        c.fail("experiment.fill", format!("gives {count} grains of this size; choose a fill or grain size that gives 1 to 1e8"));
        return;
    }
    set.count = count as usize;
}

pub(super) fn check_region(c: &mut Checker, path: &str, r: Option<&RegionSpec>, dim: usize, container: &Container) -> Aabb {
    let Some(r) = r else {
        return Aabb { lo: container.lo, hi: container.hi };
    };
    let ok = c.vector(&format!("{path}.min"), &r.min, dim) & c.vector(&format!("{path}.max"), &r.max, dim);
    if !ok {
        return Aabb { lo: container.lo, hi: container.hi };
    }
    let lo = vec_from_slice(&r.min);
    let hi = vec_from_slice(&r.max);
    for a in 0..dim {
        if lo[a] >= hi[a] {
            c.fail(format!("{path}.max[{a}]"), format!("must be > min[{a}] = {}, got {}", lo[a], hi[a]));
        } else if lo[a] < container.lo[a] - 1e-12 || hi[a] > container.hi[a] + 1e-12 {
            c.fail(
                path.to_string(),
                format!(
                    "must lie inside the container along {} ([{}, {}]), got [{}, {}]",
                    AXES[a], container.lo[a], container.hi[a], lo[a], hi[a]
                ),
            );
        }
    }
    Aabb { lo, hi }
}

/// Checks one particle set; with `count_from_fill` a randomly placed set may leave its count
/// to the drum's `fill`.
#[allow(clippy::too_many_arguments)]
pub(super) fn check_set(
    c: &mut Checker,
    path: &str,
    p: &ParticleSetSpec,
    dim: usize,
    material: usize,
    materials: &[Material],
    container: &Container,
    count_from_fill: bool,
) -> ParticleSet {
    let size = match &p.size {
        Some(size) => check_size(c, &format!("{path}.size"), size),
        None => {
            let has_diameters = matches!(&p.placement, PlacementSpec::List { diameters: Some(_), .. });
            if !has_diameters {
                c.fail(format!("{path}.size"), "required (unless a list placement gives diameters)");
            }
            SizeDist::Monodisperse(1.0)
        }
    };
    let placement = check_placement(c, path, &p.placement, dim, container);
    let within = match &p.placement {
        PlacementSpec::Random { within: Some(b), .. } | PlacementSpec::Lattice { within: Some(b), .. } => {
            Some(check_ball(c, &format!("{path}.placement.within"), b, dim, container))
        }
        _ => None,
    };
    let count = check_count(c, path, &placement, p.count, count_from_fill);
    let velocity = check_velocity(c, path, p.velocity.as_ref(), dim);
    let has_liquid = materials.get(material).is_some_and(|m| m.liquid.is_some());
    let wet_fraction = match p.wet_fraction {
        Some(f) => {
            if c.within(&format!("{path}.wet_fraction"), f, 0.0, 1.0) && f > 0.0 && !has_liquid {
                c.fail(format!("{path}.wet_fraction"), "must be 0 when the material has no liquid");
            }
            f
        }
        None if has_liquid => 1.0,
        None => 0.0,
    };
    let aggregate = p.model.as_ref().map(|m| check_grain_model(c, &format!("{path}.model"), m, dim, &size, materials.get(material)));
    ParticleSet { material, count, size, placement, velocity, wet_fraction, aggregate, within }
}

/// Checks a ball a set's grains must lie in: its centre in the box, its radius positive and,
/// along an axis with walls, the whole ball inside them.
fn check_ball(c: &mut Checker, path: &str, b: &BallSpec, dim: usize, container: &Container) -> Ball {
    let radius = if c.positive(&format!("{path}.radius"), b.radius) { b.radius } else { 1.0 };
    if !c.vector(&format!("{path}.center"), &b.center, dim) {
        return Ball { center: 0.5 * (container.lo + container.hi), radius };
    }
    let center = vec_from_slice(&b.center);
    for a in 0..dim {
        let (lo, hi) = (container.lo[a], container.hi[a]);
        let reach = if container.periodic[a] { 0.0 } else { radius };
        if center[a] - reach < lo - 1e-12 || center[a] + reach > hi + 1e-12 {
            let what = if container.periodic[a] { "the centre" } else { "the ball" };
            c.fail(
                path.to_string(),
                format!(
                    "{what} must lie inside the container along {} ([{lo}, {hi}]), got [{}, {}]",
                    AXES[a],
                    center[a] - reach,
                    center[a] + reach
                ),
            );
        }
    }
    Ball { center, radius }
}

/// Checks a set's placement: at random in a region, on a lattice, or at listed positions.
fn check_placement(c: &mut Checker, path: &str, placement: &PlacementSpec, dim: usize, container: &Container) -> Placement {
    match placement {
        PlacementSpec::Random { region, .. } => {
            Placement::Random(check_region(c, &format!("{path}.placement.region"), region.as_ref(), dim, container))
        }
        PlacementSpec::Lattice { lattice, region, spacing, select, .. } => {
            let kind = check_lattice_kind(c, path, lattice, dim);
            if let Some(s) = spacing {
                c.positive(&format!("{path}.placement.spacing"), *s);
            }
            let random_select = match select.as_deref() {
                None | Some("first") => false,
                Some("random") => true,
                Some(o) => {
                    c.fail(format!("{path}.placement.select"), format!("must be 'first' or 'random', got '{o}'"));
                    false
                }
            };
            Placement::Lattice {
                kind,
                region: check_region(c, &format!("{path}.placement.region"), region.as_ref(), dim, container),
                spacing: *spacing,
                random_select,
            }
        }
        PlacementSpec::List { positions, diameters, velocities } => {
            check_list(c, path, positions, diameters.as_ref(), velocities.as_ref(), dim)
        }
    }
}

/// The lattice a set is placed on, among those of the dimension.
fn check_lattice_kind(c: &mut Checker, path: &str, lattice: &str, dim: usize) -> LatticeKind {
    match (lattice, dim) {
        ("square", 2) => LatticeKind::Square,
        ("hexagonal", 2) => LatticeKind::Hexagonal,
        ("cubic", 3) => LatticeKind::Cubic,
        ("fcc", 3) => LatticeKind::Fcc,
        (other, d) => {
            c.fail(
                format!("{path}.placement.lattice"),
                format!("must be one of {} in {d}D, got '{other}'", if d == 2 { "square, hexagonal" } else { "cubic, fcc" }),
            );
            LatticeKind::Cubic
        }
    }
}

/// Checks a list placement: its positions, and the diameters and velocities, one per position.
fn check_list(
    c: &mut Checker,
    path: &str,
    positions: &[Vec<f64>],
    diameters: Option<&Vec<f64>>,
    velocities: Option<&Vec<Vec<f64>>>,
    dim: usize,
) -> Placement {
    let mut pos = Vec::with_capacity(positions.len());
    for (i, x) in positions.iter().enumerate() {
        if c.vector(&format!("{path}.placement.positions[{i}]"), x, dim) {
            pos.push(vec_from_slice(x));
        }
    }
    if let Some(d) = diameters {
        if d.len() != positions.len() {
            c.fail(
                format!("{path}.placement.diameters"),
                format!("must have one diameter per position ({}), got {}", positions.len(), d.len()),
            );
        }
        for (i, di) in d.iter().enumerate() {
            c.positive(&format!("{path}.placement.diameters[{i}]"), *di);
        }
    }
    let vel = velocities.map(|vs| {
        if vs.len() != positions.len() {
            c.fail(
                format!("{path}.placement.velocities"),
                format!("must have one velocity per position ({}), got {}", positions.len(), vs.len()),
            );
        }
        vs.iter()
            .enumerate()
            .map(|(i, v)| {
                c.vector(&format!("{path}.placement.velocities[{i}]"), v, dim);
                vec_from_slice(v)
            })
            .collect()
    });
    Placement::List { positions: pos, diameters: diameters.cloned(), velocities: vel }
}

/// The set's grain count: the listed positions', the given one, or (a drum's random set with
/// `count_from_fill`) 0 until the fill sets it.
fn check_count(c: &mut Checker, path: &str, placement: &Placement, given: Option<usize>, count_from_fill: bool) -> usize {
    let count = match (placement, given) {
        (Placement::List { positions, .. }, Some(n)) if n != positions.len() => {
            c.fail(format!("{path}.count"), format!("must equal the number of listed positions ({})", positions.len()));
            n
        }
        (Placement::List { positions, .. }, _) => positions.len(),
        (_, Some(n)) => n,
        // A drum's `fill` sets the count of a random set (after the experiment is checked).
        (Placement::Random(_), None) if count_from_fill => 0,
        (_, None) => {
            c.fail(format!("{path}.count"), "required for random and lattice placement");
            0
        }
    };
    if count == 0 && !matches!(placement, Placement::List { .. }) && given.is_some() {
        c.fail(format!("{path}.count"), "must be >= 1");
    }
    if count > MAX_PARTICLES {
        c.fail(format!("{path}.count"), format!("must be at most {MAX_PARTICLES}, got {count}"));
    }
    count
}

/// The set's initial velocity: zero, uniform, or Gaussian.
fn check_velocity(c: &mut Checker, path: &str, v: Option<&VelocitySpec>, dim: usize) -> InitialVelocity {
    match v {
        None | Some(VelocitySpec::Zero) => InitialVelocity::Uniform(Vec3::zeros()),
        Some(VelocitySpec::Uniform { value }) => {
            c.vector(&format!("{path}.velocity.value"), value, dim);
            InitialVelocity::Uniform(vec_from_slice(value))
        }
        Some(VelocitySpec::Gaussian { std }) => {
            c.non_negative(&format!("{path}.velocity.std"), *std);
            InitialVelocity::Gaussian(*std)
        }
    }
}

/// A size distribution at `path` (`….size`).
fn check_size(c: &mut Checker, path: &str, s: &SizeSpec) -> SizeDist {
    match s {
        SizeSpec::Monodisperse { diameter } => {
            c.positive(&format!("{path}.diameter"), *diameter);
            SizeDist::Monodisperse(*diameter)
        }
        SizeSpec::Uniform { min, max } => {
            c.positive(&format!("{path}.min"), *min);
            if !(max.is_finite() && max >= min) {
                c.fail(format!("{path}.max"), format!("must be >= {path}.min = {min}, got {max}"));
            }
            SizeDist::Uniform { min: *min, max: *max }
        }
        SizeSpec::Bidisperse { diameter, ratio, fraction_small } => {
            c.positive(&format!("{path}.diameter"), *diameter);
            if !(ratio.is_finite() && *ratio >= 1.0) {
                c.fail(format!("{path}.ratio"), format!("must be >= 1, got {ratio}"));
            }
            let f = fraction_small.unwrap_or(0.5);
            c.within(&format!("{path}.fraction_small"), f, 0.0, 1.0);
            SizeDist::Bidisperse { small: *diameter, ratio: *ratio, fraction_small: f }
        }
    }
}

/// Fewest primaries of an aggregate that make a round grain rather than a cluster of a couple
/// of rings.
pub const MIN_ROUND_PRIMARIES: usize = 30;

/// A set's `model` at `path`, for grains of `size` made of `material`.
fn check_grain_model(
    c: &mut Checker,
    path: &str,
    m: &GrainModelSpec,
    dim: usize,
    size: &SizeDist,
    material: Option<&Material>,
) -> AggregateModel {
    let GrainModelSpec::BondedPrimaries { primaries, min_primaries, attraction, friction } = m;
    if material.is_some_and(|m| m.deformable.is_some()) {
        c.fail(format!("{path}.kind"), "bonded_primaries are rigid primaries: give the set a material without `deformable`");
    }
    let primaries = check_size(c, &format!("{path}.primaries"), primaries);
    let min_primaries = min_primaries.unwrap_or(200);
    if min_primaries < MIN_ROUND_PRIMARIES {
        c.fail(
            format!("{path}.min_primaries"),
            format!("must be >= {MIN_ROUND_PRIMARIES} (fewer make a cluster of a couple of rings, not a round grain), got {min_primaries}"),
        );
    }
    let f0 = attraction.force;
    c.positive(&format!("{path}.attraction.force"), f0);
    let gamma = attraction.exponent.unwrap_or(crate::contact::attraction_lj::GAMMA);
    if !(gamma.is_finite() && gamma > 1.0) {
        c.fail(
            format!("{path}.attraction.exponent"),
            format!("must be > 1 (the bond energy F_0 a_0/(γ − 1) is finite only then; the sources use 7), got {gamma}"),
        );
    }
    let (d_min, d_max) = (primaries.min_diameter(), primaries.max_diameter());
    let cutoff = attraction.cutoff.unwrap_or(d_max);
    if !(cutoff.is_finite() && cutoff >= d_min) {
        c.fail(
            format!("{path}.attraction.cutoff"),
            format!(
                "must be at least the smallest primary's diameter {d_min} m (a shorter reach binds only touching primaries), got {cutoff}"
            ),
        );
    }
    let friction = friction.unwrap_or(0.0);
    c.non_negative(&format!("{path}.friction"), friction);
    let model =
        AggregateModel { dim, primaries, min_primaries, bonding: Bonding { attraction: AttractionLj { f0, gamma, cutoff }, friction } };
    let grain = size.min_diameter();
    if d_max.is_finite() && d_max > 0.0 && grain > 0.0 {
        let holds = model.estimated_primaries(grain.powi(dim as i32));
        if holds < min_primaries {
            c.fail(
                format!("{path}.primaries"),
                format!(
                    "the smallest grain ({grain} m) holds about {holds} primaries of this size, fewer than min_primaries ({min_primaries}): make the grains larger or the primaries smaller"
                ),
            );
        }
    }
    model
}

/// A grain is measured whole across a periodic boundary from its primaries' nearest images
/// (observe::grains): an aggregate must be less than half the period across.
pub(super) fn check_aggregate_periods(c: &mut Checker, sets: &[ParticleSet], container: &Container, dim: usize) {
    for (k, set) in sets.iter().enumerate().filter(|(_, s)| s.aggregate.is_some()) {
        let grain = set.size.max_diameter();
        for a in (0..dim).filter(|&a| container.periodic[a]) {
            let period = container.hi[a] - container.lo[a];
            if grain.is_finite() && period > 0.0 && 2.0 * grain >= period {
                c.fail(
                    format!("container.max[{a}]"),
                    format!("the period along {} ({period} m) must exceed twice the largest grain of particles[{k}] ({grain} m), whose primaries are measured as one grain by their nearest images", AXES[a]),
                );
            }
        }
    }
}

/// The number of particles a scene places in all (primaries of aggregates included), bounded
/// by [`MAX_PARTICLES`]: sets of valid counts may still add up (or multiply, by an aggregate's
/// primaries) past what any machine holds; the sum saturates rather than wraps.
pub(super) fn check_total(c: &mut Checker, from_state: usize, sets: &[ParticleSet]) {
    let total = sets.iter().map(ParticleSet::particle_count).fold(from_state, usize::saturating_add);
    if total > MAX_PARTICLES {
        let shown = if total == usize::MAX { "more than that".to_string() } else { format!("{total}") };
        c.fail(
            "particles",
            format!("the scene places at most {MAX_PARTICLES} particles in all (primaries of aggregates included), got {shown}"),
        );
    }
}

/// The grain scales an experiment's defaults are set from: the first set's (or the saved
/// state's) mean diameter and material, the solid volume, and the capillary force of wet
/// grains.
pub(super) fn grain_scales(
    dim: usize,
    initial: Option<&super::state::InitialState>,
    sets: &[ParticleSet],
    materials: &[Material],
) -> super::experiments::GrainScales {
    let volume_of = |d: Real| crate::particles::Particles::volume_of(dim, 0.5 * d);
    let (diameter, first_material, any_wet, solid_volume) = match (initial, sets.first()) {
        (Some(st), _) => (
            st.mean_diameter(),
            st.material.first().copied(),
            st.wet.iter().any(|&w| w),
            st.radius.iter().map(|&r| volume_of(2.0 * r)).sum(),
        ),
        (None, Some(set)) => (
            set.size.mean_diameter(),
            Some(set.material),
            sets.iter().any(|s| s.wet_fraction > 0.0),
            sets.iter().map(|s| s.count as Real * volume_of(1.0) * s.size.mean_power(dim as Real)).sum(),
        ),
        (None, None) => (1.0, None, false, 0.0),
    };
    let material = first_material.and_then(|m| materials.get(m));
    let capillary_force = material
        .and_then(|m| m.liquid)
        .filter(|_| any_wet)
        .map(|l| 2.0 * std::f64::consts::PI * l.surface_tension * l.contact_angle.cos() * 0.5 * diameter);
    super::experiments::GrainScales { diameter, density: material.map_or(1.0, |m| m.density), solid_volume, capillary_force }
}
