//! `mmlt` (multiplexed Metropolis over the bidirectional engine's strategies): its agreement
//! with `bpt` on `cornell-glass` and on a diffuse box, with the closed form of an emitter seen
//! through a glass slab, its start-up bias, its determinism, and its settings.
//!
//! Statistics: every render keeps R independent replicas (one Metropolis run or more each, see
//! `integrators/metropolis.rs`), and the error of a block mean or of the image mean is the
//! spread of the replicas' values (`common::replicas`). Tolerances are stated in standard errors
//! of the difference. `mmlt` stops at depth 16 (its default), so `bpt` is cut there too.

mod common;

use common::replicas::{blocks, render_replicas, z};
use std::path::Path;
use vitrum::integrators::{Accumulate, Mmlt};
use vitrum::render::{RenderOptions, RenderOutput};
use vitrum::scene::{load, load_str, Scene};

/// The depth both methods stop at.
const DEPTH: u32 = 16;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A render at `DEPTH` of `scene` by `method` at `size`² pixels.
fn render_at_depth(
    scene: &Scene,
    method: &str,
    size: u32,
    spp: u32,
    replicas: u32,
    seed: u64,
) -> RenderOutput {
    render_replicas(scene, method, (size, size), spp, replicas, seed, |o| o.params.max_depth = DEPTH)
}

/// `mmlt` against `bpt` on `scene` at 32² pixels: the 16 blocks of 8×8 pixels together (χ² of
/// their z, 16 degrees of freedom, below its 99.9% quantile 39.25) and the image mean (within 4
/// standard errors; the means of 64 and 32 replicas are close to normal).
fn assert_agrees_with_bpt(scene: &Scene, what: &str) {
    let mlt = render_at_depth(scene, "mmlt", 32, 64, 64, 1);
    let bpt = render_at_depth(scene, "bpt", 32, 64, 32, 2);
    let (a, b) = (blocks(&mlt, 8), blocks(&bpt, 8));
    let chi2: f64 = a[..16].iter().zip(&b[..16]).map(|(x, y)| z(*x, *y).powi(2)).sum();
    let image = z(a[16], b[16]);
    eprintln!(
        "{what}: mmlt {:.5} ± {:.5}, bpt {:.5} ± {:.5}, z {image:.2}; 16 blocks χ² {chi2:.1}",
        a[16].0,
        a[16].1.sqrt(),
        b[16].0,
        b[16].1.sqrt()
    );
    assert!(a[16].0 > 0.01, "{what}: a black image proves nothing");
    assert!(image.abs() <= 4.0, "{what}: image mean {image:.2} standard errors from bpt's");
    assert!(chi2 <= 39.25, "{what}: block χ² {chi2:.1} above the 99.9% quantile of χ²(16)");
}

/// `scenes/soft-shadows.toml` with its glass made white diffuse: a diffuse box lit by a quad.
fn diffuse_box() -> Scene {
    let text = std::fs::read_to_string(root().join("scenes/soft-shadows.toml")).unwrap();
    let text = text.replace("material = \"glass\"", "material = \"white\"");
    load_str(&text, "diffuse-box", None).unwrap()
}

#[test]
fn agrees_with_bpt_on_cornell_glass() {
    let scene = load(&root().join("scenes/cornell-glass.toml")).unwrap();
    assert_agrees_with_bpt(&scene, "cornell-glass");
}

#[test]
fn agrees_with_bpt_on_a_diffuse_box() {
    assert_agrees_with_bpt(&diffuse_box(), "diffuse box");
}

/// `mmlt` against `bpt` on `scene` (named `name`) at 32² pixels and `spp` samples: the image
/// mean within 4 standard errors (64 and 32 replicas).
fn assert_image_mean_agrees(scene: &Scene, name: &str, spp: u32) {
    let mlt = render_at_depth(scene, "mmlt", 32, spp, 64, 11);
    let bpt = render_at_depth(scene, "bpt", 32, spp, 32, 12);
    let (a, b) = (blocks(&mlt, 1024)[1], blocks(&bpt, 1024)[1]);
    eprintln!(
        "{name}: mmlt {:.5} ± {:.5}, bpt {:.5} ± {:.5}, z {:.2}",
        a.0,
        a.1.sqrt(),
        b.0,
        b.1.sqrt(),
        z(a, b)
    );
    assert!(a.0 > 0.01, "{name}: a black image proves nothing");
    assert!(z(a, b).abs() <= 4.0, "{name}: image mean {:.2} standard errors from bpt's", z(a, b));
}

#[test]
fn agrees_with_bpt_in_spectral_mode_on_dispersive_glass() {
    // `scenes/dispersion.toml` renders spectrally (its glass disperses): the camera and light
    // sub-paths share their wavelengths, a refraction ends the secondaries. Its caustics are
    // heavy-tailed: at 512 mutations per pixel the standard error is about 14% of the mean
    // (measured 2.94 ± 0.41 against `bpt`'s 2.74 ± 0.09), enough to catch a wrong spectral
    // factor (the hero's 3, a lost secondary), not a bias of a few percent.
    let scene = load(&root().join("scenes/dispersion.toml")).unwrap();
    let out = render_replicas(&scene, "mmlt", (8, 8), 1, 1, 1, |_| {});
    assert!(out.spectral, "the dispersive scene renders spectrally");
    assert_image_mean_agrees(&scene, "dispersion", 512);
}

#[test]
fn agrees_with_bpt_in_a_crop_window_with_a_gaussian_filter_and_a_lens() {
    // The camera samples cover the window widened by the filter's reach; light tracing's
    // strategy lands anywhere and counts in the window's pixels only. `depth-of-field` has a
    // thin lens (its strategies connect to a lens point).
    let text = std::fs::read_to_string(root().join("scenes/depth-of-field.toml")).unwrap().replace(
        "resolution = [800, 800]",
        "resolution = [800, 800]\ncrop = { offset = [200, 300], size = [400, 300] }\nfilter = \"gaussian\"",
    );
    let scene = load_str(&text, "cropped", None).unwrap();
    assert!(text.contains("aperture = 0.15"), "the scene has a lens");
    assert_image_mean_agrees(&scene, "depth-of-field, cropped", 64);
}

#[test]
fn an_emitter_through_a_glass_slab_matches_the_closed_form() {
    // Only the emitter hit makes these paths (every vertex is smooth glass): L·(1−R)/(1+R) at
    // normal incidence, R = 0.04, on every pixel of the narrow view (5° off axis at most, where
    // R changes by less than 1e-4). The image mean within 4 standard errors of the closed form
    // (32 replicas of 8 runs each), its standard error below 1% (a 4σ band of at most 4%).
    let scene = load_str(&common::glass_slab(1.5, [0.0; 3]), "slab", None).unwrap();
    let out = render_replicas(&scene, "mmlt", (16, 16), 256, 32, 3, |_| {});
    let r = 0.04f64;
    let expected = (2.0 + 1.0 + 0.5) / 3.0 * (1.0 - r) / (1.0 + r);
    let image = blocks(&out, 16)[1];
    let zz = z(image, (expected, 0.0));
    eprintln!("slab: mmlt {:.5} ± {:.5}, closed form {expected:.5}, z {zz:.2}", image.0, image.1.sqrt());
    assert!(zz.abs() <= 4.0, "slab: {zz:.2} standard errors from the closed form");
    assert!(image.1.sqrt() < 0.01 * expected, "slab: standard error {} too large to test", image.1.sqrt());
}

#[test]
fn the_image_mean_has_no_start_up_bias_at_one_or_sixteen_mutations_per_pixel() {
    // Each replica holds 1 (then 16) runs of one mutation per pixel: its mean is a render at 1
    // (16) mutations per pixel, and the replicas' spread bounds their common bias. Within 4
    // standard errors of bpt's image mean (64 replicas: close to normal).
    let scene = load(&root().join("scenes/cornell-glass.toml")).unwrap();
    let bpt = blocks(&render_at_depth(&scene, "bpt", 32, 256, 64, 3), 32)[1];
    for (spp, replicas) in [(64, 64), (256, 16)] {
        let mlt = blocks(&render_at_depth(&scene, "mmlt", 32, spp, replicas, 4), 32)[1];
        let per_pixel = spp / replicas;
        eprintln!(
            "{per_pixel} mutation(s) per pixel: mmlt {:.5} ± {:.5}, bpt {:.5} ± {:.5}: {:+.2}% ({:.2} σ)",
            mlt.0,
            mlt.1.sqrt(),
            bpt.0,
            bpt.1.sqrt(),
            100.0 * (mlt.0 / bpt.0 - 1.0),
            z(mlt, bpt)
        );
        assert!(z(mlt, bpt).abs() <= 4.0, "{per_pixel} mutations per pixel: {:.2} σ", z(mlt, bpt));
    }
}

#[test]
fn renders_are_bit_identical_at_any_thread_count_and_in_any_split() {
    let scene = load(&root().join("scenes/cornell-glass.toml")).unwrap();
    let on = |threads: usize, seed: u64| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render_replicas(&scene, "mmlt", (24, 24), 8, 8, seed, |_| {}))
    };
    let bits =
        |o: &RenderOutput| o.image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    let (one, two, other) = (on(1, 5), on(2, 5), on(2, 6));
    assert_eq!(bits(&one), bits(&two), "1 and 2 threads");
    assert_eq!(one.rays, two.rays);
    let differing = bits(&one).iter().zip(bits(&other)).filter(|(a, b)| **a != *b).count();
    assert!(differing > 24 * 24 / 2, "seeds 5 and 6 share {} pixels", 24 * 24 - differing);

    // Two chains per run at 96² pixels: 4608 mutations each, two rounds of splats. Sample
    // indices 0..3 at once, and 0..1 then 1..3, on one thread and on two: the same film.
    let mut opts = RenderOptions::for_method(&scene, &Mmlt, 3);
    opts.resolution = Some((96, 96));
    opts.params.metropolis.chains = 2;
    opts.params.metropolis.bootstrap = 256;
    let film = |threads: usize, splits: &[(u32, u32)]| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut film = Mmlt.film(&scene, &opts);
            for &(start, end) in splits {
                Mmlt.add_samples(&scene, &opts, start..end, &mut film, &|_, _| {});
                film.advance(end - start);
            }
            film
        })
    };
    let whole = film(1, &[(0, 3)]);
    assert!(whole.sum.iter().any(|p| p.element_sum() > 0.0), "a black film proves nothing");
    for (threads, splits) in [(2, vec![(0, 3)]), (2, vec![(0, 1), (1, 3)])] {
        let other = film(threads, &splits);
        assert!(other.sum == whole.sum, "{threads} threads, {splits:?}: sums differ");
        assert!(
            other.replica_sums == whole.replica_sums,
            "{threads} threads, {splits:?}: replica sums differ"
        );
    }
}

#[test]
fn bad_settings_exit_2_naming_file_line_and_field() {
    let good = "[render.mmlt]\nlarge_step = 1.0\nsigma = 0.05\nbootstrap = 16\nchains = 4\nmax_depth = 3";
    // `vitrum info --json` shows the settings the scene sets, apart from `pssmlt`'s.
    let info = common::check_method_settings(
        "mmlt",
        &[
            ("large_step = 0.0", "large_step"),
            ("large_step = 1.5", "large_step"),
            ("sigma = 0.0", "sigma"),
            ("bootstrap = 0", "bootstrap"),
            ("chains = 0", "chains"),
            ("max_depth = 300", "max_depth"),
        ],
        good,
    );
    let m = &info["render"]["methods"]["mmlt"];
    assert_eq!((m["large_step"].as_f64(), m["sigma"].as_f64()), (Some(1.0), Some(0.05f32 as f64)), "{m}");
    assert_eq!((m["bootstrap"].as_u64(), m["chains"].as_u64()), (Some(16), Some(4)), "{m}");
    assert_eq!(m["max_depth"].as_u64(), Some(3), "{m}");
    let p = &info["render"]["methods"]["pssmlt"];
    assert_eq!((p["large_step"].as_f64(), p["chains"].as_u64()), (Some(0.3f32 as f64), Some(64)), "{p}");
}
