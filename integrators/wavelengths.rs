//! Hero-wavelength MIS at rough dispersive glass: how a spectral path keeps its three wavelengths
//! through rough dielectric interfaces whose index depends on the wavelength. Written once, used
//! by `path` (radiance) and `light` (importance); the same argument holds in either transport
//! mode, since only f changes with the mode and the densities do not.
//!
//! At such a vertex each wavelength λᵢ has its own BSDF fᵢ (its own index), whose sample is the
//! random walk on the microsurface ([`crate::bsdf::rough_dielectric`]): after one facet a
//! direction with the density pᵢ that `pdf` gives (single scattering), after several a direction
//! whose density nobody knows (multiple scattering, [`BsdfSample::is_multiple`]). With
//! r = (uc′, u) the walk's numbers, walkᵢ(r) the walk at λᵢ and wᵢ its weight fᵢ|cos θ|/density,
//! the vertex estimates every channel i's integral Iᵢ = Iᵢˢ + Iᵢᵐ as follows:
//!
//! 1. The sampling wavelength j is chosen uniformly, from the top of the lobe number uc
//!    (j = ⌊3uc⌋, uc′ = 3uc − j, so no number is added to the stream and uc′ stays uniform and
//!    independent of j), and walk_j(r) is drawn ([`PathContext::sample_wavelengths`]).
//! 2. After one facet (single scattering), every wavelength goes on along its direction ω with
//!    the one-sample MIS weight of the balance heuristic (Veach 1997, §9.2.4; Wilkie et al.
//!    2014 over the wavelengths): channel i's throughput takes fᵢ(ω)|cos θ| / p̄(ω), p̄ the mean
//!    of the three densities. Over j and r this integrates fᵢ's single-scattering part exactly:
//!    Σⱼ ⅓ ∫ pⱼ fᵢ L / p̄ = Iᵢˢ, wherever some pⱼ > 0 (every pᵢ > 0 where fᵢ > 0). p̄ is the
//!    vertex's BSDF density for MIS against next-event estimation, which evaluates fᵢ at each
//!    wavelength ([`PathContext::eval_wavelengths`]) and weighs with the same p̄, so the two
//!    strategies stay a partition for every channel. (In `light` the connection to the camera is the vertex's
//!    one strategy for the light leaving it there: it takes each fᵢ, with no weight.)
//! 3. After several facets (or at a wavelength whose interface is index-matched, a delta),
//!    there is no density to weigh with. The fallback is splitting, as at smooth glass: every
//!    wavelength walks with the same numbers r, and M(r) is the set of those whose walk also
//!    scatters several times. Where j ∈ M(r), each i ∈ M(r) goes on along its own walk's
//!    direction with weight wᵢ·3/|M(r)|: j's in flight (its wavelength leading from then on),
//!    the others as branches of their own ([`PathContext::part_multiple`]; each method keeps
//!    them in its [`PendingBranches`](crate::render::PendingBranches)), which replay the path's
//!    numbers from there. Over j: E[1{j ∈ M}·3/|M|] = 1 for every i in
//!    M(r), so channel i's estimate integrates E_r[wᵢ L 1{i ∈ M(r)}] = Iᵢᵐ: unbiased. The same
//!    numbers give all three walks nearly the same facets, so usually |M| = 3 and the weights
//!    are 1, each branch carrying its channel alone as a split at smooth glass does.
//!
//! So every channel stays an unbiased estimate of its own wavelength, and the secondaries
//! survive single scattering at the cost of two more `eval`s and no ray; multiple scattering
//! costs the branches' rays, as smooth glass does. The alternatives: MIS alone cannot weigh the
//! multiply scattered samples (no density), and ending the other wavelengths there (weight 3 on
//! the sampling one) would be unbiased too but brings back the hero alone's colour noise on
//! every path through frosted glass, where most of the light scatters several times only at high
//! roughness but always in part. A path whose secondaries have ended (after smooth-glass
//! splitting), an RGB path, and `hero_alone` (which keeps the old estimator, ending the
//! secondaries at rough dispersive glass, to compare against) never come here.

use super::{channel_alone, Parting, PathContext};
use crate::bsdf::{BsdfSample, Scattering, ShadingFrame, TransportMode};
use crate::geometry::SurfaceHit;
use crate::material::Material;
use crate::sampler::ONE_MINUS_EPSILON;
use crate::spectrum::{Channels, HERO_WAVELENGTHS};
use glam::Vec3;

/// The wavelength (channel) whose walk samples a vertex, chosen uniformly by the lobe number
/// `uc`, and the lobe number its walk uses: (⌊3uc⌋, 3uc − ⌊3uc⌋).
#[inline]
pub(crate) fn wavelength_choice(uc: f32) -> (usize, f32) {
    let scaled = uc * HERO_WAVELENGTHS as f32;
    let j = (scaled as usize).min(HERO_WAVELENGTHS - 1);
    (j, (scaled - j as f32).clamp(0.0, ONE_MINUS_EPSILON))
}

impl PathContext {
    /// Whether a spectral path's wavelengths cross the surface of `material` at `hit` together,
    /// weighted by MIS over their densities (see the module documentation): rough dispersive
    /// glass, the path still carrying all three wavelengths, and not `hero_alone`.
    #[inline]
    pub(crate) fn mixes_wavelengths(&self, material: &Material, hit: &SurfaceHit) -> bool {
        self.channels.is_spectral()
            && !self.hero_only
            && !self.hero_alone
            && material.bsdf.is_dispersive()
            && !Scattering::at(material, hit.p, hit.uv, &self.channels).is_delta()
    }

    /// The scattering model of `material` at `hit` at channel `i`'s wavelength.
    #[inline]
    pub(crate) fn model_at<'m>(&self, material: &'m Material, hit: &SurfaceHit, i: usize) -> Scattering<'m> {
        let channels = match self.channels {
            Channels::Spectral(w) => Channels::Spectral(w.led_by(i)),
            rgb => rgb,
        };
        Scattering::at(material, hit.p, hit.uv, &channels)
    }

    /// At a vertex where the wavelengths mix ([`mixes_wavelengths`](Self::mixes_wavelengths)),
    /// for the local directions `wo`, `wi`: f (single scattering, in transport `mode`) at each
    /// channel's wavelength, and the mean of the wavelengths' densities of `wi` (the vertex's BSDF density
    /// for MIS). `known`: channel j's (f, density), already at hand.
    pub(crate) fn eval_wavelengths(
        &self,
        material: &Material,
        hit: &SurfaceHit,
        wo: Vec3,
        wi: Vec3,
        known: Option<(usize, f32, f32)>,
        mode: TransportMode,
    ) -> (Vec3, f32) {
        let (mut f, mut pdf) = (Vec3::ZERO, 0.0);
        for i in 0..HERO_WAVELENGTHS {
            let (fi, pi) = match known {
                Some((j, fj, pj)) if j == i => (fj, pj),
                _ => match self.model_at(material, hit, i) {
                    Scattering::Dielectric(d) => {
                        let (f, pdf) = d.eval_with_pdf(wo, wi, mode);
                        (f.x, pdf)
                    }
                    model => (model.eval(wo, wi, mode).x, model.pdf(wo, wi)),
                },
            };
            f[i] = fi;
            pdf += pi;
        }
        (f, pdf / HERO_WAVELENGTHS as f32)
    }

    /// BSDF sampling where the wavelengths mix: the walk of the wavelength the lobe number `uc`
    /// chooses ([`wavelength_choice`]) with the rest of its numbers and `u`, for the local
    /// direction `wo`, in transport `mode`. After one facet, f per channel and the mean density
    /// ([`eval_wavelengths`](Self::eval_wavelengths)), so f·|cos θ|/pdf is every channel's MIS
    /// weight; after several (not evaluable), the walk's own sample, which
    /// [`part_multiple`](Self::part_multiple) then splits.
    pub(crate) fn sample_wavelengths(
        &self,
        material: &Material,
        hit: &SurfaceHit,
        wo: Vec3,
        uc: f32,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let (j, uc) = wavelength_choice(uc);
        let s = self.model_at(material, hit, j).sample(wo, uc, u.into(), mode)?;
        if !s.is_evaluable() {
            return Some(s);
        }
        let (f, pdf) = self.eval_wavelengths(material, hit, wo, s.wi, Some((j, s.f.x, s.pdf)), mode);
        Some(BsdfSample { f, pdf, ..s })
    }

    /// The split of a path whose wavelengths mix at `hit` (shading frame `frame`, `wo` the world
    /// direction back along the path and `wo_local` in the frame) after `s`, a sample that is
    /// not evaluable, drawn by [`sample_wavelengths`](Self::sample_wavelengths) in `mode` with the
    /// numbers `(uc, u)`: every other wavelength walks with the same numbers, and those whose walk
    /// also scatters several times are parted from the path, each weighted 3/|M| with M the
    /// wavelengths whose walk does (their rays counted now). The factor keeps the sampling
    /// wavelength's channel alone, with that weight, and it leads the path from here on.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn part_multiple(
        &mut self,
        material: &Material,
        hit: &SurfaceHit,
        frame: &ShadingFrame,
        wo: Vec3,
        s: &BsdfSample,
        wo_local: Vec3,
        (uc, u): (f32, (f32, f32)),
        mode: TransportMode,
    ) -> Parting {
        let mut parted = [None; HERO_WAVELENGTHS - 1];
        let Channels::Spectral(w) = self.channels else {
            return (Vec3::ONE, parted);
        };
        let (j, uc) = wavelength_choice(uc);
        let walks: [Option<BsdfSample>; HERO_WAVELENGTHS] = std::array::from_fn(|i| {
            let si = if i == j {
                Some(*s)
            } else {
                self.model_at(material, hit, i).sample(wo_local, uc, u.into(), mode)
            };
            si.filter(|si| !si.is_evaluable())
        });
        let members = walks.iter().flatten().count().max(1);
        let weight = HERO_WAVELENGTHS as f32 / members as f32;
        let others = walks.iter().enumerate().filter_map(|(i, si)| si.filter(|_| i != j).map(|si| (i, si)));
        for (slot, (i, si)) in parted.iter_mut().zip(others) {
            *slot = self.parted(i, si, hit, frame, wo, mode, weight);
        }
        self.hero_only = true;
        self.channels = Channels::Spectral(w.led_by(j));
        (channel_alone(j) * weight, parted)
    }
}
