//! The rendering methods, one per file, each implementing the render contract
//! ([`crate::render::Integrator`] and its [`Progression`]), and the registry that builds them
//! from the table of methods ([`crate::methods`]).

mod distributed;
#[cfg(test)]
mod hero_alone_check;
mod light;
mod metropolis;
mod mmlt;
mod mnee;
mod path;
mod pssmlt;
mod raycast;
mod shadow_queue;
mod splat_film;
mod ssaa;
mod vertex_merging;
mod wavefront;
mod wavelengths;
mod whitted;

pub use crate::methods::Method;
pub use crate::params::{EngineOption, MergeParams, MetropolisParams, RenderParams, SsaaParams, Strategy};
pub use crate::render::{
    Accumulate, BatchEngine, CameraEstimator, EngineChoice, FixedImage, Integrator, PathContext, Progression,
};
pub use distributed::Distributed;
pub use light::LightTracer;
pub use mmlt::Mmlt;
pub use mnee::Mnee;
#[cfg(test)]
pub(crate) use path::power_heuristic;
pub use path::{Path, DEFAULT_PATH_DEPTH};
pub use pssmlt::Pssmlt;
pub use raycast::RayCast;
pub use ssaa::Ssaa;
pub use vertex_merging::{
    initial_radius, iteration_radius, light_paths_per_iteration, Algorithm, VertexMerging,
    DEFAULT_MAX_LIGHT_PATHS, DEFAULT_RADIUS_FRACTION, RADIUS_REFERENCE_PIXELS,
};
pub use wavefront::{Occupancy, StageOccupancy, Wavefront};
pub use whitted::Whitted;

use crate::bsdf::{BsdfSample, Scattering, ShadingFrame, TransportMode};
use crate::geometry::SurfaceHit;
use crate::material::{Bsdf, Material};
use crate::optics::fresnel_dielectric;
use crate::sampler::{Dim, Sampler};
use crate::spectrum::{Channels, HERO_ONLY, HERO_WAVELENGTHS};
use glam::{Vec2, Vec3};

/// The numbers a sample of `bsdf` takes from `sampler`, only those it uses: a lobe choice only
/// where the model has lobes to choose between (0 otherwise), then the direction pair.
#[inline]
pub(crate) fn bsdf_numbers(bsdf: &Scattering, sampler: &mut Sampler) -> (f32, Vec2) {
    let uc = if bsdf.chooses_lobe() { sampler.get_1d(Dim::Bsdf) } else { 0.0 };
    (uc, sampler.get_2d(Dim::Bsdf))
}

/// One of `count` (at least one) lights, chosen uniformly with the numbers of `sampler`; a
/// scene with a single light draws none.
#[inline]
pub(crate) fn pick_light(count: usize, sampler: &mut Sampler) -> usize {
    debug_assert!(count > 0, "a light is picked only in a scene with lights");
    if count == 1 {
        return 0;
    }
    light_index(sampler.get_1d(Dim::Light), count)
}

/// The light of `count` (at least one) that the uniform number `u` chooses: `⌊u·count⌋`, the
/// last one for `u` → 1.
#[inline(always)]
pub(crate) fn light_index(u: f32, count: usize) -> usize {
    ((u * count as f32) as usize).min(count - 1)
}

/// Bounces after which Russian roulette may end a path (every method that plays it).
pub(crate) const ROULETTE_DEPTH: u32 = 3;

/// How a camera sample's path ends its secondary wavelengths: the spectral part of
/// [`PathContext`] (defined with the contract, [`crate::render::PathContext`]), which the
/// methods share.
impl PathContext {
    /// The factor a spectral path's throughput takes at a surface of `bsdf`, modelled as
    /// `scattering`, before anything is sampled or evaluated there: [`HERO_ONLY`] the first time it
    /// meets a dispersive interface that is not smooth (rough glass, whose value at the hero
    /// wavelength next-event estimation is about to use), 1 otherwise. Smooth dispersive glass
    /// decides after its sample, in [`secondaries_after`](Self::secondaries_after).
    #[inline]
    pub fn end_secondaries_at(&mut self, bsdf: &Bsdf, scattering: &Scattering) -> Vec3 {
        if ends_secondaries(&self.channels, self.hero_only, bsdf) && !scattering.is_delta() {
            self.hero_only = true;
            HERO_ONLY
        } else {
            Vec3::ONE
        }
    }

    /// The factor a spectral path's throughput takes after sample `s` of smooth glass `bsdf`
    /// (the outgoing direction `wo` in the local frame of its outward normal), the first time it
    /// meets a dispersive one. A refraction parts the wavelengths: the hero goes on alone,
    /// [`HERO_ONLY`]. A reflection sends every wavelength the same way, so all three go on, each
    /// weighted by its own Fresnel reflectance over the hero's, F(λᵢ)/F(λ₁), which the hero chose
    /// the reflection with: the estimate of every wavelength stays unbiased. 1 otherwise.
    #[inline]
    pub fn secondaries_after(&mut self, bsdf: &Bsdf, s: &BsdfSample, wo: Vec3) -> Vec3 {
        let (Channels::Spectral(w), Bsdf::Dielectric { inside, outside, .. }) = (&self.channels, bsdf) else {
            return Vec3::ONE;
        };
        if self.hero_only || !bsdf.is_dispersive() || !s.is_specular {
            return Vec3::ONE;
        }
        let reflectance = |lambda: f32| {
            let eta = inside.ior.at(lambda) / outside.ior.at(lambda);
            fresnel_dielectric(wo.z.abs(), if wo.z > 0.0 { eta } else { 1.0 / eta })
        };
        let hero = reflectance(w.lambda[0]);
        if s.is_transmission || hero <= 0.0 {
            self.hero_only = true;
            return HERO_ONLY;
        }
        Vec3::new(1.0, reflectance(w.lambda[1]) / hero, reflectance(w.lambda[2]) / hero)
    }
}

/// A wavelength that smooth dispersive glass parted from the lead of a spectral path
/// ([`PathContext::part_wavelengths`]): its own sample of the interface, which the method
/// follows as a branch of its own (its channel alone).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PartedWavelength {
    /// Its channel.
    pub channel: usize,
    /// Its sample of the interface: at its own index, with the lead's numbers.
    pub sample: BsdfSample,
    /// The sampled direction, in the world.
    pub wi: Vec3,
    /// The factor its branch's throughput takes at the interface: its sample's f·|cos|/pdf
    /// times the shading normal's factor, in its channel, 0 in the others.
    pub weight: Vec3,
    /// The path's channels with indices taken at its wavelength (the branch's channels).
    pub channels: Channels,
}

/// What smooth dispersive glass does to the wavelengths of a path ([`PathContext::part_wavelengths`]):
/// the factor the path's own throughput takes, and the wavelengths it parted from the path.
pub(crate) type Parting = (Vec3, [Option<PartedWavelength>; HERO_WAVELENGTHS - 1]);

/// The channel `c` alone: 1 there, 0 in the others.
#[inline]
pub(crate) fn channel_alone(c: usize) -> Vec3 {
    Vec3::from_array(std::array::from_fn(|i| if i == c { 1.0 } else { 0.0 }))
}

/// Wavelength splitting, the one decision every method that splits (`path`, `light`) takes.
impl PathContext {
    /// Wavelength splitting at smooth dispersive glass `material` at `hit` (shading frame
    /// `frame`, `wo` the world direction back along the path and `wo_local` in the frame), after
    /// `s`, the sample of the lead wavelength drawn in `mode` with the numbers `(uc, u)`. Each
    /// wavelength chooses reflection or refraction by its own Fresnel reflectance with the same
    /// numbers (its own sample of the interface at its own index). Where all three reflect they
    /// go on together along the one mirror direction, each with its own weight (1): factor 1,
    /// nothing parted. Otherwise the wavelengths part: the path goes on with the lead's channel
    /// alone (the factor is 1 there, 0 in the others), and every other wavelength whose sample
    /// carries light is returned to become a branch of its own, its ray counted now; every
    /// channel is then its own unbiased estimate (no weight 3), and the context carries one
    /// wavelength from here on ([`hero_only`](Self::hero_only)). A path already down to one
    /// wavelength, an RGB path, and any other interface: factor 1. With
    /// [`hero_alone`](Self::hero_alone) (the estimator before splitting, kept to compare
    /// against), the secondaries end at a refraction instead ([`secondaries_after`](Self::secondaries_after)).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn part_wavelengths(
        &mut self,
        material: &Material,
        hit: &SurfaceHit,
        frame: &ShadingFrame,
        wo: Vec3,
        s: &BsdfSample,
        wo_local: Vec3,
        (uc, u): (f32, Vec2),
        mode: TransportMode,
    ) -> Parting {
        let none = [None; HERO_WAVELENGTHS - 1];
        let Channels::Spectral(w) = self.channels else {
            return (Vec3::ONE, none);
        };
        if self.hero_only || !material.bsdf.is_dispersive() || !s.is_specular {
            return (Vec3::ONE, none);
        }
        if self.hero_alone {
            return (self.secondaries_after(&material.bsdf, s, wo_local), none);
        }
        let lead = w.lead();
        let at = |channel: usize| Channels::Spectral(w.led_by(channel));
        let samples: [Option<BsdfSample>; HERO_WAVELENGTHS] = std::array::from_fn(|i| {
            if i == lead {
                return Some(*s);
            }
            Scattering::at(material, hit.p, hit.uv, &at(i)).sample(wo_local, uc, u, mode)
        });
        if samples.iter().all(|x| x.is_some_and(|x| !x.is_transmission)) {
            // All reflect, each with probability and weight its own F: on together.
            return (Vec3::ONE, none);
        }
        let mut parted = none;
        let others = samples.iter().enumerate().filter(|&(i, _)| i != lead);
        for (slot, (i, si)) in parted.iter_mut().zip(others) {
            *slot = si.and_then(|si| self.parted(i, si, hit, frame, wo, mode, 1.0));
        }
        self.hero_only = true;
        (channel_alone(lead), parted)
    }

    /// Channel `i`'s wavelength parted from the path at `hit` along its own sample `si` (local to
    /// `frame`, `wo` the world direction back along the path, drawn in `mode`), its throughput
    /// factor times `weight`; its ray is counted now. `None` where the sample carries nothing.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn parted(
        &mut self,
        i: usize,
        si: BsdfSample,
        hit: &SurfaceHit,
        frame: &ShadingFrame,
        wo: Vec3,
        mode: TransportMode,
        weight: f32,
    ) -> Option<PartedWavelength> {
        let Channels::Spectral(w) = self.channels else {
            return None;
        };
        let wi = frame.to_world(si.wi);
        let shading = frame.factor(wo, wi, mode);
        if si.pdf <= 0.0 || si.f == Vec3::ZERO || shading == 0.0 {
            return None;
        }
        if wi.dot(hit.n) * wo.dot(hit.n) > 0.0 {
            self.rays.reflected += 1;
        } else {
            self.rays.refracted += 1;
        }
        let weight = si.f * (si.wi.z.abs() / si.pdf) * (channel_alone(i) * weight) * shading;
        Some(PartedWavelength {
            channel: i,
            sample: si,
            wi,
            weight,
            channels: Channels::Spectral(w.led_by(i)),
        })
    }
}

/// Whether a path with these `channels`, its secondaries already ended or not (`hero_only`),
/// ends them at a surface of `bsdf`: in spectral mode, at its first dispersive interface.
#[inline]
pub(crate) fn ends_secondaries(channels: &Channels, hero_only: bool, bsdf: &Bsdf) -> bool {
    channels.is_spectral() && !hero_only && bsdf.is_dispersive()
}

/// The method `method`, built.
pub fn build(method: Method) -> Box<dyn Integrator> {
    match method {
        Method::RayCast => Box::new(RayCast),
        Method::Whitted => Box::new(Whitted),
        Method::Ssaa => Box::new(Ssaa),
        Method::Distributed => Box::new(Distributed),
        Method::Path => Box::new(Path),
        Method::Light => Box::new(LightTracer),
        Method::Bpt => Box::new(VertexMerging(Algorithm::Bpt)),
        Method::Ppm => Box::new(VertexMerging(Algorithm::Ppm)),
        Method::Bpm => Box::new(VertexMerging(Algorithm::Bpm)),
        Method::Vcm => Box::new(VertexMerging(Algorithm::Vcm)),
        Method::Pssmlt => Box::new(Pssmlt),
        Method::Mmlt => Box::new(Mmlt),
        Method::Mnee => Box::new(Mnee),
    }
}

/// Every integrator, in the order of the table of methods ([`crate::methods::METHODS`]), which
/// `vitrum integrators` lists.
pub fn all() -> Vec<Box<dyn Integrator>> {
    Method::ALL.into_iter().map(build).collect()
}

/// The integrator registered under `name`.
pub fn create(name: &str) -> Option<Box<dyn Integrator>> {
    Method::from_name(name).map(build)
}

/// The registered names, in table order.
pub fn names() -> Vec<&'static str> {
    crate::methods::NAMES.to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Lambert, RoughDielectric, TrowbridgeReitz};
    use crate::sampler::SamplerKind;

    fn sampler(sample: u32) -> Sampler {
        Sampler::new(SamplerKind::Sobol, 5, 17, sample, 0)
    }

    #[test]
    fn dispersive_glass_keeps_every_wavelength_when_it_reflects_and_the_hero_when_it_refracts() {
        use crate::dispersion::Ior;
        use crate::material::Medium;
        use crate::spectrum::Wavelengths;
        let sf11 = Medium { ior: Ior::named("sf11").unwrap(), absorption: Vec3::ZERO };
        let smooth = Bsdf::Dielectric {
            inside: sf11,
            outside: Medium::clear(1.0),
            roughness: 0.0,
            distribution: crate::material::Distribution::Ggx,
        };
        let w = Wavelengths::sample(0.1);
        let channels = Channels::Spectral(w);
        let scattering = Scattering::Dielectric(RoughDielectric::new(
            sf11.ior.at(w.hero()),
            TrowbridgeReitz::from_roughness(0.0),
        ));
        // From outside, and from inside nearer the critical angle (a larger F, varying faster with λ).
        for wo in [Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.52, 0.0, -(1.0f32 - 0.27).sqrt())] {
            let fresnel = |lambda: f32| {
                let eta = sf11.ior.at(lambda);
                crate::optics::fresnel_dielectric(wo.z.abs(), if wo.z > 0.0 { eta } else { 1.0 / eta })
            };
            let expected = Vec3::from_array(w.lambda.map(fresnel));
            assert!(expected.x != expected.y && expected.y != expected.z, "the indices differ");
            // E[weight · 1{reflection}] over the lobe choice, per wavelength: its own F(λ).
            let n = 100_000;
            let mut reflected = Vec3::ZERO;
            for k in 0..n {
                let uc = (k as f32 + 0.5) / n as f32;
                let mut ctx = PathContext { channels, ..PathContext::new(sampler(0)) };
                assert_eq!(
                    ctx.end_secondaries_at(&smooth, &scattering),
                    Vec3::ONE,
                    "smooth glass decides later"
                );
                let s = scattering.sample(wo, uc, glam::Vec2::splat(0.5), TransportMode::Radiance).unwrap();
                let factor = ctx.secondaries_after(&smooth, &s, wo);
                if s.is_transmission {
                    assert_eq!((factor, ctx.hero_only), (HERO_ONLY, true));
                    // A path whose secondaries have ended is left alone.
                    assert_eq!(ctx.secondaries_after(&smooth, &s, wo), Vec3::ONE);
                } else {
                    assert!(!ctx.hero_only);
                    reflected += s.weight() * factor / n as f32;
                }
            }
            assert!(reflected.abs_diff_eq(expected, 1e-4), "wo {wo}: {reflected} vs F(λ) {expected}");
        }
        // Rough dispersive glass ends them before anything is evaluated; RGB paths never do.
        let rough = Bsdf::Dielectric {
            inside: sf11,
            outside: Medium::clear(1.0),
            roughness: 0.3,
            distribution: crate::material::Distribution::Ggx,
        };
        let rough_model =
            Scattering::Dielectric(RoughDielectric::new(1.7, TrowbridgeReitz::from_roughness(0.3)));
        let mut ctx = PathContext { channels, ..PathContext::new(sampler(0)) };
        assert_eq!(ctx.end_secondaries_at(&rough, &rough_model), HERO_ONLY);
        let mut rgb = PathContext::new(sampler(0));
        assert_eq!(rgb.end_secondaries_at(&rough, &rough_model), Vec3::ONE);
    }

    #[test]
    fn the_registry_builds_every_method_of_the_table_as_itself() {
        let built = all();
        assert_eq!(built.len(), crate::methods::METHODS.len());
        for (integrator, row) in built.iter().zip(crate::methods::METHODS) {
            assert_eq!(integrator.method(), row.method);
            assert_eq!((integrator.name(), integrator.description()), (row.name, row.description));
            assert_eq!(create(row.name).map(|i| i.method()), Some(row.method));
        }
        assert!(create("Path").is_none() && create("").is_none());
    }

    #[test]
    fn every_method_has_exactly_one_estimator_and_the_drivers_read_it() {
        use crate::render::Progression;
        let kind = |name: &str| match create(name).unwrap().progression() {
            Progression::Camera(_) => "camera",
            Progression::Accumulated(_) => "accumulated",
            Progression::Fixed(_) => "fixed",
        };
        let kinds: Vec<_> = crate::methods::NAMES.iter().map(|n| (*n, kind(n))).collect();
        assert_eq!(
            kinds,
            [
                ("raycast", "camera"),
                ("whitted", "camera"),
                ("ssaa", "fixed"),
                ("distributed", "camera"),
                ("path", "camera"),
                ("light", "accumulated"),
                ("bpt", "accumulated"),
                ("ppm", "accumulated"),
                ("bpm", "accumulated"),
                ("vcm", "accumulated"),
                ("pssmlt", "accumulated"),
                ("mmlt", "accumulated"),
                ("mnee", "camera"),
            ]
        );
        // Only camera estimators answer per camera ray; the others have the one-ray engine.
        let scene = crate::scene::load_default();
        let opts = crate::render::RenderOptions::from_scene(&scene, 1);
        for integrator in all() {
            let camera = integrator.camera().is_some();
            assert_eq!(camera, kind(integrator.name()) == "camera", "{}", integrator.name());
            let engine = integrator.engine(&scene, &opts);
            if !camera {
                assert_eq!(engine.name(), "scalar", "{}", integrator.name());
            }
        }
    }

    #[test]
    fn a_single_light_is_picked_without_a_random_number() {
        let mut s = sampler(0);
        assert_eq!(pick_light(1, &mut s), 0);
        assert_eq!(s.requests(Dim::Light), 0);
    }

    #[test]
    fn lights_are_picked_uniformly() {
        // 3 lights, 3000 picks from one pixel's Sobol' stream: χ²(2) below its 99.9% quantile 13.8.
        let mut counts = [0u32; 3];
        for sample in 0..3000 {
            let mut s = sampler(sample);
            counts[pick_light(3, &mut s)] += 1;
            assert_eq!(s.requests(Dim::Light), 1);
        }
        let chi2: f64 = counts.iter().map(|&c| (c as f64 - 1000.0).powi(2) / 1000.0).sum();
        assert!(chi2 < 13.8, "{counts:?}");
    }

    #[test]
    fn models_that_choose_no_lobe_ignore_the_lobe_number() {
        use crate::bsdf::RoughConductor;
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let models = [
            Scattering::Diffuse(Lambert::two_sided(Vec3::splat(0.5))),
            Scattering::Conductor(RoughConductor::new(
                Vec3::splat(0.9),
                TrowbridgeReitz::from_roughness(0.0),
            )),
            Scattering::Conductor(RoughConductor::new(
                Vec3::splat(0.9),
                TrowbridgeReitz::from_roughness(0.3),
            )),
            Scattering::Dielectric(RoughDielectric::new(1.5, TrowbridgeReitz::from_roughness(0.0))),
            Scattering::Dielectric(RoughDielectric::new(1.5, TrowbridgeReitz::from_roughness(0.3))),
        ];
        for model in models {
            let mut differs = false;
            for k in 0..64 {
                let u = glam::Vec2::new((k % 8) as f32 / 8.0 + 0.03, (k / 8) as f32 / 8.0 + 0.05);
                let sample =
                    |uc| model.sample(wo, uc, u, TransportMode::Radiance).map(|s| (s.wi, s.f, s.pdf));
                differs |= sample(0.0) != sample(0.999);
            }
            // A model that uses its lobe number must say so, or it would always get 0.
            assert_eq!(differs, model.chooses_lobe(), "{model:?}");
        }
    }

    #[test]
    fn bsdf_samples_draw_a_lobe_choice_only_for_glass() {
        let sample_bsdf = |bsdf: &Scattering, wo, mode, sampler: &mut Sampler| {
            let (uc, u) = bsdf_numbers(bsdf, sampler);
            bsdf.sample(wo, uc, u, mode)
        };
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let diffuse = Scattering::Diffuse(Lambert::two_sided(Vec3::splat(0.5)));
        let glass = Scattering::Dielectric(RoughDielectric::new(1.5, TrowbridgeReitz::from_roughness(0.0)));
        let mut s = sampler(0);
        assert!(sample_bsdf(&diffuse, wo, TransportMode::Radiance, &mut s).is_some());
        assert_eq!(s.requests(Dim::Bsdf), 1, "diffuse: the direction only");
        // Glass uses its lobe choice: over many samples both reflection and refraction occur.
        let (mut reflected, mut refracted) = (0, 0);
        for sample in 0..256 {
            let mut s = sampler(sample);
            let b = sample_bsdf(&glass, wo, TransportMode::Radiance, &mut s).expect("glass scatters");
            assert_eq!(s.requests(Dim::Bsdf), 2, "glass: lobe choice and direction");
            if b.is_transmission {
                refracted += 1;
            } else {
                reflected += 1;
            }
        }
        assert!(reflected > 0 && refracted > reflected, "reflected {reflected}, refracted {refracted}");
    }
}
