//! HDR environment maps: a constant map renders as the constant environment does (and the white
//! furnace stays at 1), one bright texel (a bilinear tent of radiance) lights a diffuse plane
//! exactly as the closed form of its integral says for every method that samples it, the deterministic methods see the map in
//! the directions they trace, and bad maps exit with code 2.

mod common;

use glam::Vec3;
use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;
use vitrum::image::Image;
use vitrum::scene::{load_str, Scene};

/// Write a linear EXR map of `width` × `height` texels, row by row from the top.
fn write_map(path: &Path, width: usize, height: usize, texel: impl Fn(usize, usize) -> Vec3) {
    let mut image = Image::new(width, height);
    for j in 0..height {
        for i in 0..width {
            image.pixels[j * width + i] = texel(i, j);
        }
    }
    vitrum::output::exr::write_exr(path, &image, &Default::default()).unwrap();
}

/// `body` (materials and objects) under the environment `light` (the body of a `[[lights]]`
/// table), seen by a camera at `position` looking at `look_at`, compiled in `dir`.
fn scene(dir: &Path, camera: &str, body: &str, light: &str) -> Scene {
    let text = format!("[camera]\n{camera}\n[render]\nintegrator = \"path\"\n{body}\n[[lights]]\ntype = \"environment\"\n{light}\n");
    load_str(&text, "env.toml", Some(dir)).unwrap()
}

const GLASS_ON_FLOOR: &str = r#"
[materials.floor]
type = "diffuse"
color = 0.6
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, 2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
material = "floor"
[[objects]]
shape = "sphere"
center = [0.0, 0.5, 0.0]
radius = 0.5
material = "glass"
"#;

const LOOK_AT_GLASS: &str =
    "position = [0.0, 1.0, 3.0]\nlook_at = [0.0, 0.5, 0.0]\nfov = 40.0\nresolution = [16, 16]";

#[test]
fn a_constant_map_renders_as_the_constant_environment() {
    let dir = tempfile::tempdir().unwrap();
    write_map(&dir.path().join("grey.exr"), 8, 4, |_, _| Vec3::new(0.8, 0.9, 1.0));
    let constant = scene(dir.path(), LOOK_AT_GLASS, GLASS_ON_FLOOR, "radiance = [0.8, 0.9, 1.0]");
    let mapped = scene(dir.path(), LOOK_AT_GLASS, GLASS_ON_FLOOR, "file = \"grey.exr\"");
    let k = 16;
    let (a, sa) = common::mean_and_error(&constant, "path", 8, k);
    let (b, sb) = common::mean_and_error(&mapped, "path", 8, k);
    // 4 × 4 blocks of 4 × 4 pixels: each block mean agrees within 4.5 standard errors of the
    // difference (48 block-channel comparisons; a correct renderer fails one with p ≈ 3e-4).
    let worst = common::largest_block_z(&a, &sa, &b, &sb, 16, 4);
    println!("constant map vs constant environment: largest block difference {worst:.2} standard errors");
    assert!(worst < 4.5, "{worst}");
}

#[test]
fn the_white_furnace_with_a_map_stays_at_one() {
    let dir = tempfile::tempdir().unwrap();
    write_map(&dir.path().join("white.exr"), 16, 8, |_, _| Vec3::ONE);
    let glass = "[materials.glass]\ntype = \"dielectric\"\nior = 1.5\n\
        [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"glass\"\n";
    let camera = "position = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 30.0\nresolution = [12, 12]";
    let furnace = scene(dir.path(), camera, glass, "file = \"white.exr\"");
    let (mean, error) = common::image_mean_and_error(&furnace, "path", 4, 8);
    println!("white furnace, glass sphere under a white map: {mean:.5} ± {error:.5}");
    assert!((mean - 1.0).abs() < 4.0 * error + 1e-4, "{mean} ± {error}");
}

/// Map size and the one bright texel of [`one_bright_texel`].
const W: usize = 16;
const H: usize = 8;
const TEXEL: (usize, usize) = (3, 2);
const BRIGHT: f32 = 50.0;

/// A diffuse square of albedo 0.5 lit by a map that is black but for one texel, seen from above
/// (nothing else in the scene: every point of it sees the whole texel's tent, and the camera sees only
/// it; it is small so that light paths from the map's disk mostly reach what the camera sees).
fn one_bright_texel(dir: &Path, rotation: f32) -> Scene {
    write_map(
        &dir.join("texel.exr"),
        W,
        H,
        |i, j| if (i, j) == TEXEL { Vec3::splat(BRIGHT) } else { Vec3::ZERO },
    );
    let plane = "[materials.plane]\ntype = \"diffuse\"\ncolor = 0.5\n\
        [[objects]]\nshape = \"quad\"\ncorner = [-0.5, 0.0, 0.5]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, -1.0]\nmaterial = \"plane\"\n";
    let camera = "position = [0.0, 2.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 20.0\nresolution = [8, 8]";
    scene(dir, camera, plane, &format!("file = \"texel.exr\"\nrotation = {rotation}"))
}

#[test]
fn one_bright_texel_lights_a_plane_as_its_solid_angle_says() {
    // The map is bilinear between texels (Mitsuba's envmap): one bright texel is a tent of
    // radiance L, peaked at its centre, one texel wide each way: across φ ∈ φ_c ± 2π/W (∫ = Δφ =
    // 2π/W) and across θ ∈ [θ_{j−1}, θ_{j+1}], θ_j = π j/(H − 1) (the rows on the poles). A
    // Lambertian plane (normal up) of albedo ρ under it reflects
    //   L_o = ρ/π · L · Δφ · ∫ tent(θ) cos θ sin θ dθ, whatever the texel's azimuth (the rotation),
    // the θ integral in closed form over the tent's rising and falling halves.
    let step = PI / (H - 1) as f64;
    let (a, c, b) = (step * (TEXEL.1 - 1) as f64, step * TEXEL.1 as f64, step * (TEXEL.1 + 1) as f64);
    assert!(b < PI / 2.0, "the tent lies above the plane's horizon");
    // ∫ (θ − a) cos θ sin θ dθ and ∫ (b − θ) cos θ sin θ dθ: antiderivatives.
    let rising = |t: f64| -(t - a) * (2.0 * t).cos() / 4.0 + (2.0 * t).sin() / 8.0;
    let falling = |t: f64| -(b - t) * (2.0 * t).cos() / 4.0 - (2.0 * t).sin() / 8.0;
    let tent = (rising(c) - rising(a)) / (c - a) + (falling(b) - falling(c)) / (b - c);
    let expected = 0.5 / PI * BRIGHT as f64 * (2.0 * PI / W as f64) * tent;
    let dir = tempfile::tempdir().unwrap();
    let scene = one_bright_texel(dir.path(), 33.0);
    for (method, spp) in [("path", 16), ("light", 128), ("bpt", 8), ("vcm", 8)] {
        let (mean, error) = common::image_mean_and_error(&scene, method, spp, 8);
        println!("{method}: {mean:.5} ± {error:.5} (closed form {expected:.5})");
        assert!(
            (mean - expected).abs() < 4.0 * error + 1e-4 * expected,
            "{method}: {mean} ± {error} vs {expected}"
        );
    }
}

#[test]
fn deterministic_methods_see_the_map_in_the_directions_they_trace() {
    let dir = tempfile::tempdir().unwrap();
    // The top two of five rows (on the pole and at 45°) one colour, the bottom two another:
    // within 45° of either pole the bilinear map is exactly that colour.
    let (top, bottom) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.5, 0.25, 0.125));
    write_map(&dir.path().join("halves.exr"), 4, 5, |_, j| match j {
        0 | 1 => top,
        2 => Vec3::ONE,
        _ => bottom,
    });
    let up = "position = [0.0, 1.0, 0.0]\nlook_at = [0.0, 2.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 20.0\nresolution = [4, 4]";
    let down = "position = [0.0, 1.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 20.0\nresolution = [4, 4]";
    let mirror = "[materials.mirror]\ntype = \"mirror\"\ncolor = 0.5\n\
        [[objects]]\nshape = \"quad\"\ncorner = [-5.0, 0.0, 5.0]\nu = [10.0, 0.0, 0.0]\nv = [0.0, 0.0, -10.0]\nmaterial = \"mirror\"\n";
    let light = "file = \"halves.exr\"";
    for method in ["raycast", "whitted"] {
        let looking_up = common::render_with(&scene(dir.path(), up, "", light), method, 1, 0);
        assert!(looking_up.pixels.iter().all(|p| *p == top), "{method}: {:?}", looking_up.pixels[0]);
        let sky_below = common::render_with(&scene(dir.path(), down, "", light), method, 1, 0);
        assert!(sky_below.pixels.iter().all(|p| *p == bottom), "{method}: {:?}", sky_below.pixels[0]);
    }
    // Whitted follows the mirror's reflection up into the top half.
    let reflected = common::render_with(&scene(dir.path(), down, mirror, light), "whitted", 1, 0);
    assert!(
        reflected.pixels.iter().all(|p| (*p - 0.5 * top).abs().max_element() < 1e-6),
        "{:?}",
        reflected.pixels[0]
    );
}

#[test]
fn bad_maps_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_map(&d.join("ok.exr"), 4, 2, |_, _| Vec3::ONE);
    std::fs::write(d.join("broken.exr"), [0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, 1, 2, 3]).unwrap();
    let cases = [
        ("file = \"nowhere.exr\"", "nowhere.exr"),
        ("file = \"broken.exr\"", "broken.exr"),
        ("file = \"ok.exr\"\nscale = -1.0", "scale"),
        ("file = \"ok.exr\"\nradiance = 1.0", "radiance"),
        ("radiance = 1.0\nrotation = 30.0", "rotation"),
        ("rotation = 30.0", "`radiance` or a map `file`"),
    ];
    for (light, named) in cases {
        let text = format!(
            "[camera]\nposition = [0.0, 0.0, 1.0]\nlook_at = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n\
             [[lights]]\ntype = \"environment\"\n{light}\n"
        );
        std::fs::write(d.join("scene.toml"), text).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_vitrum"))
            .current_dir(d)
            .args(["render", "scene.toml", "-i", "raycast", "-o", "out.exr"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{light}: {stderr}");
        assert!(stderr.contains("scene.toml:"), "{light}: the line is named: {stderr}");
        assert!(stderr.contains(named), "{light}: `{named}` is named: {stderr}");
        assert!(!d.join("out.exr").exists(), "{light}: nothing is written");
    }
}

#[test]
fn a_map_declaring_too_many_pixels_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (width, height) = common::oversized::DECLARED;
    common::oversized::write_exr_declaring(&d.join("huge.exr"), width, height);
    let text = "[camera]\nposition = [0.0, 0.0, 1.0]\nlook_at = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n\
                [[lights]]\ntype = \"environment\"\nfile = \"huge.exr\"\n";
    std::fs::write(d.join("scene.toml"), text).unwrap();
    let out =
        common::oversized::vitrum_capped(d, &["render", "scene.toml", "-i", "raycast", "-o", "out.exr"]);
    common::oversized::assert_refused_as_too_large(&out, "huge.exr");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("scene.toml:7:"), "the line of `file` is named: {stderr}");
    assert!(!d.join("out.exr").exists(), "nothing is written");
}
