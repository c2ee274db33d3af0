//! `pssmlt` (primary-sample-space Metropolis over `path`): its primary sample vector's mutations,
//! its agreement with `path` on a diffuse scene and on `cornell-glass`, with `vcm` on
//! `hollow-spheres` (lit by a quad: see there why not by its point light) and on the glass slab
//! (and with the slab's closed form), its determinism, and its settings. `tests/hard_cases.rs`
//! renders every hard case with it, every pixel finite.
//!
//! Statistics: every render keeps R independent replicas (one Metropolis run or more each, see
//! `integrators/pssmlt.rs`), and the error of a block mean or of the image mean is the spread of
//! the replicas' values, never a sum of per-pixel variances (the splats of one run are
//! correlated across pixels). Tolerances are stated in standard errors of the difference between
//! the two methods.

mod common;

use common::replicas::{blocks, z};
use std::path::Path;
use vitrum::integrators::Pssmlt;
use vitrum::render::{Accumulate, RenderOptions, RenderOutput};
use vitrum::sampler::primary::{with_primary, PrimarySamples};
use vitrum::sampler::{Dim, Sampler};
use vitrum::scene::{load, load_str, Scene, SpectralMode};

/// A render of `scene` by `method` at `size`² pixels with `spp` samples in `replicas` replicas.
fn render_replicas(
    scene: &Scene,
    method: &str,
    size: u32,
    spp: u32,
    replicas: u32,
    seed: u64,
) -> RenderOutput {
    render_replicas_in(scene, method, size, spp, replicas, seed, SpectralMode::Auto)
}

/// [`render_replicas`] with the spectral mode `spectral`.
fn render_replicas_in(
    scene: &Scene,
    method: &str,
    size: u32,
    spp: u32,
    replicas: u32,
    seed: u64,
    spectral: SpectralMode,
) -> RenderOutput {
    common::replicas::render_replicas(scene, method, (size, size), spp, replicas, seed, |o| {
        o.spectral = spectral
    })
}

/// `pssmlt` against `path` on `scene` at 32² pixels ([`assert_agrees_with`]).
fn assert_agrees_with_path(scene: &Scene, what: &str) {
    assert_agrees_with(scene, what, "path", SpectralMode::Auto);
}

/// `pssmlt` against `reference` (`path`, or `vcm` where light reaches the camera by paths
/// `path` samples too) on `scene` at 32² pixels, both rendered in the spectral mode `spectral`:
/// the 16 blocks of 8×8 pixels together (χ² of their z, 16 degrees of freedom, below its 99.9%
/// quantile 39.25) and the image mean (within 4 standard errors; the means of 64 and 32
/// replicas are close to normal). The image means and their standard errors are returned.
fn assert_agrees_with(scene: &Scene, what: &str, reference: &str, spectral: SpectralMode) -> [(f64, f64); 2] {
    let mlt = render_replicas_in(scene, "pssmlt", 32, 64, 64, 1, spectral);
    let other = render_replicas_in(scene, reference, 32, 256, 32, 2, spectral);
    assert_eq!(mlt.spectral, spectral == SpectralMode::On, "{what}: the mode asked for");
    let (a, b) = (blocks(&mlt, 8), blocks(&other, 8));
    let chi2: f64 = a[..16].iter().zip(&b[..16]).map(|(x, y)| z(*x, *y).powi(2)).sum();
    let image = z(a[16], b[16]);
    eprintln!(
        "{what}: pssmlt {:.5} ± {:.5}, {reference} {:.5} ± {:.5}, z {image:.2}; 16 blocks χ² {chi2:.1}",
        a[16].0,
        a[16].1.sqrt(),
        b[16].0,
        b[16].1.sqrt()
    );
    assert!(a[16].0 > 0.01, "{what}: a black image proves nothing");
    assert!(image.abs() <= 4.0, "{what}: image mean {image:.2} standard errors from {reference}'s");
    assert!(chi2 <= 39.25, "{what}: block χ² {chi2:.1} above the 99.9% quantile of χ²(16)");
    [a[16], b[16]]
}

/// `scenes/soft-shadows.toml` with its glass made white diffuse: a diffuse box lit by a quad.
fn diffuse_box() -> Scene {
    let text = std::fs::read_to_string(root().join("scenes/soft-shadows.toml")).unwrap();
    let text = text.replace("material = \"glass\"", "material = \"white\"");
    load_str(&text, "diffuse-box", None).unwrap()
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn agrees_with_path_on_a_diffuse_box() {
    assert_agrees_with_path(&diffuse_box(), "diffuse box");
}

/// In spectral mode too, the light seen directly included (which `path` hands over in RGB).
#[test]
fn agrees_with_path_in_spectral_mode_where_the_light_is_seen() {
    assert_agrees_with(&diffuse_box(), "diffuse box, spectral", "path", SpectralMode::On);
}

#[test]
fn agrees_with_path_on_cornell_glass() {
    let scene = load(&root().join("scenes/cornell-glass.toml")).unwrap();
    assert_agrees_with_path(&scene, "cornell-glass");
}

/// Against a `vcm` reference on `hollow-spheres` (two hollow glass shells in the Cornell box:
/// light refracted through four surfaces) with its point light replaced by a quad light of the
/// same power (`common::hollow_spheres_with_a_quad_light`). The scene's own point light cannot
/// be compared: its caustics under the shells, which `vcm` renders, are invisible to `pssmlt`,
/// whose chains explore `path`'s samples (no shadow ray bends through glass, no BSDF sample hits
/// a point), so the two estimate different images there (see `integrators/pssmlt.rs`, "What it
/// cannot do"; measured once at this test's settings with the point light: image mean 0.930 ±
/// 0.009 against `vcm`'s 0.952 ± 0.003, z −2.4, too little light for these renders to tell
/// apart reliably, which is why that comparison would prove nothing either way).
#[test]
fn agrees_with_vcm_on_hollow_spheres_lit_by_a_quad() {
    assert_agrees_with(
        &common::hollow_spheres_with_a_quad_light(),
        "hollow-spheres, quad light",
        "vcm",
        SpectralMode::Auto,
    );
}

/// Against a `vcm` reference and the closed form on the glass slab (`common::glass_slab`: a
/// diffuse quad emitter of radiance (2, 1, 0.5) seen through a clear slab of index 1.5; its
/// light is an area light, which `path`'s samples reach through the slab). At normal incidence
/// the slab passes L·(1−R)/(1+R), R = 0.04, each face reflecting R: the grey mean of the
/// channels is then 7/6·(0.96/1.04) = 1.0769. The camera's rays meet the slab up to 7.1° off the
/// normal (a 10° field of view, its corners), where the slab passes a little less; the image
/// mean must lie within 4 standard errors of the range between the two.
#[test]
fn agrees_with_vcm_and_the_closed_form_on_the_glass_slab() {
    let scene = load_str(&common::glass_slab(1.5, [0.0; 3]), "slab", None).unwrap();
    let [mlt, _] = assert_agrees_with(&scene, "glass slab", "vcm", SpectralMode::Auto);
    let grey = (2.0 + 1.0 + 0.5) / 3.0;
    let passes = |r: f64| grey * (1.0 - r) / (1.0 + r);
    let r0 = ((1.5f64 - 1.0) / (1.5 + 1.0)).powi(2);
    // The corner ray's angle: half the diagonal of a square 10° field of view.
    let half = (5.0f64).to_radians().tan();
    let corner = (half * std::f64::consts::SQRT_2).atan();
    let r_corner = vitrum::optics::fresnel_dielectric(corner.cos() as f32, 1.5) as f64;
    assert!(r_corner > r0 && r_corner < r0 * 1.01, "R at the corners {r_corner}");
    let (high, low) = (passes(r0), passes(r_corner));
    let error = mlt.1.sqrt();
    let off = if mlt.0 > high {
        (mlt.0 - high) / error
    } else if mlt.0 < low {
        (low - mlt.0) / error
    } else {
        0.0
    };
    eprintln!(
        "glass slab: pssmlt {:.5} ± {error:.5}, closed form {low:.5}–{high:.5}: {off:.2} standard errors outside",
        mlt.0
    );
    assert!(
        off <= 4.0,
        "glass slab: pssmlt {:.5} is {off:.2} standard errors outside [{low:.5}, {high:.5}]",
        mlt.0
    );
}

#[test]
fn a_crop_window_with_a_gaussian_filter_agrees_with_path() {
    // The film points cover the window widened by the filter's reach: the window's mean within
    // 4 standard errors of `path`'s (64 and 32 replicas).
    let text = std::fs::read_to_string(root().join("scenes/cornell-glass.toml")).unwrap().replace(
        "resolution = [800, 800]",
        "resolution = [800, 800]\ncrop = { offset = [200, 300], size = [400, 300] }\nfilter = \"gaussian\"",
    );
    let scene = load_str(&text, "cropped", None).unwrap();
    let mlt = render_replicas(&scene, "pssmlt", 32, 64, 64, 7);
    let path = render_replicas(&scene, "path", 32, 256, 32, 8);
    assert_eq!((mlt.image.width, mlt.image.height), (16, 12));
    let (a, b) = (blocks(&mlt, 4), blocks(&path, 4));
    let (a, b) = (a[a.len() - 1], b[b.len() - 1]);
    eprintln!(
        "crop: pssmlt {:.5} ± {:.5}, path {:.5} ± {:.5}, z {:.2}",
        a.0,
        a.1.sqrt(),
        b.0,
        b.1.sqrt(),
        z(a, b)
    );
    assert!(z(a, b).abs() <= 4.0, "crop window: {:.2} standard errors", z(a, b));
}

#[test]
fn the_image_mean_has_no_start_up_bias_at_one_or_sixteen_mutations_per_pixel() {
    // Each replica holds 1 (then 16) runs of one mutation per pixel: its mean is a render at 1
    // (16) mutations per pixel, and the replicas' spread bounds their common bias. Within 4
    // standard errors of path's image mean (64 replicas: close to normal).
    let scene = load(&root().join("scenes/cornell-glass.toml")).unwrap();
    let path = blocks(&render_replicas(&scene, "path", 32, 1024, 64, 3), 32)[1];
    for (spp, replicas) in [(64, 64), (256, 16)] {
        let mlt = blocks(&render_replicas(&scene, "pssmlt", 32, spp, replicas, 4), 32)[1];
        let per_pixel = spp / replicas;
        let bias = mlt.0 / path.0 - 1.0;
        eprintln!(
            "{per_pixel} mutation(s) per pixel: pssmlt {:.5} ± {:.5}, path {:.5} ± {:.5}: {:+.2}% ({:.2} σ)",
            mlt.0,
            mlt.1.sqrt(),
            path.0,
            path.1.sqrt(),
            100.0 * bias,
            z(mlt, path)
        );
        assert!(z(mlt, path).abs() <= 4.0, "{per_pixel} mutations per pixel: {:.2} σ", z(mlt, path));
    }
}

#[test]
fn renders_are_bit_identical_at_any_thread_count_and_differ_between_seeds() {
    let scene = load(&root().join("scenes/cornell-glass.toml")).unwrap();
    let on = |threads: usize, seed: u64| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render_replicas(&scene, "pssmlt", 24, 8, 8, seed))
    };
    let bits =
        |o: &RenderOutput| o.image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    let (one, two, other) = (on(1, 5), on(2, 5), on(2, 6));
    assert_eq!(bits(&one), bits(&two), "1 and 2 threads");
    assert_eq!(one.rays, two.rays);
    let differing = bits(&one).iter().zip(bits(&other)).filter(|(a, b)| **a != *b).count();
    assert!(differing > 24 * 24 / 2, "seeds 5 and 6 share {} pixels", 24 * 24 - differing);
}

#[test]
fn chains_longer_than_a_segment_render_the_same_bits_in_any_split_and_at_any_thread_count() {
    // Two chains per run at 96² pixels: 4608 mutations each, two rounds of splats. Sample
    // indices 0..3 at once, and 0..1 then 1..3, on one thread and on two: the same film.
    let scene = load(&root().join("scenes/cornell-glass.toml")).unwrap();
    let mut opts = RenderOptions::for_method(&scene, &Pssmlt, 3);
    opts.resolution = Some((96, 96));
    opts.params.metropolis.chains = 2;
    opts.params.metropolis.bootstrap = 256;
    let film = |threads: usize, splits: &[(u32, u32)]| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut film = Pssmlt.film(&scene, &opts);
            for &(start, end) in splits {
                Pssmlt.add_samples(&scene, &opts, start..end, &mut film, &|_, _| {});
                film.advance(end - start);
            }
            film
        })
    };
    let whole = film(1, &[(0, 3)]);
    assert!(whole.sum.iter().any(|p| p.element_sum() > 0.0), "a black film proves nothing");
    for (threads, splits) in [(2, vec![(0, 3)]), (1, vec![(0, 1), (1, 3)]), (2, vec![(0, 2), (2, 3)])] {
        let other = film(threads, &splits);
        assert!(other.sum == whole.sum, "{threads} threads, {splits:?}: sums differ");
        assert!(
            other.replica_sums == whole.replica_sums,
            "{threads} threads, {splits:?}: replica sums differ"
        );
    }
}

/// χ² statistic of counts against a uniform expectation.
fn chi2(counts: &[u32]) -> f64 {
    let expected = counts.iter().sum::<u32>() as f64 / counts.len() as f64;
    counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum()
}

#[test]
fn large_steps_are_uniform_and_small_steps_stay_in_the_unit_interval() {
    // Large steps only: dimension 0 of 64,000 accepted proposals in 16 bins (χ²(15), 99.9%
    // quantile 37.7); dimension 3 too, drawn only every other proposal.
    let mut chain = PrimarySamples::new(1, 2, 0.01, 1.0);
    let (mut first, mut fourth) = ([0u32; 16], [0u32; 16]);
    for i in 0..64_000 {
        chain.start_iteration();
        assert!(chain.is_large_step());
        let v = chain.get(0);
        assert!((0.0..1.0).contains(&v));
        first[(v * 16.0) as usize] += 1;
        if i % 2 == 0 {
            fourth[(chain.get(3) * 16.0) as usize] += 1;
        }
        chain.accept();
    }
    assert!(chi2(&first) < 37.7, "dimension 0: χ² {}", chi2(&first));
    assert!(chi2(&fourth) < 37.7, "dimension 3: χ² {}", chi2(&fourth));

    // Small steps only, wide enough to wrap often: every value stays in [0, 1).
    for sigma in [0.01, 0.3, 2.0] {
        let mut chain = PrimarySamples::new(3, 4, sigma, 0.0);
        for _ in 0..20_000 {
            chain.start_iteration();
            assert!(!chain.is_large_step());
            for d in 0..6 {
                let v = chain.get(d);
                assert!((0.0..1.0).contains(&v), "sigma {sigma}: {v}");
            }
            chain.accept();
        }
    }
}

#[test]
fn small_steps_move_by_sigma_and_lazily_by_sigma_root_n() {
    // Dimension 0 is drawn every proposal (offset deviation σ), dimension 1 every fourth (the
    // four steps at once: 2σ). Sample variances of 20,000 and 5,000 wrapped offsets, within 5
    // standard errors (the variance of a sample variance is 2σ⁴/(n − 1) for normal offsets).
    let sigma = 0.01f64;
    let mut chain = PrimarySamples::new(5, 6, sigma, 0.0);
    let (mut last0, mut last1) = (chain.get(0) as f64, chain.get(1) as f64);
    let (mut d0, mut d1) = (Vec::new(), Vec::new());
    let wrapped = |a: f64, b: f64| (a - b + 1.5).rem_euclid(1.0) - 0.5;
    for i in 1..=20_000 {
        chain.start_iteration();
        let v0 = chain.get(0) as f64;
        d0.push(wrapped(v0, last0));
        last0 = v0;
        if i % 4 == 0 {
            let v1 = chain.get(1) as f64;
            d1.push(wrapped(v1, last1));
            last1 = v1;
        }
        chain.accept();
    }
    for (offsets, s) in [(&d0, sigma), (&d1, 2.0 * sigma)] {
        let n = offsets.len() as f64;
        let mean = offsets.iter().sum::<f64>() / n;
        let var = offsets.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let se = (2.0 * s.powi(4) / (n - 1.0)).sqrt();
        eprintln!("offset deviation {:.5} (expected {s}), mean {mean:.2e}", var.sqrt());
        assert!((var - s * s).abs() <= 5.0 * se, "variance {var} against {}", s * s);
        assert!(mean.abs() <= 5.0 * s / n.sqrt(), "mean offset {mean}");
    }
}

#[test]
fn a_rejected_proposal_restores_every_value_exactly_and_chains_are_pure_functions_of_their_keys() {
    for large_step in [0.0, 0.5, 1.0] {
        let mut chain = PrimarySamples::new(7, 8, 0.05, large_step);
        for d in 0..8 {
            chain.get(d);
        }
        for i in 0..2000 {
            chain.start_iteration();
            let before: Vec<u64> = (0..8).map(|d| chain.held(d).unwrap().to_bits()).collect();
            // Change a varying subset (and a new dimension now and then).
            for d in (0..8).filter(|d| (i + d) % 3 != 0) {
                chain.get(d);
            }
            chain.get(8 + i % 5);
            if i % 2 == 0 {
                chain.reject();
                let after: Vec<u64> = (0..8).map(|d| chain.held(d).unwrap().to_bits()).collect();
                assert_eq!(before, after, "proposal {i} (large steps {large_step})");
            } else {
                chain.accept();
            }
        }
    }
    // The same keys give the same numbers, through a primary sampler installed on the thread.
    let draws = |start: u64| {
        let mut chain = PrimarySamples::new(start, 9, 0.01, 0.3);
        let mut out = Vec::new();
        for _ in 0..50 {
            chain.start_iteration();
            out.extend(with_primary(&mut chain, || {
                let mut s = Sampler::primary();
                let a = s.get_1d(Dim::Other);
                let b = s.get_2d(Dim::Bsdf);
                [a, b.x, b.y]
            }));
            if chain.accept_draw() < 0.5 {
                chain.accept();
            } else {
                chain.reject();
            }
        }
        out
    };
    assert_eq!(draws(10), draws(10));
    assert_ne!(draws(10), draws(11));
}

#[test]
fn bad_settings_exit_2_naming_file_line_and_field() {
    let good = "[render.pssmlt]\nlarge_step = 1.0\nsigma = 0.05\nbootstrap = 16\nchains = 4";
    // `vitrum info --json` shows the settings the scene sets.
    let info = common::check_method_settings(
        "pssmlt",
        &[
            ("large_step = 0.0", "large_step"),
            ("large_step = 1.5", "large_step"),
            ("sigma = 0.0", "sigma"),
            ("sigma = -0.1", "sigma"),
            ("bootstrap = 0", "bootstrap"),
            ("chains = 0", "chains"),
        ],
        good,
    );
    let m = &info["render"]["methods"]["pssmlt"];
    assert_eq!((m["large_step"].as_f64(), m["sigma"].as_f64()), (Some(1.0), Some(0.05f32 as f64)), "{m}");
    assert_eq!((m["bootstrap"].as_u64(), m["chains"].as_u64()), (Some(16), Some(4)), "{m}");
}
