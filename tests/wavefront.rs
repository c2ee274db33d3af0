//! The wavefront engine of `path` against the scalar one (`--engine scalar`, the reference):
//! the same image to the bit on every shipped scene, agreement within noise between independent
//! renders, closed forms through the stages that run across lanes, thread-count invariance, and
//! what the engine choice says and refuses.

#[path = "../benches/common/mod.rs"]
mod bench_common;
mod common;

use common::{block_chi2, toml_files};
use glam::Vec3;
use std::path::Path;
use std::process::Command;
use vitrum::image::Image;
use vitrum::integrators::{create, EngineOption};
use vitrum::render::{render, Budget, RenderOptions, RenderOutput};
use vitrum::sampler::SamplerKind;
use vitrum::scene::{load, load_str, Scene};

/// A render of `scene` by `path` with `engine`: `size`², `spp` samples, `seed`, `sampler`.
fn path_render(
    scene: &Scene,
    engine: EngineOption,
    size: u32,
    spp: u32,
    seed: u64,
    sampler: SamplerKind,
) -> RenderOutput {
    let path = create("path").unwrap();
    let mut opts = RenderOptions::for_method(scene, path.as_ref(), spp);
    opts.resolution = Some((size, size));
    opts.params.engine = engine;
    opts.seed = seed;
    opts.sampler = sampler;
    render(scene, path.as_ref(), &opts, &|_, _| {})
}

/// The engine `path` runs on `scene` with `engine` asked for and the scene's own settings.
fn describe(scene: &Scene, engine: EngineOption) -> String {
    let path = create("path").unwrap();
    let mut opts = RenderOptions::for_method(scene, path.as_ref(), 1);
    opts.params.engine = engine;
    path.engine(scene, &opts).describe()
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn shipped_scenes() -> Vec<std::path::PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files = toml_files(&root);
    files.extend(toml_files(&root.join("hard")));
    files
}

#[test]
fn both_engines_render_every_shipped_scene_to_the_same_bits() {
    // The wavefront engine runs the scalar engine's vertex step (or its lane form, tested bit for
    // bit against it) with the same random numbers, and its lane hit tests return the scalar
    // tests' distances: so the images, ray counts and sampler requests are the same. With the
    // Sobol' sampler every scene whose effects allow runs every stage across lanes: the set is
    // stated, so that a scene leaving it (or joining it) is a decision, not an accident.
    let (mut across_lanes, mut every_vertex) = (Vec::new(), Vec::new());
    for file in shipped_scenes() {
        let scene = load(&file).unwrap();
        let name = file.file_name().unwrap().to_string_lossy();
        let mut runs = Vec::new();
        for engine in [EngineOption::Scalar, EngineOption::Wavefront] {
            let path = create("path").unwrap();
            let mut opts = RenderOptions::for_method(&scene, path.as_ref(), 4);
            opts.resolution = Some((20, 20));
            opts.params.engine = engine;
            runs.push(vitrum::render::camera_pass(&scene, path.as_ref(), &opts, &|_, _| {}));
        }
        let [(scalar, scalar_requests), (wavefront, wavefront_requests)] = [runs.remove(0), runs.remove(0)];
        let (a, b) = (bits(&scalar.image), bits(&wavefront.image));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert_eq!(differing, 0, "{name}: {differing} of {} pixels differ", a.len());
        assert_eq!(scalar.rays, wavefront.rays, "{name}: ray counts");
        assert_eq!(scalar_requests, wavefront_requests, "{name}: sampler requests");
        assert!(scalar.rays.total() > 400, "{name}: the render traces rays");
        let how = describe(&scene, EngineOption::Wavefront);
        if how.contains("every stage across") {
            across_lanes.push(name.to_string());
        }
        if !how.contains("lane by lane") {
            every_vertex.push(name.to_string());
        }
    }
    // Every shipped scene runs every stage across lanes.
    let mut shipped: Vec<String> =
        shipped_scenes().iter().map(|f| f.file_name().unwrap().to_string_lossy().to_string()).collect();
    shipped.sort();
    across_lanes.sort();
    assert_eq!(across_lanes, shipped, "the shipped scenes that run every stage across lanes");
    // These shade every vertex from the lanes' tables; the others send what has no lane form
    // yet (and the test above proves it gives the same bits) lane by lane to the scalar world.
    every_vertex.sort();
    let expected = [
        "camera-on-surface.toml",
        "coincident-quads.toml",
        "coloured-glass.toml",
        "cornell-glass.toml",
        "depth-of-field.toml",
        "drinking-glass.toml",
        "glass-bowl.toml",
        "grazing-cylinder.toml",
        "grazing-sphere.toml",
        "hollow-spheres.toml",
        "ior-one.toml",
        "light-behind-camera.toml",
        "small-glass-ball-far-light.toml",
        "soft-shadows.toml",
        "thin-coating.toml",
    ];
    assert_eq!(every_vertex, expected, "the shipped scenes whose every vertex has a lane form");
}

#[test]
fn every_sampler_and_the_spectral_mode_give_the_scalar_bits_across_lanes() {
    // The other samplers draw lane by lane from each path's own stream; spectral renders and
    // moving objects shade every vertex lane by lane; the mixed scenes send some materials and
    // lights lane by lane and keep the rest in the tables. All of them: the scalar engine's bits.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["cornell-glass", "metals", "glass-in-sky", "glass-of-water", "motion-blur", "textured-box"] {
        let scene = load(&root.join(format!("{name}.toml"))).unwrap();
        for sampler in SamplerKind::ALL {
            let [scalar, wavefront] = [EngineOption::Scalar, EngineOption::Wavefront]
                .map(|engine| path_render(&scene, engine, 16, 3, 5, sampler));
            assert!(describe(&scene, EngineOption::Wavefront).contains("every stage across lanes"));
            let (a, b) = (bits(&scalar.image), bits(&wavefront.image));
            let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            assert_eq!(differing, 0, "{name}, {}: {differing} of {} pixels differ", sampler.name(), a.len());
            assert_eq!(scalar.rays, wavefront.rays, "{name}, {}: ray counts", sampler.name());
        }
    }
}

#[test]
fn rough_dispersive_glass_gives_the_scalar_bits_across_lanes() {
    // frosted-glass in bk7: hero-wavelength MIS at its rough glass and the branches of multiple
    // scattering, lane by lane, with every sampler.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let text = std::fs::read_to_string(root.join("frosted-glass.toml"))
        .unwrap()
        .replace("ior = 1.52", "ior = \"bk7\"");
    let scene = load_str(&text, "frosted-glass in bk7", Some(&root)).unwrap();
    for sampler in SamplerKind::ALL {
        let [scalar, wavefront] = [EngineOption::Scalar, EngineOption::Wavefront]
            .map(|engine| path_render(&scene, engine, 16, 3, 5, sampler));
        assert!(scalar.spectral);
        let (a, b) = (bits(&scalar.image), bits(&wavefront.image));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert_eq!(differing, 0, "{}: {differing} of {} pixels differ", sampler.name(), a.len());
        assert_eq!(scalar.rays, wavefront.rays, "{}: ray counts", sampler.name());
    }
}

#[test]
fn independent_renders_of_the_two_engines_agree_within_noise() {
    // Different seeds: the images differ by their noise alone. χ² of the 8×8 block means in
    // their variances (per-pixel s²/n, which overestimates the error of the Sobol' sampler's
    // stratified samples, so the statistic is smaller than a χ² on the block count would be):
    // the bound is the 99.9% quantile of χ² with 36 degrees of freedom, 67.99.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["soft-shadows", "cornell-glass", "hollow-spheres"] {
        let scene = load(&root.join(format!("{name}.toml"))).unwrap();
        let render = |engine, seed| {
            let out = path_render(&scene, engine, 48, 64, seed, SamplerKind::Sobol);
            assert_eq!(out.non_finite_samples, 0);
            (out.image, out.variance.expect("64 samples keep a variance"))
        };
        let (chi2, blocks) =
            block_chi2(&render(EngineOption::Wavefront, 1), &render(EngineOption::Scalar, 2));
        assert_eq!(blocks, 36, "{name}");
        assert!(chi2 < 67.99, "{name}: χ² {chi2:.1} over {blocks} blocks");
        // The same seed gives the same image (so the test above compares noise, not bias).
        let (a, b) = (render(EngineOption::Wavefront, 3), render(EngineOption::Scalar, 3));
        assert_eq!(bits(&a.0), bits(&b.0), "{name}");
    }
}

/// The mean of `image` over its pixels and channels, with the standard error of that mean from
/// the pixels' own spread (the pixels see the same expected value).
fn mean_and_error(image: &Image) -> (f64, f64) {
    let values: Vec<f64> = image.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).collect();
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// A render of the scene `text` by `path` (`auto` engine, which must run every stage across
/// lanes), 32×32 at 64 samples with the Sobol' sampler: its image mean with its standard error,
/// and the render.
fn across_lanes(text: &str, seed: u64) -> (f64, f64, RenderOutput) {
    let scene = load_str(text, "closed form", None).unwrap();
    let engine = describe(&scene, EngineOption::Auto);
    assert!(engine.contains("every stage across"), "{engine}");
    let out = path_render(&scene, EngineOption::Auto, 32, 64, seed, SamplerKind::Sobol);
    let (mean, error) = mean_and_error(&out.image);
    assert!(error > 0.0, "a noiseless render would pass trivially");
    (mean, error, out)
}

#[test]
fn light_through_a_glass_slab_matches_the_closed_form_across_lanes() {
    // A quad light of radiance (2, 1, 0.5) seen through a clear slab of index 1.5 at near-normal
    // incidence (the view is 10° wide): every path that gets through carries the light's radiance
    // (the two refractions' η² cancel), and the fraction that does is (1−R)/(1+R), R = 0.04.
    let (mean, error, out) = across_lanes(&common::glass_slab(1.5, [0.0; 3]), 7);
    let r = 0.04f64;
    let expected = (2.0 + 1.0 + 0.5) / 3.0 * (1.0 - r) / (1.0 + r);
    assert!(error < 0.01, "standard error {error}");
    // 4 standard errors, plus R's change over the view's 5° (below 1e-4 of the result).
    assert!((mean - expected).abs() < 4.0 * error + 1e-4, "{mean} ± {error}, expected {expected}");
    assert!(out.rays.refracted > 0 && out.rays.reflected > 0, "{:?}", out.rays);
}

/// The irradiance at a point at height `h` below a corner of a parallel rectangle `a` × `b` of
/// Lambertian radiance `l` (π·L times the point-to-rectangle form factor).
fn corner_irradiance(l: f64, a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    l / 2.0 * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
}

#[test]
fn a_floor_under_a_quad_light_matches_the_form_factor_across_lanes() {
    // A diffuse floor (albedo 0.5) under a 1 × 0.6 quad light of radiance 3 at height 0.8; the
    // camera looks straight down at the point below the light's centre through a 0.5° view,
    // between the two. Nothing else reflects (the light's own surface is black), so the floor's
    // radiance is (ρ/π)·E: next-event estimation and BSDF sampling weighted by MIS, across lanes.
    let text = r#"
[camera]
position = [0.0, 0.4, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov = 0.5
resolution = [32, 32]
[materials.floor]
type = "diffuse"
color = 0.5
[[objects]]
shape = "quad"
corner = [-20.0, 0.0, -20.0]
u = [0.0, 0.0, 40.0]
v = [40.0, 0.0, 0.0]
material = "floor"
[[lights]]
type = "quad"
corner = [-0.5, 0.8, -0.3]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, 0.6]
radiance = 3.0
"#;
    let (mean, error, out) = across_lanes(text, 11);
    // Four rectangles of 0.5 × 0.3 meet above the centre.
    let irradiance = 4.0 * corner_irradiance(3.0, 0.5, 0.3, 0.8);
    let expected = 0.5 / std::f64::consts::PI * irradiance;
    assert!(error > 0.0 && error < 0.01 * expected, "standard error {error}");
    // The view spans ±0.0017 around the centre, where E changes by under 1e-5 of itself.
    assert!((mean - expected).abs() < 4.0 * error + 1e-5 * expected, "{mean} ± {error}, expected {expected}");
    assert!(out.rays.shadow > 0, "{:?}", out.rays);
}

#[test]
fn the_engine_is_chosen_by_what_the_scene_calls_for_and_says_why() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = |name: &str| load(&root.join(format!("{name}.toml"))).unwrap();
    // Quad lights, diffuse walls, smooth glass: every stage across lanes.
    let soft = describe(&scene("soft-shadows"), EngineOption::Auto);
    assert!(
        soft.starts_with("wavefront (every stage across lanes") && !soft.contains("lane by lane"),
        "{soft}"
    );
    // The thesis's scene, a point light: every stage across lanes too.
    let point = describe(&scene("cornell-glass"), EngineOption::Auto);
    assert!(point.contains("every stage across"), "{point}");
    // A rough mirror and rough glass: every stage across lanes, their vertices lane by lane
    // through the scalar world, and auto runs it (hits by testing every primitive).
    let frosted = describe(&scene("frosted-glass"), EngineOption::Auto);
    assert!(
        frosted.starts_with("wavefront (every stage across lanes")
            && frosted.contains("lane by lane")
            && frosted.contains("(a mirror)")
            && frosted.contains("(rough glass)"),
        "{frosted}"
    );
    // Meshes: the BVH traversed by 16 camera rays, bounces one by one, the vertices from the
    // tables but their hit records lane by lane (bit for bit the scalar engine's: the first
    // test); auto runs it and says what goes lane by lane.
    for name in ["smooth-glass", "hard/bowl-of-liquid"] {
        let auto = describe(&scene(name), EngineOption::Auto);
        assert!(
            auto.starts_with("wavefront (every stage across lanes")
                && auto.contains("the BVH traversed by 16 camera rays at once, bounces one by one")
                && auto.contains("the hit records: "),
            "{auto}"
        );
    }
    // Moving objects: no lane kernels, each ray through the BVH at its time, the vertices from
    // the tables: auto runs the wavefront engine (measured ahead) and says why.
    let motion = describe(&scene("motion-blur"), EngineOption::Auto);
    assert!(motion.starts_with("wavefront (") && motion.contains("motion blur"), "{motion}");
    // A spectral render: every vertex lane by lane, auto keeps the scalar engine.
    let water = describe(&scene("glass-of-water"), EngineOption::Auto);
    assert!(water.starts_with("scalar:") && water.contains("wavelengths"), "{water}");
    // --engine wavefront runs it anyway (each ray through the BVH at its time), --engine
    // scalar never.
    let asked = describe(&scene("motion-blur"), EngineOption::Wavefront);
    assert!(asked.contains("each ray through the BVH on its own"), "{asked}");
    assert!(describe(&scene("soft-shadows"), EngineOption::Scalar).starts_with("scalar: --engine scalar"));
    // Another sampler draws lane by lane from each path's own stream.
    let path = create("path").unwrap();
    let mut opts = RenderOptions::for_method(&scene("soft-shadows"), path.as_ref(), 1);
    opts.sampler = SamplerKind::Independent;
    let independent = path.engine(&scene("soft-shadows"), &opts).describe();
    assert!(independent.contains("independent sampler"), "{independent}");
    // The other methods have one engine.
    let whitted = create("whitted").unwrap();
    let opts = RenderOptions::for_method(&scene("soft-shadows"), whitted.as_ref(), 1);
    assert_eq!(whitted.engine(&scene("soft-shadows"), &opts).name(), "scalar");
    let _ = Budget::Samples(1);
    let _ = Vec3::ZERO;
}

/// Beyond 4,096 primitives `auto` keeps the scalar engine (the BVH's traversal dominates, where
/// the wavefront engine measured slower); `--engine wavefront` still runs it, with the same bits.
/// The scenes are the terrains `integrators/wavefront.rs` measured the threshold on.
#[test]
fn auto_keeps_one_ray_at_a_time_for_large_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let terrain = |triangles: usize| {
        let sub = dir.path().join(triangles.to_string());
        std::fs::create_dir(&sub).unwrap();
        let (vertices, faces) = bench_common::terrain(triangles);
        load(&bench_common::write_terrain_scene(&sub, &vertices, &faces)).unwrap()
    };
    // 2·45² = 4,050 triangles: still the wavefront engine; 2·46² = 4,232: scalar.
    let small = describe(&terrain(4050), EngineOption::Auto);
    assert!(small.starts_with("wavefront ("), "{small}");
    let large = terrain(4232);
    let auto = describe(&large, EngineOption::Auto);
    assert!(auto.starts_with("scalar: 4232 primitives: through a BVH of more than 4096"), "{auto}");
    assert!(describe(&large, EngineOption::Wavefront).starts_with("wavefront ("));
    let images: Vec<_> = [EngineOption::Auto, EngineOption::Wavefront]
        .map(|engine| {
            let path = create("path").unwrap();
            let mut opts = RenderOptions::for_method(&large, path.as_ref(), 2);
            opts.params.engine = engine;
            opts.resolution = Some((16, 16));
            bits(&render(&large, path.as_ref(), &opts, &|_, _| {}).image)
        })
        .into();
    assert_eq!(images[0], images[1], "the engines give the same bits");
}

fn vitrum(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).output().expect("the vitrum binary runs")
}

#[test]
fn the_command_line_chooses_and_reports_the_engine() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/soft-shadows.toml");
    let scene = scene.to_str().unwrap();
    let mut images = Vec::new();
    for (engine, threads) in [("scalar", "2"), ("wavefront", "1"), ("auto", "2")] {
        let out_path = dir.path().join(format!("{engine}.exr"));
        let out = vitrum(&[
            "render",
            scene,
            "-i",
            "path",
            "--spp",
            "2",
            "--resolution",
            "24x24",
            "--engine",
            engine,
            "--threads",
            threads,
            "--json",
            "-o",
            out_path.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let name = summary["engine"]["name"].as_str().unwrap().to_string();
        assert_eq!(name, if engine == "scalar" { "scalar" } else { "wavefront" }, "{summary}");
        assert!(!summary["engine"]["reason"].as_str().unwrap().is_empty());
        images.push(vitrum::output::exr::read_exr(&out_path).unwrap().0);
    }
    // Either engine, any thread count: the same pixels.
    assert!(images.windows(2).all(|w| bits(&w[0]) == bits(&w[1])));
    // The text summary names the engine.
    let out = vitrum(&[
        "render",
        scene,
        "-i",
        "path",
        "--spp",
        "1",
        "--resolution",
        "8x8",
        "-o",
        dir.path().join("t.exr").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("engine: wavefront (every stage across lanes"), "{stderr}");
    // A method without a wavefront engine refuses --engine wavefront, writing nothing.
    let refused = dir.path().join("refused.exr");
    let out =
        vitrum(&["render", scene, "-i", "whitted", "--engine", "wavefront", "-o", refused.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no wavefront engine"));
    assert!(!refused.exists());
    // An unknown engine is refused by the parser.
    let out = vitrum(&["render", scene, "--engine", "gpu"]);
    assert_eq!(out.status.code(), Some(2));
    // vitrum info says which engine path runs, and why.
    let out = vitrum(&["info", scene]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("path engine: wavefront"), "{text}");
    let out = vitrum(&["info", scene, "--json"]);
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(info["path_engine"]["name"], "wavefront", "{info}");
}

/// Rays through `scene` the way a path meets it: camera rays through a grid of pixels, rays in
/// uniform directions from points inside the scene's bounds, and rays leaving the camera rays'
/// hits (spawned as the integrators spawn them, a hair off the surface, so that neighbouring
/// triangles and shared edges are met at distances near zero).
fn probe_rays(scene: &Scene, count: usize, seed: u64) -> Vec<vitrum::geometry::Ray> {
    use rand::{RngExt, SeedableRng};
    use vitrum::geometry::{spawn_origin, Ray};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    let (lo, hi) = scene.bvh_stats.bounds;
    let mut unit =
        || Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5);
    let mut rays = Vec::with_capacity(count);
    let side = (count as f32 / 3.0).sqrt() as u32;
    for i in 0..side * side {
        let film = glam::Vec2::new((i % side) as f32 + 0.5, (i / side) as f32 + 0.5) / side as f32;
        let camera = scene.camera.generate_ray(film);
        rays.push(camera);
        if let Some(hit) = scene.intersect(&camera, f32::INFINITY) {
            let d = unit().normalize_or(Vec3::Y);
            rays.push(Ray::new(spawn_origin(&hit.hit, d), d));
        }
    }
    while rays.len() < count {
        let o = lo + (hi - lo) * (unit() + 0.5);
        rays.push(Ray::new(o, unit().normalize_or(Vec3::Y)));
    }
    rays
}

#[test]
fn the_bvh_across_lanes_finds_the_scalar_hits_and_blockers_to_the_bit() {
    // Mesh scenes (smooth-glass's 968 triangles with vertex normals, the bowl of liquid's 2449),
    // the shapes gallery (a mesh, a polygon, inward cylinders among 46 primitives) and polygons
    // (scale-1), all through the BVH across lanes: every lane's closest hit is the
    // scalar engine's (distance, primitive, barycentrics, so the same hit record), and every
    // shadow ray is blocked exactly when the scalar traversal says so, on every instruction set.
    use vitrum::lanes::{Isa, LaneScene, RayLanes, WIDTH};
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["smooth-glass", "hard/bowl-of-liquid", "shapes-gallery", "hard/scale-1"] {
        let scene = load(&root.join(format!("{name}.toml"))).unwrap();
        let rays = probe_rays(&scene, 3 * 4096, 17);
        let size = (scene.bvh_stats.bounds.1 - scene.bvh_stats.bounds.0).length();
        for isa in Isa::available() {
            let lanes = LaneScene::new(&scene, isa).unwrap();
            assert!(lanes.traverses_bvh(), "{name}: {}", lanes.method());
            let (mut hits, mut blocked) = (0, 0);
            for (b, batch) in rays.chunks(WIDTH).enumerate() {
                let packed = RayLanes::gather(batch);
                // Some lanes idle, some limited, most unlimited.
                let tmax: [f32; WIDTH] = std::array::from_fn(|k| match (b + k) % 7 {
                    0 if k < batch.len() => 0.7,
                    _ if k < batch.len() => f32::INFINITY,
                    _ => -1.0,
                });
                let found = lanes.closest(&packed, &tmax);
                for (k, ray) in batch.iter().enumerate() {
                    let want = scene.intersect(ray, tmax[k]);
                    let got = found.t[k]
                        .is_finite()
                        .then(|| scene.record(ray, found.t[k], found.primitive[k], found.bary[k]));
                    match (want, got) {
                        (None, None) => {}
                        (Some(w), Some(g)) => {
                            assert_eq!(
                                (w.primitive, w.hit.t.to_bits()),
                                (g.primitive, g.hit.t.to_bits()),
                                "{name} {isa:?} {ray:?}"
                            );
                            let record = |h: &vitrum::geometry::SurfaceHit| {
                                [h.p, h.n, h.shading_n, h.uv.extend(h.p_error)]
                                    .map(|v| v.to_array().map(f32::to_bits))
                            };
                            assert_eq!(record(&w.hit), record(&g.hit), "{name} {isa:?} {ray:?}");
                            hits += 1;
                        }
                        (w, g) => panic!("{name} {isa:?} {ray:?}: scalar {w:?}, lanes {g:?}"),
                    }
                }
                // Shadow segments of a 40th and a third of the scene's size that every primitive
                // blocks.
                let seg: [f32; WIDTH] = std::array::from_fn(|k| {
                    if k < batch.len() {
                        size * [0.025, 0.33][(b + k) % 2]
                    } else {
                        -1.0
                    }
                });
                let got = lanes.occluded(&packed, &seg, &[u32::MAX; WIDTH], &[f32::INFINITY; WIDTH]);
                for (k, ray) in batch.iter().enumerate() {
                    let want = scene.occluded(ray, seg[k], |_, _| true);
                    assert_eq!(got[k], want, "{name} {isa:?} {ray:?} within {}", seg[k]);
                    blocked += want as usize;
                }
            }
            // Both outcomes are common, so each comparison is tested both ways.
            assert!(
                hits > rays.len() / 4 && blocked > rays.len() / 20 && blocked < rays.len() * 19 / 20,
                "{name}: {hits} hits, {blocked} blocked of {}",
                rays.len()
            );
        }
    }
}

#[test]
fn coincident_surfaces_through_the_bvh_across_lanes_go_to_the_first_compiled() {
    // 70 copies of one quad and 10 of a sphere, written identically (more than the 64 tested one
    // by one, so the BVH is traversed across lanes): of hits at exactly the same distance the
    // primitive compiled first wins, as in the scalar traversal, whatever the order the lanes
    // visit the leaves in.
    use vitrum::lanes::{Isa, LaneScene, RayLanes, WIDTH};
    let mut text = String::from(
        "[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 60.0\n\
         [materials.grey]\ntype = \"diffuse\"\ncolor = 0.5\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 2.0]\nintensity = 1.0\n",
    );
    for _ in 0..70 {
        text += "[[objects]]\nshape = \"quad\"\ncorner = [-1.0, -1.0, 0.0]\nu = [2.0, 0.0, 0.0]\nv = [0.0, 2.0, 0.0]\nmaterial = \"grey\"\n";
    }
    for _ in 0..10 {
        text +=
            "[[objects]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.2]\nradius = 0.3\nmaterial = \"grey\"\n";
    }
    let scene = load_str(&text, "coincident", None).unwrap();
    assert_eq!(scene.primitives.len(), 80);
    let rays = probe_rays(&scene, 4096, 3);
    for isa in Isa::available() {
        let lanes = LaneScene::new(&scene, isa).unwrap();
        assert!(lanes.traverses_bvh());
        let mut hits = 0;
        for batch in rays.chunks(WIDTH) {
            let found = lanes.closest(&RayLanes::gather(batch), &[f32::INFINITY; WIDTH]);
            for (k, ray) in batch.iter().enumerate() {
                let want = scene.intersect(ray, f32::INFINITY).map(|h| (h.primitive, h.hit.t.to_bits()));
                let got = found.t[k].is_finite().then(|| (found.primitive[k], found.t[k].to_bits()));
                assert_eq!(got, want, "{isa:?} {ray:?}");
                if let Some((p, _)) = want {
                    // The first copy of its shape.
                    let rank = scene.compile_rank(p);
                    assert!(rank == 0 || rank == 70, "rank {rank}");
                    hits += 1;
                }
            }
        }
        assert!(hits > rays.len() / 4, "{hits} hits");
    }
}
