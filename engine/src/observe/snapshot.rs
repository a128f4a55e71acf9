//! The state of a run at one instant, for visualisation: particles, the contact network and the
//! walls, independent of the method that produced them. [`super::vtk`] writes it for ParaView.

use super::contacts::ContactRecord;
use crate::math::{Real, Vec3};

/// A plane wall as a finite face of the box, for drawing.
#[derive(Debug, Clone, PartialEq)]
pub struct WallFace {
    /// Face name (`x_min`, `y_max`, ...).
    pub name: String,
    /// Axis of the normal (0, 1, 2).
    pub axis: usize,
    /// Coordinate of the wall along its axis, m.
    pub position: Real,
    /// Unit normal pointing into the box.
    pub normal: Vec3,
    /// Force exerted by the particles on the wall, N.
    pub force: Vec3,
}

/// Particles, contacts and walls at one step. Units SI; in 2D, z components are zero.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// 2 or 3.
    pub dim: usize,
    /// Step number.
    pub step: u64,
    /// Simulated time, s.
    pub time: Real,
    /// Box corners, m (walls span the box).
    pub lo: Vec3,
    /// Upper box corner, m.
    pub hi: Vec3,
    /// Centres, m.
    pub position: Vec<Vec3>,
    /// Radii, m.
    pub radius: Vec<Real>,
    /// Velocities, m/s.
    pub velocity: Vec<Vec3>,
    /// Angular velocities, rad/s.
    pub omega: Vec<Vec3>,
    /// Total force on each particle (contacts, walls, gravity), N.
    pub force: Vec<Vec3>,
    /// Contacts carrying force or held by a bond, with their branch vectors (pairs and walls).
    pub contacts: Vec<ContactRecord>,
    /// The walls.
    pub walls: Vec<WallFace>,
    /// The rotating drum, if any.
    pub drum: Option<DrumShell>,
    /// The material points of deformable grains (MPM), if the method has them: the grains'
    /// shapes, where `position` and `radius` hold only their equivalent disks.
    pub material_points: Option<MaterialPoints>,
}

/// The material points of deformable grains at one step, for drawing: each point the
/// parallelogram its deformation gradient `F` makes of the square it stood for when placed,
/// so that the points of a grain tile its current shape.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MaterialPoints {
    /// Grain of each point (index of the particle it belongs to).
    pub grain: Vec<u32>,
    /// The four corners of each point's parallelogram, counter-clockwise, m (z = 0).
    pub corners: Vec<[Vec3; 4]>,
    /// `det F`: the point's current area over its initial area.
    pub jacobian: Vec<Real>,
    /// Pressure `−tr σ / 3` of the Cauchy stress (σ_zz included: plane strain), Pa.
    pub pressure: Vec<Real>,
    /// Von Mises equivalent stress `sqrt(3/2 s:s)` of the Cauchy stress, Pa.
    pub mises: Vec<Real>,
    /// Velocity, m/s.
    pub velocity: Vec<Vec3>,
}

/// Segments of the drum's surface drawn (a polygon of this many sides).
pub const DRUM_SEGMENTS: usize = 72;

/// The rotating drum for drawing: a polygon of [`DRUM_SEGMENTS`] sides (prism faces in 3D),
/// each with the force the grains put on it.
#[derive(Debug, Clone, PartialEq)]
pub struct DrumShell {
    /// Axis (0, 1, 2).
    pub axis: usize,
    /// A point of the axis, m.
    pub center: Vec3,
    /// Inner radius, m.
    pub radius: Real,
    /// Force exerted by the particles on each segment, N; segment `k` spans the angles
    /// `[k, k + 1) × 2π / DRUM_SEGMENTS` from the first axis across the drum's.
    pub segment_force: Vec<Vec3>,
}

impl DrumShell {
    /// The two unit vectors across the axis (in order of the axes), angles are measured from
    /// the first towards the second.
    pub fn across(&self) -> (usize, usize) {
        let others: Vec<usize> = (0..3).filter(|&a| a != self.axis).collect();
        (others[0], others[1])
    }

    /// Segment holding the point `x` of the surface.
    pub fn segment_of(&self, x: &Vec3) -> usize {
        let (a, b) = self.across();
        let angle = (x[b] - self.center[b]).atan2(x[a] - self.center[a]).rem_euclid(std::f64::consts::TAU);
        ((angle / std::f64::consts::TAU * DRUM_SEGMENTS as Real) as usize).min(DRUM_SEGMENTS - 1)
    }
}

impl Snapshot {
    /// Number of load-bearing particle-particle contacts of each particle (the coordination
    /// that Z averages, same rule: [`ContactRecord::bears_load`]; wall contacts are not counted).
    pub fn coordination(&self) -> Vec<u32> {
        let mut z = vec![0u32; self.position.len()];
        for c in &self.contacts {
            if let Some(j) = c.j {
                if c.bears_load() {
                    z[c.i as usize] += 1;
                    z[j as usize] += 1;
                }
            }
        }
        z
    }
}
