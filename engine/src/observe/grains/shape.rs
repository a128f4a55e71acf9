//! One grain's area (volume in 3D), centre and aspect ratio from its primaries: the union of
//! their disks (balls) closed on a grid, holes filled, and their second moments (module
//! documentation of [`super`]).

use crate::math::{Real, Vec3};
use crate::particles::Particles;
use std::ops::Range;

/// Grid cells across the smallest primary's diameter for a grain's area (2D) and volume (3D).
const CELLS_PER_PRIMARY: [Real; 2] = [8.0, 4.0];

/// One grain's measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrainShape {
    /// Area, m² (volume in 3D, m³).
    pub area: Real,
    /// Centre of mass of its primaries, m.
    pub centre: Vec3,
    /// Aspect ratio.
    pub aspect_ratio: Real,
}

/// Area (volume in 3D), centre and aspect ratio of the grain made of primaries `members` of
/// `p` at positions `pos` (the grain whole) in `dim` dimensions (module documentation), `d_min`
/// the smallest primary's diameter.
pub fn grain_shape(p: &Particles, pos: &[Vec3], dim: usize, members: &[usize], d_min: Real) -> GrainShape {
    let mass: Real = members.iter().map(|&i| p.mass[i]).sum();
    if members.is_empty() || mass <= 0.0 {
        return GrainShape { area: 0.0, centre: Vec3::zeros(), aspect_ratio: 1.0 };
    }
    let centre = members.iter().fold(Vec3::zeros(), |s, &i| s + pos[i] * p.mass[i]) / mass;
    let aspect_ratio = if dim == 2 {
        // The in-plane second moments: Σ m (d d^T) plus each disk's own m r²/4 per axis.
        let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
        for &i in members {
            let d = pos[i] - centre;
            let own = 0.25 * p.mass[i] * p.radius[i] * p.radius[i];
            xx += p.mass[i] * d.x * d.x + own;
            yy += p.mass[i] * d.y * d.y + own;
            xy += p.mass[i] * d.x * d.y;
        }
        let (mean, half) = (0.5 * (xx + yy), (0.25 * (xx - yy) * (xx - yy) + xy * xy).sqrt());
        if mean - half > 0.0 {
            ((mean + half) / (mean - half)).sqrt()
        } else {
            Real::INFINITY
        }
    } else {
        // Σ m (d d^T) plus each ball's own m r²/5 per axis.
        let mut moments = nalgebra::Matrix3::<Real>::zeros();
        for &i in members {
            let d = pos[i] - centre;
            moments += d * d.transpose() * p.mass[i] + nalgebra::Matrix3::identity() * (0.2 * p.mass[i] * p.radius[i] * p.radius[i]);
        }
        let eigen = moments.symmetric_eigenvalues();
        let (lo, hi) = (eigen.min(), eigen.max());
        if lo > 0.0 {
            (hi / lo).sqrt()
        } else {
            Real::INFINITY
        }
    };
    GrainShape { area: closed_measure(p, pos, dim, members, d_min), centre, aspect_ratio }
}

/// Points spread evenly on the circle (2D) or sphere (3D) of radius `rho` about `x`, about
/// `spacing` apart (a golden-angle spiral on the sphere).
fn surface_points(x: Vec3, rho: Real, dim: usize, spacing: Real) -> impl Iterator<Item = Vec3> {
    let tau = std::f64::consts::TAU;
    let count =
        if dim == 2 { (tau * rho / spacing).ceil() } else { (2.0 * tau * rho * rho / (spacing * spacing)).ceil() }.max(1.0) as usize;
    let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
    (0..count).map(move |k| {
        if dim == 2 {
            let angle = tau * k as Real / count as Real;
            Vec3::new(x.x + rho * angle.cos(), x.y + rho * angle.sin(), x.z)
        } else {
            let z = 1.0 - (2.0 * k as Real + 1.0) / count as Real;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let angle = golden * k as Real;
            x + Vec3::new(s * angle.cos(), s * angle.sin(), z) * rho
        }
    })
}

/// Area (2D) or volume (3D) of the union of the primaries `members` closed by a disk (ball) of
/// radius `d_min / 2`, holes filled, on a grid of `d_min / CELLS_PER_PRIMARY` (a cell belongs
/// if its centre does).
fn closed_measure(p: &Particles, pos: &[Vec3], dim: usize, members: &[usize], d_min: Real) -> Real {
    let cell = d_min / CELLS_PER_PRIMARY[usize::from(dim == 3)];
    let reach = 0.5 * d_min;
    let grid = Grid::around(p, pos, dim, members, cell, reach);
    // Dilation: cells within r + h of a primary's centre.
    let mut closed = vec![false; grid.cells()];
    for &i in members {
        grid.paint(&mut closed, &pos[i], p.radius[i] + reach, true);
    }
    erode(&grid, p, pos, members, reach, &mut closed);
    // Holes: outside cells the frame cannot reach (through faces) belong to the grain.
    let outside = outside_cells(&grid, &closed);
    outside.iter().filter(|&&o| !o).count() as Real * cell.powi(dim as i32)
}

/// A grid of cubic cells (one layer at z = 0 in 2D) over a dilated grain and a frame of empty
/// cells around it.
struct Grid {
    /// Corner of the first cell.
    origin: Vec3,
    /// Side of a cell.
    cell: Real,
    /// Cells along each axis.
    n: [usize; 3],
    /// Dimension of the grains.
    dim: usize,
}

impl Grid {
    /// The grid of cells of side `cell` over the primaries `members` dilated by `reach`, with
    /// a frame of two empty cells.
    fn around(p: &Particles, pos: &[Vec3], dim: usize, members: &[usize], cell: Real, reach: Real) -> Self {
        let (mut lo, mut hi) = (Vec3::repeat(Real::INFINITY), Vec3::repeat(Real::NEG_INFINITY));
        for &i in members {
            let r = p.radius[i] + reach;
            for a in 0..dim {
                lo[a] = lo[a].min(pos[i][a] - r);
                hi[a] = hi[a].max(pos[i][a] + r);
            }
        }
        // A frame of empty cells around the dilated grain (one layer of cells in 2D, at z = 0).
        let mut origin = lo - Vec3::new(2.0 * cell, 2.0 * cell, 2.0 * cell);
        let count = |a: usize| ((hi[a] - lo[a]) / cell).ceil() as usize + 4;
        let (nx, ny) = (count(0), count(1));
        let nz = if dim == 3 {
            count(2)
        } else {
            origin.z = -0.5 * cell;
            1
        };
        Self { origin, cell, n: [nx, ny, nz], dim }
    }

    /// Number of cells.
    fn cells(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// Centre of cell `(ix, iy, iz)`.
    fn centre_of(&self, ix: usize, iy: usize, iz: usize) -> Vec3 {
        let (o, cell) = (self.origin, self.cell);
        Vec3::new(o.x + (ix as Real + 0.5) * cell, o.y + (iy as Real + 0.5) * cell, o.z + (iz as Real + 0.5) * cell)
    }

    /// Index of cell `(ix, iy, iz)` in a flat array.
    fn flat(&self, ix: usize, iy: usize, iz: usize) -> usize {
        (iz * self.n[1] + iy) * self.n[0] + ix
    }

    /// Cells within `radius` of the point x: their index ranges, per axis (end excluded).
    fn span(&self, x: &Vec3, radius: Real) -> (Range<usize>, Range<usize>, Range<usize>) {
        let k = |v: Real, o: Real, n: usize| (((v - o) / self.cell - 0.5).floor().max(0.0) as usize).min(n - 1);
        let range = |a: usize| {
            if a >= self.dim {
                0..1
            } else {
                k(x[a] - radius, self.origin[a], self.n[a])..(k(x[a] + radius, self.origin[a], self.n[a]) + 2).min(self.n[a])
            }
        };
        (range(0), range(1), range(2))
    }

    /// Sets to `value` the cells whose centre lies within `r` of `x`.
    fn paint(&self, cells: &mut [bool], x: &Vec3, r: Real, value: bool) {
        let (rx, ry, rz) = self.span(x, r + self.cell);
        for iz in rz {
            for iy in ry.clone() {
                for ix in rx.clone() {
                    if (self.centre_of(ix, iy, iz) - x).norm_squared() <= r * r {
                        cells[self.flat(ix, iy, iz)] = value;
                    }
                }
            }
        }
    }
}

/// Erosion: a dilated cell stays unless a point of the dilated set's boundary lies within
/// `reach` of it. The boundary is sampled exactly, every cell along each dilated circle (over
/// each dilated sphere) where no other covers it (cell centres outside the set would place it
/// up to a cell too far out: 20% too much area for a lone disk at r/4 cells).
fn erode(grid: &Grid, p: &Particles, pos: &[Vec3], members: &[usize], reach: Real, closed: &mut [bool]) {
    let (dim, origin) = (grid.dim, grid.origin);
    let bin = 2.0 * members.iter().map(|&i| p.radius[i]).fold(0.0, Real::max) + 2.0 * reach;
    let key = |x: &Vec3| {
        let k = |a: usize| if a < dim { ((x[a] - origin[a]) / bin).floor() as i64 } else { 0 };
        (k(0), k(1), k(2))
    };
    let mut bins: std::collections::HashMap<(i64, i64, i64), Vec<usize>> = std::collections::HashMap::new();
    for &i in members {
        bins.entry(key(&pos[i])).or_default().push(i);
    }
    let layers: i64 = if dim == 3 { 1 } else { 0 };
    for &i in members {
        for q in surface_points(pos[i], p.radius[i] + reach, dim, grid.cell) {
            let (bx, by, bz) = key(&q);
            let covered = (-layers..=layers).any(|dz| {
                (-1..=1).any(|dy| {
                    (-1..=1).any(|dx| {
                        bins.get(&(bx + dx, by + dy, bz + dz)).is_some_and(|list| {
                            list.iter().any(|&j| {
                                let r = p.radius[j] + reach;
                                j != i && (pos[j] - q).norm_squared() < r * r
                            })
                        })
                    })
                })
            });
            if !covered {
                grid.paint(closed, &q, reach, false);
            }
        }
    }
}

/// The cells outside the closed set reachable through faces from the grid's first cell, a
/// corner of the empty frame.
fn outside_cells(grid: &Grid, closed: &[bool]) -> Vec<bool> {
    let [nx, ny, nz] = grid.n;
    let mut outside = vec![false; grid.cells()];
    let mut stack = vec![0usize];
    outside[0] = true;
    while let Some(k) = stack.pop() {
        let (ix, iy, iz) = (k % nx, (k / nx) % ny, k / (nx * ny));
        let mut visit = |j: usize| {
            if !closed[j] && !outside[j] {
                outside[j] = true;
                stack.push(j);
            }
        };
        if ix > 0 {
            visit(k - 1);
        }
        if ix + 1 < nx {
            visit(k + 1);
        }
        if iy > 0 {
            visit(k - nx);
        }
        if iy + 1 < ny {
            visit(k + nx);
        }
        if iz > 0 {
            visit(k - nx * ny);
        }
        if iz + 1 < nz {
            visit(k + nx * ny);
        }
    }
    outside
}
