//! Renders kept in independent replicas and the statistics of their block means: the error of a
//! block mean, or of the image mean, is the spread of the replicas' values, never a sum of
//! per-pixel variances (the splats of one Metropolis run are correlated across pixels).

use glam::DVec3;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions, RenderOutput};
use vitrum::sampler::{Replicas, SamplerKind};
use vitrum::scene::Scene;

/// A render of `scene` by `method` at `size`² pixels with `spp` samples in `replicas` replicas,
/// seed `seed`, independent sampling, its options changed by `edit` last; every sample finite.
pub fn render_replicas(
    scene: &Scene,
    method: &str,
    size: (u32, u32),
    spp: u32,
    replicas: u32,
    seed: u64,
    edit: impl FnOnce(&mut RenderOptions),
) -> RenderOutput {
    let integrator = create(method).unwrap();
    let mut opts = RenderOptions::for_method(scene, integrator.as_ref(), spp);
    opts.resolution = Some(size);
    opts.replicas = Replicas::new(replicas).unwrap();
    opts.sampler = SamplerKind::Independent;
    opts.seed = seed;
    edit(&mut opts);
    let out = render(scene, integrator.as_ref(), &opts, &|_, _| {});
    assert_eq!(out.non_finite_samples, 0, "{method}: non-finite samples");
    assert_eq!(out.spp, spp);
    out
}

/// The mean and the variance of that mean, from the replicas, of the grey value (mean of the
/// channels) over each `block`×`block` block (row by row), and over the whole image (last).
pub fn blocks(out: &RenderOutput, block: usize) -> Vec<(f64, f64)> {
    let reps = out.replicas.as_ref().expect("replicas");
    let (w, h, r) = (reps.width(), reps.height(), reps.count());
    assert!(reps.samples.iter().all(|&n| n == reps.samples[0]), "equal replicas");
    let mut regions: Vec<Vec<usize>> = Vec::new();
    for by in (0..h).step_by(block) {
        for bx in (0..w).step_by(block) {
            regions.push(
                (by..(by + block).min(h))
                    .flat_map(|y| (bx..(bx + block).min(w)).map(move |x| y * w + x))
                    .collect(),
            );
        }
    }
    regions.push((0..w * h).collect());
    regions
        .iter()
        .map(|pixels| {
            let values: Vec<f64> = (0..r)
                .map(|j| {
                    let sum: DVec3 = pixels.iter().map(|&p| reps.means[j].pixels[p].as_dvec3()).sum();
                    sum.element_sum() / (3 * pixels.len()) as f64
                })
                .collect();
            let mean = values.iter().sum::<f64>() / r as f64;
            let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (r * (r - 1)) as f64;
            (mean, var)
        })
        .collect()
}

/// z of the difference of two (mean, variance of the mean) pairs.
pub fn z(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0) / (a.1 + b.1).sqrt().max(1e-12)
}
