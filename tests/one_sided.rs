//! One-sided diffuse surfaces (Mitsuba's `diffuse`): black seen from behind by every method,
//! the same light transport in the methods that trace from the camera and from the lights, and
//! read and written exactly by the Mitsuba import and export.

mod common;

use common::{largest_block_z, mean_and_error, render_opts};
use std::path::Path;
use std::process::{Command, Output};
use vitrum::integrators::{create, names};
use vitrum::render::RenderOptions;
use vitrum::scene::{load_str, mitsuba};

/// A 2×2 quad whose normal (u × v = −z) points away from the camera, lit by a point light on
/// the camera's side: the camera and the light both see its back.
fn quad_seen_from_behind(one_sided: bool) -> String {
    format!(
        r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [16, 16]
[materials.white]
type = "diffuse"
color = [0.8, 0.6, 0.4]
one_sided = {one_sided}
[[objects]]
shape = "quad"
corner = [-1.0, -1.0, 0.0]
u = [0.0, 2.0, 0.0]
v = [2.0, 0.0, 0.0]
material = "white"
[[lights]]
type = "point"
position = [0.4, 0.6, 1.2]
intensity = 2.0
"#
    )
}

#[test]
fn a_quad_seen_from_behind_is_black_by_every_method_when_one_sided() {
    let one = load_str(&quad_seen_from_behind(true), "one.toml", None).unwrap();
    let two = load_str(&quad_seen_from_behind(false), "two.toml", None).unwrap();
    let render = |scene: &vitrum::scene::Scene, method: &str| {
        let opts = RenderOptions::for_method(scene, create(method).unwrap().as_ref(), 4);
        let out = render_opts(scene, method, &opts);
        assert_eq!(out.non_finite_samples, 0, "{method}");
        out.image
    };
    for method in names() {
        let black = render(&one, method);
        let lit = render(&two, method);
        let lit_pixels = lit.pixels.iter().filter(|p| p.min_element() > 0.0).count();
        assert!(lit_pixels > 0, "{method}: the two-sided back must be lit");
        assert!(
            black.pixels.iter().all(|p| *p == glam::Vec3::ZERO),
            "{method}: a one-sided back must be black"
        );
    }
}

/// A floor (two-sided) between two one-sided panels, lit by a point light between them: the left
/// panel faces the light, the right one turns its back to it (and to the camera), so light that
/// reaches the right panel ends there instead of lighting the floor beside it.
const PANELS: &str = r#"
[camera]
position = [0.0, 2.0, 4.0]
look_at = [0.0, 0.4, 0.0]
fov = 50.0
resolution = [24, 24]
[materials.floor]
type = "diffuse"
color = [0.7, 0.7, 0.7]
[materials.panel]
type = "diffuse"
color = [0.9, 0.5, 0.3]
one_sided = true
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, -2.0]
u = [0.0, 0.0, 4.0]
v = [4.0, 0.0, 0.0]
material = "floor"
[[objects]]
# left panel, normal +x (towards the light)
shape = "quad"
corner = [-1.0, 0.0, -1.5]
u = [0.0, 0.0, 3.0]
v = [0.0, 1.5, 0.0]
material = "panel"
[[objects]]
# right panel, normal +x (away from the light and the camera)
shape = "quad"
corner = [1.2, 0.0, -1.5]
u = [0.0, 0.0, 3.0]
v = [0.0, 1.5, 0.0]
material = "panel"
[[lights]]
type = "point"
position = [0.3, 1.2, 0.0]
intensity = 3.0
"#;

#[test]
fn path_light_and_bpt_agree_on_one_sided_panels() {
    let scene = load_str(PANELS, "panels.toml", None).unwrap();
    let (k, spp) = (32, 8);
    let (mp, sp) = mean_and_error(&scene, "path", spp, k);
    // The scene must call on one-sidedness: the same panels two-sided light the floor more.
    let two = load_str(&PANELS.replace("one_sided = true", "one_sided = false"), "two.toml", None).unwrap();
    let (m2, s2) = mean_and_error(&two, "path", spp, k);
    let z_two = largest_block_z(&mp, &sp, &m2, &s2, 24, 6);
    assert!(z_two > 10.0, "two-sided panels should differ clearly: {z_two:.1} standard errors");
    for method in ["light", "bpt"] {
        let (m, s) = mean_and_error(&scene, method, spp, k);
        // 16 blocks × 3 channels: the largest |z| of 48 normal variables exceeds 4.5 with
        // probability 3·10⁻⁴.
        let z = largest_block_z(&m, &s, &mp, &sp, 24, 6);
        eprintln!("{method} vs path: largest 6×6 block {z:.2} standard errors; two-sided {z_two:.1}");
        assert!(z <= 4.5, "{method} disagrees with path by {z:.2} standard errors");
    }
}

fn vitrum(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).current_dir(dir).output().unwrap()
}

/// A Mitsuba scene with a bare `diffuse` (one-sided) floor seen from above and a quad light.
const MITSUBA: &str = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0.5, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <bsdf type="diffuse" id="floor"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf>
    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
        <ref id="floor"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate y="2.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="10, 10, 10"/></emitter>
    </shape>
</scene>
"#;

#[test]
fn a_bare_mitsuba_diffuse_imports_one_sided_and_two_sided_reads_it_two_sided() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.xml"), MITSUBA).unwrap();
    let imported = mitsuba::import(&dir.path().join("m.xml"), false, None).unwrap();
    assert!(imported.toml.contains("one_sided = true"), "{}", imported.toml);
    assert!(imported.warnings.iter().all(|w| !w.contains("sided")), "exact: {:?}", imported.warnings);
    // `--two-sided`: the documented two-sided reading, with a warning.
    let out = vitrum(dir.path(), &["import", "--two-sided", "m.xml", "-o", "t.toml", "--quiet"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let toml = std::fs::read_to_string(dir.path().join("t.toml")).unwrap();
    assert!(!toml.contains("one_sided = true"), "{toml}");
    assert!(toml.contains("read as two-sided (--two-sided)"), "{toml}");
    let out = vitrum(dir.path(), &["import", "m.xml", "-o", "o.toml", "--quiet"]);
    assert!(out.status.success());
    let toml = std::fs::read_to_string(dir.path().join("o.toml")).unwrap();
    assert!(toml.contains("one_sided = true"), "{toml}");
}

#[test]
fn one_sided_diffuse_exports_bare_and_reimports_to_the_same_bits() {
    // The panels' scene → Mitsuba XML → vitrum: the same image (with the independent sampler,
    // which is what the export carries), and the panels' BSDF written without `twosided`.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("panels.toml"), PANELS).unwrap();
    let out = vitrum(dir.path(), &["export", "panels.toml", "-o", "x.xml", "--quiet"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let xml = std::fs::read_to_string(dir.path().join("x.xml")).unwrap();
    assert!(xml.contains(r#"<bsdf type="diffuse" id="mat1-panel">"#), "{xml}");
    assert!(xml.contains(r#"<bsdf type="twosided" id="mat0-floor">"#), "{xml}");
    let render = |scene: &str| {
        let out = vitrum(
            dir.path(),
            &[
                "render",
                scene,
                "-i",
                "path",
                "--spp",
                "4",
                "--sampler",
                "independent",
                "-o",
                "r.exr",
                "--quiet",
            ],
        );
        assert!(out.status.success(), "{scene}: {}", String::from_utf8_lossy(&out.stderr));
        vitrum::output::exr::read_exr(&dir.path().join("r.exr")).unwrap().0.pixels
    };
    let original = render("panels.toml");
    let reimported = render("x.xml");
    assert_eq!(original, reimported);
    let imported = mitsuba::import(&dir.path().join("x.xml"), false, None).unwrap();
    assert_eq!(imported.toml.matches("one_sided = true").count(), 1, "{}", imported.toml);
}
