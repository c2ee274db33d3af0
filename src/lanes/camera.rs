//! Camera rays across lanes: [`Camera::ray_through`], written once, compiled for the lanes.

use super::{dispatch, F32x, Lanes, Vec3x};
use crate::camera::Camera;

/// The kernel: [`Camera::ray_through`] over [`Vec3x`].
#[inline(always)]
fn camera_rays_kernel(camera: &Camera, film: &[Lanes; 2], lens: &[Lanes; 2]) -> ([Lanes; 3], [Lanes; 3]) {
    let (origin, dir) =
        camera.ray_through::<Vec3x>(F32x(film[0]), F32x(film[1]), F32x(lens[0]), F32x(lens[1]));
    (origin.to_lanes(), dir.to_lanes())
}

dispatch! {
    /// The origins and unit directions of the camera rays through the film positions `film`
    /// (x and y per lane, pixel units) from the lens samples `lens`, per axis: in each lane
    /// [`Camera::generate_ray_lens`]'s ray to the bit.
    pub fn camera_rays<'a>(camera: &'a Camera, film: &'a [Lanes; 2], lens: &'a [Lanes; 2]) -> ([Lanes; 3], [Lanes; 3]) => camera_rays_kernel
}
