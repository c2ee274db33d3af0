//! Thin dielectric slabs (Mitsuba's `thindielectric`): a pane in front of a light dims it by the
//! slab's analytic transmittance in every method that sees the light through it, and the Mitsuba
//! import and export carry it.

mod common;

use common::image_mean_and_error;
use std::process::Command;
use vitrum::integrators::create;
use vitrum::render::RenderOptions;
use vitrum::scene::{load_str, mitsuba};

/// Radiance of the light behind the pane.
const RADIANCE: f64 = 2.0;

/// A pane of index 1.5 between a narrow camera (fov 10°) and a quad light that fills the view.
fn pane_before_light() -> vitrum::scene::Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 10.0
resolution = [8, 8]
[materials.pane]
type = "thin_dielectric"
ior = 1.5
[[objects]]
shape = "quad"
corner = [-2.0, -2.0, 0.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 4.0, 0.0]
material = "pane"
[[lights]]
type = "quad"
corner = [-2.0, -2.0, -2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 4.0, 0.0]
radiance = {RADIANCE}
"#
    );
    load_str(&text, "pane.toml", None).unwrap()
}

#[test]
fn a_pane_in_front_of_a_light_dims_it_by_the_slab_transmittance() {
    // T' = 1 − 2R/(1 + R), R = ((1.5 − 1)/(1.5 + 1))² = 0.04 at normal incidence; within the 5°
    // of the view, T' changes by less than 1e-5. Behind the camera is black: the reflection adds
    // nothing.
    let r = 0.04f64;
    let expected = RADIANCE * (1.0 - 2.0 * r / (1.0 + r));
    let scene = pane_before_light();
    for method in ["path", "bpt", "vcm"] {
        let (mean, se) = image_mean_and_error(&scene, method, 16, 32);
        eprintln!("{method}: {mean:.5} ± {se:.5} vs {expected:.5}");
        assert!(se > 0.0 && (mean - expected).abs() <= 4.0 * se, "{method}: {mean} ± {se} vs {expected}");
    }
    // Whitted and distributed ray tracing follow both branches: no noise, the factor itself.
    for method in ["whitted", "distributed"] {
        let opts = RenderOptions::for_method(&scene, create(method).unwrap().as_ref(), 1);
        let image = common::render_opts(&scene, method, &opts).image;
        for p in &image.pixels {
            assert!((p.x as f64 - expected).abs() < 1e-4 * expected, "{method}: {p} vs {expected}");
        }
    }
}

#[test]
fn mitsubas_thindielectric_imports_and_exports() {
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <bsdf type="thindielectric" id="pane"><float name="int_ior" value="1.6"/></bsdf>
    <shape type="rectangle"><ref id="pane"/></shape>
</scene>
"#;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("p.xml"), xml).unwrap();
    let imported = mitsuba::import(&dir.path().join("p.xml"), false, None).unwrap();
    for line in ["type = \"thin_dielectric\"", "ior = 1.6", "ior_outside = 1.000277"] {
        assert!(imported.toml.contains(line), "{line} not in {}", imported.toml);
    }
    std::fs::write(dir.path().join("p.toml"), &imported.toml).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_vitrum"))
        .args(["export", "p.toml", "-o", "x.xml", "--quiet"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let exported = std::fs::read_to_string(dir.path().join("x.xml")).unwrap();
    assert!(exported.contains(r#"<bsdf type="thindielectric""#), "{exported}");
    let again = mitsuba::import(&dir.path().join("x.xml"), false, None).unwrap();
    assert!(
        again.toml.contains("type = \"thin_dielectric\"") && again.toml.contains("ior = 1.6"),
        "{}",
        again.toml
    );
}
