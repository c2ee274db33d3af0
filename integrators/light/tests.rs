//! Unit tests of how `light` keeps the wavelengths at dispersive glass: splitting at smooth
//! glass, MIS over the wavelengths at rough glass.
use super::*;
use crate::integrators::hero_alone_check::{agree_block_by_block, render_spectral, variance_within};
use crate::render::RenderOutput;
use crate::scene::load;

/// `light` keeping the hero alone at smooth dispersive refraction (the estimator before
/// splitting), to compare the split estimate against.
struct HeroAlone;

impl Accumulate for HeroAlone {
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film {
        LightTracer.film(scene, opts)
    }

    fn add_samples(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        samples: Range<u32>,
        film: &mut Film,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        let tracer = Tracer { hero_alone: true, ..Tracer::new(scene, &LightTracer, opts) };
        tracer.trace_samples(samples, film, progress);
    }
}

/// `light` on `scene` at `size`² pixels and `spp` samples, spectrally, with the wavelengths kept
/// (seed 1) and with the hero alone (seed 2): both unbiased, so per channel each 8×8 block's mean
/// and the whole image's (the last) agree within 4.5 standard errors of their difference (the
/// replicas' spread: 15 degrees of freedom each). Returns both renders and the worst |z|.
fn against_the_hero_alone(scene: &Scene, size: u32, spp: u32) -> (RenderOutput, RenderOutput, f64) {
    let kept = render_spectral(scene, &LightTracer, &LightTracer, size, spp, 1);
    let hero = render_spectral(scene, &LightTracer, &HeroAlone, size, spp, 2);
    let worst = agree_block_by_block(&kept, &hero, "light");
    (kept, hero, worst)
}

/// The summed per-pixel variance of a render (from the spread of its replicas).
fn variance(out: &RenderOutput) -> f64 {
    variance_within(out, |_, _| true)
}

#[test]
fn splitting_and_the_hero_alone_estimate_the_same_glass_of_water() {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass-of-water.toml");
    let scene = load(&file).unwrap();
    let (split, hero, _) = against_the_hero_alone(&scene, 32, 64);
    // The splitting took place: the branches' rays were traced.
    assert!(split.rays.refracted > hero.rays.refracted, "{:?} vs {:?}", split.rays, hero.rays);
    let ratio = variance(&split) / variance(&hero);
    eprintln!("light, glass of water: variance split/hero {ratio:.3}");
    // Light tracing's variance here is mostly the room's (spectral mode costs it 1.12× RGB
    // mode's at 160×160, docs/performance.md, "Spectral cost of `light`"), so splitting changes it by little
    // (measured 1.03×, within the spread of the replicas' variance): it must not raise it much.
    assert!(ratio < 1.25, "variance split/hero alone {ratio:.3}");
}

#[test]
fn mis_over_the_wavelengths_and_the_hero_alone_estimate_the_same_frosted_glass() {
    // frosted-glass with dispersive BK7: a rough sphere (roughness 0.3) and a satin cylinder.
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/frosted-glass.toml");
    let text = std::fs::read_to_string(&file).unwrap();
    let dispersive = text.replace("ior = 1.52", "ior = \"bk7\"");
    assert_ne!(dispersive, text, "frosted-glass names its glass's index as 1.52");
    let scene = crate::scene::load_str(&dispersive, "frosted-bk7", file.parent()).unwrap();
    let (kept, hero, _) = against_the_hero_alone(&scene, 32, 64);
    // Only the multiply scattered light splits: single scattering carries all three wavelengths
    // along one ray.
    let ratio = variance(&kept) / variance(&hero);
    eprintln!("light, frosted bk7: variance kept/hero {ratio:.3}; rays {:?} vs {:?}", kept.rays, hero.rays);
    // The hero alone's colour noise is gone: measured 0.31 (seeds 1 and 2, 32², 64 spp); a
    // ratio at 1 or above would mean the wavelengths were not kept.
    assert!(ratio < 0.6, "variance kept/hero alone {ratio:.3}");
}
