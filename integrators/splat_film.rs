//! The splat film of the methods that trace light paths (`light` and the bidirectional engine):
//! a light-path vertex connected to the camera adds its contribution to whatever pixel it
//! projects to ([`CameraTarget::splat`]), chunks of light paths collect their splats in the order
//! they made them ([`SplatBuffer`]), and the splats of one sample index go, scaled, straight into
//! the [`Film`]'s sums of that sample index ([`SampleSplats`]), beside the camera paths' own
//! estimates where a method has them. The film's sums are linear in the terms, so a pixel's term
//! of a sample index is its camera estimate plus its splats however they are added: a light
//! path's splats count as part of one sample of the pixel, the per-pixel variance (from the
//! replicas' means) is that of whole sample indices, and progressive checkpoints, render parts
//! and `merge` work on the film exactly as for the camera methods. No per-pixel buffer is held
//! besides the film. The splats of a sample index are added in chunk order, so the film does not
//! depend on the thread count.

use super::PathContext;
use crate::camera::{Camera, CameraConnection};
use crate::geometry::SurfaceHit;
use crate::lighting::{transmittance, ShadowRays};
use crate::render::Film;
use crate::sampler::Dim;
use crate::scene::Scene;
use glam::Vec3;

/// The camera splats of a chunk of light paths, in the order the paths made them.
#[derive(Default, Debug)]
pub(crate) struct SplatBuffer {
    /// (pixel index, contribution in RGB before the film's common scale).
    splats: Vec<(u32, Vec3)>,
    /// Splats that were NaN or infinite (kept, never hidden).
    non_finite: u64,
}

impl SplatBuffer {
    /// An empty buffer with room for `capacity` splats.
    pub fn with_capacity(capacity: usize) -> SplatBuffer {
        SplatBuffer { splats: Vec::with_capacity(capacity), non_finite: 0 }
    }

    /// Empty the buffer, keeping its room.
    pub fn clear(&mut self) {
        self.splats.clear();
        self.non_finite = 0;
    }

    /// The bytes the buffer holds (its room, not only what it uses).
    #[cfg(test)]
    pub fn bytes_held(&self) -> usize {
        self.splats.capacity() * std::mem::size_of::<(u32, Vec3)>()
    }

    /// Add `value` to pixel `pixel`.
    pub fn push(&mut self, pixel: u32, value: Vec3) {
        if !value.is_finite() {
            self.non_finite += 1;
        }
        self.splats.push((pixel, value));
    }
}

/// Where the splats of the current sample index go: straight into the film's sums of that
/// sample index, times a common scale.
pub(crate) struct SampleSplats {
    /// The sample index the splats belong to.
    sample: u32,
    /// The factor every splat is multiplied by before it enters the film.
    scale: f64,
}

impl SampleSplats {
    /// Splats of sample index `sample` on, each multiplied by `scale`.
    pub fn new(sample: u32, scale: f64) -> SampleSplats {
        SampleSplats { sample, scale }
    }

    /// Add the splats of `buffer` (the next chunk of the sample index, in order) to `film`'s
    /// sums, counting its non-finite splats on `film`; `buffer` is left empty (its room kept).
    pub fn add(&mut self, film: &mut Film, buffer: &mut SplatBuffer) {
        for (pixel, value) in buffer.splats.drain(..) {
            film.add(pixel as usize, self.sample, value.as_dvec3() * self.scale);
        }
        film.non_finite += std::mem::take(&mut buffer.non_finite);
    }

    /// End the sample index: later splats go to the next one. The caller advances the film's
    /// sample count.
    pub fn finish(&mut self) {
        self.sample += 1;
    }
}

/// The camera that light-path vertices connect to, in its scene.
pub(crate) struct CameraTarget<'a> {
    /// The scene whose surfaces block the connection.
    pub scene: &'a Scene,
    /// The camera.
    pub camera: &'a Camera,
    /// Whether the camera has a thin lens (connections go to a sampled lens point).
    pub lens: bool,
}

impl CameraTarget<'_> {
    /// Connect the light-path point `hit` to the camera and splat `value(ctx, connection)` into
    /// `out`: the point's weight towards the camera in the path's channels (zero: nothing to
    /// splat), which the pinhole's importance `1/(d²·cos³θ)` then multiplies (see `light`'s
    /// module documentation), when the straight, opaque ray to the camera is clear (from the
    /// near clip plane on, where the camera's rays start). With a thin lens the connection goes
    /// to a uniform point of the lens, which the camera samples with the same density, so the
    /// lens area cancels and the contribution has the pinhole's form. The contribution goes to
    /// every pixel of the crop window whose filter footprint covers the film point, times that
    /// pixel's normalised filter weight ([`crate::pixel_filter::PixelFilter::splat_weights`]).
    pub fn splat(
        &self,
        hit: &SurfaceHit,
        ctx: &mut PathContext,
        shadow: ShadowRays,
        out: &mut SplatBuffer,
        value: impl FnOnce(&PathContext, &CameraConnection) -> Vec3,
    ) {
        let camera = self.camera;
        let lens = if self.lens { camera.lens_point(ctx.sampler.get_2d(Dim::Lens)) } else { camera.position };
        let Some(c) = camera.connection(hit.p, lens) else { return };
        let v = value(ctx, &c);
        if v == Vec3::ZERO {
            return;
        }
        let visible = transmittance(self.scene, hit, c.start, None, shadow, &mut ctx.rays);
        if visible == Vec3::ZERO {
            return;
        }
        // dω = |cos_v| dA / d² and dA_film = dω / cos³θ.
        let splat = ctx.channels.to_rgb(v * visible) / (c.dist2 * c.cos * c.cos * c.cos);
        let crop = camera.crop;
        camera.filter.splat_weights(c.film, camera.width, camera.height, |x, y, weight| {
            if let Some(pixel) = crop.index(x, y) {
                out.push(pixel, if weight == 1.0 { splat } else { splat * weight });
            }
        });
    }
}
