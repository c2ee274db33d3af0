//! Physics validation of distributed ray tracing (Cook, Porter and Carpenter 1984): each effect
//! the method distributes rays over is rendered in a small scene whose answer is known in closed
//! form, and the render is measured against it.
//!
//! - Thin lens: a point on the focal plane stays as sharp as through a pinhole; a defocused
//!   emitter spreads into a disc whose diameter on the focal plane is the circle of confusion
//!   2A·|z − f|/z (lens radius A, emitter depth z, focus distance f).
//! - Motion blur: an object moving at velocity v leaves a streak longer than its static image
//!   by |v|·(close − open), projected at its depth.
//! - Soft shadows: the penumbra behind a straight occluder edge under a square light of width W
//!   spans W·(occluder-to-floor)/(light-to-occluder) on the floor, growing with the light.
//! - Spectral equivalence: a scene without dispersion renders the same image within noise in
//!   spectral and in RGB mode, and white stays white.
//!
//! Measurements are sub-pixel (interpolated crossings, line fits, areas); tolerances are one
//! pixel, the issue's 10 %, or a few standard errors estimated from the renders themselves.

use glam::{Vec2, Vec3};
use vitrum::image::Image;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions, RenderOutput};
use vitrum::scene::{load_str, Scene, SpectralMode};

fn scene(text: &str) -> Scene {
    load_str(text, "inline", None).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// `spp` samples per pixel of `distributed` with the given seed and spectral mode.
fn render_distributed(scene: &Scene, spp: u32, seed: u64, spectral: SpectralMode) -> RenderOutput {
    let integrator = create("distributed").unwrap();
    let opts = RenderOptions { seed, spectral, ..RenderOptions::from_scene(scene, spp) };
    let out = render(scene, integrator.as_ref(), &opts, &|_, _| {});
    assert_eq!(out.non_finite_samples, 0);
    out
}

/// Height of the image plane at distance `z` from the camera, in scene units.
fn plane_height(scene: &Scene, z: f32) -> f32 {
    2.0 * z * (0.5 * scene.camera.fov_degrees.to_radians()).tan()
}

/// Where a sampled profile (value `p[i]` at pixel centre `i + 0.5`) first rises through
/// `level`, linearly interpolated between pixel centres.
fn first_rise(p: &[f32], level: f32) -> f32 {
    let i = (0..p.len() - 1).find(|&i| p[i] < level && p[i + 1] >= level).expect("no rising crossing");
    i as f32 + 0.5 + (level - p[i]) / (p[i + 1] - p[i])
}

/// Where a sampled profile last falls through `level` (see [`first_rise`]).
fn last_fall(p: &[f32], level: f32) -> f32 {
    let i = (0..p.len() - 1).rev().find(|&i| p[i] >= level && p[i + 1] < level).expect("no falling crossing");
    i as f32 + 0.5 + (level - p[i]) / (p[i + 1] - p[i])
}

/// Least-squares line v = a + b·x through the points; returns (a, b).
fn fit_line(points: &[(f32, f32)]) -> (f32, f32) {
    let n = points.len() as f64;
    assert!(n >= 2.0, "a line needs two points, got {points:?}");
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(sx, sy), &(x, y)| (sx + x as f64, sy + y as f64));
    let (mx, my) = (sx / n, sy / n);
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for &(x, y) in points {
        sxx += (x as f64 - mx).powi(2);
        sxy += (x as f64 - mx) * (y as f64 - my);
    }
    let b = sxy / sxx;
    ((my - b * mx) as f32, b as f32)
}

// ---------------------------------------------------------------------------------------------
// Thin lens
// ---------------------------------------------------------------------------------------------

/// A camera at the origin looking down −z (30° vertical field of view, `res`² pixels) with a thin
/// lens, and a square emitter of side `side` centred on the axis at depth `depth`, facing it.
fn lens_scene(res: u32, aperture: f32, focus: f32, depth: f32, side: f32) -> Scene {
    scene(&format!(
        r#"
[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov = 30.0
resolution = [{res}, {res}]
aperture = {aperture:?}
focus_distance = {focus:?}

[[lights]]
type = "quad"
corner = [{h:?}, {h:?}, {z:?}]
u = [{side:?}, 0.0, 0.0]
v = [0.0, {side:?}, 0.0]
radiance = 1.0
"#,
        h = -0.5 * side,
        z = -depth,
    ))
}

/// Pixels brighter than `level` (red channel).
fn lit_pixels(img: &Image, level: f32) -> Vec<(usize, usize)> {
    let mut lit = Vec::new();
    for y in 0..img.height {
        for x in 0..img.width {
            if img.get(x, y).x > level {
                lit.push((x, y));
            }
        }
    }
    lit
}

/// Whether every pixel of `a` has one of `b` within one pixel (8-neighbourhood or itself).
fn within_one_pixel(a: &[(usize, usize)], b: &[(usize, usize)]) -> bool {
    a.iter().all(|&(x, y)| b.iter().any(|&(u, v)| x.abs_diff(u) <= 1 && y.abs_diff(v) <= 1))
}

#[test]
fn a_point_on_the_focal_plane_stays_as_sharp_as_through_a_pinhole() {
    // A 0.5-unit square 4 units away (≈ 15 px wide) exactly on the plane in focus, through a lens
    // of radius 0.4: every lens ray of a film point meets the pinhole ray on that plane.
    let (res, focus, side, spp) = (64, 4.0, 0.5, 64);
    let pinhole = render_distributed(&lens_scene(res, 0.0, focus, focus, side), spp, 1, SpectralMode::Auto);
    let with_lens = lens_scene(res, 0.4, focus, focus, side);
    assert!(with_lens.camera.has_lens());
    let lens = render_distributed(&with_lens, spp, 1, SpectralMode::Auto);
    // Lit: more than half covered (the emitter's radiance is 1).
    let (a, b) = (lit_pixels(&pinhole.image, 0.5), lit_pixels(&lens.image, 0.5));
    let max_diff =
        pinhole.image.pixels.iter().zip(&lens.image.pixels).map(|(p, q)| (*p - *q).abs().max_element());
    let max_diff = max_diff.fold(0.0f32, f32::max);
    println!(
        "in focus: {} lit pixels through the pinhole, {} through the lens; max |Δ| = {max_diff}",
        a.len(),
        b.len()
    );
    assert!(a.len() > 150, "the emitter should cover about 15×15 pixels, got {}", a.len());
    assert!(within_one_pixel(&a, &b) && within_one_pixel(&b, &a), "lit sets differ by more than a pixel");
}

/// Diameter of the lit disc around film point `centre`: from the area above half the plateau
/// and from the total flux divided by the plateau, with the plateau the mean inside
/// `inner_radius` pixels of the centre.
fn disc_diameter(img: &Image, centre: Vec2, inner_radius: f32) -> (f32, f32, f32) {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for y in 0..img.height {
        for x in 0..img.width {
            let d = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - centre;
            if d.length() <= inner_radius {
                sum += img.get(x, y).x as f64;
                n += 1;
            }
        }
    }
    let plateau = (sum / n as f64) as f32;
    let area = lit_pixels(img, 0.5 * plateau).len() as f32;
    let flux: f64 = img.pixels.iter().map(|p| p.x as f64).sum();
    let by_area = (4.0 * area / std::f32::consts::PI).sqrt();
    let by_flux = (4.0 * (flux as f32 / plateau) / std::f32::consts::PI).sqrt();
    (by_area, by_flux, plateau)
}

#[test]
fn blur_circle_of_a_defocused_emitter_matches_the_thin_lens_formula() {
    // Focus at f = 4; a small square emitter nearer (z = 2.5) and farther (z = 8) than that.
    // Its light reaches the focal plane through every lens point: a disc of diameter
    // 2A·|z − f|/z (the circle of confusion) convolved with the emitter's own image (side s·f/z).
    // The disc's area above half its plateau and its flux over its plateau both measure the
    // circle of confusion: the flux of the convolution is exactly the plateau times the disc's
    // area, and the half-plateau contour of a disc of radius R convolved with a centred kernel
    // of width k lies inside the disc's edge by about k²/(24R) (curvature), here ~0.15 px or
    // 1 % of the diameter. 1024 samples per pixel keep the noise's bias on the thresholded
    // area (the skewed hit counts of edge pixels) below that.
    let (res, focus, aperture, spp) = (64u32, 4.0f32, 0.8f32, 1024);
    for (depth, side) in [(2.5f32, 0.15f32), (8.0, 0.4)] {
        let s = lens_scene(res, aperture, focus, depth, side);
        let out = render_distributed(&s, spp, 7, SpectralMode::Auto);
        let coc = 2.0 * aperture * (depth - focus).abs() / depth;
        let predicted = coc / plane_height(&s, focus) * res as f32;
        let centre = s.camera.project(Vec3::new(0.0, 0.0, -depth)).unwrap();
        let (by_area, by_flux, plateau) = disc_diameter(&out.image, centre, 0.25 * predicted);
        // The plateau is the fraction of the lens that sees the emitter: (its image / the disc).
        let expected_plateau = (side * focus / depth).powi(2) / (std::f32::consts::PI * 0.25 * coc * coc);
        println!(
            "z = {depth}: blur diameter predicted {predicted:.2} px, by area {by_area:.2} px ({:.3}×), \
             by flux {by_flux:.2} px ({:.3}×); plateau {plateau:.4} (expected {expected_plateau:.4})",
            by_area / predicted,
            by_flux / predicted
        );
        assert!(predicted > 20.0, "blur too small to measure: {predicted} px");
        for (how, d) in [("area", by_area), ("flux", by_flux)] {
            assert!(
                (d / predicted - 1.0).abs() < 0.1,
                "z = {depth}: diameter by {how} {d} px, thin-lens formula {predicted} px"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Motion blur
// ---------------------------------------------------------------------------------------------

/// Depth of the moving square, its corner and size (scene units), and its velocity.
const MOTION_DEPTH: f32 = 4.0;
const MOTION_CORNER: [f32; 2] = [-1.5, -0.3];
const MOTION_SIZE: [f32; 2] = [0.5, 0.6];
const MOTION_SPEED: f32 = 2.0;

/// A white square lit only by the ambient term (radiance exactly 1 wherever it is seen) on a
/// black background, 4 units in front of a 96×24 camera, moving along the camera's right axis
/// (+x) at `speed` units per unit of shutter time.
fn motion_scene(shutter: [f32; 2], speed: Option<f32>) -> Scene {
    let velocity = speed.map_or(String::new(), |v| format!("velocity = [{v:?}, 0.0, 0.0]"));
    let [x, y] = MOTION_CORNER;
    let [w, h] = MOTION_SIZE;
    scene(&format!(
        r#"
[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov = 30.0
resolution = [96, 24]
shutter = [{open:?}, {close:?}]

[render]
ambient = 1.0

[materials.white]
type = "diffuse"
color = 1.0

[[objects]]
shape = "quad"
corner = [{x:?}, {y:?}, {z:?}]
u = [{w:?}, 0.0, 0.0]
v = [0.0, {h:?}, 0.0]
material = "white"
{velocity}
"#,
        open = shutter[0],
        close = shutter[1],
        z = -MOTION_DEPTH,
    ))
}

/// The mean of rows 9..=14 (those wholly inside the square's vertical extent, film y ∈
/// 12 ± 3.36), red channel.
fn motion_profile(img: &Image) -> Vec<f32> {
    (0..img.width).map(|x| (9..=14).map(|y| img.get(x, y).x).sum::<f32>() / 6.0).collect()
}

#[test]
fn motion_blur_extent_equals_velocity_times_shutter() {
    let spp = 256;
    let still = motion_scene([0.0, 1.0], None);
    let static_profile = motion_profile(&render_distributed(&still, spp, 3, SpectralMode::Auto).image);
    // The static square's extent: its row flux over its radiance (exactly 1: white × ambient 1),
    // exact for a box seen through box-shaped pixels. Its edges, where the profile crosses half
    // that radiance, must sit where the corners project.
    let static_extent = static_profile.iter().sum::<f32>();
    let (left, right) = (first_rise(&static_profile, 0.5), last_fall(&static_profile, 0.5));
    let project_x = |x: f32| still.camera.project(Vec3::new(x, 0.0, -MOTION_DEPTH)).unwrap().x;
    let (x0, x1) = (MOTION_CORNER[0], MOTION_CORNER[0] + MOTION_SIZE[0]);
    println!(
        "static: edges {left:.3}, {right:.3} px (projected {:.3}, {:.3}); extent {static_extent:.3} px \
         (projected {:.3})",
        project_x(x0),
        project_x(x1),
        project_x(x1) - project_x(x0)
    );
    assert!((left - project_x(x0)).abs() < 1.0 && (right - project_x(x1)).abs() < 1.0);
    for shutter in [[0.0f32, 1.0f32], [0.5, 1.5]] {
        let moving = motion_scene(shutter, Some(MOTION_SPEED));
        let out = render_distributed(&moving, spp, 3, SpectralMode::Auto);
        let p = motion_profile(&out.image);
        // The time-averaged coverage is a trapezoid: it ramps up linearly over the square's
        // width from where the leading edge was at the opening, holds at width/travel, and ramps
        // down to where the trailing edge is at the closing. Each ramp is fitted with a line
        // (pixels between 15 % and 85 % of the plateau, away from the box-filtered corners) and
        // extrapolated to zero: the streak's ends.
        let peak = p.iter().copied().fold(0.0f32, f32::max);
        let mut plateau: Vec<f32> = p.iter().copied().filter(|&v| v > 0.5 * peak).collect();
        plateau.sort_by(f32::total_cmp);
        let h = plateau[plateau.len() / 2];
        let centre =
            p.iter().enumerate().map(|(i, v)| (i as f32 + 0.5) * v).sum::<f32>() / p.iter().sum::<f32>();
        let ramp = |rising: bool| -> Vec<(f32, f32)> {
            let pts = p.iter().enumerate().map(|(i, &v)| (i as f32 + 0.5, v));
            pts.filter(|&(x, v)| v > 0.15 * h && v < 0.85 * h && (x < centre) == rising).collect()
        };
        let foot = |(a, b): (f32, f32)| -a / b;
        let (start, end) = (foot(fit_line(&ramp(true))), foot(fit_line(&ramp(false))));
        let streak = end - start;
        let [open, close] = shutter;
        let travel = MOTION_SPEED * (close - open);
        let expected = travel / plane_height(&moving, MOTION_DEPTH) * moving.camera.height as f32;
        let (start_expected, end_expected) =
            (project_x(x0 + MOTION_SPEED * open), project_x(x1 + MOTION_SPEED * close));
        println!(
            "shutter {shutter:?}: streak {start:.3}..{end:.3} px (projected {start_expected:.3}..{end_expected:.3}), \
             extent {streak:.3} px; streak − static = {:.3} px, |v|·(close − open) projected = {expected:.3} px; \
             plateau {h:.4} (width/travel = {:.4})",
            streak - static_extent,
            MOTION_SIZE[0] / travel
        );
        assert!(
            ((streak - static_extent) - expected).abs() <= 1.0,
            "shutter {shutter:?}: streak − static = {} px, expected {expected} px",
            streak - static_extent
        );
        assert!((start - start_expected).abs() <= 1.0 && (end - end_expected).abs() <= 1.0);
    }
}

// ---------------------------------------------------------------------------------------------
// Soft shadows
// ---------------------------------------------------------------------------------------------

/// Heights of the square light and of the occluder above the floor (y = 0).
const LIGHT_HEIGHT: f32 = 3.0;
const OCCLUDER_HEIGHT: f32 = 1.0;

/// A white Lambertian floor at y = 0, an opaque half-plane x < 0 at y = 1 (its edge along z)
/// and a square light of side `width` centred above the edge at y = 3, facing down, with
/// radiance ∝ 1/width² (the same power at every size). The camera hangs at y = 0.5 between
/// floor and occluder looking straight down, x to the image's right: the floor fills the view
/// at a uniform scale.
fn shadow_scene(width: f32) -> Scene {
    let radiance = (0.4 / width).powi(2);
    scene(&format!(
        r#"
[camera]
position = [0.0, 0.5, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov = 10.0
resolution = [200, 20]

[materials.white]
type = "diffuse"
color = 1.0

[materials.black]
type = "diffuse"
color = 0.0

[[objects]]
name = "floor"
shape = "quad"
corner = [-10.0, 0.0, -10.0]
u = [0.0, 0.0, 20.0]
v = [20.0, 0.0, 0.0]
material = "white"

[[objects]]
name = "occluder"
shape = "quad"
corner = [-10.0, {OCCLUDER_HEIGHT:?}, -10.0]
u = [0.0, 0.0, 20.0]
v = [10.0, 0.0, 0.0]
material = "black"

[[lights]]
type = "quad"
corner = [{h:?}, {LIGHT_HEIGHT:?}, {h:?}]
u = [{width:?}, 0.0, 0.0]
v = [0.0, 0.0, {width:?}]
radiance = {radiance:?}
"#,
        h = -0.5 * width,
    ))
}

/// Irradiance at `p` on a surface with normal `n` from a Lambertian polygon of unit radiance
/// (Lambert's formula: E = ½ Σ Θ_i n·(r_i × r_{i+1})/|r_i × r_{i+1}|, Θ_i the angle between
/// consecutive vertex directions r_i).
fn polygon_irradiance(p: Vec3, n: Vec3, vertices: &[Vec3]) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..vertices.len() {
        let a = (vertices[i] - p).as_dvec3().normalize();
        let b = (vertices[(i + 1) % vertices.len()] - p).as_dvec3().normalize();
        let c = a.cross(b);
        if c.length() > 0.0 {
            sum += a.dot(b).clamp(-1.0, 1.0).acos() * n.as_dvec3().dot(c.normalize());
        }
    }
    0.5 * sum.abs()
}

/// The part of the light of side `width` a floor point `p` sees past the occluder's edge (the
/// light points with x ≥ x_L, x_L where the line from `p` over the edge meets the light's
/// plane), as a polygon; `None` in the umbra.
fn visible_light(p: Vec3, width: f32) -> Option<[Vec3; 4]> {
    let h = 0.5 * width;
    let x_l = (-p.x * (LIGHT_HEIGHT - OCCLUDER_HEIGHT) / OCCLUDER_HEIGHT).max(-h);
    (x_l < h).then(|| {
        let y = LIGHT_HEIGHT;
        [Vec3::new(x_l, y, -h), Vec3::new(h, y, -h), Vec3::new(h, y, h), Vec3::new(x_l, y, h)]
    })
}

/// The 10 %–90 % width (scene units) of a profile of visible fractions sampled at increasing x.
fn rise_width(xs: &[f32], v: &[f32]) -> f32 {
    let (i10, i90) = (first_rise(v, 0.1), first_rise(v, 0.9));
    // Crossings are in pixel units with pixel i's centre at i + 0.5; map them to x.
    let x_at = |f: f32| {
        let i = ((f - 0.5).floor() as usize).min(xs.len() - 2);
        xs[i] + (f - 0.5 - i as f32) * (xs[i + 1] - xs[i])
    };
    x_at(i90) - x_at(i10)
}

#[test]
fn penumbra_widens_with_the_light_as_geometry_predicts() {
    // For a floor point at x, the occluder's edge hides the light points with
    // x_light < −x·(H_L − H_O)/H_O: the visible part of a light of width W goes from none to
    // all over a penumbra of width W·H_O/(H_L − H_O) on the floor, linearly (in area). Each
    // pixel's radiance over that of the unoccluded light (Lambert's formula) is the visible
    // fraction of the light weighted by cos·cos/r², whose 10 %–90 % width is 0.8 of the
    // penumbra's in the linear model. The exact weighted fraction (Lambert's formula over the
    // visible polygon) differs from the linear model by a computed amount; the tolerance is that
    // model difference plus one pixel's footprint on the floor.
    let spp = 64;
    let mut widths = Vec::new();
    for width in [0.2f32, 0.4, 0.8] {
        let s = shadow_scene(width);
        let out = render_distributed(&s, spp, 5, SpectralMode::Auto);
        let (w, h) = (out.image.width, out.image.height);
        let light = {
            let (y, c) = (LIGHT_HEIGHT, 0.5 * width);
            [Vec3::new(-c, y, -c), Vec3::new(c, y, -c), Vec3::new(c, y, c), Vec3::new(-c, y, c)]
        };
        let radiance = (0.4 / width).powi(2) as f64;
        // Per column: the floor point under each pixel centre, the measured visible fraction
        // (radiance = albedo/π · E) and the exact one, averaged over the rows.
        let (mut xs, mut measured, mut exact) = (vec![0.0f32; w], vec![0.0f32; w], vec![0.0f32; w]);
        for x in 0..w {
            for y in 0..h {
                let ray = s.camera.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                let p = ray.at(-ray.origin.y / ray.dir.y);
                let open = radiance * polygon_irradiance(p, Vec3::Y, &light);
                let seen =
                    visible_light(p, width).map_or(0.0, |v| radiance * polygon_irradiance(p, Vec3::Y, &v));
                let value = out.image.get(x, y).x as f64 * std::f64::consts::PI;
                xs[x] += p.x / h as f32;
                measured[x] += (value / open) as f32 / h as f32;
                exact[x] += (seen / open) as f32 / h as f32;
            }
        }
        let pixel = xs[1] - xs[0];
        let measured_width = rise_width(&xs, &measured);
        let exact_width = rise_width(&xs, &exact);
        let geometric = 0.8 * width * OCCLUDER_HEIGHT / (LIGHT_HEIGHT - OCCLUDER_HEIGHT);
        let tolerance = pixel + (exact_width - geometric).abs();
        println!(
            "light {width}: 10–90 % width measured {measured_width:.4}, geometric {geometric:.4} \
             ({:.3}×), exact irradiance {exact_width:.4}; pixel {pixel:.4}; tolerance {tolerance:.4}; \
             fully lit fraction {:.4}, umbra {:.4}",
            measured_width / geometric,
            measured[w - 1],
            measured[0]
        );
        assert!(
            (measured_width - geometric).abs() <= tolerance,
            "light {width}: {measured_width} vs {geometric}"
        );
        widths.push(measured_width);
    }
    assert!(widths.windows(2).all(|w| w[1] > w[0]), "penumbra widths not increasing: {widths:?}");
}

// ---------------------------------------------------------------------------------------------
// Spectral rendering without dispersion
// ---------------------------------------------------------------------------------------------

/// A small box with coloured walls, an absorbing glass sphere (constant index), a moving rough
/// mirror sphere, a square ceiling light, a thin lens and an open shutter: every effect but
/// dispersion, so nothing in it depends on the wavelength.
const NON_DISPERSIVE: &str = r#"
[camera]
position = [0.0, 1.0, 3.5]
look_at = [0.0, 1.0, 0.0]
fov = 40.0
resolution = [32, 32]
aperture = 0.03
focus_distance = 3.5
shutter = [0.0, 1.0]

[render]
ambient = 0.05

[materials.white]
type = "diffuse"
color = 0.73

[materials.red]
type = "diffuse"
color = [0.63, 0.065, 0.05]

[materials.green]
type = "diffuse"
color = [0.14, 0.45, 0.091]

[materials.glass]
type = "dielectric"
ior = 1.5
absorption = [0.1, 0.4, 0.8]

[materials.brushed]
type = "mirror"
color = [0.9, 0.8, 0.7]
roughness = 0.3

[[objects]]
shape = "quad"
corner = [-1.0, 0.0, -1.0]
u = [0.0, 0.0, 2.0]
v = [2.0, 0.0, 0.0]
material = "white"

[[objects]]
shape = "quad"
corner = [-1.0, 0.0, -1.0]
u = [2.0, 0.0, 0.0]
v = [0.0, 2.0, 0.0]
material = "white"

[[objects]]
shape = "quad"
corner = [-1.0, 0.0, -1.0]
u = [0.0, 2.0, 0.0]
v = [0.0, 0.0, 2.0]
material = "red"

[[objects]]
shape = "quad"
corner = [1.0, 0.0, -1.0]
u = [0.0, 0.0, 2.0]
v = [0.0, 2.0, 0.0]
material = "green"

[[objects]]
shape = "sphere"
center = [-0.4, 0.4, -0.2]
radius = 0.4
material = "glass"

[[objects]]
shape = "sphere"
center = [0.45, 0.3, 0.2]
radius = 0.3
material = "brushed"
velocity = [0.0, 0.1, 0.0]

[[lights]]
type = "quad"
corner = [-0.3, 1.98, -0.3]
u = [0.6, 0.0, 0.0]
v = [0.0, 0.0, 0.6]
radiance = 8.0
"#;

/// Means of the `block`×`block` tiles of an image, per channel, in f64.
fn block_means(img: &Image, block: usize) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for by in (0..img.height).step_by(block) {
        for bx in (0..img.width).step_by(block) {
            let mut sum = [0.0f64; 3];
            for y in by..by + block {
                for x in bx..bx + block {
                    let p = img.get(x, y);
                    for c in 0..3 {
                        sum[c] += p[c] as f64;
                    }
                }
            }
            out.push(sum.map(|s| s / (block * block) as f64));
        }
    }
    out
}

/// `a − b`, or `(a + b)/2`, or per pixel and channel `(a − b)²/2`: from two independent,
/// identically distributed renders, an unbiased estimate of the variance of either's pixel.
fn combine(a: &Image, b: &Image, f: impl Fn(Vec3, Vec3) -> Vec3) -> Image {
    let pixels = a.pixels.iter().zip(&b.pixels).map(|(p, q)| f(*p, *q)).collect();
    Image { width: a.width, height: a.height, pixels }
}

#[test]
fn spectral_and_rgb_modes_agree_on_a_scene_without_dispersion() {
    // Two renders per mode, seeds 1 and 2, the same seed in both modes (so a pair shares its
    // pixel, lens and time samples and is correlated). Per pixel, the difference spectral − RGB
    // of pair 1 and of pair 2 are independent estimates of the same mean; their average is
    // tested against zero, its variance estimated per pixel from the two differences
    // ((d₁ − d₂)²/2 per difference, halved for the average). Pixels are independent streams,
    // so an 8×8 block mean's variance is the sum of its pixels' over 64². Each block's
    // variance estimate has 64 degrees of freedom; with 16 blocks × 3 channels (+3 whole-image
    // means) a bound of Z = 4.5 standard errors fails by chance with probability ~1e-3
    // (Student t). The standard errors are printed: at 256 spp about 1 % of the image mean.
    const Z: f64 = 4.5;
    let s = scene(NON_DISPERSIVE);
    let spp = 256;
    let spectral = [1, 2].map(|seed| render_distributed(&s, spp, seed, SpectralMode::On));
    let rgb = [1, 2].map(|seed| render_distributed(&s, spp, seed, SpectralMode::Off));
    assert!(spectral.iter().all(|o| o.spectral) && rgb.iter().all(|o| !o.spectral));
    let d1 = combine(&spectral[0].image, &rgb[0].image, |a, b| a - b);
    let d2 = combine(&spectral[1].image, &rgb[1].image, |a, b| a - b);
    let diff = combine(&d1, &d2, |a, b| 0.5 * (a + b));
    let var = combine(&d1, &d2, |a, b| 0.25 * (a - b) * (a - b));
    let level = combine(&rgb[0].image, &rgb[1].image, |a, b| 0.5 * (a + b));
    for block in [8, 32] {
        let n = (block * block) as f64;
        let (dm, vm, lm) = (block_means(&diff, block), block_means(&var, block), block_means(&level, block));
        let mut worst = 0.0f64;
        let mut relative_se = Vec::new();
        for (i, ((d, v), l)) in dm.iter().zip(&vm).zip(&lm).enumerate() {
            for c in 0..3 {
                // Block mean of independent pixels: Var = mean pixel variance / n.
                let se = (v[c] / n).sqrt();
                let z = d[c] / se;
                worst = worst.max(z.abs());
                relative_se.push(se / l[c]);
                assert!(
                    z.abs() < Z,
                    "{block}×{block} block {i}, channel {c}: spectral − RGB = {} ± {se} on {} (z = {z})",
                    d[c],
                    l[c]
                );
            }
        }
        relative_se.sort_by(f64::total_cmp);
        println!(
            "{block}×{block} blocks: largest |z| = {worst:.2}; relative standard error median {:.2} %, max {:.2} %",
            100.0 * relative_se[relative_se.len() / 2],
            100.0 * relative_se[relative_se.len() - 1]
        );
    }
}

#[test]
fn white_stays_white_in_spectral_mode() {
    // A white Lambertian wall under a white square light, rendered spectrally: every sample
    // carries the RGB weight of its wavelength (with negative lobes), and only the mean over
    // wavelengths is white. Under "white stays white" each pixel's R − G and B − G have mean
    // zero, so their image means must be zero within Z standard errors, the standard error
    // estimated from the pixels' own squares (Σ(R − G)² is unbiased for Σ Var when the means
    // are zero). The estimate must also be sharp: a standard error under 1 % of the level.
    const Z: f64 = 4.0;
    let s = scene(
        r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [48, 48]

[materials.white]
type = "diffuse"
color = 1.0

[[objects]]
shape = "quad"
corner = [-2.0, -2.0, 0.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 4.0, 0.0]
material = "white"

[[lights]]
type = "quad"
corner = [-0.5, 1.5, 0.5]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, 1.0]
radiance = 5.0
"#,
    );
    let out = render_distributed(&s, 128, 11, SpectralMode::On);
    assert!(out.spectral);
    let n = out.image.pixels.len() as f64;
    let g_mean = out.image.pixels.iter().map(|p| p.y as f64).sum::<f64>() / n;
    for (name, c) in [("R − G", 0), ("B − G", 2)] {
        let d: Vec<f64> = out.image.pixels.iter().map(|p| (p[c] - p.y) as f64).collect();
        let mean = d.iter().sum::<f64>() / n;
        let se = (d.iter().map(|x| x * x).sum::<f64>()).sqrt() / n;
        println!(
            "{name}: image mean {mean:.6} ± {se:.6} (G mean {g_mean:.5}; {:.3} % ± {:.3} %)",
            100.0 * mean / g_mean,
            100.0 * se / g_mean
        );
        assert!(se < 0.01 * g_mean, "{name}: the test cannot resolve 1 % (se {se}, level {g_mean})");
        assert!((mean / se).abs() < Z, "{name}: mean {mean} is {} standard errors from 0", mean / se);
    }
}
