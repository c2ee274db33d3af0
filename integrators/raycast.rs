//! Ray casting: the first hit only, shaded by the Phong model with hard shadows.
//!
//! Glass and mirrors show only their own surface shading (the thesis's Fig. 12): nothing is
//! reflected or refracted, and every object, glass included, casts a full shadow.

use super::{CameraEstimator, Integrator, Method, PathContext, Progression, RenderParams};
use crate::geometry::Ray;
use crate::lighting::{emitted, phong_local, ShadowMode, ShadowRays};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use glam::Vec3;

/// First-hit Phong shading with hard shadows.
pub struct RayCast;

impl Integrator for RayCast {
    fn method(&self) -> Method {
        Method::RayCast
    }

    fn support(&self, effect: Effect) -> Support {
        match effect {
            Effect::SoftShadows => Support::Approximates("an area light acts as a point light at its centre"),
            Effect::Environment => {
                Support::Approximates("the environment is only the background: it lights nothing")
            }
            Effect::Textures | Effect::Meshes | Effect::MotionBlur | Effect::DepthOfField => {
                Support::Simulates
            }
            Effect::Dispersion | Effect::Absorption | Effect::Glossy => {
                Support::Ignores("glass shows only its surface shading")
            }
        }
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Camera(self)
    }
}

impl CameraEstimator for RayCast {
    fn radiance(&self, scene: &Scene, _: &RenderParams, ray: &Ray, ctx: &mut PathContext) -> Vec3 {
        let Some(isect) = scene.intersect(ray, f32::INFINITY) else {
            return ctx.channels.colour(scene.background(ray.dir));
        };
        let wo = -ray.dir;
        let material = scene.material_of(isect.primitive);
        let shadow = ShadowRays { mode: ShadowMode::Opaque, channels: ctx.channels, time: ray.time };
        ctx.channels.colour(emitted(scene, isect.primitive, &isect.hit, wo))
            + phong_local(scene, material, material.phong, &isect.hit, wo, shadow, &mut ctx.rays, |l, p| {
                l.as_point_from(p)
            })
    }
}
