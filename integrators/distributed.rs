//! Distributed ray tracing (Cook, Porter and Carpenter 1984): Whitted's recursion with its rays
//! distributed over the dimensions it used to fix — the pixel area, the area of each light
//! (soft shadows), the GGX lobe of rough mirrors and glass (glossy reflection, frosted glass),
//! the lens (depth of field), the shutter interval (motion blur) and, for dispersive media, the
//! wavelength. No indirect diffuse light: diffuse surfaces see only the lights (plus the
//! empirical ambient term), so caustics are absent as in Whitted.

use super::whitted::{trace, Sampling, Segment};
use super::{CameraEstimator, Integrator, Method, PathContext, Progression, RenderParams};
use crate::geometry::Ray;
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use glam::Vec3;

/// Cook's stochastic ray tracing.
pub struct Distributed;

impl Integrator for Distributed {
    fn method(&self) -> Method {
        Method::Distributed
    }

    fn support(&self, effect: Effect) -> Support {
        match effect {
            Effect::Environment => Support::Approximates(
                "the environment is seen only where rays leave the scene: it casts no light",
            ),
            _ => Support::Simulates,
        }
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Camera(self)
    }
}

impl CameraEstimator for Distributed {
    fn radiance(&self, scene: &Scene, params: &RenderParams, ray: &Ray, ctx: &mut PathContext) -> Vec3 {
        trace(scene, params, ray, Segment::camera(), Sampling::Distributed, ctx)
    }
}
