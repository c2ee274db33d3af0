//! The camera's pixel filters, crop window and near clip plane, rendered: a sharp edge against
//! the filter's integral across it, `light` against `path` with a tent and a Gaussian filter,
//! crop windows that are their pixels of the whole film bit for bit (every method, both engines
//! of `path`), filtered images at any thread count, and a near clip plane that hides what is
//! closer. The sampler's χ² test of the filtered offsets is in `src/pixel_filter.rs`.

mod common;

use common::{mean_and_error, render_opts};
use glam::Vec3;
use vitrum::image::Image;
use vitrum::integrators::create;
use vitrum::params::EngineOption;
use vitrum::pixel_filter::{FilterKind, PixelFilter};
use vitrum::render::RenderOptions;
use vitrum::sampler::SamplerKind;
use vitrum::scene::{load_str, Scene};

/// A diffuse quad lit by a point light, its edges inside the 16×16 image; `camera` is added to
/// the `[camera]` table.
fn lit_quad(camera: &str) -> String {
    format!(
        r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [16, 16]
{camera}
[render]
integrator = "path"
[materials.white]
type = "diffuse"
color = [0.8, 0.6, 0.4]
[[objects]]
shape = "quad"
corner = [-0.45, -0.7, 0.0]
u = [1.3, 0.0, 0.0]
v = [0.0, 1.6, 0.0]
material = "white"
[[lights]]
type = "point"
position = [0.4, 0.6, 1.2]
intensity = 2.0
"#
    )
}

/// A black quad 0.5 in front of `lit_quad`'s camera, over the view's centre.
const OCCLUDER: &str = r#"
[materials.black]
type = "diffuse"
color = [0.0, 0.0, 0.0]
[[objects]]
shape = "quad"
corner = [-0.2, -0.2, 2.5]
u = [0.4, 0.0, 0.0]
v = [0.0, 0.4, 0.0]
material = "black"
"#;

const TENT: &str = r#"filter = { type = "tent", radius = 1.5 }"#;
const GAUSSIAN: &str = r#"filter = { type = "gaussian", stddev = 0.5 }"#;

fn scene(text: &str) -> Scene {
    load_str(text, "pixel filters", None).unwrap()
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn render(scene: &Scene, method: &str, spp: u32, seed: u64, engine: EngineOption) -> Image {
    let mut opts = RenderOptions::for_method(scene, create(method).unwrap().as_ref(), spp);
    opts.seed = seed;
    opts.params.engine = engine;
    let out = render_opts(scene, method, &opts);
    assert_eq!(out.non_finite_samples, 0, "{method}: non-finite samples");
    out.image
}

/// An emitter of radiance 1 over the left of the view, its edge at film x = 8.34 of a 16×8
/// film (x_world = 0.17 at depth 2, fov 90°: x_film = 2·x_world + 8), nothing else: a pixel
/// centred at c sees `∫ f(x − c)·[x < 8.34] dx / ∫ f(x − c) dx` (integrals over the film), the
/// filter's integral across the edge (the filter being Mitsuba's table of its profile).
#[test]
fn a_sharp_edge_renders_the_filters_integral_across_it() {
    let edge = 8.34f64;
    for (filter, line) in [
        (PixelFilter::BOX, ""),
        (PixelFilter::new(FilterKind::Tent { radius: 1.5 }), TENT),
        (PixelFilter::new(FilterKind::Gaussian { stddev: 0.5 }), GAUSSIAN),
    ] {
        let text = format!(
            r#"
[camera]
position = [0.0, 0.0, 2.0]
look_at = [0.0, 0.0, 0.0]
fov = 90.0
resolution = [16, 8]
{line}
[render]
integrator = "path"
[[lights]]
type = "quad"
corner = [-6.0, -6.0, 0.0]
u = [6.17, 0.0, 0.0]
v = [0.0, 12.0, 0.0]
radiance = [1.0, 1.0, 1.0]
"#
        );
        let s = scene(&text);
        assert_eq!(s.camera.filter, filter);
        let spp = 4096;
        let image = render(&s, "path", spp, 3, EngineOption::Auto);
        // The expected value by a midpoint sum of the filter's own profile (not its sampler).
        let expected = |c: f64| {
            let r = filter.radius() as f64;
            let n = 200_000;
            let (lo, hi) = ((c - r).max(0.0), (c + r).min(16.0));
            let h = (hi - lo) / n as f64;
            let (mut covered, mut all) = (0.0, 0.0);
            for i in 0..n {
                let x = lo + (i as f64 + 0.5) * h;
                let f = filter.eval((x - c) as f32) as f64;
                all += f;
                if x < edge {
                    covered += f;
                }
            }
            covered / all
        };
        let mut differs_from_box = false;
        for x in 0..16 {
            let p = expected(x as f64 + 0.5);
            // A pixel's value is k/n, k of its n samples on the emitter: a binomial count (Sobol'
            // samples, being stratified, spread less). Allowed: four standard deviations of k,
            // plus two samples for the count's granularity where n·p·(1 − p) is far below 1 (a
            // Poisson count of mean 0.05 reaches 3 with probability 2·10⁻⁵).
            let n = spp as f64;
            let bound = 4.0 * (p * (1.0 - p) / n).sqrt() + 2.0 / n;
            let box_value = if x < 8 {
                1.0
            } else if x == 8 {
                edge - 8.0
            } else {
                0.0
            };
            differs_from_box |= (p - box_value).abs() > 0.02;
            for y in 0..8 {
                let v = image.pixels[y * 16 + x].x as f64;
                assert!(
                    (v - p).abs() <= bound,
                    "{}: pixel ({x}, {y}) = {v}, the filter's integral {p} (bound {bound})",
                    filter.describe()
                );
            }
        }
        assert_eq!(differs_from_box, !filter.is_box(), "{}: the edge's width", filter.describe());
    }
}

/// `light` splats each film point into every pixel whose footprint covers it with the
/// normalised weight; `path` samples the footprint. Per pixel, over 128 independent renders
/// each, they agree within 5 standard errors of their difference (t with 127 degrees of freedom
/// beyond 5 has probability below 2·10⁻⁶ per pixel; fewer renders leave the light tracer's
/// heavy-tailed pixels with unreliable error estimates: at 32, even the box reaches |z| = 3.7).
#[test]
fn light_and_path_agree_with_tent_and_gaussian_filters() {
    for line in [TENT, GAUSSIAN] {
        let s = scene(&lit_quad(line));
        let (mp, sp) = mean_and_error(&s, "path", 16, 128);
        let (ml, sl) = mean_and_error(&s, "light", 16, 128);
        let (mut worst, mut edge_pixels) = (0.0f32, 0);
        for i in 0..mp.len() {
            for c in 0..3 {
                let se = (sp[i][c] * sp[i][c] + sl[i][c] * sl[i][c]).sqrt();
                if se == 0.0 {
                    assert_eq!(mp[i][c], ml[i][c], "{line}: pixel {i}: noise-free pixel differs");
                    continue;
                }
                let z = (mp[i][c] - ml[i][c]) / se;
                assert!(
                    z.abs() <= 5.0,
                    "{line}: pixel {i} channel {c}: path {} vs light {} (z = {z})",
                    mp[i][c],
                    ml[i][c]
                );
                worst = worst.max(z.abs());
            }
            // Pixels whose footprint reaches over the quad's edge: partly lit.
            let m = mp[i].x;
            if m > 0.0 && m < 0.5 * mp.iter().map(|p| p.x).fold(0.0, f32::max) {
                edge_pixels += 1;
            }
        }
        eprintln!("{line}: max |z| = {worst:.2}, {edge_pixels} partly covered pixels");
        assert!(edge_pixels > 0, "{line}: the filter must blur the quad's edge");
    }
}

/// The crop window's pixels are the whole film's, bit for bit, for every method and both
/// engines of `path`, with each filter (the sample streams are keyed by the whole film's pixel
/// index, the footprints cut at the whole film's edge).
#[test]
fn a_crop_window_renders_its_pixels_of_the_whole_film_bit_for_bit() {
    let crop = "crop = { offset = [3, 5], size = [7, 6] }";
    for line in ["", TENT, GAUSSIAN] {
        let full = scene(&lit_quad(line));
        let cropped = scene(&lit_quad(&format!("{line}\n{crop}")));
        for (method, engine) in [
            ("path", EngineOption::Auto),
            ("path", EngineOption::Scalar),
            ("light", EngineOption::Auto),
            ("bpt", EngineOption::Auto),
            ("vcm", EngineOption::Auto),
            ("ssaa", EngineOption::Auto),
            ("distributed", EngineOption::Auto),
        ] {
            let whole = render(&full, method, 8, 5, engine);
            let part = render(&cropped, method, 8, 5, engine);
            assert_eq!((part.width, part.height), (7, 6), "{method}: the crop's size");
            let mut window = Vec::new();
            for y in 5..11 {
                for x in 3..10 {
                    window.push(whole.pixels[y * 16 + x]);
                }
            }
            let want = bits(&Image { width: 7, height: 6, pixels: window });
            let differing = bits(&part).iter().zip(&want).filter(|(a, b)| a != b).count();
            assert_eq!(differing, 0, "{method} ({engine:?}) {line:?}: {differing} of 42 crop pixels differ");
            assert!(part.pixels.iter().any(|p| p.max_element() > 0.0), "{method}: black crop");
        }
    }
}

/// Filtered camera samples and filtered splats give the same bits at 1 and 2 threads.
#[test]
fn filtered_images_are_the_same_at_any_thread_count() {
    for line in [TENT, GAUSSIAN] {
        let s = scene(&lit_quad(line));
        for method in ["path", "light", "vcm"] {
            let run = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                pool.install(|| render(&s, method, 8, 7, EngineOption::Auto))
            };
            let (one, two) = (run(1), run(2));
            assert_eq!(bits(&one), bits(&two), "{method} {line}: 1 and 2 threads differ");
            assert!(one.pixels.iter().any(|p| p.max_element() > 0.0), "{method}: black image");
        }
    }
}

/// `filter = "box"` is the default, bit for bit.
#[test]
fn the_box_written_out_is_the_default() {
    let default = scene(&lit_quad(""));
    let boxed = scene(&lit_quad(r#"filter = "box""#));
    assert_eq!(boxed.camera.filter, PixelFilter::BOX);
    for method in ["path", "light"] {
        let a = render(&default, method, 4, 1, EngineOption::Auto);
        let b = render(&boxed, method, 4, 1, EngineOption::Auto);
        assert_eq!(bits(&a), bits(&b), "{method}");
    }
}

/// A black quad 0.5 in front of the camera covers the view's centre; a near clip plane at 1
/// hides it: `path`, `light` and `vcm` (direct light only, so that the quad's lit back cannot
/// light the scene) render what they render without it, and without the plane it darkens the
/// image.
#[test]
fn near_clip_hides_what_is_closer() {
    let occluder = OCCLUDER;
    let open = scene(&lit_quad(""));
    let clipped = scene(&(lit_quad("near_clip = 1.0") + occluder));
    let blocked = scene(&(lit_quad("") + occluder));
    assert_eq!(clipped.camera.near_clip, 1.0, "a plane that clips something is kept");
    assert_eq!(
        scene(&lit_quad("near_clip = 1.0")).camera.near_clip,
        0.0,
        "a plane before the whole scene clips nothing"
    );
    // `vcm` also checks that its camera MIS counts the lens-to-plane distance of the first
    // segment: without it the weights of the clipped render would differ.
    for method in ["path", "light", "vcm"] {
        let direct = |s: &Scene| {
            let mut opts = RenderOptions::for_method(s, create(method).unwrap().as_ref(), 16);
            opts.params.max_depth = 1;
            opts.sampler = SamplerKind::Independent;
            render_opts(s, method, &opts).image
        };
        let (want, got, dark) = (direct(&open), direct(&clipped), direct(&blocked));
        let sum = |i: &Image| i.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>();
        for (i, (a, b)) in want.pixels.iter().zip(&got.pixels).enumerate() {
            // The same random numbers; only the rays' origins moved to the plane (roundoff).
            assert!(
                (*a - *b).abs().max_element() <= 1e-4 * a.max_element().max(1e-3),
                "{method}: pixel {i}: {a} vs {b}"
            );
        }
        assert!(sum(&dark) < 0.9 * sum(&want), "{method}: the quad must block without the clip plane");
        assert!(want.pixels.iter().zip(&got.pixels).any(|(a, _)| *a != Vec3::ZERO));
    }
}

/// Bad filters, crop windows and clip planes are refused with the field named.
#[test]
fn bad_filters_crops_and_clip_planes_are_refused_at_their_field() {
    for (line, needle) in [
        (r#"filter = "mitchell""#, "unknown filter `mitchell`"),
        (r#"filter = { type = "box", radius = 2.0 }"#, "not a parameter of the `box` filter"),
        (r#"filter = { type = "tent", stddev = 2.0 }"#, "not a parameter of the `tent` filter"),
        (r#"filter = { type = "gaussian", radius = 2.0 }"#, "give `stddev`"),
        (r#"filter = { type = "tent", radius = -1.0 }"#, "radius"),
        (r#"filter = { type = "gaussian", stddev = 9.0 }"#, "at most 16 px"),
        (r#"filter = { type = "tent", size = 1.0 }"#, "size"),
        ("crop = { offset = [10, 0], size = [7, 6] }", "reaches past the 16×16 film"),
        ("crop = { size = [0, 6] }", "at least 1"),
        ("near_clip = -1.0", "near_clip"),
    ] {
        let err = load_str(&lit_quad(line), "bad.toml", None)
            .err()
            .unwrap_or_else(|| panic!("{line} was accepted"));
        let message = err.to_string();
        assert!(message.contains(needle), "{line}: {message}");
        assert!(message.contains("bad.toml:7"), "{line}: the line is named: {message}");
    }
}

/// The wavefront engine's camera across lanes places its samples through the scalar camera's
/// filter function, and leaves a clipped camera's rays to the scalar camera: both engines of
/// `path` render the same bits with each filter, and with a near clip plane that hides
/// [`OCCLUDER`].
#[test]
fn both_engines_of_path_place_filtered_samples_alike() {
    let clipped = lit_quad(&format!("{TENT}\nnear_clip = 1.0")) + OCCLUDER;
    for text in [lit_quad(TENT), lit_quad(GAUSSIAN), clipped] {
        let s = scene(&text);
        let line = s.camera.filter.describe();
        let path = create("path").unwrap();
        let opts = RenderOptions::for_method(&s, path.as_ref(), 8);
        let engine = path.engine(&s, &opts).describe();
        assert!(engine.contains("every stage across"), "{engine}");
        let lanes = render(&s, "path", 8, 9, EngineOption::Auto);
        let scalar = render(&s, "path", 8, 9, EngineOption::Scalar);
        assert_eq!(bits(&lanes), bits(&scalar), "{line}");
    }
}
