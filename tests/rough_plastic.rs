//! Rough plastic (Mitsuba's `roughplastic`): a white rough plastic sphere in a white
//! environment renders the model's albedo (the integral of its BSDF) in the unbiased methods,
//! the back of a one-sided one is black, and the Mitsuba import, export and `vitrum info` carry
//! every parameter. (The sampler's χ², reciprocity and the tables against Mitsuba's values are
//! unit tests in `src/bsdf/rough_plastic.rs`; the render against Mitsuba 3's is the
//! `roughplastic` case of `tests/mitsuba_reference.rs`.)

mod common;

use common::image_mean_and_error;
use glam::Vec3;
use std::process::Command;
use vitrum::bsdf::{Scattering, TransportMode};
use vitrum::material::Bsdf;
use vitrum::scene::{load_str, mitsuba};
use vitrum::spectrum::Channels;

/// A camera looking at a white rough plastic (Beckmann α 0.2, index 1.5) that fills its view
/// (within 9° of normal incidence), in a constant environment of radiance 1; `extra` goes into
/// the material and `z` is where the camera stands (in front: +3, behind: −3).
fn rough_plastic_in_a_furnace(shape: &str, extra: &str, z: f32) -> vitrum::scene::Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, {z}]
look_at = [0.0, 0.0, 0.0]
fov = 10.0
resolution = [8, 8]
[render.path]
max_depth = 8
[materials.plastic]
type = "rough_plastic"
diffuse_reflectance = 1.0
ior = 1.5
alpha = 0.2
{extra}
[[objects]]
{shape}
material = "plastic"
[[lights]]
type = "environment"
radiance = 1.0
"#
    );
    load_str(&text, "rough_plastic.toml", None).unwrap()
}

/// The directional albedo ∫ f(wo, wi) cos θi dωi of the scene's first material for wo at
/// `theta` degrees from the normal, by the midpoint rule over (θi, φi).
fn albedo(scene: &vitrum::scene::Scene, theta: f32) -> f64 {
    let m = &scene.materials[0];
    let bsdf = Scattering::at(m, Vec3::ZERO, glam::Vec2::ZERO, &Channels::Rgb);
    let wo = Vec3::new(theta.to_radians().sin(), 0.0, theta.to_radians().cos());
    let (nt, np) = (4000, 256);
    let (dt, dp) = (std::f64::consts::FRAC_PI_2 / nt as f64, std::f64::consts::TAU / np as f64);
    let mut sum = 0.0;
    for i in 0..nt {
        let t = (i as f64 + 0.5) * dt;
        for j in 0..np {
            let p = (j as f64 + 0.5) * dp;
            let wi = Vec3::new((t.sin() * p.cos()) as f32, (t.sin() * p.sin()) as f32, t.cos() as f32);
            let f = bsdf.eval(wo, wi, TransportMode::Radiance).x as f64;
            sum += f * t.cos() * t.sin() * dt * dp;
        }
    }
    sum
}

#[test]
fn a_white_rough_plastic_sphere_in_a_white_furnace_renders_its_albedo() {
    let scene =
        rough_plastic_in_a_furnace("shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0", "", 3.0);
    let (normal, tilted) = (albedo(&scene, 0.0), albedo(&scene, 9.0));
    eprintln!("albedo at 0°: {normal:.6}, at 9°: {tilted:.6}");
    // Single scattering in the coating loses light: below 1, by more than the test resolves.
    assert!(normal < 0.99 && normal > 0.9, "{normal}");
    // Within the view the albedo changes by far less than the noise.
    assert!((normal - tilted).abs() < 1e-4, "{normal} vs {tilted}");
    for method in ["path", "bpt"] {
        let (mean, se) = image_mean_and_error(&scene, method, 512, 16);
        eprintln!("{method}: {mean:.6} ± {se:.6} vs {normal:.6}");
        assert!(se > 0.0 && (mean - normal).abs() <= 4.0 * se + 1e-4, "{method}: {mean} ± {se}");
        assert!(mean + 4.0 * se < 1.0, "{method}: the test must tell the albedo from 1 (± {se})");
    }
}

#[test]
fn a_one_sided_rough_plastic_is_black_from_behind_and_a_two_sided_one_is_not() {
    let quad = "shape = \"quad\"\ncorner = [-2.0, -2.0, 0.0]\nu = [4.0, 0.0, 0.0]\nv = [0.0, 4.0, 0.0]";
    let behind = rough_plastic_in_a_furnace(quad, "", -3.0);
    let (mean, _) = image_mean_and_error(&behind, "path", 4, 2);
    assert_eq!(mean, 0.0, "one-sided, seen from behind");
    let front = rough_plastic_in_a_furnace(quad, "", 3.0);
    let two_sided = rough_plastic_in_a_furnace(quad, "two_sided = true", -3.0);
    let (a, sa) = image_mean_and_error(&front, "path", 64, 16);
    let (b, sb) = image_mean_and_error(&two_sided, "path", 64, 16);
    assert!((a - b).abs() <= 4.0 * (sa * sa + sb * sb).sqrt(), "front {a} ± {sa}, two-sided back {b} ± {sb}");
}

#[test]
fn mitsubas_roughplastic_imports_exports_and_is_described() {
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <bsdf type="roughplastic" id="one">
        <string name="distribution" value="ggx"/>
        <float name="alpha" value="0.3"/>
        <rgb name="diffuse_reflectance" value="0.2, 0.4, 0.8"/>
        <float name="specular_reflectance" value="0.5"/>
        <string name="int_ior" value="pet"/>
        <boolean name="nonlinear" value="true"/>
    </bsdf>
    <bsdf type="twosided" id="two"><bsdf type="roughplastic"/></bsdf>
    <shape type="rectangle"><ref id="one"/></shape>
    <shape type="sphere"><point name="center" x="0" y="0" z="-3"/><ref id="two"/></shape>
</scene>
"#;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("p.xml"), xml).unwrap();
    let imported = mitsuba::import(&dir.path().join("p.xml"), false, None).unwrap();
    let check = |toml: &str| {
        for line in [
            "type = \"rough_plastic\"",
            "distribution = \"ggx\"",
            "alpha = 0.3",
            "diffuse_reflectance = [0.2, 0.4, 0.8]",
            "specular_reflectance = [0.5, 0.5, 0.5]",
            "ior = 1.575",
            "ior = 1.49",
            "ior_outside = 1.000277",
            "nonlinear = true",
            "two_sided = true",
            // Mitsuba's defaults.
            "distribution = \"beckmann\"",
            "alpha = 0.1",
            "diffuse_reflectance = [0.5, 0.5, 0.5]",
        ] {
            assert!(toml.contains(line), "{line} not in {toml}");
        }
    };
    check(&imported.toml);
    let scene = load_str(&imported.toml, "p.toml", None).unwrap();
    let rough: Vec<_> =
        scene.materials.iter().filter(|m| matches!(m.bsdf, Bsdf::RoughPlastic { .. })).collect();
    assert_eq!(rough.len(), 2);
    std::fs::write(dir.path().join("p.toml"), &imported.toml).unwrap();
    let vitrum = |args: &[&str]| {
        let out =
            Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).current_dir(dir.path()).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    vitrum(&["export", "p.toml", "-o", "x.xml", "--quiet"]);
    let exported = std::fs::read_to_string(dir.path().join("x.xml")).unwrap();
    assert!(exported.contains(r#"<bsdf type="roughplastic""#), "{exported}");
    let again = mitsuba::import(&dir.path().join("x.xml"), false, None).unwrap();
    check(&again.toml);
    let info = vitrum(&["info", "p.xml"]);
    assert!(info.contains("rough plastic (one-sided), ggx (alpha 0.3)"), "{info}");
    assert!(info.contains("rough plastic (two-sided), beckmann (alpha 0.1)"), "{info}");
    // A textured reflectance is refused with the element named.
    let textured = xml.replace(
        r#"<rgb name="diffuse_reflectance" value="0.2, 0.4, 0.8"/>"#,
        r#"<texture type="checkerboard" name="diffuse_reflectance"/>"#,
    );
    std::fs::write(dir.path().join("t.xml"), textured).unwrap();
    let err = mitsuba::import(&dir.path().join("t.xml"), false, None).err().expect("refused").to_string();
    assert!(err.contains("roughplastic") && err.contains("diffuse_reflectance"), "{err}");
    // Bad values exit with the field named.
    for (bad, field) in [("alpha = 0.0", "alpha"), ("alpha = 1.5", "alpha"), ("ior = 1.0", "ior")] {
        let text = format!(
            "[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\n[materials.p]\n\
             type = \"rough_plastic\"\nior_outside = 1.0\n{bad}\n[[objects]]\nshape = \"sphere\"\n\
             center = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"p\"\n"
        );
        let err = load_str(&text, "bad.toml", None).err().expect("refused").to_string();
        assert!(err.contains(field), "{bad}: {err}");
    }
}

#[test]
fn every_method_renders_it_finite_and_black_from_behind_when_one_sided() {
    use vitrum::integrators::{create, names};
    use vitrum::render::RenderOptions;
    // A 2×2 quad whose normal (u × v = −z) points away from the camera, lit by a point light on
    // the camera's side: the camera and the light both see its back.
    let scene = |two_sided: bool| {
        let text = format!(
            r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [16, 16]
[materials.p]
type = "rough_plastic"
diffuse_reflectance = [0.8, 0.6, 0.4]
distribution = "ggx"
alpha = 0.3
two_sided = {two_sided}
[[objects]]
shape = "quad"
corner = [-1.0, -1.0, 0.0]
u = [0.0, 2.0, 0.0]
v = [2.0, 0.0, 0.0]
material = "p"
[[lights]]
type = "point"
position = [0.4, 0.6, 1.2]
intensity = 2.0
"#
        );
        load_str(&text, "p.toml", None).unwrap()
    };
    let (one, two) = (scene(false), scene(true));
    for method in names() {
        let render = |scene: &vitrum::scene::Scene| {
            let opts = RenderOptions::for_method(scene, create(method).unwrap().as_ref(), 4);
            let out = common::render_opts(scene, method, &opts);
            assert_eq!(out.non_finite_samples, 0, "{method}");
            out.image
        };
        let lit = render(&two).pixels.iter().filter(|p| p.min_element() > 0.0).count();
        assert!(lit > 0, "{method}: the two-sided back must be lit");
        assert!(
            render(&one).pixels.iter().all(|p| *p == Vec3::ZERO),
            "{method}: a one-sided back must be black"
        );
    }
}
