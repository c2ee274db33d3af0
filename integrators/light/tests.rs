//! Unit tests of how `light` keeps the wavelengths at dispersive glass: splitting at smooth
//! glass, MIS over the wavelengths at rough glass.
use super::*;
use crate::render::{render_accumulated, RenderOutput};
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

/// `light` (`method`: splitting, or the hero alone) on `scene` at `size`² pixels, `spp` samples
/// in 16 replicas, independent sampling with `seed`, spectrally.
fn render(scene: &Scene, method: &dyn Accumulate, size: u32, spp: u32, seed: u64) -> RenderOutput {
    let mut opts = RenderOptions::for_method(scene, &LightTracer, spp);
    opts.resolution = Some((size, size));
    opts.replicas = Replicas::new(16).unwrap();
    opts.sampler = SamplerKind::Independent;
    opts.seed = seed;
    opts.spectral = crate::scene::SpectralMode::On;
    let out = render_accumulated(scene, method, &opts, &|_, _| {});
    assert!(out.spectral);
    assert_eq!(out.non_finite_samples, 0);
    out
}

/// Per channel, the mean over each `block`² block (row by row), then over the whole image
/// (last), and the variance of that mean from the spread of the replicas (the bidirectional
/// engine's splitting test uses it too).
pub(crate) fn blocks(out: &RenderOutput, block: usize) -> Vec<(glam::DVec3, glam::DVec3)> {
    let reps = out.replicas.as_ref().expect("replicas");
    let (w, h) = (reps.width(), reps.height());
    let mut regions: Vec<Vec<usize>> = (0..h.div_ceil(block) * w.div_ceil(block))
        .map(|b| {
            let (bx, by) = (b % w.div_ceil(block) * block, b / w.div_ceil(block) * block);
            (by..(by + block).min(h))
                .flat_map(|y| (bx..(bx + block).min(w)).map(move |x| y * w + x))
                .collect()
        })
        .collect();
    regions.push((0..w * h).collect());
    let r = reps.count() as f64;
    regions
        .iter()
        .map(|pixels| {
            let values: Vec<glam::DVec3> = (0..reps.count())
                .map(|j| pixels.iter().map(|&p| reps.means[j].pixels[p].as_dvec3()).sum::<glam::DVec3>())
                .map(|sum| sum / pixels.len() as f64)
                .collect();
            let mean = values.iter().sum::<glam::DVec3>() / r;
            let var = values.iter().map(|v| (*v - mean) * (*v - mean)).sum::<glam::DVec3>() / (r * (r - 1.0));
            (mean, var)
        })
        .collect()
}

/// `light` on `scene` at `size`² pixels and `spp` samples, spectrally, with the wavelengths kept
/// (seed 1) and with the hero alone (seed 2): both unbiased, so per channel each 8×8 block's mean
/// and the whole image's (the last) agree within 4.5 standard errors of their difference (the
/// replicas' spread: 15 degrees of freedom each). Returns both renders and the worst |z|.
fn against_the_hero_alone(scene: &Scene, size: u32, spp: u32) -> (RenderOutput, RenderOutput, f64) {
    let split = render(scene, &LightTracer, size, spp, 1);
    let hero = render(scene, &HeroAlone, size, spp, 2);
    let (a, b) = (blocks(&split, 8), blocks(&hero, 8));
    let mut worst = 0.0f64;
    for (k, ((ms, vs), (mh, vh))) in a.iter().zip(&b).enumerate() {
        for c in 0..3 {
            let z = (ms[c] - mh[c]) / (vs[c] + vh[c]).sqrt().max(1e-12);
            assert!(z.abs() < 4.5, "block {k} channel {c}: kept {} vs hero {} (z = {z:.2})", ms[c], mh[c]);
            worst = worst.max(z.abs());
        }
    }
    eprintln!(
        "light: wavelengths kept {} vs hero alone {}, worst |z| {worst:.2}",
        a[a.len() - 1].0,
        b[b.len() - 1].0
    );
    (split, hero, worst)
}

/// The summed per-pixel variance of a render (from the spread of its replicas).
fn variance(out: &RenderOutput) -> f64 {
    let v = out.replicas.as_ref().unwrap().variance();
    v.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>()
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
    // mode's at 160×160, README "Spectral rendering"), so splitting changes it by little
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
