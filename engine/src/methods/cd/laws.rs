//! The laws of each pair of materials for contact dynamics: restitution, friction, rolling
//! resistance and cohesion (the elastic constants of the materials play no part: grains are
//! rigid).

use crate::contact::capillary_richefeu::CapillaryRichefeu;
use crate::contact::lubrication::Lubrication;
use crate::math::Real;
use crate::scene::Material;

/// What attracts two grains of a pair of materials (both materials must carry it, as in DEM).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Attraction {
    /// Constant attraction F_0 (N) within D_0 (m) of contact (Roux & Chevoir 2005, §2.2.3), geometric means of
    /// the materials'.
    pub constant: Option<(Real, Real)>,
    /// Capillary bridge between wet grains (Nezamabadi 2020, eqs. 1.5–1.8), the parameters mixed as in DEM.
    pub capillary: Option<CapillaryRichefeu>,
    /// Lubrication by the bridge's liquid (Nezamabadi 2020, eqs. 1.9–1.11; acts while the bridge holds).
    pub lubrication: Option<Lubrication>,
}

impl Attraction {
    /// Distance beyond contact within which the pair may attract, m.
    pub fn range(&self) -> Real {
        let constant = self.constant.map_or(0.0, |(_, d)| d);
        constant.max(self.capillary.map_or(0.0, |c| c.rupture_distance))
    }
}

/// Restitution, friction, rolling friction and attraction between materials, and against the
/// wall material; mixing as for DEM (geometric means, [`crate::contact::PairLaw::between`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PairLaws {
    n: usize,
    restitution: Vec<Real>,
    friction: Vec<Real>,
    /// Rolling friction coefficient mu_r (0: none; both materials must define `rolling`).
    rolling: Vec<Real>,
    attraction: Vec<Attraction>,
    /// The materials' own friction, restored when a stage's override ends.
    base_friction: Vec<Real>,
    wall_material: usize,
    /// Impacts are perfectly inelastic (a damped stage, [`PairLaws::set_inelastic`]).
    inelastic: bool,
}

impl PairLaws {
    /// The table of `materials`, with `wall_material` for the walls and, if given, one friction
    /// for every particle pair.
    pub fn new(materials: &[Material], wall_material: usize, friction: Option<Real>) -> Self {
        let n = materials.len();
        let gm = |x: Real, y: Real| (x * y).sqrt();
        let mut restitution = vec![0.0; n * n];
        let mut base_friction = vec![0.0; n * n];
        let mut rolling = vec![0.0; n * n];
        let mut attraction = vec![Attraction::default(); n * n];
        for (a, ma) in materials.iter().enumerate() {
            for (b, mb) in materials.iter().enumerate() {
                let k = a * n + b;
                restitution[k] = gm(ma.restitution, mb.restitution);
                base_friction[k] = gm(ma.friction, mb.friction);
                if let (Some(ra), Some(rb)) = (ma.rolling, mb.rolling) {
                    rolling[k] = gm(ra.friction, rb.friction);
                }
                let constant = match (ma.cohesion, mb.cohesion) {
                    (Some(ca), Some(cb)) => Some((gm(ca.force, cb.force), gm(ca.distance, cb.distance))),
                    _ => None,
                };
                // The liquid's parameters as DEM mixes them.
                let dem = crate::contact::PairLaw::between(ma, mb);
                attraction[k] = Attraction { constant, capillary: dem.capillary, lubrication: dem.lubrication };
            }
        }
        let mut laws = Self {
            n,
            restitution,
            rolling,
            attraction,
            friction: base_friction.clone(),
            base_friction,
            wall_material: wall_material.min(n.saturating_sub(1)),
            inelastic: false,
        };
        laws.set_friction(friction);
        laws
    }

    /// Sets one friction coefficient between particles (a stage's override), or restores the
    /// materials' own with `None`. Walls keep their material's.
    pub fn set_friction(&mut self, friction: Option<Real>) {
        self.friction = match friction {
            Some(mu) => vec![mu; self.n * self.n],
            None => self.base_friction.clone(),
        };
    }

    /// Makes every impact perfectly inelastic (`true`) or restores the materials' restitution:
    /// the counterpart, for rigid grains, of the local damping a stage asks for (a preparation's
    /// cushion). Rigid grains have no vibrations to damp; what the damping takes from a
    /// compressed gas of grains — the agitation that the walls feed and that elastic impacts
    /// keep — inelastic impacts take.
    pub fn set_inelastic(&mut self, inelastic: bool) {
        self.inelastic = inelastic;
    }

    /// The restitution of the pair `k`, 0 in an inelastic stage.
    #[inline(always)]
    fn restitution(&self, k: usize) -> Real {
        if self.inelastic {
            0.0
        } else {
            self.restitution[k]
        }
    }

    /// Restitution and friction between particles of materials `a` and `b`.
    #[inline(always)]
    pub fn pair(&self, a: u16, b: u16) -> (Real, Real) {
        let k = a as usize * self.n + b as usize;
        (self.restitution(k), self.friction[k])
    }

    /// Restitution and friction between a particle of material `a` and a wall.
    #[inline(always)]
    pub fn wall(&self, a: u16) -> (Real, Real) {
        let k = a as usize * self.n + self.wall_material;
        (self.restitution(k), self.base_friction[k])
    }

    /// Rolling friction coefficient between particles of materials `a` and `b` (0: none).
    #[inline(always)]
    pub fn rolling(&self, a: u16, b: u16) -> Real {
        self.rolling[a as usize * self.n + b as usize]
    }

    /// Rolling friction coefficient between a particle of material `a` and a wall (0: none).
    #[inline(always)]
    pub fn wall_rolling(&self, a: u16) -> Real {
        self.rolling[a as usize * self.n + self.wall_material]
    }

    /// What attracts particles of materials `a` and `b`.
    #[inline(always)]
    pub fn attraction(&self, a: u16, b: u16) -> &Attraction {
        &self.attraction[a as usize * self.n + b as usize]
    }

    /// What attracts a particle of material `a` to a wall (no capillary bridges with walls, as
    /// in DEM).
    #[inline(always)]
    pub fn wall_attraction(&self, a: u16) -> Attraction {
        Attraction { capillary: None, lubrication: None, ..self.attraction[a as usize * self.n + self.wall_material] }
    }

    /// Largest range of attraction beyond contact over all pairs, m.
    pub fn range(&self) -> Real {
        self.attraction.iter().map(Attraction::range).fold(0.0, Real::max)
    }

    /// True if some particle pair has friction.
    pub fn frictional(&self) -> bool {
        self.friction.iter().any(|&mu| mu > 0.0)
    }
}
