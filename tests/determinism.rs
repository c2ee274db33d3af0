//! A render is a function of the scene, the options and the seed, never of the thread count:
//! the `vitrum` binary run with `--threads 1` and `--threads 2` writes bit-identical EXR pixels
//! (and the same ray counts); a different `--seed` changes the pixels, so the check can fail.

use std::path::{Path, PathBuf};
use std::process::Command;
use tempfile::TempDir;
use vitrum::output::exr::read_exr;

/// The pixels of a render as raw bits (so NaN and -0.0 compare exactly), and its ray counts.
struct Render {
    bits: Vec<[u32; 3]>,
    rays: String,
}

/// Render `scene` (the embedded default when `None`) at 96×96 with `args` into `dir`.
fn render(dir: &TempDir, scene: Option<&Path>, args: &[&str]) -> Render {
    let name = format!("{}.exr", args.join("_").replace(['-', ' '], ""));
    let output: PathBuf = dir.path().join(name);
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vitrum"));
    cmd.arg("render");
    if let Some(s) = scene {
        cmd.arg(s);
    }
    cmd.args(["--resolution", "96x96", "--quiet", "-o"]).arg(&output).args(args);
    let out = cmd.output().expect("the vitrum binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "vitrum render {args:?} failed:\n{stderr}");
    let (image, meta) = read_exr(&output).expect("a readable EXR");
    assert_eq!((image.width, image.height), (96, 96));
    let bits = image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
    Render { bits, rays: meta["vitrum:rays"].clone() }
}

/// Renders with `--threads 1` and `--threads 2` (plus `args`) are bit-identical.
fn assert_thread_count_invariant(scene: Option<&Path>, args: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let one = render(&dir, scene, &[args, &["--threads", "1"]].concat());
    let two = render(&dir, scene, &[args, &["--threads", "2"]].concat());
    let differing = one.bits.iter().zip(&two.bits).filter(|(a, b)| a != b).count();
    assert_eq!(
        differing,
        0,
        "{args:?}: {differing} of {} pixels differ between 1 and 2 threads",
        one.bits.len()
    );
    assert_eq!(one.rays, two.rays, "{args:?}: ray counts differ between 1 and 2 threads");
    // A black image would pass trivially.
    assert!(one.bits.iter().any(|p| p.iter().any(|&c| f32::from_bits(c) > 0.0)), "{args:?}: black image");
}

#[test]
fn whitted_is_independent_of_the_thread_count() {
    assert_thread_count_invariant(None, &["-i", "whitted", "--seed", "11"]);
}

#[test]
fn raycast_is_independent_of_the_thread_count() {
    assert_thread_count_invariant(None, &["-i", "raycast", "--seed", "11"]);
}

#[test]
fn random_pixel_positions_are_independent_of_the_thread_count() {
    assert_thread_count_invariant(None, &["-i", "whitted", "--spp", "4", "--seed", "11"]);
}

#[test]
fn area_light_sampling_is_independent_of_the_thread_count() {
    // `distributed` samples points on the area light, lens, time and glossy lobes.
    let scene = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/drinking-glass.toml"));
    assert_thread_count_invariant(Some(scene), &["-i", "distributed", "--spp", "3", "--seed", "5"]);
}

#[test]
fn adaptive_supersampling_is_independent_of_the_thread_count() {
    assert_thread_count_invariant(None, &["-i", "ssaa"]);
}

#[test]
fn another_seed_gives_other_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let a = render(&dir, None, &["--spp", "4", "--seed", "1", "--threads", "2"]);
    let b = render(&dir, None, &["--spp", "4", "--seed", "2", "--threads", "2"]);
    let differing = a.bits.iter().zip(&b.bits).filter(|(x, y)| x != y).count();
    assert!(differing > a.bits.len() / 10, "only {differing} pixels differ between seeds 1 and 2");
    // And the same seed again reproduces the first render exactly.
    let again = render(&dir, None, &["--spp", "4", "--seed", "1", "--threads", "1"]);
    assert!(a.bits == again.bits, "seed 1 rendered twice differs");
}

#[test]
fn vertex_connection_and_merging_is_independent_of_the_thread_count() {
    // Light paths in chunks, the photon grid, splats and merges: the default scene's point light
    // and glass, with every strategy of the engine.
    for method in ["vcm", "ppm"] {
        assert_thread_count_invariant(None, &["-i", method, "--spp", "3", "--seed", "4"]);
    }
}

#[test]
fn bidirectional_wavelength_splitting_is_independent_of_the_thread_count() {
    // Spectral glass-of-water: camera and light sub-paths split their wavelengths at its
    // dispersive glass and water, and the branches walk from the paths' own random streams.
    let scene = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/glass-of-water.toml"));
    for method in ["bpt", "vcm"] {
        assert_thread_count_invariant(
            Some(scene),
            &["-i", method, "--spp", "2", "--seed", "4", "--spectral", "on"],
        );
    }
}

#[test]
fn metropolis_is_independent_of_the_thread_count() {
    // Bootstraps and chains in parallel, several sample indices at once, splats in chain order;
    // a scene with depth of field (the lens dimensions of the primary sample vector).
    let scene = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/depth-of-field.toml"));
    assert_thread_count_invariant(Some(scene), &["-i", "pssmlt", "--spp", "3", "--seed", "4"]);
}
