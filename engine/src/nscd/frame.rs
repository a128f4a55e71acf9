//! The local frame of a contact.

use crate::math::{Real, Vec3};

/// Orthonormal frame of a contact: `n` is the normal (from the second body towards the first),
/// `t1` and `t2` span the tangent plane. Local vectors are written `(n, t1, t2)` components.
/// In 2D, `n` and `t1` lie in the plane and `t2` is the z axis, along which nothing moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactFrame {
    /// Unit normal.
    pub n: Vec3,
    /// First unit tangent.
    pub t1: Vec3,
    /// Second unit tangent.
    pub t2: Vec3,
}

impl ContactFrame {
    /// The frame of unit normal `n` (`dim` 2: `n` in the xy plane).
    pub fn new(dim: usize, n: Vec3) -> Self {
        if dim == 2 {
            return Self { n, t1: Vec3::new(-n.y, n.x, 0.0), t2: Vec3::z() };
        }
        // The tangent from the axis least aligned with n (Frisvad-style choice, no branch on
        // a near-zero component).
        let a = if n.x.abs() < 0.57 {
            Vec3::x()
        } else if n.y.abs() < 0.57 {
            Vec3::y()
        } else {
            Vec3::z()
        };
        let t1 = (a - n * n.dot(&a)).normalize();
        let t2 = n.cross(&t1);
        Self { n, t1, t2 }
    }

    /// Components of a global vector in this frame.
    #[inline(always)]
    pub fn to_local(&self, v: &Vec3) -> Vec3 {
        Vec3::new(v.dot(&self.n), v.dot(&self.t1), v.dot(&self.t2))
    }

    /// The global vector of local components `l`.
    #[inline(always)]
    pub fn to_global(&self, l: &Vec3) -> Vec3 {
        self.n * l.x + self.t1 * l.y + self.t2 * l.z
    }
}

/// Magnitude of the tangential part of a local vector.
#[inline(always)]
pub fn tangential_norm(l: &Vec3) -> Real {
    (l.y * l.y + l.z * l.z).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_round_trip() {
        for n in [Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.9, 0.1, 0.0), Vec3::new(-0.3, 0.95, 0.05)] {
            let n = n.normalize();
            let f = ContactFrame::new(3, n);
            for (a, b) in [(f.n, f.t1), (f.n, f.t2), (f.t1, f.t2)] {
                assert!(a.dot(&b).abs() < 1e-14);
            }
            assert!((f.t1.norm() - 1.0).abs() < 1e-14 && (f.t2.norm() - 1.0).abs() < 1e-14);
            assert!((f.n.cross(&f.t1) - f.t2).norm() < 1e-14, "right-handed");
            let v = Vec3::new(0.3, -1.2, 2.5);
            assert!((f.to_global(&f.to_local(&v)) - v).norm() < 1e-14);
        }
        let f = ContactFrame::new(2, Vec3::new(0.6, 0.8, 0.0));
        assert_eq!(f.t1, Vec3::new(-0.8, 0.6, 0.0));
        assert_eq!(f.t2, Vec3::z());
    }
}
