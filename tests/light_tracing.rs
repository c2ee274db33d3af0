//! `light` (light tracing): determinism at any thread count, the pixel-area normalisation of its
//! splats against `path`, lights seen directly, what it cannot see (specular surfaces seen
//! directly), the analytic closed sphere, the diffuse Cornell box, caustics (from point lights
//! too), the thin lens, motion blur, spectral mode (wavelengths split at dispersive glass at any
//! thread count) and time budgets.
//!
//! Statistical checks estimate each render's per-pixel variance from two independent seeds,
//! `s² ≈ (a − b)² / 2`, and the variance of a block mean as the sum of its pixels' variances
//! over the block size squared (pixels of one render are independent for `path`; for `light` one
//! path splats each vertex into one pixel, so pixels are at most weakly correlated). The tolerance
//! is stated in standard errors of the difference between the two methods.

mod common;

use common::{closed_sphere, mean_and_error, render_opts, render_sampled, render_with};
use glam::Vec3;
use vitrum::image::Image;
use vitrum::render::RenderOptions;
use vitrum::sampler::SamplerKind;
use vitrum::scene::{load_str, Scene};

/// The mean of two renders of a method (seeds `seed`, `seed + 1`) and, per pixel, the variance
/// of that mean.
struct Estimate {
    mean: Vec<Vec3>,
    variance: Vec<Vec3>,
    width: usize,
}

fn estimate(scene: &Scene, integrator: &str, spp: u32, seed: u64) -> Estimate {
    estimate_sampled(scene, integrator, spp, seed, SamplerKind::Independent)
}

fn estimate_sampled(scene: &Scene, integrator: &str, spp: u32, seed: u64, sampler: SamplerKind) -> Estimate {
    let a = render_sampled(scene, integrator, spp, seed, sampler);
    let b = render_sampled(scene, integrator, spp, seed + 1, sampler);
    Estimate::from_pair(&a, &b)
}

impl Estimate {
    /// The estimate from two independent renders `a` and `b`.
    fn from_pair(a: &Image, b: &Image) -> Estimate {
        let mean = a.pixels.iter().zip(&b.pixels).map(|(x, y)| 0.5 * (*x + *y)).collect();
        // s² = (a − b)²/2 per render, so the mean of two has variance (a − b)²/4.
        let variance = a.pixels.iter().zip(&b.pixels).map(|(x, y)| 0.25 * (*x - *y) * (*x - *y)).collect();
        Estimate { mean, variance, width: a.width }
    }

    /// Mean and variance of the mean over the pixels `pixels`.
    fn over(&self, pixels: &[usize]) -> (Vec3, Vec3) {
        let n = pixels.len() as f32;
        let mean = pixels.iter().map(|&i| self.mean[i]).sum::<Vec3>() / n;
        let var = pixels.iter().map(|&i| self.variance[i]).sum::<Vec3>() / (n * n);
        (mean, var)
    }

    /// The pixel indices of the `b`×`b` blocks, row by row.
    fn blocks(&self, b: usize) -> Vec<Vec<usize>> {
        let height = self.mean.len() / self.width;
        let mut out = Vec::new();
        for by in 0..height / b {
            for bx in 0..self.width / b {
                out.push(
                    (0..b * b).map(|k| (by * b + k / b) * self.width + bx * b + k % b).collect::<Vec<_>>(),
                );
            }
        }
        out
    }
}

/// Every `block`×`block` block of `light` agrees with `path` within `tolerance` standard errors
/// of their difference, per channel; returns the largest |z| and the RMS z (printed by callers).
fn assert_blocks_agree(
    light: &Estimate,
    path: &Estimate,
    block: usize,
    tolerance: f32,
    what: &str,
) -> (f32, f32) {
    let (mut worst, mut sum_sq, mut count) = (0.0f32, 0.0f32, 0);
    for pixels in light.blocks(block) {
        let (ml, vl) = light.over(&pixels);
        let (mp, vp) = path.over(&pixels);
        for c in 0..3 {
            let se = (vl[c] + vp[c]).sqrt();
            if se == 0.0 {
                assert_eq!(ml[c], mp[c], "{what}: noise-free block differs");
                continue;
            }
            let z = (ml[c] - mp[c]) / se;
            assert!(
                z.abs() <= tolerance,
                "{what}: block at pixel {} channel {c}: light {} vs path {} (z = {z})",
                pixels[0],
                ml[c],
                mp[c]
            );
            worst = worst.max(z.abs());
            sum_sq += z * z;
            count += 1;
        }
    }
    let rms = (sum_sq / count.max(1) as f32).sqrt();
    eprintln!("{what}: {count} block-channels, max |z| = {worst:.2}, RMS z = {rms:.2}");
    (worst, rms)
}

/// A 2×2 diffuse quad facing the camera, lit by a point light.
const LIT_QUAD: &str = r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [32, 32]
[render]
integrator = "path"
[materials.white]
type = "diffuse"
color = [0.8, 0.6, 0.4]
[[objects]]
shape = "quad"
corner = [-1.0, -1.0, 0.0]
u = [2.0, 0.0, 0.0]
v = [0.0, 2.0, 0.0]
material = "white"
[[lights]]
type = "point"
position = [0.4, 0.6, 1.2]
intensity = 2.0
"#;

#[test]
fn splatting_is_bit_identical_at_any_thread_count() {
    // The embedded Cornell box with glass and a point light: refraction, reflection, caustics.
    let scene = vitrum::scene::load_default();
    let mut opts = RenderOptions::from_scene(&scene, 16);
    opts.resolution = Some((64, 64));
    opts.seed = 11;
    // 16 × 64 × 64 = 65,536 paths: sixteen chunks, so two threads really interleave them.
    let run = |threads: usize, opts: &RenderOptions| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render_opts(&scene, "light", opts))
    };
    let one = run(1, &opts);
    let two = run(2, &opts);
    let bits = |img: &Image| img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&one.image), bits(&two.image), "images differ between 1 and 2 threads");
    assert_eq!(one.rays, two.rays, "ray counts differ between 1 and 2 threads");
    assert!(one.image.pixels.iter().any(|p| p.max_element() > 0.0), "black image");
    assert_eq!(one.rays.primary, 16 * 64 * 64, "one emitted ray per light path");
    // The check can fail: another seed gives another image.
    opts.seed = 12;
    assert_ne!(bits(&run(2, &opts).image), bits(&one.image));
}

#[test]
fn split_wavelengths_are_bit_identical_at_any_thread_count() {
    // Spectral `glass-of-water`: light paths split at its dispersive glass and water into one
    // branch per wavelength (run after the path in flight, replaying its numbers), all within
    // the path's chunk, so the image and the ray counts do not depend on the thread count.
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass-of-water.toml");
    let scene = vitrum::scene::load(&file).unwrap();
    let integrator = vitrum::integrators::create("light").unwrap();
    let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 8);
    opts.resolution = Some((64, 64));
    opts.seed = 5;
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render_opts(&scene, "light", &opts))
    };
    let (one, two) = (run(1), run(2));
    assert!(one.spectral, "the scene's named indices turn spectral mode on");
    let bits = |img: &Image| img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&one.image), bits(&two.image), "images differ between 1 and 2 threads");
    assert_eq!(one.rays, two.rays, "ray counts differ between 1 and 2 threads");
    // The paths reached the glass and the camera saw their light.
    assert!(one.rays.refracted > 0 && one.image.pixels.iter().any(|p| p.max_element() > 0.0));
}

#[test]
fn lit_quad_agrees_with_path_block_by_block() {
    // The splat normalisation (importance 1/(A cos⁴θ), the camera's cos θ, 1/(spp·A)) against
    // the camera pass's box-filtered pixel mean.
    let scene = load_str(LIT_QUAD, "lit quad", None).unwrap();
    let light = estimate(&scene, "light", 256, 1);
    let path = estimate(&scene, "path", 16, 1);
    let all: Vec<usize> = (0..light.mean.len()).collect();
    let ((ml, vl), (mp, vp)) = (light.over(&all), path.over(&all));
    eprintln!("lit quad: image mean light {ml} ± {} vs path {mp} ± {}", vl.powf(0.5), vp.powf(0.5));
    assert!(((ml - mp).abs() - 4.0 * (vl + vp).powf(0.5)).max_element() <= 0.0, "image means differ");
    assert_blocks_agree(&light, &path, 8, 4.0, "lit quad");
}

#[test]
fn an_area_light_seen_directly_renders_its_radiance() {
    // A one-sided unit quad of radiance L facing the camera: the fully covered pixels average
    // L, and nothing lands outside its projection.
    let text = r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [32, 32]
[render]
integrator = "path"
[[lights]]
type = "quad"
corner = [-0.5, -0.4, 0.0]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.9, 0.0]
radiance = [2.5, 1.5, 0.5]
"#;
    let scene = load_str(text, "area light", None).unwrap();
    let radiance = Vec3::new(2.5, 1.5, 0.5);
    // `path` sees the emitter exactly: L where every sample hits it, 0 where none does.
    let path = render_with(&scene, "path", 16, 1);
    let covered: Vec<usize> = (0..path.pixels.len()).filter(|&i| path.pixels[i] == radiance).collect();
    let outside: Vec<usize> = (0..path.pixels.len()).filter(|&i| path.pixels[i] == Vec3::ZERO).collect();
    assert!(covered.len() > 100, "{} covered pixels", covered.len());
    let light = estimate(&scene, "light", 64, 1);
    let (mean, var) = light.over(&covered);
    let se = var.powf(0.5);
    eprintln!("area light: {} covered pixels, light mean {mean} ± {se} vs L = {radiance}", covered.len());
    assert!(((mean - radiance).abs() - 4.0 * se).max_element() <= 0.0, "{mean} ± {se} vs {radiance}");
    assert!(outside.iter().all(|&i| light.mean[i] == Vec3::ZERO), "splats outside the light");
}

#[test]
fn a_mirror_seen_directly_is_black() {
    // A mirror facing the camera in front of a lit diffuse backdrop, with a lit wall behind the
    // camera that the mirror shows to `path`. Light tracing cannot connect a mirror vertex to a
    // pinhole, and the backdrop behind the mirror is hidden: the mirror is exactly black.
    let text = r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [32, 32]
[render]
integrator = "path"
[materials.white]
type = "diffuse"
color = 0.8
[materials.mirror]
type = "mirror"
color = 0.9
[[objects]]
name = "mirror"
shape = "quad"
corner = [-0.5, -0.5, 0.0]
u = [1.0, 0.0, 0.0]
v = [0.0, 1.0, 0.0]
material = "mirror"
[[objects]]
name = "backdrop"
shape = "quad"
corner = [-3.0, -3.0, -1.0]
u = [6.0, 0.0, 0.0]
v = [0.0, 6.0, 0.0]
material = "white"
[[objects]]
name = "wall behind the camera"
shape = "quad"
corner = [-5.0, -5.0, 6.0]
u = [10.0, 0.0, 0.0]
v = [0.0, 10.0, 0.0]
material = "white"
[[lights]]
type = "point"
position = [0.0, 1.2, 2.0]
intensity = 4.0
"#;
    let scene = load_str(text, "mirror", None).unwrap();
    let light = render_with(&scene, "light", 64, 1);
    let path = render_with(&scene, "path", 16, 1);
    // Pixels whose whole area sees the mirror: the mirror spans ±0.5 at distance 4.
    let camera = &scene.camera;
    let lo = camera.project(Vec3::new(-0.5, 0.5, 0.0)).unwrap();
    let hi = camera.project(Vec3::new(0.5, -0.5, 0.0)).unwrap();
    let (x0, y0, x1, y1) = (lo.x.ceil() as usize, lo.y.ceil() as usize, hi.x as usize, hi.y as usize);
    assert!(x1 > x0 + 4 && y1 > y0 + 4);
    let mirror: Vec<usize> = (y0..y1).flat_map(|y| (x0..x1).map(move |x| y * 32 + x)).collect();
    let backdrop: Vec<usize> =
        (0..32 * 32).filter(|i| (i % 32 < x0 - 1 || i % 32 > x1) && i / 32 < 4).collect();
    let mean = |img: &Image, px: &[usize]| px.iter().map(|&i| img.pixels[i]).sum::<Vec3>() / px.len() as f32;
    eprintln!(
        "mirror: light {} / path {} on the mirror; light {} / path {} on the backdrop",
        mean(&light, &mirror),
        mean(&path, &mirror),
        mean(&light, &backdrop),
        mean(&path, &backdrop)
    );
    assert!(mirror.iter().all(|&i| light.pixels[i] == Vec3::ZERO), "light tracing sees the mirror");
    assert!(mean(&path, &mirror).min_element() > 0.05, "path sees the lit wall in the mirror");
    // The diffuse backdrop beside it is seen by both.
    assert!(mean(&light, &backdrop).min_element() > 0.5 * mean(&path, &backdrop).min_element());
}

/// The image mean is `expected` within 3 standard errors, and every 3×3 block within 4 of its
/// own (the standard error of one pixel estimated from `k` renders is itself too noisy for a
/// per-pixel bound over the whole image).
fn assert_uniform(scene: &Scene, spp: u32, k: u64, expected: f32, what: &str) {
    let (mean, error) = mean_and_error(scene, "light", spp, k);
    let n = mean.len() as f32;
    let overall = mean.iter().map(|m| m.element_sum()).sum::<f32>() / (3.0 * n);
    let overall_error = (error.iter().map(|e| e.length_squared()).sum::<f32>()).sqrt() / (3.0 * n);
    eprintln!("{what}: mean {overall} ± {overall_error}");
    assert!((overall - expected).abs() <= 3.0 * overall_error, "{what}: mean {overall} vs {expected}");
    let width = scene.camera.width as usize;
    let variance: Vec<Vec3> = error.iter().map(|e| *e * *e).collect();
    let blocks = Estimate { mean, variance, width };
    let mut worst = 0.0f32;
    for pixels in blocks.blocks(3) {
        let (m, v) = blocks.over(&pixels);
        let z = ((m - Vec3::splat(expected)).abs() / v.powf(0.5)).max_element();
        worst = worst.max(z);
        assert!(z <= 4.0, "{what}: block at pixel {} = {m}, {z} standard errors off", pixels[0]);
    }
    eprintln!("{what}: worst 3×3 block {worst:.2} standard errors off");
}

#[test]
fn closed_diffuse_sphere_with_emission_is_uniformly_one() {
    // L = Le + ρ·L  ⇒  L = 0.5 / (1 − 0.5) = 1 everywhere inside.
    assert_uniform(&closed_sphere("light", "emission = 0.5"), 64, 8, 1.0, "emitting sphere");
}

#[test]
fn closed_diffuse_sphere_around_a_point_light_is_uniformly_one() {
    // Intensity π at the centre of a unit sphere: E = π, direct L = ρ·E/π = 0.5, and every
    // bounce adds the same fraction: L = 0.5 / (1 − 0.5) = 1.
    let scene = closed_sphere(
        "light",
        "[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 0.0]\nintensity = 3.14159265",
    );
    assert_uniform(&scene, 64, 8, 1.0, "point light in a sphere");
}

#[test]
fn cornell_box_without_glass_agrees_with_path() {
    // soft-shadows with its glass bodies made white: diffuse only, an area light, depth 5.
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/soft-shadows.toml")).unwrap();
    let no_glass = text.replace("material = \"glass\"", "material = \"white\"");
    let mut scene = load_str(&no_glass, "diffuse box", None).unwrap();
    scene.camera = scene.camera.clone().with_resolution(32, 32);
    // The stratified sampler this time (the scene's default): groups of 16 light paths are
    // stratified together, which must not bias the image.
    let light = estimate_sampled(&scene, "light", 256, 1, SamplerKind::Stratified);
    let path = estimate_sampled(&scene, "path", 256, 1, SamplerKind::Stratified);
    assert_blocks_agree(&light, &path, 8, 4.0, "diffuse Cornell box");
}

/// A floor under a glass sphere of radius 0.3, lit from 2 m above the floor (the sphere images
/// the light about 0.2 m above the floor), seen from between them. The light is close and the
/// view wide so that most light paths land in view.
fn caustic(light: &str) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.62, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = 90.0
resolution = [33, 33]
[materials.floor]
type = "diffuse"
color = 0.8
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
shape = "quad"
corner = [-1.0, 0.0, -1.0]
u = [0.0, 0.0, 2.0]
v = [2.0, 0.0, 0.0]
material = "floor"
[[objects]]
shape = "sphere"
center = [0.0, 1.0, 0.0]
radius = 0.3
material = "glass"
{light}
"#
    );
    load_str(&text, "caustic", None).unwrap()
}

/// Mean of the central 3×3 pixels and of the four corners (lit floor outside the shadow).
fn centre_and_corner(img: &Image) -> (f32, f32) {
    let (c, e) = (img.width / 2, img.width - 1);
    let mut sum = 0.0;
    for y in c - 1..=c + 1 {
        for x in c - 1..=c + 1 {
            sum += img.get(x, y).y;
        }
    }
    let corners = img.get(0, 0).y + img.get(e, 0).y + img.get(0, e).y + img.get(e, e).y;
    (sum / 9.0, corners / 4.0)
}

#[test]
fn glass_sphere_focuses_caustics_from_area_and_point_lights() {
    let area = caustic(
        "[[lights]]\ntype = \"quad\"\ncorner = [-0.1, 2.0, -0.1]\nu = [0.2, 0.0, 0.0]\nv = [0.0, 0.0, 0.2]\nradiance = 100.0",
    );
    let (centre, corner) = centre_and_corner(&render_with(&area, "light", 256, 1));
    eprintln!("caustic (area light): light centre {centre} vs lit floor {corner}");
    assert!(centre > 1.5 * corner, "light: {centre} vs lit floor {corner}");
    // A point light's caustic is out of reach of `path` (next-event estimation cannot pass
    // through glass, BSDF sampling cannot hit a point) but not of light tracing.
    let point = caustic("[[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\nintensity = 4.0");
    let (centre, corner) = centre_and_corner(&render_with(&point, "light", 256, 1));
    let (path_centre, path_corner) = centre_and_corner(&render_with(&point, "path", 16, 1));
    eprintln!(
        "caustic (point light): light centre {centre} vs lit floor {corner}; path {path_centre} vs {path_corner}"
    );
    assert!(centre > 1.5 * corner, "light: {centre} vs lit floor {corner}");
    assert!(path_centre < 0.1 * path_corner, "path: {path_centre} vs lit floor {path_corner}");
}

#[test]
fn a_time_budget_renders_whole_passes() {
    let scene = load_str(LIT_QUAD, "lit quad", None).unwrap();
    let mut opts = RenderOptions::from_scene(&scene, 1);
    opts.budget = vitrum::render::Budget::Time(std::time::Duration::from_millis(50));
    let out = render_opts(&scene, "light", &opts);
    assert!(out.spp >= 1);
    assert_eq!(out.rays.primary, out.spp as u64 * 32 * 32);
    assert!(out.image.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// A scene file of `scenes/` with its glass made white diffuse, at 32×32.
fn without_glass(name: &str) -> Scene {
    let path = format!("{}/scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(path).unwrap().replace("material = \"glass\"", "material = \"white\"");
    let mut scene = load_str(&text, name, None).unwrap();
    scene.camera = scene.camera.clone().with_resolution(32, 32);
    scene
}

#[test]
fn thin_lens_and_motion_blur_agree_with_path() {
    // Depth of field: connections to a sampled lens point land where the camera pass's ray from
    // that point through the focal plane starts. Motion blur: one shutter time per light path.
    for name in ["depth-of-field", "motion-blur"] {
        let scene = without_glass(name);
        let light = estimate(&scene, "light", 256, 1);
        let path = estimate(&scene, "path", 256, 1);
        assert_blocks_agree(&light, &path, 8, 4.0, name);
    }
}

#[test]
fn spectral_light_tracing_agrees_with_rgb_path() {
    // Three wavelengths per light path (src/spectrum.rs): a scene without dispersion rendered
    // spectrally estimates the same image as in RGB.
    let scene = load_str(LIT_QUAD, "lit quad", None).unwrap();
    let spectral = |seed| {
        let mut opts = RenderOptions::from_scene(&scene, 256);
        opts.seed = seed;
        opts.sampler = SamplerKind::Independent;
        opts.spectral = vitrum::scene::SpectralMode::On;
        let out = render_opts(&scene, "light", &opts);
        assert!(out.spectral);
        out.image
    };
    let light = Estimate::from_pair(&spectral(1), &spectral(2));
    let path = estimate(&scene, "path", 16, 1);
    assert_blocks_agree(&light, &path, 8, 4.0, "spectral lit quad");
}
