//! `vitrum diff` end to end: the metrics it prints are the hand-computed ones, every bad input
//! (missing, corrupt or truncated EXR, one declaring too many pixels, different sizes, a crop
//! outside) exits with code 2 and a message naming the problem, and `--error-map` writes a PNG —
//! or, on failure, nothing at all.

use glam::Vec3;
use serde_json::Value;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tempfile::TempDir;
use vitrum::image::Image;
use vitrum::output::exr::{stage_exr_with_channels, variance_channels, write_exr, ExrMetadata};

mod common;

/// Run `vitrum diff` with `args`.
fn vitrum<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    let binary = env!("CARGO_BIN_EXE_vitrum");
    Command::new(binary).arg("diff").args(args).output().expect("the vitrum binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A temporary folder with the two 2×2 images of the hand computation and an empty `out/`.
struct Sandbox {
    dir: TempDir,
}

impl Sandbox {
    fn new() -> Sandbox {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir(dir.path().join("out")).unwrap();
        let sandbox = Sandbox { dir };
        sandbox.exr("test.exr", &test_image());
        sandbox.exr("reference.exr", &reference());
        sandbox
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Writes `image` as the EXR `name` and returns its path.
    fn exr(&self, name: &str, image: &Image) -> PathBuf {
        let path = self.path(name);
        write_exr(&path, image, &ExrMetadata::default()).unwrap();
        path
    }

    /// The names of the files in `out/`.
    fn out_files(&self) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(self.path("out"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into())
            .collect();
        names.sort();
        names
    }
}

/// Reference, row by row: (1,1,1), (0,0,0); (2,0,0.5), (1,1,1).
fn reference() -> Image {
    let pixels = vec![Vec3::ONE, Vec3::ZERO, Vec3::new(2.0, 0.0, 0.5), Vec3::ONE];
    Image { width: 2, height: 2, pixels }
}

/// Test: equal at (0,0), red off by 0.1 at (1,0), green off by 0.2 at (0,1), a NaN at (1,1).
fn test_image() -> Image {
    let pixels =
        vec![Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), Vec3::new(2.0, 0.2, 0.5), Vec3::new(f32::NAN, 0.0, 0.0)];
    Image { width: 2, height: 2, pixels }
}

fn json(out: &Output) -> Value {
    assert_eq!(out.status.code(), Some(0), "stderr: {}", stderr(out));
    serde_json::from_str(&stdout(out)).unwrap_or_else(|e| panic!("not JSON ({e}): {}", stdout(out)))
}

fn assert_close(v: &Value, key: &str, expected: f64) {
    let got = v[key].as_f64().unwrap_or_else(|| panic!("`{key}` is not a number in {v}"));
    assert!((got - expected).abs() <= 1e-6 * expected.abs().max(1e-3), "{key}: {got} against {expected}");
}

/// Asserts exit code 2, a message containing every one of `needles`, and nothing in `out/`.
fn assert_bad_input(sandbox: &Sandbox, out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for needle in needles {
        assert!(err.contains(needle), "stderr lacks `{needle}`: {err}");
    }
    assert!(stdout(out).is_empty(), "stdout: {}", stdout(out));
    assert!(sandbox.out_files().is_empty(), "left behind: {:?}", sandbox.out_files());
}

#[test]
fn json_metrics_are_the_hand_computed_ones() {
    let s = Sandbox::new();
    let out = vitrum(&[s.path("test.exr"), s.path("reference.exr"), "--json".into()]);
    let v = json(&out);
    // Three pixels compared (nine channels); squared errors 0.1² and 0.2², the rest 0.
    assert_eq!(v["pixels"], 3);
    assert_eq!((v["non_finite_test"].as_u64(), v["non_finite_reference"].as_u64()), (Some(1), Some(0)));
    assert_close(&v, "mse", 0.05 / 9.0);
    assert_close(&v, "rmse", (0.05f64 / 9.0).sqrt());
    assert_close(&v, "rel_mse", (0.01 / 0.01 + 0.04 / 0.01) / 9.0);
    assert_close(&v, "mae", 0.3 / 9.0);
    // Peak: the largest reference value among the compared pixels.
    assert_close(&v, "peak", 2.0);
    assert_close(&v, "psnr", 10.0 * (4.0 / (0.05f64 / 9.0)).log10());
    assert_eq!((v["width"].as_u64(), v["height"].as_u64()), (Some(2), Some(2)));
    assert!(v["crop"].is_null() && v["error_map"].is_null());
    // Under 1000 pixels the trimmed relMSE drops none; a 2×2 image has no 11×11 SSIM window.
    assert_close(&v, "rel_mse_trimmed", v["rel_mse"].as_f64().unwrap());
    assert!(v["ssim"].is_null(), "{v}");
    // Preview PSNR (peak 1, exposure 0): the 8-bit sRGB codes of 0.1 and 0.2 against 0.
    let code = |x: f64| (255.0 * (1.055 * x.powf(1.0 / 2.4) - 0.055)).round() / 255.0;
    let preview_mse = (code(0.1).powi(2) + code(0.2).powi(2)) / 9.0;
    assert_close(&v, "psnr_preview", -10.0 * preview_mse.log10());
    assert_eq!(v["exposure"], 0.0);
    // No variance channels: no split.
    assert!(v["split"].is_null(), "{v}");
    // The NaN pixel is reported, not silently skipped.
    assert!(stderr(&out).contains("1 pixel of") && stderr(&out).contains("test.exr"), "{}", stderr(&out));
}

#[test]
fn a_crop_and_the_table() {
    let s = Sandbox::new();
    let (t, r) = (s.path("test.exr"), s.path("reference.exr"));
    let v = json(&vitrum(&[
        t.as_os_str(),
        r.as_os_str(),
        "--crop".as_ref(),
        "0,1,1,1".as_ref(),
        "--json".as_ref(),
    ]));
    assert_eq!((v["pixels"].as_u64(), v["non_finite_test"].as_u64()), (Some(1), Some(0)));
    assert_close(&v, "mse", 0.04 / 3.0);
    assert_close(&v, "peak", 2.0);
    assert_eq!(v["crop"]["width"], 1);

    let out = vitrum(&[&t, &r]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let table = stdout(&out);
    for needle in [
        "MSE",
        "RMSE",
        "relMSE",
        "relMSE 99.9%",
        "MAE",
        "PSNR HDR",
        "peak 2.0000e0",
        "PSNR LDR",
        "peak 1, on the 8-bit sRGB preview at exposure 0 EV",
        "SSIM",
        "3 compared",
        "1 in the test image",
        "n/a: the test image keeps no replicas or variance",
    ] {
        assert!(table.contains(needle), "the table lacks `{needle}`:\n{table}");
    }
    assert!(table.contains(&format!("{:.4e}", 0.05f64 / 9.0)), "{table}");

    let same = json(&vitrum(&[&r, &r, &"--json".into()]));
    assert_eq!(same["mse"], 0.0);
    assert!(same["psnr"].is_null(), "PSNR of identical images is infinite: {same}");
}

#[test]
fn error_map_is_a_png_of_the_crop() {
    let s = Sandbox::new();
    let map = s.path("out/map.png");
    let args = [s.path("test.exr"), s.path("reference.exr"), "--error-map".into(), map.clone()];
    let out = vitrum(&args);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert_eq!(s.out_files(), ["map.png"]);
    let whole = image::open(&map).unwrap().to_rgb8();
    // The 2×2 map is magnified; the NaN pixel is magenta.
    assert!(whole.width() > 256 && whole.height() >= 256, "{:?}", whole.dimensions());
    assert!(whole.pixels().any(|p| p.0 == [255, 0, 255]));

    let mut cropped = args.to_vec();
    cropped.extend(["--crop".into(), "0,0,1,2".into()]);
    assert_eq!(vitrum(&cropped).status.code(), Some(0));
    let crop = image::open(&map).unwrap().to_rgb8();
    assert_eq!(crop.height(), whole.height(), "the same layout for a 1×2 map");
    // The left column has no NaN: no magenta inside the map region (left of the bar).
    let map_region = (0..crop.height()).flat_map(|y| (0..crop.width() / 3).map(move |x| (x, y)));
    assert!(map_region.clone().all(|(x, y)| crop.get_pixel(x, y).0 != [255, 0, 255]));
    assert_eq!(s.out_files(), ["map.png"]);
}

#[test]
fn different_sizes_are_bad_input_naming_both() {
    let s = Sandbox::new();
    let wide = s.exr("wide.exr", &Image::new(3, 2));
    let out = vitrum(&[s.path("test.exr"), wide, "--error-map".into(), s.path("out/map.png")]);
    assert_bad_input(&s, &out, &["differ in size", "2x2", "3x2", "test.exr", "wide.exr"]);
}

#[test]
fn unreadable_images_are_bad_input_naming_the_file() {
    let s = Sandbox::new();
    let map = s.path("out/map.png");
    let good = s.path("reference.exr");

    let missing = s.path("missing.exr");
    let out = vitrum(&[missing.as_path(), &good, "--error-map".as_ref(), &map]);
    assert_bad_input(&s, &out, &["missing.exr", "test image"]);

    let corrupt = s.path("corrupt.exr");
    fs::write(&corrupt, b"this is not an EXR file at all, just text").unwrap();
    let out = vitrum(&[good.as_path(), &corrupt, "--error-map".as_ref(), &map]);
    assert_bad_input(&s, &out, &["corrupt.exr", "reference image"]);

    // A real EXR cut short: first half, then just the header's beginning.
    let big =
        s.exr("big.exr", &Image { width: 64, height: 64, pixels: vec![Vec3::new(0.3, 0.5, 0.7); 64 * 64] });
    let bytes = fs::read(&big).unwrap();
    for len in [bytes.len() / 2, bytes.len() - 1, 40] {
        let truncated = s.path("truncated.exr");
        fs::write(&truncated, &bytes[..len]).unwrap();
        let out = vitrum(&[truncated.as_path(), &big, "--error-map".as_ref(), &map]);
        assert_bad_input(&s, &out, &["truncated.exr"]);
    }

    let empty = s.path("empty.exr");
    fs::write(&empty, b"").unwrap();
    assert_bad_input(&s, &vitrum(&[empty.as_path(), &good]), &["empty.exr"]);
}

#[test]
fn images_declaring_too_many_pixels_are_bad_input_refused_before_allocating() {
    let s = Sandbox::new();
    let (width, height) = common::oversized::DECLARED;
    common::oversized::write_exr_declaring(&s.path("huge.exr"), width, height);
    common::oversized::write_png_declaring(&s.path("huge.png"), width, height);
    let cases: [(&[&str], &str); 3] = [
        (&["diff", "huge.exr", "reference.exr"], "huge.exr"),
        (&["diff", "test.exr", "huge.exr"], "huge.exr"),
        (&["diff", "test.exr", "reference.exr", "--mask", "huge.png"], "huge.png"),
    ];
    for (args, file) in cases {
        let out = common::oversized::vitrum_capped(s.dir.path(), args);
        common::oversized::assert_refused_as_too_large(&out, file);
        assert!(stdout(&out).is_empty(), "{args:?}: {}", stdout(&out));
    }
    // The library's readers refuse it too.
    let err = vitrum::output::exr::read_exr_channels(&s.path("huge.exr")).unwrap_err().to_string();
    assert!(err.contains("huge.exr") && err.contains("limit"), "{err}");
}

#[test]
fn bad_crops_and_output_paths_are_bad_input() {
    let s = Sandbox::new();
    let (t, r) = (s.path("test.exr"), s.path("reference.exr"));
    let map = s.path("out/map.png");
    let run = |extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec![t.as_os_str(), r.as_os_str()];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        vitrum(&args)
    };
    let m = map.to_str().unwrap();
    assert_bad_input(&s, &run(&["--crop", "1,1,2,1", "--error-map", m]), &["--crop 1,1,2,1", "2x2"]);
    assert_bad_input(&s, &run(&["--crop", "0,0,0,1"]), &["--crop"]);
    assert_bad_input(&s, &run(&["--crop", "a,b"]), &["--crop"]);
    let nowhere = s.path("no-such-folder/map.png");
    assert_bad_input(&s, &run(&["--error-map", nowhere.to_str().unwrap()]), &["no-such-folder"]);
    assert_bad_input(&s, &run(&["--error-map", s.path("out/map.jpg").to_str().unwrap()]), &[".png"]);
    // The output check comes first: with a missing input too, the message is about the output.
    let out = vitrum(&[Path::new("missing.exr"), &r, Path::new("--error-map"), &s.path("out")]);
    assert_bad_input(&s, &out, &["folder"]);
}

/// `reference` plus `offset` plus Gaussian noise of standard deviation `sigma` per channel
/// (Box–Muller, seeded), written as `name` with variance channels σ² when `sigma` > 0 and with
/// `meta`.
fn noisy_exr(
    s: &Sandbox,
    name: &str,
    reference: &Image,
    (offset, sigma): (f32, f32),
    meta: &ExrMetadata,
) -> PathBuf {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(name.len() as u64 * 7 + 1);
    let mut normal = || {
        let (u, v): (f64, f64) = (1.0 - rng.random::<f64>(), rng.random::<f64>());
        ((-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()) as f32
    };
    let pixels: Vec<Vec3> = reference
        .pixels
        .iter()
        .map(|p| *p + offset + sigma * Vec3::new(normal(), normal(), normal()))
        .collect();
    let image = Image { width: reference.width, height: reference.height, pixels };
    let path = s.path(name);
    let variance = Image { pixels: vec![Vec3::splat(sigma * sigma); image.pixels.len()], ..image.clone() };
    let extra =
        if sigma > 0.0 { variance_channels(&variance, &vec![16.0; image.pixels.len()]) } else { vec![] };
    stage_exr_with_channels(&path, &image, meta, &extra).unwrap().commit().unwrap();
    path
}

/// A 64×64 reference with some structure.
fn gradient() -> Image {
    let pixels =
        (0..64 * 64).map(|i| Vec3::new((i % 64) as f32 / 64.0, (i / 64) as f32 / 64.0, 0.5)).collect();
    Image { width: 64, height: 64, pixels }
}

#[test]
fn variance_channels_split_the_error_into_a_known_bias_and_variance() {
    // Test = reference + 0.05 + N(0, 0.1²), its variance channels 0.01: bias² 2.5e-3, variance
    // 1e-2, both under the split's relative weights.
    let s = Sandbox::new();
    let reference = s.exr("gradient.exr", &gradient());
    let meta = ExrMetadata::default();
    let biased = noisy_exr(&s, "biased.exr", &gradient(), (0.05, 0.1), &meta);
    let v = json(&vitrum(&[biased.as_path(), &reference, Path::new("--json")]));
    let split = &v["split"];
    // The parts are relative (weights 1/(r̃² + 0.01)), the same weights for each: the bias part
    // is bias²/σ² = 1/4 of the variance part.
    let (bias, se) = (split["bias"].as_f64().unwrap(), split["bias_se"].as_f64().unwrap());
    let variance = split["variance"].as_f64().unwrap();
    // The relative weights put most of it on the dark channels: about 7 standard errors.
    assert!((bias - 0.25 * variance).abs() < 4.0 * se && bias > 5.0 * se, "{split}");
    assert_eq!(split["verdict"], "biased", "{split}");
    // Variance channels without replicas: the standard error is the spread over the pixels.
    assert!(split["errors"].as_str().unwrap().starts_with("spread over the pixels"), "{split}");
    let table = stdout(&vitrum(&[biased.as_path(), &reference]));
    assert!(table.contains("biased: the bias part is") && table.contains("taken as exact"), "{table}");

    // No offset: the bias part is zero within 4 standard errors; not biased.
    let unbiased = noisy_exr(&s, "unbiased.exr", &gradient(), (0.0, 0.1), &meta);
    let v = json(&vitrum(&[unbiased.as_path(), &reference, Path::new("--json")]));
    let split = &v["split"];
    assert!(split["bias"].as_f64().unwrap().abs() < 4.0 * split["bias_se"].as_f64().unwrap(), "{split}");
    assert_eq!(split["verdict"], "no bias detected");

    // A noisy reference with its variance channels: its variance is taken out of the bias.
    let noisy_reference = noisy_exr(&s, "noisy-reference.exr", &gradient(), (0.0, 0.05), &meta);
    let v = json(&vitrum(&[biased.as_path(), &noisy_reference, Path::new("--json")]));
    let split = &v["split"];
    // Variance parts 0.01 and 0.0025 under the same weights: the reference's is 1/4 of the
    // test's, and the bias part is again bias²/σ² = 1/4 of the test's.
    let variance = split["variance"].as_f64().unwrap();
    assert!(
        (split["reference_variance"].as_f64().unwrap() - 0.25 * variance).abs() < 1e-6 * variance,
        "{split}"
    );
    let (bias, se) = (split["bias"].as_f64().unwrap(), split["bias_se"].as_f64().unwrap());
    assert!((bias - 0.25 * variance).abs() < 4.0 * se, "{split}");

    // An `ssaa` render has no variance: all of its error is bias.
    let ssaa = ExrMetadata { integrator: "ssaa".into(), ..ExrMetadata::default() };
    let deterministic = noisy_exr(&s, "ssaa.exr", &gradient(), (0.01, 0.0), &ssaa);
    let v = json(&vitrum(&[deterministic.as_path(), &reference, Path::new("--json")]));
    assert_eq!(
        (v["split"]["variance"].as_f64(), v["split"]["verdict"].as_str()),
        (Some(0.0), Some("biased"))
    );
    assert_eq!(v["split"]["bias"], v["split"]["error"], "all of the error is bias: {v}");
}

#[test]
fn the_error_map_marks_and_counts_the_pixels_above_its_scale() {
    // 1000 pixels off by 0.1 against 1 (relative squared error 0.0099, scale 10⁻³..10⁻²) and
    // three fireflies of 101 (about 10⁴): drawn red and counted.
    let s = Sandbox::new();
    let reference = s.exr("one.exr", &Image { width: 40, height: 25, pixels: vec![Vec3::ONE; 1000] });
    let mut pixels = vec![Vec3::splat(1.1); 1000];
    for i in [7, 400, 999] {
        pixels[i] = Vec3::splat(101.0);
    }
    let test = s.exr("fireflies.exr", &Image { width: 40, height: 25, pixels });
    let map = s.path("out/map.png");
    let out = vitrum(&[test.as_path(), &reference, Path::new("--error-map"), &map]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stdout(&out).contains("(scale 10⁻³..10⁻²; 3 px above it, drawn red)"), "{}", stdout(&out));
    let png = image::open(&map).unwrap().to_rgb8();
    let red = png.pixels().filter(|p| p.0 == [255, 0, 0]).count();
    // Three pixels magnified 7 times (⌈256/40⌉, maps are at least 256 pixels wide) and the
    // legend's swatch.
    assert!(red > 3 * 7 * 7, "{red}");
    let v = json(&vitrum(&[test.as_path(), &reference, Path::new("--error-map"), &map, Path::new("--json")]));
    assert_eq!(v["error_map_above_scale"], 3);
    // The trimmed relMSE drops ⌊1000/1000⌋ = 1 firefly; the full one is made by all three.
    let d = f64::from(1.1f32 - 1.0);
    assert_close(&v, "rel_mse_trimmed", (997.0 * d * d / 1.01 + 2.0 * 1e4 / 1.01) / 999.0);
    assert!(v["rel_mse"].as_f64().unwrap() > v["rel_mse_trimmed"].as_f64().unwrap());
}
