//! Structured meshes of four-node quadrilaterals: a grain's disk (an O-grid) and a rectangle
//! (blocks and beams of the tests).
//!
//! The disk's O-grid: a central square of half-side half the radius, `m × m` elements, wrapped
//! by `k` rings of `4m` elements whose inner loop is the square's perimeter and whose outer loop
//! is a regular `4m`-gon; the rings blend linearly from the square to the polygon, so every
//! element is convex and none is much smaller than the rest. The polygon's vertices are spaced
//! evenly along the circle, on the radius that gives the polygon the disk's area (the grain's
//! solid fraction is then that of the disks the scene describes). No meshing crate is needed for
//! one convex shape; a triangulator (spade, for instance) would give triangles, which lock when
//! the material is nearly incompressible.

use nalgebra::Vector2;

use crate::math::Real;

type V2 = Vector2<Real>;

/// A mesh of quadrilaterals, each with its nodes counter-clockwise.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Reference positions of the nodes, m.
    pub nodes: Vec<V2>,
    /// The elements' nodes, counter-clockwise.
    pub quads: Vec<[u32; 4]>,
    /// The boundary's nodes in counter-clockwise order (a closed loop; the segments join each
    /// to the next and the last to the first).
    pub boundary: Vec<u32>,
}

impl Mesh {
    /// The O-grid of a disk of centre `c` and radius `r` (m) with elements about `size` (m)
    /// along its boundary (module documentation): at least 8 boundary segments.
    pub fn disk(c: V2, r: Real, size: Real) -> Self {
        let m = ((std::f64::consts::PI * r / (2.0 * size)).round() as usize).max(2);
        let a = 0.5 * r;
        let k = (((r - a) / size).round() as usize).max(1);
        let perimeter = 4 * m;
        // The polygon of the disk's area.
        let big_n = perimeter as Real;
        let radius = r * (2.0 * std::f64::consts::PI / (big_n * (2.0 * std::f64::consts::PI / big_n).sin())).sqrt();
        let mut nodes = Vec::with_capacity((m + 1) * (m + 1) + k * perimeter);
        for j in 0..=m {
            for i in 0..=m {
                let s = |t: usize| -a + 2.0 * a * t as Real / m as Real;
                nodes.push(c + V2::new(s(i), s(j)));
            }
        }
        let central = |i: usize, j: usize| (j * (m + 1) + i) as u32;
        let mut quads = Vec::with_capacity(m * m + k * perimeter);
        for j in 0..m {
            for i in 0..m {
                quads.push([central(i, j), central(i + 1, j), central(i + 1, j + 1), central(i, j + 1)]);
            }
        }
        // The square's perimeter, counter-clockwise from its corner (a, -a).
        let loop0: Vec<u32> = (0..perimeter)
            .map(|q| {
                let (side, t) = (q / m, q % m);
                match side {
                    0 => central(m, t),
                    1 => central(m - t, m),
                    2 => central(0, m - t),
                    _ => central(t, 0),
                }
            })
            .collect();
        let mut inner = loop0.clone();
        for l in 1..=k {
            let tau = l as Real / k as Real;
            let outer: Vec<u32> = (0..perimeter)
                .map(|q| {
                    let square = nodes[loop0[q] as usize] - c;
                    let angle = -0.25 * std::f64::consts::PI + 2.0 * std::f64::consts::PI * q as Real / big_n;
                    let circle = V2::new(angle.cos(), angle.sin()) * radius;
                    nodes.push(c + square * (1.0 - tau) + circle * tau);
                    (nodes.len() - 1) as u32
                })
                .collect();
            for q in 0..perimeter {
                let next = (q + 1) % perimeter;
                quads.push([inner[q], outer[q], outer[next], inner[next]]);
            }
            inner = outer;
        }
        let mesh = Self { nodes, quads, boundary: inner };
        debug_assert!(mesh.quads.iter().all(|q| mesh.signed_area(q) > 0.0));
        mesh
    }

    /// A rectangle from `min` to `max` (m) in `nx × ny` elements; its boundary starts at `min`.
    pub fn rectangle(min: V2, max: V2, nx: usize, ny: usize) -> Self {
        let (nx, ny) = (nx.max(1), ny.max(1));
        let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1));
        for j in 0..=ny {
            for i in 0..=nx {
                let t = V2::new(i as Real / nx as Real, j as Real / ny as Real);
                nodes.push(min + (max - min).component_mul(&t));
            }
        }
        let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
        let mut quads = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                quads.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let mut boundary: Vec<u32> = (0..nx).map(|i| id(i, 0)).collect();
        boundary.extend((0..ny).map(|j| id(nx, j)));
        boundary.extend((0..nx).map(|i| id(nx - i, ny)));
        boundary.extend((0..ny).map(|j| id(0, ny - j)));
        Self { nodes, quads, boundary }
    }

    /// The signed area of element `q` at the reference positions, m² (positive when
    /// counter-clockwise).
    pub fn signed_area(&self, q: &[u32; 4]) -> Real {
        let p = |k: usize| self.nodes[q[k] as usize];
        let mut s = 0.0;
        for k in 0..4 {
            let (a, b) = (p(k), p((k + 1) % 4));
            s += a.x * b.y - a.y * b.x;
        }
        0.5 * s
    }

    /// Area of the mesh at the reference positions, m².
    pub fn area(&self) -> Real {
        self.quads.iter().map(|q| self.signed_area(q)).sum()
    }

    /// Longest edge of any element, m.
    pub fn largest_edge(&self) -> Real {
        self.quads
            .iter()
            .flat_map(|q| (0..4).map(move |k| (q[k], q[(k + 1) % 4])))
            .map(|(a, b)| (self.nodes[a as usize] - self.nodes[b as usize]).norm())
            .fold(0.0, Real::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_disk_mesh_has_the_disk_area_and_a_closed_boundary_loop() {
        for (r, size) in [(1.0, 0.25), (0.0012, 0.0002), (1.0, 2.0)] {
            let mesh = Mesh::disk(V2::new(0.3, -0.1), r, size);
            let exact = std::f64::consts::PI * r * r;
            assert!((mesh.area() - exact).abs() < 1e-12 * exact, "area {} against {exact}", mesh.area());
            assert!(mesh.quads.iter().all(|q| mesh.signed_area(q) > 0.0));
            // Each boundary segment is the edge of exactly one element, in the same direction.
            let edges: Vec<(u32, u32)> = mesh.quads.iter().flat_map(|q| (0..4).map(move |k| (q[k], q[(k + 1) % 4]))).collect();
            let n = mesh.boundary.len();
            assert!(n >= 8);
            for k in 0..n {
                let e = (mesh.boundary[k], mesh.boundary[(k + 1) % n]);
                assert_eq!(edges.iter().filter(|&&x| x == e).count(), 1, "boundary edge {e:?}");
                assert_eq!(edges.iter().filter(|&&x| x == (e.1, e.0)).count(), 0);
                // On the circle of the polygon with the disk's area.
                let d = (mesh.nodes[e.0 as usize] - V2::new(0.3, -0.1)).norm();
                let big_n = n as Real;
                let polygon = r * (2.0 * std::f64::consts::PI / (big_n * (2.0 * std::f64::consts::PI / big_n).sin())).sqrt();
                assert!((d / polygon - 1.0).abs() < 1e-12, "boundary node at {d} of a radius {r}");
            }
            // Interior edges are shared by two elements in opposite directions.
            let shared = edges.iter().filter(|e| edges.contains(&(e.1, e.0))).count();
            assert_eq!(shared + n, edges.len());
            let longest = mesh.largest_edge();
            assert!(longest < 1.6 * size.min(r), "longest edge {longest} for a size {size}");
        }
    }

    #[test]
    fn a_rectangle_mesh_has_its_area_and_boundary() {
        let mesh = Mesh::rectangle(V2::new(0.0, 0.0), V2::new(2.0, 0.5), 8, 2);
        assert_eq!((mesh.nodes.len(), mesh.quads.len(), mesh.boundary.len()), (27, 16, 20));
        assert!((mesh.area() - 1.0).abs() < 1e-14);
    }
}
