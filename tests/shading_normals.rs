//! Shading normals (OBJ `vn`): a smooth-shaded triangulated glass sphere renders like the
//! analytic sphere, the closer the finer it is tessellated, and a smooth-shaded glass mesh in a
//! white furnace stays white.

mod common;

use std::f64::consts::PI;
use std::fmt::Write;
use std::path::Path;
use vitrum::geometry::Ray;
use vitrum::image::Image;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions};
use vitrum::sampler::SamplerKind;
use vitrum::scene::{load_str, Scene};

/// A UV sphere of radius 1 at the origin with `rings` × 2·`rings` quads (triangles at the
/// poles), wound outwards, with vn = the normalised position (exactly the analytic normal).
fn smooth_sphere_obj(rings: usize) -> String {
    let segments = 2 * rings;
    let mut s = String::new();
    writeln!(s, "v 0 1 0\nvn 0 1 0").unwrap();
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            let p = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
            writeln!(s, "v {} {} {}\nvn {} {} {}", p[0], p[1], p[2], p[0], p[1], p[2]).unwrap();
        }
    }
    writeln!(s, "v 0 -1 0\nvn 0 -1 0").unwrap();
    let south = 2 + (rings - 1) * segments;
    let ring = |i: usize, j: usize| 2 + (i - 1) * segments + j % segments;
    let mut face = |a: usize, b: usize, c: usize| writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}").unwrap();
    for j in 0..segments {
        face(1, ring(1, j + 1), ring(1, j));
        face(south, ring(rings - 1, j), ring(rings - 1, j + 1));
        for i in 1..rings - 1 {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            face(a, b, c);
            face(b, d, c);
        }
    }
    s
}

/// A glass ball (`ball`: the object's shape lines) before a checkered wall, under a white sky.
fn glass_scene(ball: &str, dir: Option<&Path>, size: u32) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.3, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 32.0
resolution = [{size}, {size}]
[render]
integrator = "path"
[materials.glass]
type = "dielectric"
ior = 1.5
[materials.wall]
type = "diffuse"
texture = {{ type = "checker", color1 = 0.9, color2 = 0.05, size = 0.25 }}
[[objects]]
material = "glass"
{ball}
[[objects]]
material = "wall"
shape = "quad"
corner = [-4.0, -4.0, -2.5]
u = [8.0, 0.0, 0.0]
v = [0.0, 8.0, 0.0]
[[lights]]
type = "environment"
radiance = 1.0
"#
    );
    load_str(&text, "glass ball", dir).unwrap_or_else(|e| panic!("{e}"))
}

/// A render by `path` with independent samples: the image and its per-pixel variance.
fn render_path(scene: &Scene, spp: u32, seed: u64) -> (Image, Image) {
    let method = create("path").unwrap();
    let mut opts = RenderOptions::for_method(scene, method.as_ref(), spp);
    opts.seed = seed;
    opts.sampler = SamplerKind::Independent;
    let out = render(scene, method.as_ref(), &opts, &|_, _| {});
    assert_eq!(out.non_finite_samples, 0);
    (out.image, out.variance.expect("a Monte Carlo render has a variance"))
}

/// Per block of `b`×`b` pixels: the mean over its pixels and channels and that mean's variance.
fn blocks(image: &Image, variance: &Image, b: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for by in 0..image.height / b {
        for bx in 0..image.width / b {
            let (mut sum, mut var) = (0.0, 0.0);
            for y in by * b..(by + 1) * b {
                for x in bx * b..(bx + 1) * b {
                    let i = y * image.width + x;
                    sum += image.pixels[i].element_sum() as f64;
                    // Channels are correlated (a grey scene): bound the variance of their mean
                    // by that of one channel, the mean of the three.
                    var += variance.pixels[i].element_sum() as f64 / 3.0;
                }
            }
            let n = (b * b) as f64;
            out.push((sum / (3.0 * n), var / (n * n)));
        }
    }
    out
}

#[test]
fn smooth_triangulated_glass_sphere_converges_to_the_analytic_one() {
    // 32×32 pixels in 64 blocks of 4×4, 256 samples per pixel; the analytic sphere and each
    // tessellation rendered with different seeds, so that the two estimates are independent and
    // a block's difference has the variance of the one plus that of the other. Measured: the
    // mean of z² over blocks (z = difference / its standard error), about 1 for agreement.
    let (size, spp) = (32, 256);
    let analytic = glass_scene("shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0", None, size);
    let (a_image, a_var) = render_path(&analytic, spp, 1);
    let reference = blocks(&a_image, &a_var, 4);
    let dir = tempfile::tempdir().unwrap();
    let mut chi2 = Vec::new();
    for (k, rings) in [4usize, 12, 48].into_iter().enumerate() {
        let file = format!("sphere-{rings}.obj");
        std::fs::write(dir.path().join(&file), smooth_sphere_obj(rings)).unwrap();
        let mesh = glass_scene(&format!("shape = \"mesh\"\nfile = \"{file}\""), Some(dir.path()), size);
        let (image, var) = render_path(&mesh, spp, 2 + k as u64);
        let z: Vec<f64> = blocks(&image, &var, 4)
            .iter()
            .zip(&reference)
            .map(|(m, a)| (m.0 - a.0) / (m.1 + a.1).sqrt())
            .collect();
        let mean_z2 = z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64;
        let max_z = z.iter().fold(0f64, |m, z| m.max(z.abs()));
        let mad = image
            .pixels
            .iter()
            .zip(&a_image.pixels)
            .map(|(m, a)| (*m - *a).abs().element_sum() as f64)
            .sum::<f64>()
            / (3 * image.pixels.len()) as f64;
        println!(
            "{rings} rings ({} triangles): mean z² over 64 blocks {mean_z2:.2}, largest |z| {max_z:.1}, \
             mean absolute pixel difference {mad:.4}",
            4 * rings * rings - 4 * rings
        );
        chi2.push((mean_z2, max_z));
    }
    let (coarse, fine) = (chi2[0], chi2[2]);
    // The finest tessellation agrees with the analytic sphere within the noise: mean z² within
    // 4.5 of its own standard deviations (√(2/64) = 0.18) of 1, every block within 4.5 standard
    // errors (a chance of about 4e-4 for the 64 together).
    assert!(fine.0 <= 1.8, "48 rings: mean z² {}", fine.0);
    assert!(fine.1 <= 4.5, "48 rings: a block {} standard errors away", fine.1);
    // The coarse one visibly does not, and the difference shrinks with the tessellation.
    assert!(coarse.0 > 4.0 * fine.0, "4 rings: mean z² {} (48 rings: {})", coarse.0, fine.0);
    assert!(chi2[1].0 < coarse.0, "12 rings: mean z² {} (4 rings: {})", chi2[1].0, coarse.0);
}

/// A smooth-shaded glass mesh sphere (24 rings) under a white sky of radiance 1, in `dir`.
fn smooth_glass_furnace(dir: &Path) -> Scene {
    std::fs::write(dir.join("sphere.obj"), smooth_sphere_obj(24)).unwrap();
    let text = r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 30.0
resolution = [24, 24]
[render]
integrator = "path"
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
shape = "mesh"
file = "sphere.obj"
material = "glass"
[[lights]]
type = "environment"
radiance = 1.0
"#;
    load_str(text, "furnace", Some(dir)).unwrap()
}

#[test]
fn the_bidirectional_methods_keep_the_smooth_glass_furnace_as_path_does() {
    // Light paths through shading normals carry Veach's adjoint factor and the engine's MIS
    // weights mix shading and geometric cosines: bpt and vcm must conserve the furnace's energy
    // as path does. Image means of 8 independent renders each (each render's mean one sample):
    // every method within 1% of 1, and bpt and vcm within 4 standard errors of path.
    let dir = tempfile::tempdir().unwrap();
    let scene = smooth_glass_furnace(dir.path());
    let (path_mean, path_error) = common::image_mean_and_error(&scene, "path", 8, 8);
    println!("path: {path_mean:.5} ± {path_error:.5}");
    for method in ["bpt", "vcm"] {
        let (mean, error) = common::image_mean_and_error(&scene, method, 4, 8);
        println!("{method}: {mean:.5} ± {error:.5}");
        assert!((mean - 1.0).abs() <= 0.01, "{method}: furnace {mean} ± {error}");
        let z = (mean - path_mean).abs() / (error * error + path_error * path_error).sqrt().max(1e-9);
        assert!(
            z < 4.0,
            "{method} {mean} ± {error} vs path {path_mean} ± {path_error}: {z:.1} standard errors"
        );
    }
}

#[test]
fn white_furnace_with_a_smooth_glass_mesh_stays_one() {
    // Lossless glass under a white sky: every pixel's expectation is 1. The estimate is the image
    // mean over independent renders (each render's mean is one sample).
    let dir = tempfile::tempdir().unwrap();
    let scene = smooth_glass_furnace(dir.path());
    // The pixels whose centre sees the glass: the sphere's silhouette is at tan 14.48° = 0.258
    // from the centre of the image, whose half height is tan 15° = 0.268.
    let size = 24;
    let glass: Vec<bool> = (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f64 + 0.5, (i / size) as f64 + 0.5);
            let half = 15f64.to_radians().tan();
            let (u, v) = ((2.0 * x / size as f64 - 1.0) * half, (2.0 * y / size as f64 - 1.0) * half);
            (u * u + v * v).sqrt() < 0.25
        })
        .collect();
    let k = 16;
    let (mut all, mut inside) = (Vec::new(), Vec::new());
    for seed in 0..k {
        let (image, _) = render_path(&scene, 16, 100 + seed);
        let mean = |keep: &dyn Fn(usize) -> bool| {
            let kept: Vec<f64> = (0..image.pixels.len())
                .filter(|&i| keep(i))
                .map(|i| image.pixels[i].element_sum() as f64 / 3.0)
                .collect();
            kept.iter().sum::<f64>() / kept.len() as f64
        };
        all.push(mean(&|_| true));
        inside.push(mean(&|i| glass[i]));
    }
    for (what, means) in [("image", &all), ("glass pixels", &inside)] {
        let mean = means.iter().sum::<f64>() / k as f64;
        let error = (means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k * (k - 1)) as f64).sqrt();
        println!("path: smooth glass mesh in the furnace, {what}: {mean:.5} ± {error:.5}");
        assert!((mean - 1.0).abs() <= 0.01, "{what}: furnace {mean} ± {error}");
        assert!(error < 0.003, "{what}: the estimate is too noisy to tell ({error})");
    }
}

/// Per render of `method` (independent seeds), the mean over the pixels `keep` selects.
fn region_means(scene: &Scene, method: &str, spp: u32, k: u64, keep: &[bool]) -> (f64, f64) {
    let means: Vec<f64> = (0..k)
        .map(|seed| {
            let m = create(method).unwrap();
            let mut opts = RenderOptions::for_method(scene, m.as_ref(), spp);
            opts.seed = 300 + seed;
            opts.sampler = SamplerKind::Independent;
            let out = render(scene, m.as_ref(), &opts, &|_, _| {});
            assert_eq!(out.non_finite_samples, 0);
            let kept: Vec<f64> = (0..keep.len())
                .filter(|&i| keep[i])
                .map(|i| out.image.pixels[i].element_sum() as f64 / 3.0)
                .collect();
            kept.iter().sum::<f64>() / kept.len() as f64
        })
        .collect();
    let mean = means.iter().sum::<f64>() / k as f64;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k * (k - 1)) as f64;
    (mean, var.sqrt())
}

#[test]
fn light_tracing_agrees_with_path_tracing_through_a_smooth_glass_mesh() {
    // Light paths carry Veach's adjoint correction for shading normals, camera paths do not
    // need it: both must estimate the same image wherever light passed a smooth-shaded surface.
    // A coarse (6-ring) smooth glass ball above a diffuse floor, lit by a quad light: the floor
    // and the caustic under the ball, seen directly (pixels whose whole footprint sees the
    // floor; light tracing cannot see the glass itself). This checks agreement to about 0.4% in
    // the caustic; it does not single out the correction, whose net effect here is smaller
    // (measured: light tracing without it renders the caustic 0.2% brighter, within the noise).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), smooth_sphere_obj(6)).unwrap();
    let text = r#"
[camera]
position = [0.0, 3.0, 2.2]
look_at = [0.0, 0.0, 0.0]
fov = 50.0
resolution = [24, 24]
[render]
integrator = "path"
[materials.glass]
type = "dielectric"
ior = 1.5
[materials.floor]
type = "diffuse"
color = 0.8
[[objects]]
material = "glass"
shape = "mesh"
file = "ball.obj"
transform = { scale = 0.6, rotate = { axis = [1.0, 0.0, 1.0], angle = 20.0 }, translate = [0.0, 0.9, 0.0] }
[[objects]]
material = "floor"
shape = "quad"
corner = [-3.0, 0.0, -3.0]
u = [0.0, 0.0, 6.0]
v = [6.0, 0.0, 0.0]
[[lights]]
type = "quad"
corner = [-1.5, 3.5, -1.5]
u = [3.0, 0.0, 0.0]
v = [0.0, 0.0, 3.0]
radiance = 2.0
"#;
    let scene = load_str(text, "caustic", Some(dir.path())).unwrap_or_else(|e| panic!("{e}"));
    let floor = scene.materials.iter().position(|m| m.name == "floor").unwrap();
    let glass = scene.materials.iter().position(|m| m.name == "glass").unwrap();
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let sees_floor = |x: f32, y: f32| {
        let ray = scene.camera.generate_ray(glam::Vec2::new(x, y));
        scene
            .intersect(&ray, f32::INFINITY)
            .is_some_and(|i| scene.primitives[i.primitive as usize].material as usize == floor)
    };
    let keep: Vec<bool> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)]
                .iter()
                .all(|(dx, dy)| sees_floor(x + dx, y + dy))
        })
        .collect();
    // Of those, the pixels where the floor sees the light's centre through the glass: the
    // caustic, where all the light has passed the ball.
    let light_centre = glam::Vec3::new(0.0, 3.5, 0.0);
    let under: Vec<bool> = (0..w * h)
        .map(|i| {
            let ray = scene.camera.generate_ray(glam::Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5));
            let Some(at) = scene.intersect(&ray, f32::INFINITY) else { return false };
            let up = Ray::new(at.hit.p + glam::Vec3::Y * 1e-3, (light_centre - at.hit.p).normalize());
            keep[i]
                && scene
                    .intersect(&up, f32::INFINITY)
                    .is_some_and(|g| scene.primitives[g.primitive as usize].material as usize == glass)
        })
        .collect();
    for (what, mask) in [("floor", &keep), ("caustic", &under)] {
        let kept = mask.iter().filter(|&&k| k).count();
        assert!(kept >= 16, "{what}: only {kept} pixels");
        let (p, pe) = region_means(&scene, "path", 1024, 16, mask);
        let (l, le) = region_means(&scene, "light", 256, 16, mask);
        let z = (p - l) / (pe * pe + le * le).sqrt();
        println!("{what} ({kept} pixels): path {p:.5} ± {pe:.5}, light {l:.5} ± {le:.5}, z = {z:.2}");
        assert!(z.abs() <= 4.0, "{what}: path {p} ± {pe} vs light {l} ± {le}");
    }
}
