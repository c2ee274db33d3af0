//! Test support: an estimator that keeps the three wavelengths against the hero alone (the
//! estimator before splitting and MIS over the wavelengths), both unbiased, compared block by
//! block from their replicas. `light`'s and the bidirectional engine's tests use it.

use super::Integrator;
use crate::render::{render_accumulated, Accumulate, RenderOptions, RenderOutput};
use crate::sampler::{Replicas, SamplerKind};
use crate::scene::{Scene, SpectralMode};
use glam::DVec3;

/// `method` (an engine of `integrator`, with the wavelengths kept or the hero alone) on `scene`
/// at `size`² pixels, `spp` samples in 16 replicas, independent sampling with `seed`,
/// spectrally; every sample finite.
pub(crate) fn render_spectral(
    scene: &Scene,
    integrator: &dyn Integrator,
    method: &dyn Accumulate,
    size: u32,
    spp: u32,
    seed: u64,
) -> RenderOutput {
    let mut opts = RenderOptions::for_method(scene, integrator, spp);
    opts.resolution = Some((size, size));
    opts.replicas = Replicas::new(16).unwrap();
    opts.sampler = SamplerKind::Independent;
    opts.seed = seed;
    opts.spectral = SpectralMode::On;
    let out = render_accumulated(scene, method, &opts, &|_, _| {});
    assert!(out.spectral);
    assert_eq!(out.non_finite_samples, 0);
    out
}

/// Per channel, the mean over each `block`² block (row by row), then over the whole image
/// (last), and the variance of that mean from the spread of the replicas.
pub(crate) fn blocks(out: &RenderOutput, block: usize) -> Vec<(DVec3, DVec3)> {
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
            let values: Vec<DVec3> = (0..reps.count())
                .map(|j| pixels.iter().map(|&p| reps.means[j].pixels[p].as_dvec3()).sum::<DVec3>())
                .map(|sum| sum / pixels.len() as f64)
                .collect();
            let mean = values.iter().sum::<DVec3>() / r;
            let var = values.iter().map(|v| (*v - mean) * (*v - mean)).sum::<DVec3>() / (r * (r - 1.0));
            (mean, var)
        })
        .collect()
}

/// Asserts that `kept` and `hero` (independent renders of the same scene) agree: per channel,
/// each 8×8 block's mean and the whole image's within 4.5 standard errors of their difference
/// (the replicas' spread: 15 degrees of freedom each). Returns the worst |z|; `label` names the
/// method in messages.
pub(crate) fn agree_block_by_block(kept: &RenderOutput, hero: &RenderOutput, label: &str) -> f64 {
    let (a, b) = (blocks(kept, 8), blocks(hero, 8));
    let mut worst = 0.0f64;
    for (k, ((ms, vs), (mh, vh))) in a.iter().zip(&b).enumerate() {
        for c in 0..3 {
            let z = (ms[c] - mh[c]) / (vs[c] + vh[c]).sqrt().max(1e-12);
            assert!(
                z.abs() < 4.5,
                "{label}: block {k} channel {c}: kept {} vs hero {} (z = {z:.2})",
                ms[c],
                mh[c]
            );
            worst = worst.max(z.abs());
        }
    }
    eprintln!(
        "{label}: wavelengths kept {} vs hero alone {}, worst |z| {worst:.2}",
        a[a.len() - 1].0,
        b[b.len() - 1].0
    );
    worst
}

/// The variance of a render (the replicas' spread, summed over channels) over the pixels whose
/// position, as fractions (x, y) of the image's width, `within` keeps.
pub(crate) fn variance_within(out: &RenderOutput, within: impl Fn(f64, f64) -> bool) -> f64 {
    let v = out.replicas.as_ref().unwrap().variance();
    let w = v.width;
    let at = |i: usize| ((i % w) as f64 / w as f64, (i / w) as f64 / w as f64);
    let pixels = v.pixels.iter().enumerate().filter(|&(i, _)| {
        let (x, y) = at(i);
        within(x, y)
    });
    pixels.map(|(_, p)| p.element_sum() as f64).sum()
}
