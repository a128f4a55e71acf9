//! Scalar and vector types used throughout the engine.
//!
//! Every simulation is stored in three dimensions. A 2D scene (disks) keeps every z component
//! at exactly zero: branch vectors, forces and velocities stay in the plane and torques and
//! angular velocities point along z, so one implementation serves both dimensions.

/// The floating-point type of every physical quantity (SI units).
pub type Real = f64;

/// A 3-vector of [`Real`].
pub type Vec3 = nalgebra::Vector3<Real>;

/// A 3x3 matrix of [`Real`] (stress tensors).
pub type Mat3 = nalgebra::Matrix3<Real>;

/// Axis names in order, used in field paths and wall names.
pub const AXES: [&str; 3] = ["x", "y", "z"];

/// Builds a [`Vec3`] from a slice of length 2 or 3 (missing z is zero).
pub fn vec_from_slice(v: &[Real]) -> Vec3 {
    Vec3::new(v.first().copied().unwrap_or(0.0), v.get(1).copied().unwrap_or(0.0), v.get(2).copied().unwrap_or(0.0))
}

/// The positive part of a square matrix: its symmetric part with every negative eigenvalue set
/// to zero, `Σ max(λ_i, 0) v_i v_iᵀ`. The nearest positive semidefinite matrix to the symmetric
/// part in the Frobenius norm (Higham, Linear Algebra Appl. 103, 103, 1988); the "definiteness
/// fix" of a stiffness that compression makes indefinite (Teran, Sifakis, Irving & Fedkiw,
/// SCA 2005).
pub fn positive_part<const N: usize>(m: &nalgebra::SMatrix<Real, N, N>) -> nalgebra::SMatrix<Real, N, N> {
    let sym = nalgebra::DMatrix::from_fn(N, N, |i, j| 0.5 * (m[(i, j)] + m[(j, i)]));
    let eig = nalgebra::SymmetricEigen::new(sym);
    let clamped = eig.eigenvalues.map(|l| l.max(0.0));
    let p = &eig.eigenvectors * nalgebra::DMatrix::from_diagonal(&clamped) * eig.eigenvectors.transpose();
    nalgebra::SMatrix::from_fn(|i, j| p[(i, j)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_positive_part_drops_negative_eigenvalues_only() {
        // Eigenvalues 3 and -1 on the axes rotated by 30 degrees, plus an antisymmetric part.
        let (c, s) = (30.0_f64.to_radians().cos(), 30.0_f64.to_radians().sin());
        let q = nalgebra::Matrix2::new(c, -s, s, c);
        let m = q * nalgebra::Matrix2::new(3.0, 0.0, 0.0, -1.0) * q.transpose() + nalgebra::Matrix2::new(0.0, 0.5, -0.5, 0.0);
        let p = positive_part(&m);
        let want = q * nalgebra::Matrix2::new(3.0, 0.0, 0.0, 0.0) * q.transpose();
        assert!((p - want).norm() < 1e-12, "{p} != {want}");
        let pd = nalgebra::Matrix2::new(2.0, 1.0, 1.0, 2.0);
        assert!((positive_part(&pd) - pd).norm() < 1e-12);
    }
}
