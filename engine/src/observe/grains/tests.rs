//! The grains' measures on hand-made aggregates: area, shape, pairs, rattlers, pressure, and
//! grains across periodic boundaries.

use super::*;
use crate::particles::aggregate::Bonding;

fn grain(primaries: &[(Real, Real, Real)]) -> Particles {
    grain_in(2, &primaries.iter().map(|&(x, y, r)| (Vec3::new(x, y, 0.0), r)).collect::<Vec<_>>())
}

/// A walled box in `dim` dimensions (no periodic image).
fn walled(dim: usize) -> Domain {
    Domain { dim, lo: Vec3::repeat(-10.0), hi: Vec3::repeat(10.0), periodic: [false; 3], shear_rate: 0.0, le_offset: 0.0 }
}

/// A 2D box from the origin, `length` long and periodic along x, 10 high and walled along y.
fn periodic_along_x(length: Real) -> Domain {
    Domain { dim: 2, lo: Vec3::zeros(), hi: Vec3::new(length, 10.0, 0.0), periodic: [true, false, false], shear_rate: 0.0, le_offset: 0.0 }
}

/// One grain in `dim` dimensions of the primaries at these centres and radii.
fn grain_in(dim: usize, primaries: &[(Vec3, Real)]) -> Particles {
    let mut p = Particles::default();
    for &(x, r) in primaries {
        p.push(dim, x, Vec3::zeros(), r, 1000.0, 0, false);
        if let Some(a) = p.aggregate.last_mut() {
            *a = 0;
        }
    }
    p.bondings
        .push(Bonding { attraction: crate::contact::attraction_lj::AttractionLj { f0: 1.0, gamma: 7.0, cutoff: 1.0 }, friction: 0.0 });
    p
}

/// A square of four touching disks of radius 1: the closing by h = 1 fills the pore between
/// them (area of the union `4π` plus the pore `4 − π`) and rounds the outline's four
/// re-entrant notches, so the area lies between `4 + 3π` and the convex hull's `4 + 8 + π`;
/// on a hexagonal ring of seven disks the grain is round (aspect ratio 1 within 1e-12).
#[test]
fn a_grain_area_closes_its_pores_and_its_shape_is_round() {
    let square = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0), (0.0, 2.0, 1.0), (2.0, 2.0, 1.0)]);
    let shape = grain_shape(&square, &square.pos, 2, &[0, 1, 2, 3], 2.0);
    let pi = std::f64::consts::PI;
    assert!(shape.area > 4.0 + 3.0 * pi && shape.area < 12.0 + pi, "area {}", shape.area);
    assert!((shape.aspect_ratio - 1.0).abs() < 1e-12);
    let mut ring = vec![(0.0, 0.0, 1.0)];
    ring.extend((0..6).map(|k| {
        let a = k as Real * pi / 3.0;
        (2.0 * a.cos(), 2.0 * a.sin(), 1.0)
    }));
    let hex = grain(&ring);
    let s = grain_shape(&hex, &hex.pos, 2, &(0..7).collect::<Vec<_>>(), 2.0);
    assert!((s.aspect_ratio - 1.0).abs() < 1e-12, "aspect {}", s.aspect_ratio);
    // Two disks in a row: the second moments 2·(1)² + 2·(1/4) against 2·(1/4).
    let pair = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0)]);
    let s = grain_shape(&pair, &pair.pos, 2, &[0, 1], 2.0);
    assert!((s.aspect_ratio - 5.0f64.sqrt()).abs() < 1e-12, "aspect {}", s.aspect_ratio);
}

/// Makes the second primary of `p` a grain of its own and returns the contact of the two
/// pressed together by F = 3 along x (centres 2 apart).
fn into_two_grains(p: &mut Particles) -> ContactRecord {
    p.aggregate[1] = 1;
    let bond = p.bondings[0];
    p.bondings.push(bond);
    ContactRecord { i: 0, j: Some(1), force: Vec3::new(-3.0, 0.0, 0.0), branch: Vec3::new(-2.0, 0.0, 0.0), touching: true, bonded: false }
}

/// Two one-disk grains of radius 1 squeezed against each other by F = 3 along x: Z = 1 and
/// the grains' pressure `−Σ f·(x_c − x_g) / (2 ΣA) = 2F / (2 ΣA)` (each disk's force times
/// its radius); a contact without force counts for neither.
#[test]
fn two_grains_in_contact_share_a_pair_and_a_pressure() {
    let mut p = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0)]);
    let pressed = into_two_grains(&mut p);
    let idle = ContactRecord { force: Vec3::zeros(), ..pressed };
    let g = measure_grains(&p, 2, &[pressed, idle], 100.0, &walled(2)).expect("grains");
    assert_eq!((g.count, g.z), (2, 1.0));
    let area = 2.0 * g.mean_area;
    assert!((g.pressure - 3.0 / area).abs() < 1e-12 * g.pressure, "pressure {} against {}", g.pressure, 3.0 / area);
    assert!((g.phi - area / 100.0).abs() < 1e-15);
    let g = measure_grains(&p, 2, &[idle], 100.0, &walled(2)).expect("grains");
    assert_eq!((g.z, g.pressure), (0.0, 0.0));
}

/// Three grains on a floor (a walled box's y_min: contacts facing +y): grain 0 (two
/// primaries) touches only the floor, through both primaries; grains 1 and 2 (one primary
/// each) press on each other and on the floor. Z over the three is 2/3; grain 0's two wall
/// contacts are one wall, too few to keep it (a grain needs two), so the backbone is grains 1
/// and 2 and its coordination 1. Counting each wall contact apart would keep grain 0 (2/3).
#[test]
fn a_grain_on_one_wall_alone_is_a_rattler() {
    let mut p = grain(&[(0.0, 1.0, 1.0), (2.0, 1.0, 1.0), (6.0, 1.0, 1.0), (8.0, 1.0, 1.0)]);
    let bond = p.bondings[0];
    p.bondings.extend([bond, bond]);
    p.aggregate[2] = 1;
    p.aggregate[3] = 2;
    let floor = |i: u32| ContactRecord {
        i,
        j: None,
        force: Vec3::new(0.0, 1.0, 0.0),
        branch: Vec3::new(0.0, 1.0, 0.0),
        touching: true,
        bonded: false,
    };
    let between = ContactRecord {
        i: 2,
        j: Some(3),
        force: Vec3::new(-1.0, 0.0, 0.0),
        branch: Vec3::new(-2.0, 0.0, 0.0),
        touching: true,
        bonded: false,
    };
    let g = measure_grains(&p, 2, &[floor(0), floor(1), floor(2), floor(3), between], 100.0, &walled(2)).expect("grains");
    assert!((g.z - 2.0 / 3.0).abs() < 1e-15, "Z {}", g.z);
    assert_eq!(g.z_no_rattlers, 1.0);
    // A second wall (x_min: contacts facing +x) keeps grain 0 in the backbone.
    let side = ContactRecord { branch: Vec3::new(1.0, 0.0, 0.0), force: Vec3::new(1.0, 0.0, 0.0), ..floor(0) };
    let g = measure_grains(&p, 2, &[floor(0), floor(1), side, floor(2), floor(3), between], 100.0, &walled(2)).expect("grains");
    assert!((g.z_no_rattlers - 2.0 / 3.0).abs() < 1e-15, "Z without rattlers {}", g.z_no_rattlers);
}

/// A sample of aggregates ([`super::super::metrics::measure`]) reports the grains' Φ and Z
/// in its own fields, the same as its `grains` block, and the primaries' beside them: two
/// grains of two disks of radius 1 in a box of area 100, pressed by one contact, each
/// grain's own primaries bonded. The primaries' Φ is their disks' area, 4π / 100, their Z
/// counts the bonds (3 pairs over 4 disks); the grains' Φ is larger (closed outlines) and
/// their Z is 1.
#[test]
fn a_sample_of_aggregates_reports_its_grains_and_its_primaries() {
    let mut p = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0), (4.0, 0.0, 1.0), (6.0, 0.0, 1.0)]);
    let bond = p.bondings[0];
    p.bondings.push(bond);
    p.aggregate[2] = 1;
    p.aggregate[3] = 1;
    let pair = |i: u32, bonded: bool| ContactRecord {
        i,
        j: Some(i + 1),
        force: Vec3::new(-1.0, 0.0, 0.0),
        branch: Vec3::new(-2.0, 0.0, 0.0),
        touching: true,
        bonded,
    };
    let contacts = [pair(0, true), pair(1, false), pair(2, true)];
    let domain = walled(2);
    let view = super::super::metrics::SystemView {
        dim: 2,
        step: 0,
        time: 0.0,
        particles: &p,
        volume: 100.0,
        contacts: &contacts,
        walls: &[],
        shear: None,
        elastic_energy: 0.0,
        rattler_threshold: 3,
        drum: None,
        deformable: None,
        domain: &domain,
    };
    let s = super::super::metrics::measure(&view);
    let g = s.grains.as_deref().copied().expect("grains");
    let primaries = s.primaries.expect("primaries");
    assert_eq!((s.phi, s.z, s.z_no_rattlers), (g.phi, g.z, g.z_no_rattlers));
    assert_eq!((g.count, g.z), (2, 1.0));
    assert!((primaries.phi - 4.0 * std::f64::consts::PI / 100.0).abs() < 1e-15 && primaries.z == 1.5, "{primaries:?}");
    assert!(g.phi > primaries.phi * 1.05, "the grains' outline closes their pores: {} against {}", g.phi, primaries.phi);
}

/// One disk alone: closing changes nothing, the area is `π r²` within the grid's error
/// (cells of r/32, as a grain of 1.6 mm has with primaries of 0.1 mm: under 1%).
#[test]
fn a_lone_disk_keeps_its_area() {
    let one = grain(&[(0.3, -0.2, 1.0)]);
    let s = grain_shape(&one, &one.pos, 2, &[0], 0.25);
    let exact = std::f64::consts::PI;
    assert!((s.area - exact).abs() < 0.01 * exact, "area {} against {exact}", s.area);
}

/// In 3D: one ball alone keeps its volume `4/3 π r³` within 1.5% (cells of r/16: measured
/// +2.8%, +1.0% and +0.4% at r/8, r/16 and r/32, about a tenth of a cell too far out); six balls of
/// radius 1 touching a seventh at the centre along the axes make a round grain (aspect
/// ratio 1 within 1e-12) whose volume lies between the union's `7 · 4/3 π` and the cube
/// that holds them, its pores closed; two balls in a row have the aspect ratio
/// `sqrt((2 + 2/5) / (2/5)) = sqrt(6)`; two one-ball grains pressed by F = 3 have Z = 1 and
/// the pressure `2F / (3 ΣV)`.
#[test]
fn in_3d_a_grain_has_its_volume_and_shape() {
    let ball = 4.0 / 3.0 * std::f64::consts::PI;
    let one = grain_in(3, &[(Vec3::new(0.3, -0.2, 0.1), 1.0)]);
    let s = grain_shape(&one, &one.pos, 3, &[0], 0.25);
    assert!((s.area - ball).abs() < 0.015 * ball, "volume {} against {ball}", s.area);
    let mut seven = vec![(Vec3::zeros(), 1.0)];
    for a in 0..3 {
        for sign in [-2.0, 2.0] {
            let mut x = Vec3::zeros();
            x[a] = sign;
            seven.push((x, 1.0));
        }
    }
    let cluster = grain_in(3, &seven);
    let s = grain_shape(&cluster, &cluster.pos, 3, &(0..7).collect::<Vec<_>>(), 2.0);
    assert!((s.aspect_ratio - 1.0).abs() < 1e-12, "aspect {}", s.aspect_ratio);
    // Bounded above by the cube of side 6 that holds the seven.
    assert!(s.area > 7.0 * ball && s.area < 216.0, "volume {}", s.area);
    let pair = grain_in(3, &[(Vec3::zeros(), 1.0), (Vec3::new(2.0, 0.0, 0.0), 1.0)]);
    let s = grain_shape(&pair, &pair.pos, 3, &[0, 1], 2.0);
    assert!((s.aspect_ratio - 6.0f64.sqrt()).abs() < 1e-12, "aspect {}", s.aspect_ratio);
    let mut p = pair;
    let pressed = into_two_grains(&mut p);
    let g = measure_grains(&p, 3, &[pressed], 1000.0, &walled(3)).expect("grains");
    assert_eq!((g.count, g.z), (2, 1.0));
    let volume = 2.0 * g.mean_area;
    assert!((g.pressure - 6.0 / (3.0 * volume)).abs() < 1e-12 * g.pressure, "pressure {}", g.pressure);
}

/// A grain across a periodic boundary is measured whole: a ring of seven disks about
/// x = 0 in a box periodic along x from 0 to 10, its primaries left of the boundary at their
/// images near x = 10, has the area (within a few grid cells) and aspect ratio it has inside
/// the box about x = 5; and two one-disk grains pressed across the boundary share a pair and
/// the pressure they have inside.
#[test]
fn a_grain_across_a_periodic_boundary_is_measured_whole() {
    let pi = std::f64::consts::PI;
    let ring = |x0: f64| {
        let mut r = vec![(Vec3::new(x0, 5.0, 0.0), 1.0)];
        r.extend((0..6).map(|k| {
            let a = k as Real * pi / 3.0 + 0.3;
            (Vec3::new((x0 + 2.0 * a.cos()).rem_euclid(10.0), 5.0 + 2.0 * a.sin(), 0.0), 1.0)
        }));
        grain_in(2, &r)
    };
    let periodic = periodic_along_x(10.0);
    let inside = measure_grains(&ring(5.0), 2, &[], 100.0, &periodic).expect("grains");
    let across = measure_grains(&ring(0.0), 2, &[], 100.0, &periodic).expect("grains");
    // The grid's cells fall differently by round-off: within a few cells (of 1/16 each).
    assert!((across.mean_area - inside.mean_area).abs() < 0.005 * inside.mean_area, "{across:?} against {inside:?}");
    assert!((across.max_aspect_ratio - inside.max_aspect_ratio).abs() < 1e-9, "{across:?} against {inside:?}");
    // Walled, the same primaries make a grain split in two far apart: no longer round.
    let split = measure_grains(&ring(0.0), 2, &[], 100.0, &walled(2)).expect("grains");
    assert!(split.max_aspect_ratio > 2.0, "{split:?}");
    // Two one-disk grains at x = 9.5 and 1.5 (2 apart through the boundary), pressed by F = 3.
    let mut p = grain(&[(9.5, 5.0, 1.0), (1.5, 5.0, 1.0)]);
    let pressed = into_two_grains(&mut p);
    let g = measure_grains(&p, 2, &[pressed], 100.0, &periodic).expect("grains");
    let area = 2.0 * g.mean_area;
    assert_eq!(g.z, 1.0);
    assert!((g.pressure - 3.0 / area).abs() < 1e-12 * g.pressure, "pressure {} against {}", g.pressure, 3.0 / area);
}

/// In a cell a grain or two across, the contacts with an image count as contacts between
/// grains. Along x, period 4:
///
/// - a grain of two disks of radius 1 at x = 1 and 2.9, pressed by F = 3 against its own
///   image (its second disk against the first's image at x = 5) has Z = 2 (a neighbour on
///   each side) and the pressure of Love–Weber across the cell, `F L / (2 A)`; before, this
///   contact counted as one inside the grain: no load, no neighbour;
/// - two one-disk grains at x = 1 and 3, pressed by F = 3 on both sides (directly and
///   through the boundary), make two pairs (Z = 2, not 1) and twice one contact's pressure.
#[test]
fn a_grain_pressed_against_its_own_image_in_a_small_cell_is_loaded() {
    let cell = periodic_along_x(4.0);
    let long = grain(&[(1.0, 5.0, 1.0), (2.9, 5.0, 1.0)]);
    let inside = ContactRecord {
        i: 0,
        j: Some(1),
        force: Vec3::new(1.0, 0.0, 0.0),
        branch: Vec3::new(-1.9, 0.0, 0.0),
        touching: true,
        bonded: true,
    };
    let against_image = ContactRecord {
        i: 1,
        j: Some(0),
        force: Vec3::new(-3.0, 0.0, 0.0),
        branch: Vec3::new(-2.1, 0.0, 0.0),
        touching: true,
        bonded: false,
    };
    let g = measure_grains(&long, 2, &[inside, against_image], 40.0, &cell).expect("grains");
    assert_eq!((g.count, g.z), (1, 2.0));
    assert!((g.pressure - 3.0 * 4.0 / (2.0 * g.mean_area)).abs() < 1e-12 * g.pressure, "pressure {}", g.pressure);
    let alone = measure_grains(&long, 2, &[inside], 40.0, &cell).expect("grains");
    assert_eq!((alone.z, alone.pressure), (0.0, 0.0));

    let mut p = grain(&[(1.0, 5.0, 1.0), (3.0, 5.0, 1.0)]);
    let direct = into_two_grains(&mut p);
    let through = ContactRecord { force: Vec3::new(3.0, 0.0, 0.0), branch: Vec3::new(2.0, 0.0, 0.0), ..direct };
    let g = measure_grains(&p, 2, &[direct, through], 40.0, &cell).expect("grains");
    let area = 2.0 * g.mean_area;
    assert_eq!(g.z, 2.0);
    assert!((g.pressure - 6.0 / area).abs() < 1e-12 * g.pressure, "pressure {} against {}", g.pressure, 6.0 / area);
    // The same contact twice is one pair.
    assert_eq!(measure_grains(&p, 2, &[direct, direct], 40.0, &cell).expect("grains").z, 1.0);
}
