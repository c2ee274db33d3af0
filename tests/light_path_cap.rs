//! The cap on light sub-paths per iteration of the bidirectional methods (`max_light_paths`):
//! reachable from the scene's `[render.bpt|ppm|bpm|vcm]` tables and from `--max-light-paths`,
//! bad values refused with the field named (exit code 2), and, with the cap, every method's
//! memory beyond its film independent of the resolution.

use std::path::Path;
use std::process::{Command, Output};
use vitrum::integrators::{all, create, DEFAULT_MAX_LIGHT_PATHS};
use vitrum::memory::MemoryEstimate;
use vitrum::output::exr::read_exr;
use vitrum::render::RenderOptions;
use vitrum::scene::load_str;

/// The scene the cases change (the embedded default scene).
const CORNELL: &str = include_str!("../scenes/cornell-glass.toml");

/// `CORNELL` with `table` appended.
fn with_table(table: &str) -> String {
    format!("{CORNELL}\n{table}\n")
}

fn vitrum(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vitrum")).current_dir(dir).args(args).output().unwrap()
}

#[test]
fn the_scene_sets_the_cap_of_every_bidirectional_method() {
    for method in ["bpt", "ppm", "bpm", "vcm"] {
        let scene =
            load_str(&with_table(&format!("[render.{method}]\nmax_light_paths = 4096")), "scene.toml", None)
                .unwrap();
        let integrator = create(method).unwrap();
        let opts = RenderOptions::for_method(&scene, integrator.as_ref(), 1);
        assert_eq!(opts.params.merging.max_light_paths, 4096, "{method}");
        // The other methods keep the default.
        let other = if method == "vcm" { "bpt" } else { "vcm" };
        let opts = RenderOptions::for_method(&scene, create(other).unwrap().as_ref(), 1);
        assert_eq!(opts.params.merging.max_light_paths, DEFAULT_MAX_LIGHT_PATHS, "{other} beside {method}");
    }
}

#[test]
fn a_bad_cap_in_the_scene_is_refused_naming_the_field() {
    let lines = CORNELL.lines().count();
    // (table, words the message must contain)
    let cases = [
        ("[render.vcm]\nmax_light_paths = 0", vec!["max_light_paths", "at least 1"]),
        ("[render.bpt]\nmax_light_paths = -3", vec!["max_light_paths"]),
        ("[render.ppm]\nmax_light_paths = 2.5", vec!["max_light_paths"]),
        ("[render.path]\nmax_light_paths = 16", vec!["max_light_paths"]),
    ];
    for (table, words) in cases {
        let Err(err) = load_str(&with_table(table), "scene.toml", None) else { panic!("{table} accepted") };
        let err = err.to_string();
        for word in words {
            assert!(err.contains(word), "{table}: `{word}` in: {err}");
        }
        // The line of the field: the table's second line after the scene's own.
        assert!(err.contains(&format!(":{}:", lines + 3)), "{table}: the line in: {err}");
    }
}

#[test]
fn a_bad_cap_on_the_command_line_exits_2_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    for (method, value, words) in [
        ("vcm", "0", &["--max-light-paths 0", "whole number"][..]),
        ("bpt", "many", &["--max-light-paths many", "whole number"][..]),
        ("ppm", "-5", &["--max-light-paths -5", "whole number"][..]),
        ("path", "64", &["--max-light-paths 64", "`path`"][..]),
    ] {
        let out = vitrum(
            dir.path(),
            &[
                "render",
                "-i",
                method,
                "--resolution",
                "8x8",
                "--max-light-paths",
                value,
                "-o",
                "r.exr",
                "--quiet",
            ],
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{method} {value}: {stderr}");
        for word in words {
            assert!(stderr.contains(word), "{method} {value}: `{word}` in: {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!dir.path().join("r.exr").exists(), "{method} {value} wrote an image");
    }
}

#[test]
fn the_command_line_cap_reaches_the_engine() {
    // At 16×16 an iteration traces min(256, cap) light paths: a cap of 256 is the default's image
    // bit for bit, a cap of 16 another image (camera paths share 16 light paths).
    let dir = tempfile::tempdir().unwrap();
    let render = |cap: Option<&str>, name: &str| {
        let mut args =
            vec!["render", "-i", "vcm", "--resolution", "16x16", "--spp", "2", "-o", name, "--quiet"];
        if let Some(cap) = cap {
            args.extend(["--max-light-paths", cap]);
        }
        let out = vitrum(dir.path(), &args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        read_exr(&dir.path().join(name)).unwrap().0
    };
    let default = render(None, "default.exr");
    assert_eq!(render(Some("256"), "all.exr").pixels, default.pixels, "a cap at the pixel count");
    assert_ne!(render(Some("16"), "capped.exr").pixels, default.pixels, "a cap below the pixel count");
}

#[test]
fn memory_beyond_the_film_does_not_grow_with_the_resolution() {
    // From 1024² on (where the default cap is reached), every method's working memory beyond its
    // film and outputs is the same at any resolution; the bidirectional methods' is set by the
    // cap: the stored light paths' part is linear in it (halving the cap from 2²⁰ to 2¹⁹ saves
    // twice what halving it again to 2¹⁸ saves), the chunks in flight and the band of camera
    // estimates aside.
    let scene = load_str(CORNELL, "scene.toml", None).unwrap();
    for integrator in all() {
        let name = integrator.name();
        let method = |side: u32, cap: u32| {
            let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 1);
            opts.resolution = Some((side, side));
            opts.params.merging.max_light_paths = cap;
            MemoryEstimate::of(&scene, integrator.as_ref(), &opts).method
        };
        let at_1024 = method(1024, DEFAULT_MAX_LIGHT_PATHS);
        for side in [2048, 4096, 8192] {
            assert_eq!(method(side, DEFAULT_MAX_LIGHT_PATHS), at_1024, "{name} at {side}²");
        }
        if ["bpt", "ppm", "bpm", "vcm"].contains(&name) {
            let half = method(4096, DEFAULT_MAX_LIGHT_PATHS / 2);
            let quarter = method(4096, DEFAULT_MAX_LIGHT_PATHS / 4);
            assert!(quarter < half && half < at_1024, "{name}: {quarter}, {half}, {at_1024}");
            assert_eq!(at_1024 - half, 2 * (half - quarter), "{name}: the cap sets the light paths' memory");
        } else if name == "pssmlt" || name == "mmlt" {
            // Its chains' segments of splats and its bootstraps: set by its settings alone.
            assert!(at_1024 > 0, "{name}: its chains in flight hold memory");
        } else {
            assert_eq!(at_1024, 0, "{name}: no working memory beyond the film");
        }
    }
}

#[test]
fn the_estimate_at_the_default_cap_is_within_512_mib() {
    // The estimate is an upper bound at any scene (a batch of light paths holds at most 3
    // vertices per path of the cap, `tests/light_path_batches.rs`): at the default cap and any
    // resolution, every bidirectional method's working memory is within issue 34's 512 MiB.
    let scene = load_str(CORNELL, "scene.toml", None).unwrap();
    for name in ["bpt", "ppm", "bpm", "vcm"] {
        let integrator = create(name).unwrap();
        let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 1);
        opts.resolution = Some((4096, 4096));
        let method = MemoryEstimate::of(&scene, integrator.as_ref(), &opts).method;
        println!("{name}: {} MiB", method >> 20);
        assert!(method <= 512 << 20, "{name}: {method} bytes");
    }
}
