//! `vitrum info` and `vitrum render` warn about coincident surfaces of different objects
//! (`src/scene/overlap.rs`), naming both objects; the shipped scenes have none.

mod common;

use std::path::Path;
use std::process::Command;

/// A drinking glass with a separate water cylinder of the glass's inner radius standing on its
/// cavity floor: the cylinder's wall lies on the glass's inner wall and its bottom cap on the
/// cavity floor (the mistake `fill` avoids).
const GLASS_AND_WATER: &str = r#"
[camera]
position = [0.0, 1.0, 2.6]
look_at = [0.0, 0.45, 0.0]
resolution = [8, 8]
[materials.glass]
type = "dielectric"
ior = 1.52
[materials.water]
type = "dielectric"
ior = 1.33
[[objects]]
name = "the glass"
shape = "drinking_glass"
base = [0.0, 0.0, 0.0]
radius = 0.35
height = 0.9
wall = 0.03
bottom = 0.06
material = "glass"
[[objects]]
name = "the water"
shape = "cylinder"
base = [0.0, 0.06, 0.0]
radius = 0.32
height = 0.5
material = "water"
[[lights]]
type = "environment"
radiance = 1.0
"#;

fn vitrum(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).output().unwrap()
}

fn coincidence_warnings(stderr: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(stderr)
        .lines()
        .filter(|l| l.contains("warning:") && l.contains("coincident surfaces"))
        .map(str::to_string)
        .collect()
}

#[test]
fn a_water_cylinder_inside_a_drinking_glass_is_reported_by_info_and_render() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("glass-and-water.toml");
    std::fs::write(&scene, GLASS_AND_WATER).unwrap();
    let out = vitrum(&["info".as_ref(), scene.as_os_str()]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let warnings = coincidence_warnings(&out.stderr);
    assert_eq!(warnings.len(), 1, "one warning per pair of objects: {warnings:?}");
    assert!(warnings[0].starts_with("vitrum: warning: "), "{warnings:?}");
    assert!(warnings[0].contains("`the glass`") && warnings[0].contains("`the water`"), "{warnings:?}");
    let exr = dir.path().join("out.exr");
    let out =
        vitrum(&["render".as_ref(), scene.as_os_str(), "--quiet".as_ref(), "-o".as_ref(), exr.as_os_str()]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(coincidence_warnings(&out.stderr), warnings, "render warns the same");
    // `fill` builds the same water as one interface: no warning.
    let filled = GLASS_AND_WATER.split("[[objects]]\nname = \"the water\"").next().unwrap().to_string()
        + "[[lights]]\ntype = \"environment\"\nradiance = 1.0\n";
    let filled = filled.replace("bottom = 0.06\n", "bottom = 0.06\nfill = 0.5\nliquid = \"water\"\n");
    std::fs::write(&scene, filled).unwrap();
    let out = vitrum(&["info".as_ref(), scene.as_os_str()]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(coincidence_warnings(&out.stderr).is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn the_shipped_scenes_have_no_coincident_surfaces() {
    // Except the hard case that is about them (two pairs of identical quads).
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut checked = 0;
    for dir in ["scenes", "scenes/hard"] {
        for file in common::toml_files(&root.join(dir)) {
            let scene = vitrum::scene::load(&file).unwrap();
            let found: Vec<&String> =
                scene.warnings.iter().filter(|w| w.contains("coincident surfaces")).collect();
            if file.ends_with("coincident-quads.toml") {
                assert_eq!(found.len(), 2, "{found:?}");
            } else {
                assert!(found.is_empty(), "{}: {found:?}", file.display());
            }
            checked += 1;
        }
    }
    assert!(checked >= 30, "{checked} scenes");
    let out = vitrum(&["info".as_ref(), root.join("scenes/cornell-glass.toml").as_os_str()]);
    assert_eq!(out.status.code(), Some(0));
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("warning"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
