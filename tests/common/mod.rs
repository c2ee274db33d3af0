//! Helpers shared by the integration tests: scene files, and renders of the Monte Carlo methods.
#![allow(dead_code)] // each test crate uses a subset

use glam::Vec3;
use vitrum::image::Image;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions, RenderOutput};
use vitrum::sampler::SamplerKind;
use vitrum::scene::{load_str, Scene};

pub mod browser;
pub mod oversized;
pub mod replicas;
pub mod system;

/// A render of `scene` by `integrator` with the given options.
pub fn render_opts(scene: &Scene, integrator: &str, opts: &RenderOptions) -> RenderOutput {
    render(scene, create(integrator).unwrap().as_ref(), opts, &|_, _| {})
}

/// A render of `scene` by `integrator` with independent sampling.
pub fn render_with(scene: &Scene, integrator: &str, spp: u32, seed: u64) -> Image {
    render_sampled(scene, integrator, spp, seed, SamplerKind::Independent)
}

/// A render with the given sampler (different seeds give independent renders with either), with
/// the method's own settings from the scene (its depth, its merge radius); every sample must be
/// finite.
pub fn render_sampled(scene: &Scene, integrator: &str, spp: u32, seed: u64, sampler: SamplerKind) -> Image {
    let mut opts = RenderOptions::for_method(scene, create(integrator).unwrap().as_ref(), spp);
    opts.seed = seed;
    opts.sampler = sampler;
    let out = render_opts(scene, integrator, &opts);
    assert_eq!(out.non_finite_samples, 0, "{integrator}: non-finite samples");
    assert_eq!(out.spp, spp);
    out.image
}

/// Per-pixel mean and standard error (of the mean) from `k` independent renders (k ≥ 32 keeps
/// the estimated error itself reliable enough for a 5-standard-error bound on every pixel).
pub fn mean_and_error(scene: &Scene, integrator: &str, spp: u32, k: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let renders: Vec<Image> = (0..k).map(|seed| render_with(scene, integrator, spp, 100 + seed)).collect();
    let n = renders[0].pixels.len();
    let mut mean = vec![Vec3::ZERO; n];
    let mut error = vec![Vec3::ZERO; n];
    for i in 0..n {
        let m = renders.iter().map(|r| r.pixels[i]).sum::<Vec3>() / k as f32;
        let var =
            renders.iter().map(|r| (r.pixels[i] - m) * (r.pixels[i] - m)).sum::<Vec3>() / (k - 1) as f32;
        mean[i] = m;
        error[i] = (var / k as f32).powf(0.5);
    }
    (mean, error)
}

/// Asserts that `integrator` renders `scene` (12 pixels wide) as 1 everywhere, as a closed
/// emitter of unit radiance seen from inside does: the image mean within 4 standard errors of 1
/// and no 3×3 block more than 4.5 standard errors from 1 (`what` names the case in messages).
pub fn assert_uniformly_one(scene: &Scene, integrator: &str, what: &str) {
    let (mean, error) = mean_and_error(scene, integrator, 64, 6);
    let n = mean.len() as f32;
    let overall = mean.iter().map(|m| m.element_sum()).sum::<f32>() / (3.0 * n);
    let overall_error = error.iter().map(|e| e.length_squared()).sum::<f32>().sqrt() / (3.0 * n);
    eprintln!("{what}: mean {overall} ± {overall_error}");
    assert!(
        (overall - 1.0).abs() <= 4.0 * overall_error.max(1e-6),
        "{what}: mean {overall} ± {overall_error}, expected 1"
    );
    let ones = vec![Vec3::ONE; mean.len()];
    let zeros = vec![Vec3::ZERO; mean.len()];
    let z = largest_block_z(&mean, &error, &ones, &zeros, 12, 3);
    eprintln!("{what}: worst 3×3 block {z:.2} standard errors from 1");
    assert!(z <= 4.5, "{what}: a block is {z} standard errors from 1");
}

/// The largest difference, in standard errors of the difference, between the block means of two
/// per-pixel means (`a` with errors `sa`, `b` with `sb`, images `width` pixels wide) over square
/// blocks of `block` × `block` pixels, channel by channel. Pixels are independent renders' means,
/// so a block's variance is the sum of its pixels' squared errors.
pub fn largest_block_z(a: &[Vec3], sa: &[Vec3], b: &[Vec3], sb: &[Vec3], width: usize, block: usize) -> f32 {
    let height = a.len() / width;
    let mut worst = 0.0f32;
    for by in (0..height).step_by(block) {
        for bx in (0..width).step_by(block) {
            let (mut da, mut db, mut va, mut vb) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            for y in by..(by + block).min(height) {
                for x in bx..(bx + block).min(width) {
                    let i = y * width + x;
                    (da, db) = (da + a[i], db + b[i]);
                    (va, vb) = (va + sa[i] * sa[i], vb + sb[i] * sb[i]);
                }
            }
            let z = (da - db).abs() / (va + vb).powf(0.5).max(Vec3::splat(1e-9));
            worst = worst.max(z.max_element());
        }
    }
    worst
}

/// The mean over all pixels and its standard error, from `k` independent renders: each render's
/// image mean is one sample, so pixels that share random numbers (the photons of an iteration,
/// a light path's splats) do not make the error look smaller than it is.
pub fn image_mean_and_error(scene: &Scene, integrator: &str, spp: u32, k: u64) -> (f64, f64) {
    let means: Vec<f64> = (0..k)
        .map(|seed| {
            let image = render_with(scene, integrator, spp, 100 + seed);
            let sum: f64 = image.pixels.iter().map(|p| p.element_sum() as f64).sum();
            sum / (3 * image.pixels.len()) as f64
        })
        .collect();
    let mean = means.iter().sum::<f64>() / k as f64;
    let var = means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / (k - 1) as f64;
    (mean, (var / k as f64).sqrt())
}

/// The inside of a closed unit sphere of diffuse albedo 0.5, seen by a camera at its centre,
/// with `inside` added to the scene (an emission line for the material, or a light). The part of
/// a sphere within a distance r of one of its points has the area π r² exactly (Archimedes), so
/// a uniform field carries no kernel bias: `ppm` (every merge weighted 1) merges within 0.3, which
/// the 144 photons of an iteration need. `bpm` and `vcm` weight merges by the densities at the
/// camera vertex and at the photon, which differ within the kernel (their weights sum to one only
/// as r → 0; measured over 32 renders of 64 iterations: `vcm` 1.0027 ± 0.0011 at 0.3, 1.0001 ±
/// 0.0003 at 0.1): they merge within 0.1.
pub fn closed_sphere(integrator: &str, inside: &str) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.1, 0.2, 0.3]
look_at = [1.0, 0.0, 0.0]
fov = 120.0
resolution = [12, 12]
[render]
integrator = "{integrator}"
[render.ppm]
radius = 0.3
[render.bpm]
radius = 0.1
[render.vcm]
radius = 0.1
[materials.wall]
type = "diffuse"
color = 0.5
{inside}
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "wall"
"#
    );
    load_str(&text, "closed sphere", None).unwrap()
}

/// A diffuse quad emitter of radiance (2, 1, 0.5) seen through a flat slab of index `ior` in air,
/// absorbing `absorption` per unit length: the slab's faces at z = ±0.5 (far larger than the
/// view, normals pointing out of it), the emitter at z = −3 facing +z, the camera at z = 5
/// looking down −z. At normal incidence a clear slab transmits L·(1−R)/(1+R).
pub fn glass_slab(ior: f32, absorption: [f32; 3]) -> String {
    let [r, g, b] = absorption;
    format!(
        r#"
[camera]
position = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 10.0
resolution = [9, 9]

[render.whitted]
max_depth = 40

[materials.glass]
type = "dielectric"
ior = {ior:?}
absorption = [{r:?}, {g:?}, {b:?}]
phong = {{ specular = 0.0 }}

[[objects]]
shape = "quad"
corner = [-50.0, -50.0, 0.5]
u = [100.0, 0.0, 0.0]
v = [0.0, 100.0, 0.0]
material = "glass"

[[objects]]
shape = "quad"
corner = [-50.0, -50.0, -0.5]
u = [0.0, 100.0, 0.0]
v = [100.0, 0.0, 0.0]
material = "glass"

[[lights]]
type = "quad"
corner = [-50.0, -50.0, -3.0]
u = [100.0, 0.0, 0.0]
v = [0.0, 100.0, 0.0]
radiance = [2.0, 1.0, 0.5]
"#
    )
}

/// `scenes/hollow-spheres.toml` (two hollow glass spheres in the Cornell box) with its point
/// light replaced by a quad light of the same power (6 W/sr ≈ π·0.36·L / π, so L = 6/0.36): the
/// variant on which `path`, and the methods built on its samples, see the caustics of the shells
/// (a point light's are invisible to them: no shadow ray bends through glass, and no BSDF sample
/// hits a point).
pub fn hollow_spheres_with_a_quad_light() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hollow-spheres.toml");
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "type = \"point\"\nposition = [0.0, 1.9, 0.0]\nintensity = 6.0",
        "type = \"quad\"\ncorner = [-0.3, 1.98, -0.3]\nu = [0.6, 0.0, 0.0]\nv = [0.0, 0.0, 0.6]\nradiance = 16.67",
    );
    assert!(text.contains("type = \"quad\""), "the point light of hollow-spheres.toml moved");
    load_str(&text, "hollow-quad.toml", None).unwrap()
}

/// The `.toml` files directly in `dir`, sorted.
pub fn toml_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

/// The names in `dir`, sorted.
pub fn entries(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A glass sphere of index 1.5 and GGX `roughness` in a white environment of radiance 1, seen
/// at `size`×`size`: lossless glass shows 1 everywhere (the white furnace). The scene's method is
/// `path`, so that renders from its settings trace to 256 bounces (as the bidirectional methods do);
/// `ppm` and `bpm` merge within 0.1 (the sphere's field is the same at every point, so only the
/// tilt of the normal within the kernel biases a merge; 256 photons per iteration need a wide one).
pub fn glass_furnace(roughness: f32, size: u32) -> Scene {
    glass_furnace_of("1.5", roughness, size)
}

/// [`glass_furnace`] with the glass's `ior` written as this TOML value (`"1.5"`, or a dispersive
/// `"\"sf11\""`).
pub fn glass_furnace_of(ior: &str, roughness: f32, size: u32) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 30.0
resolution = [{size}, {size}]
[render]
integrator = "path"
[render.ppm]
radius = 0.1
[render.bpm]
radius = 0.1
[materials.glass]
type = "dielectric"
ior = {ior}
roughness = {roughness}
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "glass"
[[lights]]
type = "environment"
radiance = 1.0
"#
    );
    load_str(&text, "furnace", None).unwrap()
}

/// A render with independent sampling and its per-pixel variance.
pub fn render_with_variance(scene: &Scene, method: &str, size: u32, spp: u32, seed: u64) -> (Image, Image) {
    let integrator = create(method).unwrap();
    let mut opts = RenderOptions::for_method(scene, integrator.as_ref(), spp);
    opts.resolution = Some((size, size));
    opts.sampler = SamplerKind::Independent;
    opts.seed = seed;
    let out = render_opts(scene, method, &opts);
    assert_eq!(out.non_finite_samples, 0, "{method}: non-finite samples");
    (out.image, out.variance.expect("two samples or more keep a variance"))
}

/// χ² of the 8×8 block means of `a` against `b` in their own variances, and the block count.
pub fn block_chi2(a: &(Image, Image), b: &(Image, Image)) -> (f64, usize) {
    let (w, h) = (a.0.width, a.0.height);
    let mut chi2 = 0.0;
    let mut blocks = 0;
    for by in (0..h).step_by(8) {
        for bx in (0..w).step_by(8) {
            let (mut ma, mut mb, mut va, mut vb) = (0.0f64, 0.0, 0.0, 0.0);
            for y in by..by + 8 {
                for x in bx..bx + 8 {
                    let i = y * w + x;
                    ma += a.0.pixels[i].element_sum() as f64 / 3.0;
                    mb += b.0.pixels[i].element_sum() as f64 / 3.0;
                    // Channels may be fully correlated: the variance of their mean is at most
                    // the square of the mean of their standard errors.
                    va += (a.1.pixels[i].max(Vec3::ZERO).powf(0.5).element_sum() as f64 / 3.0).powi(2);
                    vb += (b.1.pixels[i].max(Vec3::ZERO).powf(0.5).element_sum() as f64 / 3.0).powi(2);
                }
            }
            if va + vb > 0.0 {
                chi2 += (ma - mb).powi(2) / (va + vb);
                blocks += 1;
            }
        }
    }
    (chi2, blocks)
}

/// The closed bright room of `tests/data/bright-room.toml` (its comment says what it is): 96²
/// pixels, at most 9216 light paths per iteration.
pub const BRIGHT_ROOM: &str = include_str!("../data/bright-room.toml");

/// The settings table of `method` checked end to end on `scenes/cornell-glass.toml`: every
/// `(line, field)` of `bad`, appended under `[render.METHOD]`, exits with code 2 naming the
/// scene's file, the line and `render.METHOD.FIELD`, without a panic; the table `good` (whole,
/// its header included) renders; returns `vitrum info --json` of the scene with `good`.
pub fn check_method_settings(method: &str, bad: &[(&str, &str)], good: &str) -> serde_json::Value {
    for (line, field) in bad {
        let (code, err, last) = render_cornell_with_table(method, &format!("[render.{method}]\n{line}"));
        assert_eq!(code, Some(2), "{line}: {err}");
        assert!(!err.contains("panicked"), "{line}: {err}");
        assert!(err.contains(&format!("scene.toml:{last}:")), "{line}: no line {last} in {err}");
        assert!(err.contains(&format!("render.{method}.{field}")), "{line}: {err}");
    }
    let (code, err, _) = render_cornell_with_table(method, good);
    assert_eq!(code, Some(0), "good settings: {err}");
    let dir = tempfile::tempdir().unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = dir.path().join("scene.toml");
    let text = std::fs::read_to_string(root.join("scenes/cornell-glass.toml")).unwrap() + "\n" + good;
    std::fs::write(&scene, text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vitrum"))
        .arg("info")
        .arg(&scene)
        .arg("--json")
        .output()
        .unwrap();
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `vitrum render -i METHOD` (1 spp, 8×8) of `scenes/cornell-glass.toml` with `table` appended:
/// its exit code, its stderr and the number of the text's last line (where a bad value of the
/// appended table is reported).
pub fn render_cornell_with_table(method: &str, table: &str) -> (Option<i32>, String, usize) {
    let dir = tempfile::tempdir().unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("scenes/cornell-glass.toml")).unwrap() + "\n" + table;
    let line = text.lines().count();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vitrum"))
        .arg("render")
        .arg(&scene)
        .args(["-i", method, "--spp", "1", "--resolution", "8x8", "--quiet", "-o"])
        .arg(dir.path().join("out.exr"))
        .output()
        .unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned(), line)
}
