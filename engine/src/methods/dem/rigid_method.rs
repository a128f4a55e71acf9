//! What the rigid-grain runner asks of DEM ([`RigidMethod`]): its step, contacts, samples, a
//! stage's controls and the equilibrium criterion.

use super::pair_state::PairBlock;
use super::stability::EnergyBudget;
use super::Dem;
use crate::contact::ContactTable;
use crate::error::EngineError;
use crate::loading::CellDeformation;
use crate::math::{Real, Vec3};
use crate::methods::rigid::RigidMethod;
use crate::observe::Sample;
use crate::resume::ContactHistory;
use crate::run::{Balance, GrainModel};
use crate::scene::{Controls, Deformation, Material};

impl RigidMethod for Dem {
    const NAME: &'static str = "dem";
    const GRAIN_MODEL: GrainModel = GrainModel::SoftContacts;

    crate::methods::rigid::rigid_method_common!();

    fn drum_loads(&self) -> Vec<(Vec3, Vec3)> {
        let slot = self.w.walls.len() as u16;
        self.wall_contacts.iter().filter(|c| c.w == slot).map(|c| (self.w.p.pos[c.i as usize], c.force)).collect()
    }

    fn measure(&mut self) -> Result<Sample, EngineError> {
        let clock = self.profile.map(|_| std::time::Instant::now());
        let sample = self.take_sample();
        if let (Some(c), Some(t)) = (clock, self.profile.as_mut()) {
            t.sampling += c.elapsed().as_secs_f64();
        }
        sample
    }

    fn heap_size(&self) -> usize {
        self.heap_bytes()
    }

    fn running_values(&self) -> Vec<Real> {
        let mut v = vec![self.dt];
        v.extend(self.w.walls.iter().map(|w| w.default_gain()));
        if let Some(d) = &self.deformation {
            v.extend(d.rate.iter());
        }
        v
    }

    fn set_running_values(&mut self, values: &[Real]) {
        let Some((&dt, rest)) = values.split_first() else { return };
        if dt.is_finite() && dt > 0.0 {
            self.dt = dt;
            self.kin_current = false;
        }
        let walls = self.w.walls.len();
        if rest.len() < walls {
            return;
        }
        let (gains, rates) = rest.split_at(walls);
        for (w, &g) in self.w.walls.iter_mut().zip(gains) {
            if g.is_finite() && g > 0.0 {
                w.set_default_gain(g);
            }
        }
        if let (Some(d), [x, y, z]) = (self.deformation.as_mut(), rates) {
            d.rate = Vec3::new(*x, *y, *z);
        }
    }

    fn history(&self) -> ContactHistory {
        self.springs()
    }

    fn restore_history(&mut self, history: Option<&ContactHistory>) -> Result<(), EngineError> {
        self.set_springs(history)
    }

    fn controls(&mut self, controls: &Controls) -> Result<(), EngineError> {
        if self.w.apply_controls(controls) {
            // Walls closed onto the grains.
            self.refresh_neighbors();
            self.compute_forces(false);
        }
        if controls.glue.is_some() {
            self.kin_current = false;
        }
        if let Some(d) = controls.deformation {
            self.deformation = d.map(CellDeformation::new);
        }
        // Friction between particles; the walls keep their material's.
        self.table = match controls.friction {
            Some(mu) => ContactTable::new(&self.w.materials.iter().map(|m| Material { friction: mu, ..m.clone() }).collect::<Vec<_>>())
                .with_history_of(&self.wall_table),
            None => self.wall_table.clone(),
        };
        self.params.local_damping = controls.local_damping.unwrap_or(self.base_local_damping);
        if let Some(rate) = controls.shear_rate {
            // Into the box first (with the old images), so that every grain gets the profile of
            // its own position.
            self.refresh_neighbors();
            self.w.impose_shear_rate(rate);
            // The shear velocities of the images changed: pairs across the boundary must be found
            // again.
            self.refresh_neighbors();
            self.compute_forces(false);
        }
        // New boundary work and forces from here: the energy budget restarts.
        self.budget = EnergyBudget::start(self.mechanical_energy());
        Ok(())
    }

    fn equilibrium(&mut self) -> Balance {
        let kinetic = self.w.kinetic_energy();
        let elastic = self.elastic_energy();
        let net = self.w.mean_net_force();
        let (mut sum, mut count) = (0.0, 0usize);
        for c in self.pairs.iter().flat_map(PairBlock::pairs) {
            if c.out.force != Vec3::zeros() {
                sum += c.out.force.norm();
                count += 1;
            }
        }
        for c in self.wall_contacts.iter().filter(|c| c.force != Vec3::zeros()) {
            sum += c.force.norm();
            count += 1;
        }
        let mean_contact = if count > 0 { sum / count as Real } else { 0.0 };
        let unbalanced_force = if mean_contact > 0.0 { net / mean_contact } else { Real::INFINITY };
        // Stress-controlled boundaries against their targets.
        let mut stress_error = self.w.wall_stress_error();
        match self.deformation.as_ref().map(|d| d.kind) {
            Some(Deformation::Pressure { target, .. }) => {
                let (stress, _) = self.stress_and_stiffness();
                let pressure = (0..self.w.dim).map(|a| stress[a]).sum::<Real>() / self.w.dim as Real;
                stress_error = stress_error.max((pressure - target).abs() / target);
            }
            Some(Deformation::NormalStress { axis, target, .. }) => {
                let (stress, _) = self.stress_and_stiffness();
                stress_error = stress_error.max((stress[axis] - target).abs() / target);
            }
            _ => {}
        }
        Balance { kinetic_energy: kinetic, reference_energy: elastic, unbalanced_force, stress_error }
    }
}

impl Dem {
    /// Takes a sample: the guard's scan (its elastic energy), the contacts, the metrics.
    fn take_sample(&mut self) -> Result<Sample, EngineError> {
        let energies = self.check_stability()?;
        let contacts = self.contacts();
        let frictional = self.table.laws().iter().any(|l| l.friction > 0.0);
        let s = self.w.measure(&contacts, energies.elastic, frictional);
        if !s.is_finite() {
            return Err(self.unstable(crate::error::InstabilityCause::NonFinite { particle: 0 }));
        }
        Ok(s)
    }
}
