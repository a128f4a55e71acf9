//! The neighbour list never misses a contact: in a periodic cell that is compressed, then
//! servo-controlled to a pressure (the cell deforms every step), every pair that overlaps —
//! found by brute force over minimum images — was evaluated by the force stage at every check. A missed
//! pair would let grains pass through each other unseen, so this is checked exactly, not
//! statistically.

use crate::common;

use std::collections::HashSet;

use sable_engine::methods::dem::Dem;
use sable_engine::run::Simulation;
use sable_engine::scene::Deformation;
use serde_json::json;

/// Pairs (i < j) that overlap, by brute force over minimum images.
fn overlapping(sim: &Dem) -> HashSet<(u32, u32)> {
    let p = sim.particles();
    let domain = sim.domain();
    let mut out = HashSet::new();
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let (d, _) = domain.image(&p.pos[i], &p.pos[j]);
            // A margin of 1e-12 relative keeps exact-touching pairs out of the comparison.
            if d.norm() < (p.radius[i] + p.radius[j]) * (1.0 - 1e-12) {
                out.insert((i as u32, j as u32));
            }
        }
    }
    out
}

/// Pairs the force stage evaluated as interacting (a touching pair whose damped force is
/// floored at zero still counts).
fn in_contact(sim: &Dem) -> HashSet<(u32, u32)> {
    sim.interacting_pair_list().into_iter().collect()
}

fn check(sim: &Dem, stage: &str) -> usize {
    let expected = overlapping(sim);
    let found = in_contact(sim);
    let missed: Vec<_> = expected.difference(&found).collect();
    assert!(
        missed.is_empty(),
        "{stage}, step {}: {} overlapping pair(s) not evaluated, e.g. {:?}",
        sim.steps_done(),
        missed.len(),
        &missed[..missed.len().min(5)]
    );
    expected.len()
}

#[test]
fn no_contact_is_missed_while_the_periodic_cell_deforms() {
    let n = 300;
    let d = 1e-3;
    let area = std::f64::consts::PI / 4.0 * d * d * (1.0 + 1.4 * 1.4) / 2.0;
    let side = (n as f64 * area / 0.5).sqrt();
    let k_n = 1e7;
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "time_step_fraction": 0.02, "local_damping": 0.3, "max_overlap": 0.2},
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.2, "friction": 0.3}},
        "particles": [{"material": "m", "count": n, "size": {"kind": "bidisperse", "diameter": d, "ratio": 1.4}, "placement": {"kind": "random"},
                       "velocity": {"kind": "gaussian", "std": 0.05}}],
        "container": {"min": [0, 0], "max": [side, side], "periodic": ["x", "y"],
                      "deformation": {"kind": "strain_rate", "rate": [-10.0, -10.0]}},
        "stop": {"steps": 1},
        "seed": 11
    }));
    let mut sim = common::dem(&s);
    let mut most = 0;
    // Compression through jamming, checked every 5 steps.
    while sim.packing_fraction() < 0.845 {
        for _ in 0..5 {
            sim.step().expect("stable");
        }
        most = most.max(check(&sim, "compression"));
        assert!(sim.steps_done() < 400_000, "compression stalled at phi = {}", sim.packing_fraction());
    }
    // Pressure servo: the cell expands and breathes.
    let target = 1e-3 * k_n;
    sim.set_deformation(Some(Deformation::Pressure { target, max_strain_rate: 5.0, gain: 1.0 / target }));
    for _ in 0..2000 {
        for _ in 0..5 {
            sim.step().expect("stable");
        }
        most = most.max(check(&sim, "servo"));
    }
    assert!(most > n, "the test must see a dense contact network, saw at most {most} contacts");
    assert!(sim.neighbor_builds() > 10, "the test must cross many neighbour-list rebuilds");
}

/// What a sheared run saw: the most contacts at a check, offset wraps, and the shortest and
/// longest height of the cell.
struct Sheared {
    most: usize,
    wraps: usize,
    shortest: f64,
    longest: f64,
}

const SHEAR_RATE: f64 = 20.0;
const N_SHEARED: usize = 290;

/// A dense square lattice of 290 disks with 10% vacancies, sheared by Lees-Edwards to a strain of
/// 3 (the offset wraps about three times), with the height servo-controlled to `normal_stress`
/// when given; every overlapping pair is checked every 5 steps.
fn shear_and_check(seed: u64, normal_stress: Option<f64>, stage: &str) -> (Sheared, f64, f64) {
    let (d, spacing, cells) = (1e-3, 1.02e-3, 18);
    let side = cells as f64 * spacing;
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "time_step_fraction": 0.02, "max_overlap": 0.2},
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "m", "count": N_SHEARED, "size": {"kind": "monodisperse", "diameter": d},
                       "placement": {"kind": "lattice", "lattice": "square", "spacing": spacing, "select": "random"},
                       "velocity": {"kind": "gaussian", "std": 0.02}}],
        "container": {"min": [0, 0], "max": [side, side], "periodic": ["x", "y"],
                      "lees_edwards": {"shear_rate": SHEAR_RATE, "initial_profile": true}},
        "stop": {"steps": 1},
        "seed": seed
    }));
    let mut sim = common::dem(&s);
    if let Some(target) = normal_stress {
        sim.set_deformation(Some(Deformation::NormalStress { axis: 1, target, max_strain_rate: 5.0, gain: 5.0 / target }));
    }
    let mut seen = Sheared { most: 0, wraps: 0, shortest: side, longest: side };
    let mut last_offset = sim.domain().le_offset;
    while sim.time() * SHEAR_RATE < 3.0 {
        for _ in 0..5 {
            sim.step().expect("stable");
        }
        if sim.domain().le_offset < last_offset {
            seen.wraps += 1;
        }
        last_offset = sim.domain().le_offset;
        let ly = sim.domain().length(1);
        (seen.shortest, seen.longest) = (seen.shortest.min(ly), seen.longest.max(ly));
        seen.most = seen.most.max(check(&sim, stage));
    }
    (seen, side, sim.domain().length(0))
}

/// Under Lees-Edwards shear the image offset grows and wraps around the box length: pairs that
/// cross the sheared boundary must still be found on both sides of the wrap.
#[test]
fn no_contact_is_missed_under_lees_edwards_shear() {
    let (seen, _, _) = shear_and_check(5, None, "shear");
    assert!(seen.wraps >= 2, "the offset must wrap around the box, wrapped {} times", seen.wraps);
    assert!(seen.most > N_SHEARED / 10, "the test must see many contacts, saw at most {}", seen.most);
}

/// The plane-shear cell: Lees-Edwards shear while the height (y) is servo-controlled to a
/// normal stress, so the offset wraps and the sheared period changes length at once.
#[test]
fn no_contact_is_missed_under_shear_with_a_breathing_height() {
    let (seen, side, lx) = shear_and_check(6, Some(1e-3 * 1e5), "shear with servo");
    assert!(seen.wraps >= 2, "the offset must wrap around the box, wrapped {} times", seen.wraps);
    assert!(seen.longest - seen.shortest > 0.02 * side, "the height must move: {} .. {}", seen.shortest, seen.longest);
    assert_eq!(lx, side, "only the height is servo-controlled");
    assert!(seen.most > N_SHEARED / 10, "the test must see many contacts, saw at most {}", seen.most);
}
