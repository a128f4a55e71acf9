//! The simulation box: bounds, periodic axes, Lees-Edwards shear, minimum images.
//!
//! Lees-Edwards convention: flow along x, gradient along y. The periodic image of the box one
//! period up (y + L_y) is shifted by `offset` along x and moves at `+shear_rate L_y` along x, so
//! the mean flow is `u_x = shear_rate y + const`.

use crate::math::{Real, Vec3};

/// The box and its boundary conditions.
#[derive(Debug, Clone, PartialEq)]
pub struct Domain {
    /// 2 or 3.
    pub dim: usize,
    /// Lower corner, m (on walled axes: the walls' positions).
    pub lo: Vec3,
    /// Upper corner, m.
    pub hi: Vec3,
    /// Periodic axes.
    pub periodic: [bool; 3],
    /// Lees-Edwards shear rate, 1/s (0 without Lees-Edwards).
    pub shear_rate: Real,
    /// Current Lees-Edwards offset along x, m, in [0, L_x).
    pub le_offset: Real,
}

impl Domain {
    /// Box length along axis `a`, m.
    #[inline(always)]
    pub fn length(&self, a: usize) -> Real {
        self.hi[a] - self.lo[a]
    }

    /// Volume (area in 2D, per metre of thickness), m³.
    pub fn volume(&self) -> Real {
        (0..self.dim).map(|a| self.length(a)).product()
    }

    /// True if Lees-Edwards shear is active.
    #[inline(always)]
    pub fn sheared(&self) -> bool {
        self.shear_rate != 0.0
    }

    /// True if the periodic images along y are shifted along x: a Lees-Edwards cell, sheared now
    /// or before (its offset stays when the shear stops).
    #[inline(always)]
    pub fn shifted_images(&self) -> bool {
        self.shear_rate != 0.0 || self.le_offset != 0.0
    }

    /// Minimum-image separation `r_i - r_j'` and the x-velocity of the image j' relative to j
    /// (`k shear_rate L_y`), so that the relative velocity is `v_i - v_j - (that, 0, 0)`.
    /// Both particles must lie in the box (as [`Domain::wrap`] keeps them), so one period at
    /// most separates them; comparisons replace `round`, which is a library call on baseline
    /// x86-64 and dominated the force loop.
    #[inline(always)]
    pub fn separation(&self, pi: &Vec3, pj: &Vec3) -> (Vec3, Real) {
        let mut d = pi - pj;
        let mut dvx = 0.0;
        if self.periodic[1] {
            let ly = self.hi.y - self.lo.y;
            let k = if d.y > 0.5 * ly {
                1.0
            } else if d.y < -0.5 * ly {
                -1.0
            } else {
                0.0
            };
            if k != 0.0 {
                // The offset may be non-zero without shear (a state saved from a sheared cell).
                d.y -= k * ly;
                d.x -= k * self.le_offset;
                dvx = k * self.shear_rate * ly;
            }
        }
        if self.periodic[0] {
            let lx = self.hi.x - self.lo.x;
            // After a Lees-Edwards shift |d.x| may reach 1.5 L_x.
            while d.x > 0.5 * lx {
                d.x -= lx;
            }
            while d.x < -0.5 * lx {
                d.x += lx;
            }
        }
        if self.periodic[2] {
            let lz = self.hi.z - self.lo.z;
            if d.z > 0.5 * lz {
                d.z -= lz;
            } else if d.z < -0.5 * lz {
                d.z += lz;
            }
        }
        (d, dvx)
    }

    /// Minimum-image separation `r_i - r_j'` and the periodic image of j used, as the number of
    /// periods `k` crossed along each axis (`r_j' = r_j + image_shift(k)`). Valid for positions
    /// within a few periods of the box.
    pub fn image(&self, pi: &Vec3, pj: &Vec3) -> (Vec3, [i8; 3]) {
        let mut d = pi - pj;
        let mut k = [0i8; 3];
        if self.periodic[1] {
            let ly = self.length(1);
            while d.y > 0.5 * ly {
                d.y -= ly;
                d.x -= self.le_offset;
                k[1] += 1;
            }
            while d.y < -0.5 * ly {
                d.y += ly;
                d.x += self.le_offset;
                k[1] -= 1;
            }
        }
        for a in [0, 2] {
            if self.periodic[a] {
                let l = self.length(a);
                while d[a] > 0.5 * l {
                    d[a] -= l;
                    k[a] += 1;
                }
                while d[a] < -0.5 * l {
                    d[a] += l;
                    k[a] -= 1;
                }
            }
        }
        (d, k)
    }

    /// Displacement of the image of a particle `k` periods away (Lees-Edwards: each period along
    /// y also shifts x by the current offset).
    #[inline(always)]
    pub fn image_shift(&self, k: [i8; 3]) -> Vec3 {
        let (kx, ky, kz) = (k[0] as Real, k[1] as Real, k[2] as Real);
        Vec3::new(kx * (self.hi.x - self.lo.x) + ky * self.le_offset, ky * (self.hi.y - self.lo.y), kz * (self.hi.z - self.lo.z))
    }

    /// Relative x-velocity of an image `ky` periods up along y (Lees-Edwards), m/s.
    #[inline(always)]
    pub fn image_velocity(&self, ky: i8) -> Real {
        ky as Real * self.shear_rate * (self.hi.y - self.lo.y)
    }

    /// Brings a particle back into the box on periodic axes (Lees-Edwards: crossing y shifts x by
    /// the offset and x-velocity by `shear_rate L_y`).
    #[inline(always)]
    pub fn wrap(&self, pos: &mut Vec3, vel: &mut Vec3) {
        if self.periodic[1] {
            let ly = self.length(1);
            while pos.y >= self.hi.y {
                pos.y -= ly;
                pos.x -= self.le_offset;
                vel.x -= self.shear_rate * ly;
            }
            while pos.y < self.lo.y {
                pos.y += ly;
                pos.x += self.le_offset;
                vel.x += self.shear_rate * ly;
            }
        }
        for a in [0, 2] {
            if self.periodic[a] {
                let l = self.length(a);
                if pos[a] >= self.hi[a] || pos[a] < self.lo[a] {
                    pos[a] -= ((pos[a] - self.lo[a]) / l).floor() * l;
                    // Guard against rounding that lands exactly on hi.
                    if pos[a] >= self.hi[a] {
                        pos[a] = self.lo[a];
                    }
                }
            }
        }
    }

    /// Advances the Lees-Edwards offset by `dt`.
    pub fn advance_shear(&mut self, dt: Real) {
        if self.shear_rate != 0.0 {
            let lx = self.length(0);
            self.le_offset += self.shear_rate * self.length(1) * dt;
            self.le_offset -= (self.le_offset / lx).floor() * lx;
        }
    }
}
