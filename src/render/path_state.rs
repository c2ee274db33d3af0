//! The state of one camera path of `path` in flight ([`PathState`]), and the branches a
//! spectral path split at dispersive glass sets aside in its context ([`PendingBranches`]):
//! data the sample's context ([`PathContext`](super::PathContext)) holds, whose behaviour is
//! the method's (`integrators/path.rs`).

use crate::lanes::{Mask3, Vector};
use crate::spectrum::{Channels, HERO_WAVELENGTHS};
use glam::Vec3;
use std::mem::MaybeUninit;

/// One camera path in flight, or one per lane: everything `path` carries from one vertex to the
/// next. The scalar engine (`Path::radiance`) advances one path at a time; the wavefront
/// engine (`integrators/wavefront.rs`) advances many, asking the scene for their closest hits
/// and their shadow rays across lanes, and shading them one at a time or, where the scene allows,
/// 16 at a time. All of them run the same `PathState::advance` (`integrators/path.rs`), so they estimate the same image
/// with the same random numbers.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathState<V: Vector = Vec3> {
    /// The origin of the ray to trace next.
    pub origin: V,
    /// Its direction.
    pub dir: V,
    /// Its time (moving objects).
    pub time: V::Real,
    /// Radiance gathered so far.
    pub l: V,
    /// Throughput from the camera to the ray's origin.
    pub beta: V,
    /// Product of η² over the refractions so far (undone for Russian roulette).
    pub eta_scale: V::Real,
    /// Whether the last scattering was not evaluable (delta or multiple): no MIS on what it hits.
    pub skip_mis: Mask3<V>,
    /// The density of the last BSDF sample (for MIS against next-event estimation).
    pub bsdf_pdf: V::Real,
    /// Absorption coefficient of the medium the ray travels in.
    pub absorption: V,
    /// Bounces so far (a whole number).
    pub depth: V::Real,
    /// For manifold next-event estimation (`mnee`): the smooth glass interfaces the path has
    /// crossed or reflected at since the last vertex where the manifold strategy ran and BSDF
    /// sampling took an evaluable lobe, as long as every turn is one the strategy finds and
    /// there are at most its `max_chain`; −1 otherwise (and always without the strategy).
    /// An area light such a chain reaches is the strategy's, not BSDF sampling's.
    pub chain: V::Real,
}

/// The branches of a spectral path that dispersive glass split (smooth glass, or rough
/// glass that scattered the light between several facets), waiting for the
/// branch in flight to end (last in, first out): each the channel of the one wavelength it
/// carries and its state `S` where it leaves the glass (a camera path's [`PathState`] by
/// default; a light path of `light` its own). The live branches share out the
/// [`HERO_WAVELENGTHS`] channels, so at most two wait.
#[derive(Clone, Copy)]
#[repr(C)]
pub(crate) struct PendingBranches<S: Copy = PathState> {
    /// How many wait (first, so that a new context writes it without touching the branches).
    count: u8,
    /// The branches, the first `count` of them set (the others never read: a camera sample's
    /// context is made without writing them, so RGB renders, which never split, pay nothing).
    branches: [MaybeUninit<Branch<S>>; HERO_WAVELENGTHS - 1],
}

impl<S: Copy> std::fmt::Debug for PendingBranches<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PendingBranches").field("count", &self.count).finish_non_exhaustive()
    }
}

/// A branch of a split path waiting to run.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Branch<S = PathState> {
    /// The channel of the one wavelength it carries.
    pub channel: usize,
    /// Its state where it leaves the glass.
    pub state: S,
    /// The dimension of the path's random stream it draws from when it runs: where the branch
    /// in flight drew its next numbers after the split, so that it replays them.
    pub replay: u32,
}

impl<S: Copy> Default for PendingBranches<S> {
    #[inline]
    fn default() -> PendingBranches<S> {
        PendingBranches { branches: [MaybeUninit::uninit(); HERO_WAVELENGTHS - 1], count: 0 }
    }
}

impl<S: Copy> PendingBranches<S> {
    /// Sets aside `branch`.
    #[inline]
    pub(crate) fn push(&mut self, branch: Branch<S>) {
        let slot = self.branches.get_mut(self.count as usize);
        slot.expect("at most two branches wait: one per other wavelength").write(branch);
        self.count += 1;
    }

    /// The branch set aside last, taken out.
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<Branch<S>> {
        (self.count > 0).then(|| {
            self.count -= 1;
            // SAFETY: the first `count` slots were written by `push`.
            unsafe { self.branches[self.count as usize].assume_init() }
        })
    }

    /// The branch set aside last, taken out to run: `channels`, the path's, then take their
    /// indices at the one wavelength it carries.
    #[inline]
    pub(crate) fn resume(&mut self, channels: &mut Channels) -> Option<Branch<S>> {
        let branch = self.pop()?;
        if let Channels::Spectral(w) = *channels {
            *channels = Channels::Spectral(w.led_by(branch.channel));
        }
        Some(branch)
    }
}
