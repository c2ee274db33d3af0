//! Ray counts, split as the thesis reports them.

use serde::Serialize;
use std::ops::AddAssign;

/// How many rays of each kind a render traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RayCounts {
    /// Rays from the camera.
    pub primary: u64,
    /// Rays spawned by reflection.
    pub reflected: u64,
    /// Rays spawned by refraction.
    pub refracted: u64,
    /// Visibility rays towards lights (each segment through glass counts once).
    pub shadow: u64,
}

impl RayCounts {
    /// All rays together.
    pub fn total(&self) -> u64 {
        self.primary + self.reflected + self.refracted + self.shadow
    }
}

impl AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.primary += o.primary;
        self.reflected += o.reflected;
        self.refracted += o.refracted;
        self.shadow += o.shadow;
    }
}
