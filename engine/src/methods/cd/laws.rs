//! Restitution and friction of each pair of materials for contact dynamics (the elastic
//! constants of the materials play no part: grains are rigid).

use crate::math::Real;
use crate::scene::Material;

/// Restitution and friction between materials, and against the wall material; mixing as for
/// DEM (geometric means, [`crate::contact::PairLaw::between`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PairLaws {
    n: usize,
    restitution: Vec<Real>,
    friction: Vec<Real>,
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
        for (a, ma) in materials.iter().enumerate() {
            for (b, mb) in materials.iter().enumerate() {
                restitution[a * n + b] = gm(ma.restitution, mb.restitution);
                base_friction[a * n + b] = gm(ma.friction, mb.friction);
            }
        }
        let mut laws = Self {
            n,
            restitution,
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

    /// True if some particle pair has friction.
    pub fn frictional(&self) -> bool {
        self.friction.iter().any(|&mu| mu > 0.0)
    }
}
