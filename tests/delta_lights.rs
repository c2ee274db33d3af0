//! Spot and directional lights (Mitsuba 3's `spot` and `directional`): the radiance of a diffuse
//! plane they light against the closed form, for every method; the methods against `path` on a
//! scene with interreflection and occlusion; bad input refused at its line.

mod common;

use common::{block_chi2, image_mean_and_error, render_with_variance};
use std::f64::consts::PI;
use vitrum::scene::{load_str, Scene};

/// Albedo of the plane.
const ALBEDO: f64 = 0.5;
/// Height of the spot above the plane.
const HEIGHT: f64 = 2.0;
/// The spot's intensity on its axis (W/sr), cutoff and beam width (degrees).
const INTENSITY: f64 = 5.0;
const CUTOFF: f64 = 30.0;
const BEAM_WIDTH: f64 = 20.0;
/// Height of the camera, looking straight down, and its field of view (degrees).
const CAMERA_HEIGHT: f64 = 4.0;
const FOV: f64 = 1.0;
/// The merge radius of the photon methods: the whole patch the camera sees is within a few radii,
/// and the kernel's bias (second order in the radius, |∇²E/E| · r²/8 ≲ 5 m⁻² · 0.05² / 8 < 0.2%)
/// is far below their standard error here.
const RADIUS: f64 = 0.05;

/// A 4 m × 4 m diffuse plane at y = 0 seen from straight above `(x, 0, 0)` through a 1° field of
/// view (32 × 32 pixels), lit by `light` (a `[[lights]]` table).
fn plane(x: f64, light: &str) -> Scene {
    let text = format!(
        r#"
[camera]
position = [{x}, {CAMERA_HEIGHT}, 0.0]
look_at = [{x}, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov = {FOV}
resolution = [32, 32]
[render.ppm]
radius = {RADIUS}
radius_alpha = 1.0
[render.bpm]
radius = {RADIUS}
radius_alpha = 1.0
[render.vcm]
radius = {RADIUS}
[materials.plane]
type = "diffuse"
color = {ALBEDO}
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, -2.0]
u = [0.0, 0.0, 4.0]
v = [4.0, 0.0, 0.0]
material = "plane"
{light}
"#
    );
    load_str(&text, "plane.toml", None).unwrap()
}

/// Mitsuba's falloff at angle θ (radians) from the spot's axis.
fn falloff(theta: f64) -> f64 {
    let (c, b) = (CUTOFF.to_radians(), BEAM_WIDTH.to_radians());
    if theta >= c {
        0.0
    } else if theta <= b {
        1.0
    } else {
        (c - theta) / (c - b)
    }
}

/// Radiance of the plane at `(x, 0, z)` under the spot at height [`HEIGHT`] above the origin
/// pointing straight down: `ρ/π · I·f(θ)·cos θ / d²`, with `cos θ = h/d`.
fn spot_radiance(x: f64, z: f64) -> f64 {
    let d = (x * x + z * z + HEIGHT * HEIGHT).sqrt();
    let theta = (HEIGHT / d).acos();
    ALBEDO / PI * INTENSITY * falloff(theta) * HEIGHT / (d * d * d)
}

/// The mean of `radiance` over the square of the plane the camera above `(x, 0, 0)` sees (the
/// image mean every method converges to), by a 400 × 400 midpoint rule.
fn patch_mean(x: f64, radiance: impl Fn(f64, f64) -> f64) -> f64 {
    let half = CAMERA_HEIGHT * (0.5 * FOV).to_radians().tan();
    let n = 400;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let u = -half + 2.0 * half * (i as f64 + 0.5) / n as f64;
            let v = -half + 2.0 * half * (j as f64 + 0.5) / n as f64;
            sum += radiance(x + u, v);
        }
    }
    sum / (n * n) as f64
}

/// Iterations (samples per pixel) of a method for the plane: the photon methods gather few photons
/// per iteration in the small patch.
fn spp(method: &str) -> u32 {
    match method {
        "ppm" | "bpm" => 64,
        "raycast" | "whitted" => 1,
        _ => 16,
    }
}

/// The image mean of `method` on `scene` equals `expected` within 4 standard errors (over 16
/// independent renders) plus 1e-4 relative for single-precision arithmetic; the deterministic
/// methods (one render) within that 1e-4.
fn assert_plane_mean(scene: &Scene, method: &str, expected: f64, what: &str) {
    let deterministic = matches!(method, "raycast" | "whitted");
    let renders = if deterministic { 2 } else { 16 };
    let (mean, error) = image_mean_and_error(scene, method, spp(method), renders);
    println!("{what}, {method}: mean {mean:.6} ± {error:.6}, closed form {expected:.6}");
    let tolerance = if deterministic { 0.0 } else { 4.0 * error } + 1e-4 * expected.max(1e-3);
    assert!(
        (mean - expected).abs() <= tolerance,
        "{what}, {method}: mean {mean} vs closed form {expected} (standard error {error})"
    );
}

const METHODS: [&str; 8] = ["path", "light", "bpt", "vcm", "ppm", "bpm", "raycast", "whitted"];

#[test]
fn a_spot_lights_a_diffuse_plane_as_the_closed_form_says() {
    let light = format!(
        "[[lights]]\ntype = \"spot\"\nposition = [0.0, {HEIGHT}, 0.0]\ndirection = [0.0, -1.0, 0.0]\n\
         intensity = {INTENSITY}\ncutoff_angle = {CUTOFF}\nbeam_width = {BEAM_WIDTH}"
    );
    // Inside the beam (θ = 0), in the transition (θ = 25°) and beyond the cutoff (θ = 35°).
    for (name, theta) in
        [("inside the beam", 0.0f64), ("in the transition", 25.0), ("outside the cutoff", 35.0)]
    {
        let x = HEIGHT * theta.to_radians().tan();
        let scene = plane(x, &light);
        let expected = patch_mean(x, spot_radiance);
        if theta > CUTOFF {
            assert_eq!(expected, 0.0);
        } else {
            assert!(expected > 0.01, "{name}: {expected}");
        }
        for method in METHODS {
            assert_plane_mean(&scene, method, expected, &format!("spot, {name}"));
        }
    }
}

#[test]
fn a_directional_light_lights_a_diffuse_plane_with_its_irradiance_times_the_cosine() {
    // E·cos α on the plane everywhere: radiance ρ/π · E · cos α.
    let (irradiance, alpha) = (1.5f64, 35.0f64.to_radians());
    let light = format!(
        "[[lights]]\ntype = \"directional\"\ndirection = [{}, {}, 0.0]\nirradiance = {irradiance}",
        alpha.sin(),
        -alpha.cos()
    );
    let scene = plane(0.3, &light);
    let expected = ALBEDO / PI * irradiance * alpha.cos();
    for method in METHODS {
        assert_plane_mean(&scene, method, expected, "directional light");
    }
}

/// A floor, a back wall and a sphere lit by a spot (its beam edge across the floor) and a
/// directional light (the sphere's shadow on the floor): light is reflected between them.
fn lit_room() -> Scene {
    load_str(
        r#"
[camera]
position = [0.0, 1.5, 4.0]
look_at = [0.0, 0.4, 0.0]
fov = 45.0
resolution = [32, 32]
[materials.white]
type = "diffuse"
color = 0.7
[materials.red]
type = "diffuse"
color = [0.7, 0.2, 0.1]
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, -1.0]
u = [0.0, 0.0, 3.0]
v = [4.0, 0.0, 0.0]
material = "white"
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, -1.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 2.0, 0.0]
material = "red"
[[objects]]
shape = "sphere"
center = [0.2, 0.4, 0.2]
radius = 0.4
material = "white"
[[lights]]
type = "spot"
position = [-0.8, 1.6, 1.0]
look_at = [0.0, 0.0, 0.0]
intensity = 4.0
cutoff_angle = 35.0
[[lights]]
type = "directional"
direction = [0.4, -1.0, -0.5]
irradiance = 0.8
"#,
        "lit-room.toml",
        None,
    )
    .unwrap()
}

#[test]
fn light_bpt_and_vcm_match_path_under_spot_and_directional_lights() {
    // Delta lights only: `path` is unbiased (no specular surface). The 8×8 block means of each
    // method agree with a `path` render in their standard errors: χ² over the 16 blocks below its
    // 99.99% quantile (about 42), so a bias of a few percent in a block fails.
    let scene = lit_room();
    let reference = render_with_variance(&scene, "path", 32, 1024, 71);
    for method in ["light", "bpt", "vcm"] {
        let render = render_with_variance(&scene, method, 32, 256, 5);
        let (chi2, blocks) = block_chi2(&render, &reference);
        println!("lit room, {method}: χ² {chi2:.1} over {blocks} blocks");
        assert_eq!(blocks, 16);
        assert!(chi2 < 42.0, "{method}: block χ² {chi2} over {blocks} blocks against path");
    }
}

#[test]
fn the_photon_methods_converge_towards_path_under_spot_and_directional_lights() {
    // `ppm` and `bpm` are biased by their merge radius, which shrinks with the iterations
    // (α = 0.75): their image mean comes to `path`'s. After 512 iterations it agrees within
    // 4 standard errors of the difference (16 renders each) plus the kernel's bias, bounded by
    // that after 32 iterations: the bias must not grow as the radius shrinks.
    let scene = lit_room();
    let (reference, reference_error) = image_mean_and_error(&scene, "path", 64, 16);
    for method in ["ppm", "bpm"] {
        let (early, early_error) = image_mean_and_error(&scene, method, 32, 16);
        let (late, late_error) = image_mean_and_error(&scene, method, 512, 16);
        let early_bias = (early - reference).abs();
        let late_bias = (late - reference).abs();
        let late_noise = 4.0 * (late_error.powi(2) + reference_error.powi(2)).sqrt();
        let early_noise = 4.0 * (early_error.powi(2) + reference_error.powi(2)).sqrt();
        println!(
            "lit room, {method}: path {reference:.5} ± {reference_error:.5}; 32 iterations {early:.5} ± \
             {early_error:.5}; 512 iterations {late:.5} ± {late_error:.5}"
        );
        assert!(
            late_bias <= late_noise + (early_bias - early_noise).max(0.0),
            "{method}: 512 iterations {late} vs path {reference} (32 iterations: {early})"
        );
    }
}

/// The error of loading `text` as a scene file.
fn load_error(text: &str) -> String {
    load_str(text, "bad.toml", None).err().expect("the scene is refused").to_string()
}

#[test]
fn bad_spot_and_directional_lights_are_refused_at_their_line() {
    let head = "[camera]\nposition = [0.0, 1.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\n";
    let spot =
        |fields: &str| format!("{head}[[lights]]\ntype = \"spot\"\nposition = [0.0, 2.0, 0.0]\n{fields}");
    let cases = [
        (spot("direction = [0.0, -1.0, 0.0]\nintensity = 1.0\ncutoff_angle = -5.0"), 9, "cutoff_angle"),
        (spot("direction = [0.0, -1.0, 0.0]\nintensity = 1.0\ncutoff_angle = 200.0"), 9, "cutoff_angle"),
        (spot("direction = [0.0, -1.0, 0.0]\nintensity = 1.0\ncutoff_angle = 20.0\nbeam_width = 25.0"), 10, "beam_width"),
        (spot("direction = [0.0, -1.0, 0.0]\nintensity = 1.0\nbeam_width = -1.0"), 9, "beam_width"),
        (spot("direction = [0.0, 0.0, 0.0]\nintensity = 1.0"), 7, "direction"),
        (spot("look_at = [0.0, 2.0, 0.0]\nintensity = 1.0"), 7, "look_at"),
        (spot("intensity = 1.0"), 4, "direction"),
        (spot("direction = [0.0, -1.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nintensity = 1.0"), 8, "look_at"),
        (spot("direction = [0.0, -1.0, 0.0]\nintensity = -1.0"), 8, "intensity"),
        (format!("{head}[[lights]]\ntype = \"directional\"\ndirection = [0.0, 0.0, 0.0]\nirradiance = 1.0"), 6, "direction"),
        (format!("{head}[[lights]]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nirradiance = [1.0, -1.0, 0.0]"), 7, "irradiance"),
    ];
    for (text, line, field) in &cases {
        let message = load_error(text);
        println!("{message}");
        assert!(message.contains(&format!("bad.toml:{line}")), "expected line {line}: {message}");
        assert!(message.contains(field), "expected the field `{field}`: {message}");
    }
}

#[test]
fn a_bad_spot_exits_with_code_2_naming_file_and_line() {
    let dir = std::env::temp_dir().join(format!("vitrum-delta-lights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad-spot.toml");
    std::fs::write(
        &file,
        "[camera]\nposition = [0.0, 1.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\n[[lights]]\ntype = \"spot\"\n\
         position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1.0\ncutoff_angle = 10.0\n\
         beam_width = 12.0\n",
    )
    .unwrap();
    let out =
        std::process::Command::new(env!("CARGO_BIN_EXE_vitrum")).arg("info").arg(&file).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad-spot.toml:10") && stderr.contains("beam_width"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn both_engines_of_path_render_spot_and_directional_lights_to_the_same_bits() {
    // The wavefront engine keeps hits and shadow rays across lanes and shades with the scalar
    // engine's step: the same bits.
    use vitrum::integrators::{create, EngineOption};
    use vitrum::render::{render, RenderOptions};
    let scene = lit_room();
    let path = create("path").unwrap();
    let images: Vec<Vec<[u32; 3]>> = [EngineOption::Scalar, EngineOption::Wavefront]
        .into_iter()
        .map(|engine| {
            let mut opts = RenderOptions::for_method(&scene, path.as_ref(), 8);
            opts.params.engine = engine;
            let out = render(&scene, path.as_ref(), &opts, &|_, _| {});
            out.image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
        })
        .collect();
    assert!(images[0].iter().any(|p| p[0] != 0), "the room is lit");
    assert_eq!(images[0], images[1]);
}

#[test]
fn a_delta_light_meeting_glass_makes_vcm_the_reference() {
    for light in [
        "type = \"spot\"\nposition = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1.0",
        "type = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nirradiance = 1.0",
    ] {
        let text = format!(
            "[camera]\nposition = [0.0, 1.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\n[materials.glass]\ntype = \
             \"dielectric\"\nior = 1.5\n[[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.5, 0.0]\nradius = \
             0.5\nmaterial = \"glass\"\n[[lights]]\n{light}\n"
        );
        let scene = load_str(&text, "glass.toml", None).unwrap();
        let choice = vitrum::reference::choose_method(&scene);
        assert_eq!(choice.method, "vcm", "{light}: {}", choice.why);
    }
}

/// The `lights` of `vitrum info --json` on `file` in `dir`.
fn info_lights(dir: &std::path::Path, file: &str) -> Vec<serde_json::Value> {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vitrum"))
        .current_dir(dir)
        .args(["info", "--json", file])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    json["lights"].as_array().unwrap().clone()
}

#[test]
fn spot_and_directional_lights_survive_export_to_mitsuba_and_import_back() {
    // vitrum TOML → Mitsuba XML (a spot's to_world frame, a directional's direction) → vitrum:
    // the same lights, every number within single-precision roundoff.
    let dir = tempfile::tempdir().unwrap();
    let room = std::fs::read_to_string("tests/delta_lights.rs").unwrap();
    let start = room.find("[camera]\nposition = [0.0, 1.5, 4.0]").unwrap();
    let toml = &room[start..start + room[start..].find("\"#,").unwrap()];
    std::fs::write(dir.path().join("room.toml"), toml).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vitrum"))
        .current_dir(dir.path())
        .args(["export", "room.toml", "-o", "room.xml", "--quiet"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let xml = std::fs::read_to_string(dir.path().join("room.xml")).unwrap();
    assert!(
        xml.contains("<emitter type=\"spot\">") && xml.contains("<emitter type=\"directional\">"),
        "{xml}"
    );
    let (original, imported) = (info_lights(dir.path(), "room.toml"), info_lights(dir.path(), "room.xml"));
    assert_eq!(original.len(), 2);
    assert_eq!(imported.len(), 2);
    fn close(a: &serde_json::Value, b: &serde_json::Value) -> bool {
        match (a, b) {
            (serde_json::Value::Number(x), serde_json::Value::Number(y)) => {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                (x - y).abs() <= 1e-6 * x.abs().max(1.0)
            }
            (serde_json::Value::Array(x), serde_json::Value::Array(y)) => {
                x.len() == y.len() && x.iter().zip(y).all(|(a, b)| close(a, b))
            }
            (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
                x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| close(v, w)))
            }
            _ => a == b,
        }
    }
    for (a, b) in original.iter().zip(&imported) {
        assert!(close(a, b), "exported {a}\nimported {b}");
    }
}

#[test]
fn mitsuba_3_and_vitrum_agree_on_spot_and_directional_lights() {
    // The room of `lit_room` as Mitsuba 3 XML (tests/data/mitsuba3/lights.xml, written by hand by
    // scripts/mitsuba3/lights.py, not by vitrum's exporter), imported by vitrum, rendered by
    // `path`, against Mitsuba 3's `path` (scalar_rgb, 16 renders of 1024 samples, their mean and
    // its variance stored in tests/data/mitsuba3/lights.exr by that script). The 8×8 block means
    // agree in their standard errors: χ² over the 16 blocks below its 99.99% quantile (about 42).
    let data = std::path::Path::new("tests/data/mitsuba3");
    let scene = vitrum::scene::load(&data.join("lights.xml")).unwrap();
    let ours = render_with_variance(&scene, "path", 32, 1024, 17);
    let exr = vitrum::output::exr::read_exr_channels(&data.join("lights.exr")).unwrap();
    assert_eq!((exr.width, exr.height), (32, 32));
    let image = |prefix: &str| {
        let mut image = vitrum::image::Image::new(32, 32);
        for (i, p) in image.pixels.iter_mut().enumerate() {
            let c = |name: &str| exr.channels[&format!("{prefix}{name}")][i];
            *p = glam::Vec3::new(c("R"), c("G"), c("B"));
        }
        image
    };
    let mitsuba = (image(""), image("variance."));
    let mean = |i: &vitrum::image::Image| {
        i.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>() / (3 * i.pixels.len()) as f64
    };
    let (chi2, blocks) = block_chi2(&ours, &mitsuba);
    println!(
        "Mitsuba 3 mean {:.6}, vitrum mean {:.6}; block χ² {chi2:.1} over {blocks} blocks",
        mean(&mitsuba.0),
        mean(&ours.0)
    );
    assert_eq!(blocks, 16);
    assert!(chi2 < 42.0, "block χ² {chi2} over {blocks} blocks against Mitsuba 3");
}

#[test]
fn a_mitsuba_spot_with_a_projected_texture_is_refused_or_with_lenient_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let xml = std::fs::read_to_string("tests/data/mitsuba3/lights.xml").unwrap().replace(
        "<float name=\"cutoff_angle\" value=\"35\"/>",
        "<float name=\"cutoff_angle\" value=\"35\"/>\n<texture type=\"bitmap\" name=\"texture\">\
         <string name=\"filename\" value=\"t.png\"/></texture>",
    );
    assert!(xml.contains("<texture"), "the spot of lights.xml moved");
    std::fs::write(dir.path().join("t.xml"), xml).unwrap();
    let info = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_vitrum"))
            .current_dir(dir.path())
            .arg("info")
            .args(args)
            .arg("t.xml")
            .output()
            .unwrap()
    };
    let strict = info(&[]);
    let stderr = String::from_utf8_lossy(&strict.stderr);
    assert_eq!(strict.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("t.xml:") && stderr.contains("texture"), "{stderr}");
    let lenient = info(&["--lenient"]);
    assert!(lenient.status.success(), "{}", String::from_utf8_lossy(&lenient.stderr));
    assert!(String::from_utf8_lossy(&lenient.stdout).contains("spot at"));
}
