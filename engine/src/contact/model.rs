//! The composed contact law of a pair of materials and the per-contact kernel.

use super::capillary_richefeu::CapillaryRichefeu;
use super::damping::{hertz_damping_coefficient, zeta_limited, zeta_unlimited};
use super::lubrication::Lubrication;
use super::normal_hertz::NormalHertz;
use super::normal_linear::NormalLinear;
use super::rolling::RollingResistance;
use super::tangential::{carry_spring, tangential_force};
use super::NormalForce;
use crate::math::Vec3;
use crate::scene::{ElasticLaw, Material};

/// Names of the elastic laws a scene may use (`contact.law`), with what they are.
pub const LAW_NAMES: [(&str, &str); 2] = [
    ("linear", "linear spring-dashpot with tangential history (Nezamabadi 2020, eqs. 1.2-1.3)"),
    ("hertz_mindlin", "Hertz normal force, Mindlin tangential stiffness (Roux & Chevoir 2005, eqs. 1-2)"),
];

/// Normal law of a pair (static dispatch in the hot loop).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NormalLaw {
    /// Linear spring-dashpot.
    Linear(NormalLinear),
    /// Hertz.
    Hertz(NormalHertz),
}

impl NormalForce for NormalLaw {
    #[inline(always)]
    fn stiffness(&self, delta: f64, r_eff: f64) -> f64 {
        match self {
            Self::Linear(l) => l.stiffness(delta, r_eff),
            Self::Hertz(h) => h.stiffness(delta, r_eff),
        }
    }
    #[inline(always)]
    fn elastic(&self, delta: f64, r_eff: f64) -> f64 {
        match self {
            Self::Linear(l) => l.elastic(delta, r_eff),
            Self::Hertz(h) => h.elastic(delta, r_eff),
        }
    }
    #[inline(always)]
    fn damping(&self, delta: f64, r_eff: f64, m_eff: f64) -> f64 {
        match self {
            Self::Linear(l) => l.damping(delta, r_eff, m_eff),
            Self::Hertz(h) => h.damping(delta, r_eff, m_eff),
        }
    }
    fn energy(&self, delta: f64, r_eff: f64) -> f64 {
        match self {
            Self::Linear(l) => l.energy(delta, r_eff),
            Self::Hertz(h) => h.energy(delta, r_eff),
        }
    }
}

/// Tangential stiffness and damping of a pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TangentialLaw {
    /// Constant k_t (N/m); gamma_t = ratio × gamma_n.
    Linear {
        /// k_t, N/m.
        k_t: f64,
        /// gamma_t / gamma_n.
        damping_ratio: f64,
    },
    /// Mindlin: k_t = 8 G* sqrt(R* delta), gamma_t = c sqrt(k_t m*) (docs/references.md check 4).
    Mindlin {
        /// G* = 1 / ((2 - nu1)/G1 + (2 - nu2)/G2), Pa.
        g_star: f64,
        /// Damping coefficient c.
        damp: f64,
    },
}

impl TangentialLaw {
    /// (k_t, gamma_t) at overlap delta.
    #[inline(always)]
    fn coefficients(&self, delta: f64, r_eff: f64, m_eff: f64, gamma_n: f64) -> (f64, f64) {
        match *self {
            Self::Linear { k_t, damping_ratio } => (k_t, damping_ratio * gamma_n),
            Self::Mindlin { g_star, damp } => {
                let k_t = 8.0 * g_star * (r_eff * delta).sqrt();
                (k_t, damp * (k_t * m_eff).sqrt())
            }
        }
    }
    /// Elastic energy of the tangential spring, J.
    pub fn energy(&self, xi2: f64, delta: f64, r_eff: f64) -> f64 {
        match *self {
            Self::Linear { k_t, .. } => 0.5 * k_t * xi2,
            Self::Mindlin { g_star, .. } => 0.5 * 8.0 * g_star * (r_eff * delta.max(0.0)).sqrt() * xi2,
        }
    }
}

/// The full law between two materials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairLaw {
    /// Normal law.
    pub normal: NormalLaw,
    /// Tangential law.
    pub tangential: TangentialLaw,
    /// Coulomb coefficient.
    pub friction: f64,
    /// Carry the tangential spring even while the friction is zero: set when the materials
    /// have friction (a stage that removes it keeps the springs as the history law updates
    /// them, so that the next frictional stage starts from the same state); without friction
    /// for the whole run the contact computes no tangential force or spring at all.
    pub tangential_history: bool,
    /// Floor the contact normal force at zero.
    pub limit_damping: bool,
    /// Rolling resistance.
    pub rolling: Option<RollingResistance>,
    /// Capillary bridge (both materials wet).
    pub capillary: Option<CapillaryRichefeu>,
    /// Lubrication (both materials wet, viscosity > 0).
    pub lubrication: Option<Lubrication>,
}

/// Geometry and kinematics of one contact, computed by the caller.
#[derive(Debug, Clone, Copy, Default)]
pub struct ContactInput {
    /// Unit normal from j to i.
    pub n: Vec3,
    /// Overlap, m (negative: gap).
    pub delta: f64,
    /// Radius of i, m.
    pub r_i: f64,
    /// Radius of j, m (infinite for a wall).
    pub r_j: f64,
    /// Effective radius R*, m.
    pub r_eff: f64,
    /// Effective mass m*, kg.
    pub m_eff: f64,
    /// Lever from the centre of i to the contact point, m.
    pub a_i: f64,
    /// Lever from the centre of j to the contact point, m (0 for a wall).
    pub a_j: f64,
    /// Velocity of i's contact point minus j's at mid-step, m/s (advances the springs:
    /// `v_c dt` is the exact displacement increment of velocity Verlet).
    pub v_c: Vec3,
    /// The same velocity predicted at the end of the step, m/s (used by the dashpots, which
    /// makes viscous damping second-order accurate in dt).
    pub v_damp: Vec3,
    /// (omega_i - omega_j), rad/s.
    pub w_rel: Vec3,
    /// Mean spin about the normal, 0.5 (omega_i + omega_j)·n, rad/s.
    pub spin_n: f64,
}

/// What a contact exerts.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactOutput {
    /// Force on i, N (j receives the opposite).
    pub force: Vec3,
    /// Torque on i, N·m.
    pub torque_i: Vec3,
    /// Torque on j, N·m.
    pub torque_j: Vec3,
}

impl PairLaw {
    /// Builds the law between two materials (`a` may equal `b`). Mixing: Hertz uses the exact
    /// E* and G*; the linear stiffnesses, restitution, friction and rolling parameters take the
    /// geometric mean (equal to the common value for one material); liquid parameters the
    /// arithmetic mean, and only when both materials carry liquid.
    pub fn between(a: &Material, b: &Material) -> Self {
        let gm = |x: f64, y: f64| (x * y).sqrt();
        let e = gm(a.restitution, b.restitution);
        let limit_damping = a.limit_damping && b.limit_damping;
        let (normal, tangential) = match (a.law, b.law) {
            (ElasticLaw::HertzMindlin { young: ea, poisson: na }, ElasticLaw::HertzMindlin { young: eb, poisson: nb }) => {
                let e_star = 1.0 / ((1.0 - na * na) / ea + (1.0 - nb * nb) / eb);
                let (ga, gb) = (ea / (2.0 * (1.0 + na)), eb / (2.0 * (1.0 + nb)));
                let g_star = 1.0 / ((2.0 - na) / ga + (2.0 - nb) / gb);
                let damp = hertz_damping_coefficient(e, limit_damping);
                (NormalLaw::Hertz(NormalHertz { e_star, damp }), TangentialLaw::Mindlin { g_star, damp })
            }
            (la, lb) => {
                let (kna, kta) = linear_constants(la);
                let (knb, ktb) = linear_constants(lb);
                let zeta = if limit_damping { zeta_limited(e) } else { zeta_unlimited(e) };
                (
                    NormalLaw::Linear(NormalLinear { k_n: gm(kna, knb), zeta }),
                    TangentialLaw::Linear { k_t: gm(kta, ktb), damping_ratio: gm(a.tangential_damping_ratio, b.tangential_damping_ratio) },
                )
            }
        };
        let rolling = match (a.rolling, b.rolling) {
            (Some(ra), Some(rb)) => {
                Some(RollingResistance { stiffness: gm(ra.stiffness, rb.stiffness), friction: gm(ra.friction, rb.friction) })
            }
            _ => None,
        };
        let (capillary, lubrication) = match (a.liquid, b.liquid) {
            (Some(la), Some(lb)) => {
                let mean = |x: f64, y: f64| 0.5 * (x + y);
                let cap = CapillaryRichefeu::new(
                    mean(la.surface_tension, lb.surface_tension),
                    mean(la.contact_angle, lb.contact_angle),
                    mean(la.bridge_volume, lb.bridge_volume),
                );
                let eta = mean(la.viscosity, lb.viscosity);
                let lub = (eta > 0.0).then(|| Lubrication { viscosity: eta, roughness: mean(la.roughness, lb.roughness) });
                (Some(cap), lub)
            }
            _ => (None, None),
        };
        let friction = gm(a.friction, b.friction);
        Self { normal, tangential, friction, tangential_history: friction > 0.0, limit_damping, rolling, capillary, lubrication }
    }

    /// Interaction range beyond contact, m (the capillary rupture distance, or 0).
    pub fn range(&self) -> f64 {
        self.capillary.map_or(0.0, |c| c.rupture_distance)
    }

    /// Computes the contact: updates the tangential spring `xi`, the rolling spring `roll` and
    /// the bridge state `bridge` (both `None` when the law has no such part) and returns the
    /// force and torques. Springs are reset when the grains separate.
    #[inline(always)]
    pub fn compute(&self, c: &ContactInput, xi: &mut Vec3, roll: Option<&mut Vec3>, bridge: Option<&mut bool>, dt: f64) -> ContactOutput {
        let n = c.n;
        let vn = c.v_damp.dot(&n);
        let delta_dot = -vn;
        let mut f_normal = 0.0;
        let mut f_t = Vec3::zeros();
        let mut moment = Vec3::zeros();
        if c.delta > 0.0 {
            let gamma_n = self.normal.damping(c.delta, c.r_eff, c.m_eff);
            let mut f_contact = self.normal.elastic(c.delta, c.r_eff) + gamma_n * delta_dot;
            if self.limit_damping && f_contact < 0.0 {
                f_contact = 0.0;
            }
            // Without friction for the whole run the Coulomb cap is zero: no tangential force and
            // no spring to keep (the method advisor reports this as a term the scene does not
            // need).
            if self.friction > 0.0 || self.tangential_history {
                let v_t = c.v_c - n * c.v_c.dot(&n);
                let v_t_damp = c.v_damp - n * vn;
                let (k_t, gamma_t) = self.tangential.coefficients(c.delta, c.r_eff, c.m_eff, gamma_n);
                carry_spring(xi, &n, c.spin_n, dt);
                f_t = tangential_force(xi, &v_t, &v_t_damp, dt, k_t, gamma_t, self.friction, f_contact.max(0.0));
            } else {
                *xi = Vec3::zeros();
            }
            if let (Some(rr), Some(theta)) = (self.rolling, roll) {
                moment = rr.moment(theta, &n, &c.w_rel, dt, c.r_eff, f_contact.max(0.0));
            }
            f_normal = f_contact;
        } else {
            *xi = Vec3::zeros();
            if let Some(theta) = roll {
                *theta = Vec3::zeros();
            }
        }
        if let (Some(cap), Some(b)) = (self.capillary, bridge) {
            if c.delta > 0.0 {
                *b = true;
            }
            let h = -c.delta;
            if *b && h > cap.rupture_distance {
                *b = false;
            }
            if *b {
                f_normal += cap.force(h, c.r_i, c.r_j);
                if let Some(lub) = self.lubrication {
                    f_normal += lub.force(h, delta_dot, c.r_i, c.r_j);
                }
            }
        }
        let nxf = n.cross(&f_t);
        ContactOutput { force: n * f_normal + f_t, torque_i: -nxf * c.a_i + moment, torque_j: -nxf * c.a_j - moment }
    }
}

fn linear_constants(law: ElasticLaw) -> (f64, f64) {
    match law {
        ElasticLaw::Linear { k_n, k_t } => (k_n, k_t),
        // Validation forbids mixing laws; keep a sensible value anyway.
        ElasticLaw::HertzMindlin { young, .. } => (young, young),
    }
}

/// Laws between every pair of materials; index `n_materials` is reserved for nothing — walls
/// use their own material index.
#[derive(Debug, Clone)]
pub struct ContactTable {
    n: usize,
    laws: Vec<PairLaw>,
}

impl ContactTable {
    /// Builds the table for all material pairs.
    pub fn new(materials: &[Material]) -> Self {
        let n = materials.len();
        let mut laws = Vec::with_capacity(n * n);
        for a in materials {
            for b in materials {
                laws.push(PairLaw::between(a, b));
            }
        }
        Self { n, laws }
    }

    /// Law between materials `a` and `b`.
    #[inline(always)]
    pub fn get(&self, a: usize, b: usize) -> &PairLaw {
        &self.laws[a * self.n + b]
    }

    /// All laws.
    pub fn laws(&self) -> &[PairLaw] {
        &self.laws
    }

    /// This table with the tangential springs carried wherever `base` carries them (a stage
    /// that changes the friction keeps the materials' history law).
    pub fn with_history_of(mut self, base: &ContactTable) -> Self {
        for (law, b) in self.laws.iter_mut().zip(&base.laws) {
            law.tangential_history |= b.tangential_history;
        }
        self
    }
}
