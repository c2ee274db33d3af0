//! The rendering methods, one per file, behind one trait, and the registry of their names.

mod distributed;
mod light;
mod path;
mod raycast;
mod splat_film;
mod ssaa;
mod vertex_merging;
mod wavefront;
mod whitted;

pub use crate::params::{EngineOption, MergeParams, RenderParams, SsaaParams, Strategy};
pub use distributed::Distributed;
pub use light::LightTracer;
#[cfg(test)]
pub(crate) use path::power_heuristic;
pub use path::{Path, DEFAULT_PATH_DEPTH};
pub use raycast::RayCast;
pub use ssaa::Ssaa;
pub use vertex_merging::{
    initial_radius, iteration_radius, light_paths_per_iteration, Algorithm, VertexMerging,
    DEFAULT_MAX_LIGHT_PATHS, DEFAULT_RADIUS_FRACTION, RADIUS_REFERENCE_PIXELS,
};
pub use wavefront::{Occupancy, StageOccupancy, Wavefront};
pub use whitted::Whitted;

use crate::bsdf::{BsdfSample, Scattering, TransportMode};
use crate::geometry::Ray;
use crate::material::Bsdf;
use crate::optics::fresnel_dielectric;
use crate::render::{Progression, RenderOptions, RenderOutput};
use crate::sampler::{Dim, Sampler};
use crate::scene::effects::Support;
use crate::scene::{Effect, RenderSettings, Scene};
use crate::spectrum::{Channels, HERO_ONLY};
use crate::stats::RayCounts;
use glam::Vec3;

/// A sample of `bsdf` for the local direction `wo`, drawing from `sampler` only the numbers it
/// uses: a lobe choice only where the model has lobes to choose between, then the direction.
#[inline]
pub(crate) fn sample_bsdf(
    bsdf: &Scattering,
    wo: Vec3,
    mode: TransportMode,
    sampler: &mut Sampler,
) -> Option<BsdfSample> {
    let uc = if bsdf.chooses_lobe() { sampler.get_1d(Dim::Bsdf) } else { 0.0 };
    let u = sampler.get_2d(Dim::Bsdf);
    bsdf.sample(wo, uc, u, mode)
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

/// The state of one camera sample while its path is traced.
#[derive(Clone, Debug)]
pub struct PathContext {
    /// The sample's random stream.
    pub sampler: Sampler,
    /// Rays traced so far, by kind.
    pub rays: RayCounts,
    /// What the channels of the sample's radiance hold: RGB, or its wavelengths.
    pub channels: Channels,
    /// Whether the path has ended its secondary wavelengths (at a dispersive interface).
    pub hero_only: bool,
}

impl PathContext {
    /// A context for the given stream, in RGB mode.
    pub fn new(sampler: Sampler) -> PathContext {
        PathContext { sampler, rays: RayCounts::default(), channels: Channels::Rgb, hero_only: false }
    }

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

/// Whether a path with these `channels`, its secondaries already ended or not (`hero_only`),
/// ends them at a surface of `bsdf`: in spectral mode, at its first dispersive interface.
#[inline]
pub(crate) fn ends_secondaries(channels: &Channels, hero_only: bool, bsdf: &Bsdf) -> bool {
    channels.is_spectral() && !hero_only && bsdf.is_dispersive()
}

/// Which engine runs a method on a scene, and why (for `vitrum info` and the render summary).
#[derive(Clone, Debug)]
pub struct EngineChoice {
    /// The wavefront engine, when it runs; `None`: one ray at a time.
    pub wavefront: Option<std::sync::Arc<Wavefront>>,
    /// Why this engine runs.
    pub reason: String,
}

impl EngineChoice {
    /// The one-ray engine, for `reason`.
    pub fn scalar(reason: impl Into<String>) -> EngineChoice {
        EngineChoice { wavefront: None, reason: reason.into() }
    }

    /// The wavefront engine `engine`, for `reason`.
    pub fn wavefront(engine: Wavefront, reason: impl Into<String>) -> EngineChoice {
        EngineChoice { wavefront: Some(std::sync::Arc::new(engine)), reason: reason.into() }
    }

    /// `wavefront` or `scalar`.
    pub fn name(&self) -> &'static str {
        if self.wavefront.is_some() {
            "wavefront"
        } else {
            "scalar"
        }
    }

    /// The engine, how it finds hits and why it runs, in one phrase.
    pub fn describe(&self) -> String {
        match &self.wavefront {
            Some(w) => format!("wavefront ({}): {}", w.describe(), self.reason),
            None => format!("scalar: {}", self.reason),
        }
    }
}

/// A rendering method.
pub trait Integrator: Send + Sync {
    /// Registry name (`raycast`, `whitted`, …).
    fn name(&self) -> &'static str;
    /// One line for `vitrum integrators`.
    fn description(&self) -> &'static str;
    /// What the method does with an effect the scene calls for.
    fn support(&self, effect: Effect) -> Support;
    /// The maximum depth when neither the scene nor the command line sets one.
    fn default_max_depth(&self) -> u32 {
        5
    }
    /// Radiance arriving at the camera along `ray`.
    fn radiance(&self, scene: &Scene, params: &RenderParams, ray: &Ray, ctx: &mut PathContext) -> Vec3;
    /// Methods with their own image loop (adaptive supersampling, light tracing) render here;
    /// `None` means the shared camera pass estimates every pixel with [`Integrator::radiance`].
    fn render_image(
        &self,
        _scene: &Scene,
        _opts: &RenderOptions,
        _progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Option<RenderOutput> {
        None
    }
    /// Which engine traces `scene` under `opts` ([`RenderParams::engine`]), and why: a method
    /// with a wavefront engine (`path`) runs it where it supports the scene; the default is one
    /// ray at a time.
    fn engine(&self, _scene: &Scene, _opts: &RenderOptions) -> EngineChoice {
        EngineChoice::scalar("one ray at a time: only `path` has a wavefront engine")
    }
    /// How the method's image grows with the sample count (progressive rendering, per-pixel
    /// variance); the default is the shared camera pass.
    fn progression(&self) -> Progression<'_> {
        Progression::CameraPass
    }
    /// The bytes the method allocates for a render of `scene` with `opts` beyond the film and
    /// the outputs ([`crate::memory::MemoryEstimate`]); none by default.
    fn working_memory(&self, _scene: &Scene, _opts: &RenderOptions) -> u64 {
        0
    }
}

/// Every integrator, in the order `vitrum integrators` lists them.
pub fn all() -> Vec<Box<dyn Integrator>> {
    vec![
        Box::new(RayCast),
        Box::new(Whitted),
        Box::new(Ssaa),
        Box::new(Distributed),
        Box::new(Path),
        Box::new(LightTracer),
        Box::new(VertexMerging(Algorithm::Bpt)),
        Box::new(VertexMerging(Algorithm::Ppm)),
        Box::new(VertexMerging(Algorithm::Bpm)),
        Box::new(VertexMerging(Algorithm::Vcm)),
    ]
}

/// The integrator registered under `name`.
pub fn create(name: &str) -> Option<Box<dyn Integrator>> {
    all().into_iter().find(|i| i.name() == name)
}

/// The registered names.
pub fn names() -> Vec<&'static str> {
    all().iter().map(|i| i.name()).collect()
}

/// How a scene's settings meet a method: its depth and its parameters.
impl RenderSettings {
    /// The maximum depth of a render by `integrator`: `cli` (the command line's `--max-depth`),
    /// else the scene's `[render.METHOD] max_depth`, else the method's own default.
    pub fn max_depth(&self, integrator: &dyn Integrator, cli: Option<u32>) -> u32 {
        cli.or_else(|| self.max_depths.get(integrator.name()).copied())
            .unwrap_or_else(|| integrator.default_max_depth())
    }

    /// The parameters of a render by `integrator` with the scene's settings, the depth as
    /// [`RenderSettings::max_depth`] gives it.
    pub fn params(&self, integrator: &dyn Integrator, cli_depth: Option<u32>) -> RenderParams {
        RenderParams {
            max_depth: self.max_depth(integrator, cli_depth),
            reflectance: self.reflectance,
            ssaa: self.ssaa,
            merging: self.merging.get(integrator.name()).copied().unwrap_or_default(),
            engine: crate::params::EngineOption::Auto,
        }
    }
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
