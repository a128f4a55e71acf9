//! Time step of explicit DEM from the collision time (docs/physics.md §2, docs/references.md checks 1, 3, 5).
//!
//! For the linear law `t_c = pi / sqrt(k_n/m* - (gamma_n / 2m*)²)` with the lightest pair of each
//! material pair; for Hertz the elastic collision time `t_H = 2.87 (m*² / (R* E*² v))^(1/5)` at a
//! reference impact velocity. The default step is t_c / 50 (`time_step_fraction` 0.02), the usual
//! practice for velocity Verlet (Silbert et al. 2001; docs/references.md check 2); the linear law is
//! unstable beyond `2 / omega_0` for a single contact and earlier in dense packings.

use crate::contact::{ContactTable, NormalLaw};
use crate::math::Real;

/// Collision-time estimate of the stiffest, lightest contact.
#[derive(Debug, Clone, PartialEq)]
pub struct CollisionTime {
    /// Shortest collision time, s.
    pub t_c: Real,
    /// Stable limit of velocity Verlet for that contact (2/omega_0; for Hertz at the reference
    /// velocity's largest overlap), s.
    pub dt_limit: Real,
    /// Description of the limiting contact for messages.
    pub limiting: String,
}

/// Light-weight description of what may touch: per material, its lightest particle mass and
/// smallest radius; plus the wall material.
pub struct Bodies<'a> {
    /// Per material index: (lightest mass, smallest radius), or `None` if unused.
    pub lightest: &'a [Option<(Real, Real)>],
    /// Material names, by index.
    pub names: &'a [&'a str],
    /// Wall material index.
    pub wall_material: Option<usize>,
}

/// Computes the collision time over all material pairs that can meet.
pub fn collision_time(table: &ContactTable, bodies: &Bodies<'_>, v_ref: Real) -> CollisionTime {
    let mut best = CollisionTime { t_c: Real::INFINITY, dt_limit: Real::INFINITY, limiting: String::new() };
    let mut consider = |law: &crate::contact::PairLaw, m_eff: Real, r_eff: Real, what: String| {
        let (t_c, limit) = match law.normal {
            NormalLaw::Linear(l) => {
                let w0 = (l.k_n / m_eff).sqrt();
                let w = w0 * (1.0 - l.zeta * l.zeta).max(1e-12).sqrt();
                (std::f64::consts::PI / w, 2.0 / w0)
            }
            NormalLaw::Hertz(h) => {
                let t = 2.87 * (m_eff * m_eff / (r_eff * h.e_star * h.e_star * v_ref)).powf(0.2);
                // Largest overlap of that impact and the stiffness there (docs/references.md check 3).
                let dmax = (15.0 * m_eff * v_ref * v_ref / (16.0 * h.e_star * r_eff.sqrt())).powf(0.4);
                let k = 2.0 * h.e_star * (r_eff * dmax).sqrt();
                (t, 2.0 / (k / m_eff).sqrt())
            }
        };
        if t_c < best.t_c {
            best = CollisionTime { t_c, dt_limit: limit, limiting: what };
        }
    };
    for (a, la) in bodies.lightest.iter().enumerate() {
        let Some((ma, ra)) = la else { continue };
        for (b, lb) in bodies.lightest.iter().enumerate() {
            let Some((mb, rb)) = lb else { continue };
            let (na, nb) = (bodies.names.get(a).unwrap_or(&"?"), bodies.names.get(b).unwrap_or(&"?"));
            let what =
                if a == b { format!("contact between '{na}' particles") } else { format!("contact between '{na}' and '{nb}' particles") };
            consider(table.get(a, b), ma * mb / (ma + mb), ra * rb / (ra + rb), what);
        }
        if let Some(w) = bodies.wall_material {
            let (na, nw) = (bodies.names.get(a).unwrap_or(&"?"), bodies.names.get(w).unwrap_or(&"?"));
            consider(table.get(a, w), *ma, *ra, format!("contact of a '{na}' particle with a '{nw}' wall"));
        }
    }
    best
}
