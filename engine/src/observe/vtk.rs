//! Snapshots as VTK XML PolyData files (`.vtp`) and a ParaView collection (`.pvd`).
//!
//! For each snapshot `k` a series writes three files: `particles_<k>.vtp` (one vertex per particle
//! with point arrays `radius`, `velocity`, `omega`, `force`, `coordination`; show them with the
//! Glyph filter, sphere glyphs scaled by `radius`, scale factor 2; for deformable grains one
//! quad per material point instead, [`material_points_vtp`]), `contacts_<k>.vtp` (one line
//! per contact from the centre of i to the centre of j's interacting image — lines never cross a
//! periodic box — with cell arrays `normal_force` (N, positive in compression),
//! `tangential_force` (N, magnitude), `force` (N, on i), `branch` (m, `r_i - r_j`), `bonded`;
//! wall contacts are left out) and `walls_<k>.vtp` (each wall as the face of the box it closes —
//! a quad in 3D, a segment in 2D — with cell arrays `force` and `normal`). `snapshots.pvd` lists
//! them with their simulated times as parts 0, 1 and 2, so ParaView opens the whole series at
//! once. ASCII with 10 significant digits: readable, and exact enough for plots.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::snapshot::{MaterialPoints, Snapshot, DRUM_SEGMENTS};
use crate::math::{Real, Vec3};

/// Errors of the snapshot writer.
#[derive(Debug, thiserror::Error)]
pub enum VtkError {
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

fn vec_array(out: &mut String, name: &str, values: impl Iterator<Item = Vec3>) {
    let _ = writeln!(out, r#"        <DataArray type="Float64" Name="{name}" NumberOfComponents="3" format="ascii">"#);
    for v in values {
        let _ = writeln!(out, "          {:.9e} {:.9e} {:.9e}", v.x, v.y, v.z);
    }
    out.push_str("        </DataArray>\n");
}

fn scalar_array<T: std::fmt::Display>(out: &mut String, name: &str, ty: &str, values: impl Iterator<Item = T>) {
    let _ = writeln!(out, r#"        <DataArray type="{ty}" Name="{name}" format="ascii">"#);
    for v in values {
        let _ = writeln!(out, "          {v}");
    }
    out.push_str("        </DataArray>\n");
}

fn sci(x: f64) -> String {
    format!("{x:.9e}")
}

/// Points section followed by the given topology (`Verts`, `Lines` or `Polys`).
fn poly_data(points: &[Vec3], topology: &str, connectivity: &[Vec<usize>], point_data: &str, cell_data: &str) -> String {
    let (nv, nl, np) = match topology {
        "Verts" => (connectivity.len(), 0, 0),
        "Lines" => (0, connectivity.len(), 0),
        _ => (0, 0, connectivity.len()),
    };
    let mut out = String::with_capacity(64 * points.len() + 256);
    out.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PolyData>\n");
    let _ = writeln!(
        out,
        r#"    <Piece NumberOfPoints="{}" NumberOfVerts="{nv}" NumberOfLines="{nl}" NumberOfStrips="0" NumberOfPolys="{np}">"#,
        points.len()
    );
    out.push_str("      <Points>\n");
    vec_array(&mut out, "points", points.iter().copied());
    out.push_str("      </Points>\n");
    out.push_str("      <PointData>\n");
    out.push_str(point_data);
    out.push_str("      </PointData>\n      <CellData>\n");
    out.push_str(cell_data);
    out.push_str("      </CellData>\n");
    let _ = writeln!(out, "      <{topology}>");
    scalar_array(&mut out, "connectivity", "Int64", connectivity.iter().flatten());
    let mut end = 0;
    scalar_array(
        &mut out,
        "offsets",
        "Int64",
        connectivity.iter().map(|c| {
            end += c.len();
            end
        }),
    );
    let _ = writeln!(out, "      </{topology}>");
    out.push_str("    </Piece>\n  </PolyData>\n</VTKFile>\n");
    out
}

/// The particles as vertices with their point arrays; deformable grains as their material
/// points ([`material_points_vtp`]).
pub fn particles_vtp(s: &Snapshot) -> String {
    if let Some(m) = &s.material_points {
        return material_points_vtp(m);
    }
    let mut pd = String::new();
    scalar_array(&mut pd, "radius", "Float64", s.radius.iter().map(|&r| sci(r)));
    vec_array(&mut pd, "velocity", s.velocity.iter().copied());
    vec_array(&mut pd, "omega", s.omega.iter().copied());
    vec_array(&mut pd, "force", s.force.iter().copied());
    scalar_array(&mut pd, "coordination", "Int32", s.coordination().into_iter());
    let verts: Vec<Vec<usize>> = (0..s.position.len()).map(|k| vec![k]).collect();
    poly_data(&s.position, "Verts", &verts, &pd, "")
}

/// Deformable grains as their material points: one quad per point (the parallelogram `F`
/// makes of its initial square) with cell arrays `grain`, `jacobian` (`det F`), `pressure` and
/// `mises` (Pa) and `velocity` (m/s). Colour by `grain` to see the grains' shapes, by
/// `pressure` to see the stress; where two grains' quads overlap, their contact let them
/// interpenetrate.
pub fn material_points_vtp(m: &MaterialPoints) -> String {
    let points: Vec<Vec3> = m.corners.iter().flatten().copied().collect();
    let quads: Vec<Vec<usize>> = (0..m.corners.len()).map(|k| (4 * k..4 * k + 4).collect()).collect();
    let mut cd = String::new();
    scalar_array(&mut cd, "grain", "Int32", m.grain.iter());
    scalar_array(&mut cd, "jacobian", "Float64", m.jacobian.iter().map(|&x| sci(x)));
    scalar_array(&mut cd, "pressure", "Float64", m.pressure.iter().map(|&x| sci(x)));
    scalar_array(&mut cd, "mises", "Float64", m.mises.iter().map(|&x| sci(x)));
    vec_array(&mut cd, "velocity", m.velocity.iter().copied());
    poly_data(&points, "Polys", &quads, "", &cd)
}

/// The contact network: one line per particle-particle contact.
pub fn contacts_vtp(s: &Snapshot) -> String {
    let pairs: Vec<_> = s.contacts.iter().filter(|c| c.j.is_some()).collect();
    let mut points = Vec::with_capacity(2 * pairs.len());
    let mut lines = Vec::with_capacity(pairs.len());
    for (k, c) in pairs.iter().enumerate() {
        let ri = s.position[c.i as usize];
        points.push(ri);
        points.push(ri - c.branch);
        lines.push(vec![2 * k, 2 * k + 1]);
    }
    let normal = |c: &&crate::observe::ContactRecord| {
        let len = c.branch.norm();
        if len > 0.0 {
            c.branch / len
        } else {
            Vec3::zeros()
        }
    };
    let mut cd = String::new();
    scalar_array(&mut cd, "normal_force", "Float64", pairs.iter().map(|c| sci(c.force.dot(&normal(c)))));
    scalar_array(
        &mut cd,
        "tangential_force",
        "Float64",
        pairs.iter().map(|c| {
            let n = normal(c);
            sci((c.force - n * c.force.dot(&n)).norm())
        }),
    );
    vec_array(&mut cd, "force", pairs.iter().map(|c| c.force));
    vec_array(&mut cd, "branch", pairs.iter().map(|c| c.branch));
    scalar_array(&mut cd, "bonded", "Int32", pairs.iter().map(|c| i32::from(c.bonded)));
    poly_data(&points, "Lines", &lines, "", &cd)
}

/// The walls as faces of the box.
/// The rotating drum, if any, follows as [`DRUM_SEGMENTS`] segments (2D) or prism faces (3D)
/// with the force the grains put on each.
pub fn walls_vtp(s: &Snapshot) -> String {
    let mut points = Vec::new();
    let mut cells = Vec::new();
    for w in &s.walls {
        let a = w.axis;
        let others: Vec<usize> = (0..s.dim).filter(|&b| b != a).collect();
        let corner = |signs: &[bool]| {
            let mut p = Vec3::zeros();
            p[a] = w.position;
            for (&b, &up) in others.iter().zip(signs) {
                p[b] = if up { s.hi[b] } else { s.lo[b] };
            }
            p
        };
        let first = points.len();
        if s.dim == 2 {
            points.push(corner(&[false]));
            points.push(corner(&[true]));
            cells.push(vec![first, first + 1]);
        } else {
            for signs in [[false, false], [true, false], [true, true], [false, true]] {
                points.push(corner(&signs));
            }
            cells.push((first..first + 4).collect());
        }
    }
    let mut forces: Vec<Vec3> = s.walls.iter().map(|w| w.force).collect();
    let mut normals: Vec<Vec3> = s.walls.iter().map(|w| w.normal).collect();
    if let Some(d) = &s.drum {
        // The drum as a polygon (2D) or a prism (3D) spanning the box along its axis.
        let (a, b) = d.across();
        let point = |k: usize, end: bool| {
            let angle = k as Real * std::f64::consts::TAU / DRUM_SEGMENTS as Real;
            let mut p = d.center;
            p[a] += d.radius * angle.cos();
            p[b] += d.radius * angle.sin();
            p[d.axis] = if s.dim == 2 {
                0.0
            } else if end {
                s.hi[d.axis]
            } else {
                s.lo[d.axis]
            };
            p
        };
        for k in 0..DRUM_SEGMENTS {
            let first = points.len();
            let next = (k + 1) % DRUM_SEGMENTS;
            if s.dim == 2 {
                points.extend([point(k, false), point(next, false)]);
                cells.push(vec![first, first + 1]);
            } else {
                points.extend([point(k, false), point(next, false), point(next, true), point(k, true)]);
                cells.push((first..first + 4).collect());
            }
            let mid = (k as Real + 0.5) * std::f64::consts::TAU / DRUM_SEGMENTS as Real;
            let mut n = Vec3::zeros();
            n[a] = -mid.cos();
            n[b] = -mid.sin();
            normals.push(n);
            forces.push(d.segment_force[k]);
        }
    }
    let mut cd = String::new();
    vec_array(&mut cd, "force", forces.into_iter());
    vec_array(&mut cd, "normal", normals.into_iter());
    poly_data(&points, if s.dim == 2 { "Lines" } else { "Polys" }, &cells, "", &cd)
}

/// A series of snapshots in one directory, indexed by `snapshots.pvd`.
#[derive(Debug)]
pub struct SnapshotSeries {
    dir: PathBuf,
    /// (time, index) of each snapshot written.
    entries: Vec<(f64, usize)>,
}

impl SnapshotSeries {
    /// A series writing into `dir` (created if missing).
    pub fn create(dir: &Path) -> Result<Self, VtkError> {
        std::fs::create_dir_all(dir).map_err(|source| VtkError::Io { path: dir.to_path_buf(), source })?;
        Ok(Self { dir: dir.to_path_buf(), entries: Vec::new() })
    }

    /// Number of snapshots written.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True before the first snapshot.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// File names of snapshot `index` (particles, contacts, walls).
    pub fn file_names(index: usize) -> [String; 3] {
        ["particles", "contacts", "walls"].map(|p| format!("{p}_{index:06}.vtp"))
    }

    fn write(&self, name: &str, text: &str) -> Result<(), VtkError> {
        let path = self.dir.join(name);
        let mut f = std::fs::File::create(&path).map_err(|source| VtkError::Io { path: path.clone(), source })?;
        f.write_all(text.as_bytes()).map_err(|source| VtkError::Io { path, source })
    }

    /// Writes the three files of `s` and rewrites the collection file.
    pub fn push(&mut self, s: &Snapshot) -> Result<(), VtkError> {
        let index = self.entries.len();
        let [p, c, w] = Self::file_names(index);
        self.write(&p, &particles_vtp(s))?;
        self.write(&c, &contacts_vtp(s))?;
        self.write(&w, &walls_vtp(s))?;
        self.entries.push((s.time, index));
        self.write("snapshots.pvd", &self.collection())
    }

    fn collection(&self) -> String {
        let mut out = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n  <Collection>\n");
        for &(t, index) in &self.entries {
            for (part, name) in Self::file_names(index).iter().enumerate() {
                let _ = writeln!(out, r#"    <DataSet timestep="{t:.12e}" part="{part}" file="{name}"/>"#);
            }
        }
        out.push_str("  </Collection>\n</VTKFile>\n");
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::{ContactRecord, WallFace};

    /// The values of the named data array, as numbers.
    fn array(doc: &roxmltree::Document<'_>, name: &str) -> Vec<f64> {
        let node = doc
            .descendants()
            .find(|n| n.has_tag_name("DataArray") && n.attribute("Name") == Some(name))
            .unwrap_or_else(|| panic!("no array {name}"));
        node.text().unwrap_or("").split_whitespace().map(|x| x.parse().expect("number")).collect()
    }

    fn piece<'a>(doc: &'a roxmltree::Document<'a>) -> roxmltree::Node<'a, 'a> {
        doc.descendants().find(|n| n.has_tag_name("Piece")).expect("a Piece")
    }

    /// Three spheres in a periodic box: 0 and 1 touch across the x boundary, 2 rests on a wall.
    fn scene() -> Snapshot {
        let (lo, hi) = (Vec3::zeros(), Vec3::new(0.01, 0.01, 0.01));
        let position = vec![Vec3::new(0.0004, 0.005, 0.005), Vec3::new(0.0096, 0.005, 0.005), Vec3::new(0.005, 0.005, 0.0005)];
        // r_0 - image of r_1 (one period to the left): (0.0004 - (0.0096 - 0.01), 0, 0).
        let branch = Vec3::new(0.0008, 0.0, 0.0);
        let pair_force = Vec3::new(2.0, 0.5, 0.0);
        Snapshot {
            dim: 3,
            step: 7,
            time: 1.5e-3,
            lo,
            hi,
            position,
            radius: vec![5e-4, 5e-4, 6e-4],
            velocity: vec![Vec3::new(1.0, 0.0, 0.0), Vec3::zeros(), Vec3::new(0.0, 0.0, -0.25)],
            omega: vec![Vec3::zeros(), Vec3::new(0.0, 0.0, 3.0), Vec3::zeros()],
            force: vec![pair_force, -pair_force, Vec3::new(0.0, 0.0, 1.0)],
            contacts: vec![
                ContactRecord { i: 0, j: Some(1), force: pair_force, branch, touching: true, bonded: false },
                ContactRecord {
                    i: 2,
                    j: None,
                    force: Vec3::new(0.0, 0.0, 1.0),
                    branch: Vec3::new(0.0, 0.0, 5e-4),
                    touching: true,
                    bonded: false,
                },
            ],
            walls: vec![
                WallFace { name: "z_min".into(), axis: 2, position: 0.0, normal: Vec3::z(), force: Vec3::new(0.0, 0.0, -1.0) },
                WallFace { name: "z_max".into(), axis: 2, position: 0.01, normal: -Vec3::z(), force: Vec3::zeros() },
            ],
            drum: None,
            material_points: None,
        }
    }

    #[test]
    fn the_drum_is_a_prism_of_segments_with_their_forces() {
        let mut s = scene();
        let mut shell = crate::observe::snapshot::DrumShell {
            axis: 0,
            center: Vec3::new(0.0, 0.005, 0.005),
            radius: 0.005,
            segment_force: vec![Vec3::zeros(); DRUM_SEGMENTS],
        };
        // A grain pushing on the drum at its lowest point (z = 0, angle 3π/2 from y towards z).
        let k = shell.segment_of(&Vec3::new(0.003, 0.005, 0.0));
        assert_eq!(k, 3 * DRUM_SEGMENTS / 4);
        shell.segment_force[k] = Vec3::new(0.0, 0.0, -2.0);
        s.drum = Some(shell);
        let text = walls_vtp(&s);
        let doc = roxmltree::Document::parse(&text).expect("well-formed XML");
        assert_eq!(piece(&doc).attribute("NumberOfPolys"), Some(format!("{}", 2 + DRUM_SEGMENTS).as_str()));
        // Every drum corner lies on the cylinder, at one end of the box along x.
        let points = array(&doc, "points");
        for p in points.chunks(3).skip(8) {
            let r = ((p[1] - 0.005).powi(2) + (p[2] - 0.005).powi(2)).sqrt();
            assert!((r - 0.005).abs() < 1e-12 && (p[0] == 0.0 || p[0] == 0.01), "{p:?}");
        }
        let force = array(&doc, "force");
        assert_eq!(force[3 * (2 + k) + 2], -2.0);
        // Normals point to the axis: at the bottom, +z.
        let normal = array(&doc, "normal");
        assert!((normal[3 * (2 + k) + 2] - 1.0).abs() < 0.01);
    }

    #[test]
    fn particles_carry_every_array() {
        let s = scene();
        let text = particles_vtp(&s);
        let doc = roxmltree::Document::parse(&text).expect("well-formed XML");
        assert_eq!(piece(&doc).attribute("NumberOfPoints"), Some("3"));
        assert_eq!(piece(&doc).attribute("NumberOfVerts"), Some("3"));
        let points = array(&doc, "points");
        assert_eq!(points.len(), 9);
        for (k, p) in s.position.iter().enumerate() {
            for a in 0..3 {
                assert!((points[3 * k + a] - p[a]).abs() <= 1e-9 * p[a].abs().max(1e-12));
            }
        }
        assert_eq!(array(&doc, "radius"), vec![5e-4, 5e-4, 6e-4]);
        assert_eq!(array(&doc, "velocity")[8], -0.25);
        assert_eq!(array(&doc, "omega")[5], 3.0);
        assert_eq!(array(&doc, "force")[..3], [2.0, 0.5, 0.0]);
        // The wall contact does not count in the coordination.
        assert_eq!(array(&doc, "coordination"), vec![1.0, 1.0, 0.0]);
        assert_eq!(array(&doc, "offsets"), vec![1.0, 2.0, 3.0]);
    }

    #[test]
    fn contact_lines_follow_the_branch_across_the_periodic_boundary() {
        let s = scene();
        let text = contacts_vtp(&s);
        let doc = roxmltree::Document::parse(&text).expect("well-formed XML");
        assert_eq!(piece(&doc).attribute("NumberOfLines"), Some("1"));
        let points = array(&doc, "points");
        // From the centre of 0 to the image of 1 just left of the box, not across it.
        assert!((points[0] - 0.0004).abs() < 1e-15 && (points[3] - -0.0004).abs() < 1e-15, "{points:?}");
        // n = x; f = (2, 0.5, 0): normal 2 N (compression), tangential 0.5 N.
        assert_eq!(array(&doc, "normal_force"), vec![2.0]);
        assert_eq!(array(&doc, "tangential_force"), vec![0.5]);
        assert_eq!(array(&doc, "connectivity"), vec![0.0, 1.0]);
        assert_eq!(array(&doc, "bonded"), vec![0.0]);
    }

    #[test]
    fn walls_are_faces_of_the_box() {
        let mut s = scene();
        let doc_text = walls_vtp(&s);
        let doc = roxmltree::Document::parse(&doc_text).expect("well-formed XML");
        assert_eq!(piece(&doc).attribute("NumberOfPolys"), Some("2"));
        let points = array(&doc, "points");
        assert_eq!(points.len(), 2 * 4 * 3);
        // The upper wall's corners lie at z = 0.01 and span the box in x and y.
        let upper: Vec<&[f64]> = points.chunks(3).skip(4).collect();
        assert!(upper.iter().all(|p| p[2] == 0.01));
        assert_eq!(upper.iter().map(|p| p[0]).fold(f64::MAX, f64::min), 0.0);
        assert_eq!(upper.iter().map(|p| p[1]).fold(0.0, f64::max), 0.01);
        assert_eq!(array(&doc, "force")[2], -1.0);
        // In 2D a wall is a segment.
        s.dim = 2;
        let doc_text = walls_vtp(&s);
        let doc = roxmltree::Document::parse(&doc_text).expect("well-formed XML");
        assert_eq!(piece(&doc).attribute("NumberOfLines"), Some("2"));
        assert_eq!(array(&doc, "offsets"), vec![2.0, 4.0]);
    }

    #[test]
    fn a_series_indexes_its_files_with_their_times() {
        let dir = std::env::temp_dir().join(format!("sable-vtk-test-{}", std::process::id()));
        let mut series = SnapshotSeries::create(&dir).expect("directory");
        let mut s = scene();
        series.push(&s).expect("written");
        s.time = 3.0e-3;
        series.push(&s).expect("written");
        let pvd = std::fs::read_to_string(dir.join("snapshots.pvd")).expect("collection");
        let doc = roxmltree::Document::parse(&pvd).expect("well-formed XML");
        let sets: Vec<_> = doc.descendants().filter(|n| n.has_tag_name("DataSet")).collect();
        assert_eq!(sets.len(), 6);
        assert_eq!(sets[5].attribute("file"), Some("walls_000001.vtp"));
        assert_eq!(sets[5].attribute("part"), Some("2"));
        assert_eq!(sets[5].attribute("timestep").map(|t| t.parse::<f64>().expect("number")), Some(3.0e-3));
        for name in SnapshotSeries::file_names(1) {
            assert!(dir.join(&name).is_file(), "{name}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Deformable grains are drawn as one quad per material point with its cell arrays.
    #[test]
    fn material_points_are_quads_with_their_arrays() {
        let mut s = scene();
        let sq = |x: f64| [Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1e-4, 0.0, 0.0), Vec3::new(x + 1e-4, 1e-4, 0.0), Vec3::new(x, 1e-4, 0.0)];
        s.material_points = Some(MaterialPoints {
            grain: vec![0, 1],
            corners: vec![sq(0.0), sq(2e-4)],
            jacobian: vec![1.0, 0.98],
            pressure: vec![0.0, 1.5e4],
            mises: vec![0.0, 2.0e3],
            velocity: vec![Vec3::zeros(), Vec3::new(0.1, 0.0, 0.0)],
        });
        let text = particles_vtp(&s);
        let doc = roxmltree::Document::parse(&text).expect("valid XML");
        let p = piece(&doc);
        assert_eq!(p.attribute("NumberOfPoints"), Some("8"));
        assert_eq!(p.attribute("NumberOfPolys"), Some("2"));
        assert_eq!(p.attribute("NumberOfVerts"), Some("0"));
        assert_eq!(array(&doc, "grain"), vec![0.0, 1.0]);
        assert_eq!(array(&doc, "pressure"), vec![0.0, 1.5e4]);
        assert_eq!(array(&doc, "jacobian"), vec![1.0, 0.98]);
        assert_eq!(array(&doc, "offsets"), vec![4.0, 8.0]);
        assert_eq!(array(&doc, "velocity"), vec![0.0, 0.0, 0.0, 0.1, 0.0, 0.0]);
    }
}
