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
//! depend on the thread count. A splat waits for its shadow ray in its buffer
//! ([`super::shadow_queue`]: tested with the next rays, [`WIDTH`](crate::lanes::WIDTH) at a
//! time) and joins the buffer's splats in the order it was made.

use super::shadow_queue::{ShadowQueue, Shadows, Ticket};
use super::PathContext;
use crate::camera::{Camera, CameraConnection};
use crate::geometry::SurfaceHit;
use crate::render::Film;
use crate::sampler::Dim;
use glam::Vec3;

/// The camera splats of a chunk of light paths, in the order the paths made them.
#[derive(Default, Debug)]
pub(crate) struct SplatBuffer {
    /// (pixel index, contribution in RGB before the film's common scale).
    splats: Vec<(u32, Vec3)>,
    /// Splats that were NaN or infinite (kept, never hidden).
    non_finite: u64,
    /// Splats waiting for their shadow rays (pixel index, contribution), in order.
    pending: ShadowQueue<(u32, Vec3)>,
}

impl SplatBuffer {
    /// An empty buffer with room for `capacity` splats.
    pub fn with_capacity(capacity: usize) -> SplatBuffer {
        SplatBuffer { splats: Vec::with_capacity(capacity), ..Default::default() }
    }

    /// Add `value` to pixel `pixel` with no shadow ray to wait for (a splat whose visibility
    /// is already known: a Metropolis sample's camera ray).
    pub fn add_visible(&mut self, pixel: u32, value: Vec3) {
        debug_assert!(self.pending.is_empty(), "unshadowed splats are not mixed with waiting ones");
        push(&mut self.splats, &mut self.non_finite, pixel, value);
    }

    /// Empty the buffer, keeping its room.
    pub fn clear(&mut self) {
        debug_assert!(self.pending.is_empty(), "a buffer's splats are settled before it is emptied");
        self.splats.clear();
        self.non_finite = 0;
    }

    /// Add `value` to pixel `pixel` where the ray of `ticket` reaches the camera: at once where
    /// its answer is known and no splat waits ahead of it, else once it is tested.
    fn add(&mut self, pixel: u32, value: Vec3, ticket: Ticket) {
        match ticket.known() {
            Some(visible) if !self.pending.has_items() => {
                if visible {
                    push(&mut self.splats, &mut self.non_finite, pixel, value);
                }
            }
            _ => self.pending.add((pixel, value), ticket),
        }
    }

    /// Test the shadow rays of the splats that wait (all of them with `all`, else whole batches
    /// of 16) and add the visible ones, in order. A chunk's buffer is settled with `all` before
    /// it goes to the film.
    pub fn settle(&mut self, shadows: &Shadows, all: bool) {
        let (splats, non_finite) = (&mut self.splats, &mut self.non_finite);
        self.pending.answer(shadows, all, |(pixel, value), visible| {
            if visible {
                push(splats, non_finite, pixel, value);
            }
        });
    }

    /// The bytes the buffer holds (its room, not only what it uses).
    #[cfg(test)]
    pub fn bytes_held(&self) -> usize {
        self.splats.capacity() * std::mem::size_of::<(u32, Vec3)>()
    }
}

/// Add `value` to pixel `pixel` of `splats`, counting it in `non_finite` if it is NaN or infinite.
fn push(splats: &mut Vec<(u32, Vec3)>, non_finite: &mut u64, pixel: u32, value: Vec3) {
    if !value.is_finite() {
        *non_finite += 1;
    }
    splats.push((pixel, value));
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
        debug_assert!(buffer.pending.is_empty(), "a buffer's splats are settled before they join the film");
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
    /// The camera.
    pub camera: &'a Camera,
    /// Whether the camera has a thin lens (connections go to a sampled lens point).
    pub lens: bool,
    /// How the shadow rays towards the camera are tested.
    pub shadows: Shadows<'a>,
}

impl CameraTarget<'_> {
    /// Connect the light-path point `hit` to the camera and splat `value(ctx, connection)` into
    /// `out`: the point's weight towards the camera in the path's channels (zero: nothing to
    /// splat), which the pinhole's importance `1/(d²·cos³θ)` then multiplies (see `light`'s
    /// module documentation), when the straight, opaque ray to the camera at time `time` is
    /// clear (from the near clip plane on, where the camera's rays start; the splat waits in
    /// `out` for the ray's answer, [`SplatBuffer::settle`]). With a thin lens the connection goes
    /// to a uniform point of the lens, which the camera samples with the same density, so the
    /// lens area cancels and the contribution has the pinhole's form. The contribution goes to
    /// every pixel of the crop window whose filter footprint covers the film point, times that
    /// pixel's normalised filter weight ([`crate::pixel_filter::PixelFilter::splat_weights`]).
    pub fn splat(
        &self,
        hit: &SurfaceHit,
        ctx: &mut PathContext,
        time: f32,
        out: &mut SplatBuffer,
        value: impl FnOnce(&PathContext, &CameraConnection) -> Vec3,
    ) {
        let Some((c, splat)) = self.project(hit, ctx, value) else { return };
        let ticket = out.pending.ray(&self.shadows, hit, c.start, None, time, &mut ctx.rays);
        film_splats(self.camera, c.film, splat, |pixel, v| out.add(pixel, v, ticket));
        if out.pending.full() {
            out.settle(&self.shadows, false);
        }
    }

    /// The connection of the light-path point `hit` to the camera (a lens point drawn from
    /// `ctx` with a thin lens) and its splat in RGB, `value(ctx, connection)` times the
    /// pinhole's importance, where the shadow ray from `hit` to the connection's start still
    /// decides whether it counts ([`CameraTarget::splat`]); `None` where the point cannot reach
    /// the film or its value is zero.
    pub fn project(
        &self,
        hit: &SurfaceHit,
        ctx: &mut PathContext,
        value: impl FnOnce(&PathContext, &CameraConnection) -> Vec3,
    ) -> Option<(CameraConnection, Vec3)> {
        let camera = self.camera;
        let lens = if self.lens { camera.lens_point(ctx.sampler.get_2d(Dim::Lens)) } else { camera.position };
        let c = camera.connection(hit.p, lens)?;
        let v = value(ctx, &c);
        if v == Vec3::ZERO {
            return None;
        }
        // dω = |cos_v| dA / d² and dA_film = dω / cos³θ (a visible ray's transmittance is 1).
        let splat = ctx.channels.to_rgb(v) / (c.dist2 * c.cos * c.cos * c.cos);
        Some((c, splat))
    }
}

/// Share `value`, which lands on the film point `film` (pixel units), among the pixels of the
/// camera's crop window whose filter footprint covers it: `add(pixel, value · weight)` with that
/// pixel's normalised filter weight ([`crate::pixel_filter::PixelFilter::splat_weights`]).
pub(crate) fn film_splats(camera: &Camera, film: glam::Vec2, value: Vec3, mut add: impl FnMut(u32, Vec3)) {
    let crop = camera.crop;
    camera.filter.splat_weights(film, camera.width, camera.height, |x, y, weight| {
        if let Some(pixel) = crop.index(x, y) {
            add(pixel, if weight == 1.0 { value } else { value * weight });
        }
    });
}
