//! One deformable grain: its range of material points, constitutive law, friction, size and
//! outline.

use std::ops::Range;

use super::outline::Outline;
use crate::math::Real;

/// One deformable grain: a cloud of points with one constitutive law.
#[derive(Debug, Clone, PartialEq)]
pub struct Grain {
    /// Its points in [`super::points::Points`].
    pub points: Range<usize>,
    /// Index of its constitutive law in the method's table.
    pub law: usize,
    /// Coulomb friction coefficient of its surface (a pair of grains, or a grain and a wall,
    /// takes the geometric mean of the two).
    pub friction: Real,
    /// Radius of the disk it was cut from, m (the length the contact criterion measures
    /// violations against; the grain's size in the metrics).
    pub radius: Real,
    /// Its outline, where its contacts are measured (none: the grain touches nothing).
    pub outline: Outline,
}
