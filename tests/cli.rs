//! The `vitrum` binary end to end: every bad input exits with code 2 and a message on stderr that
//! names the problem (and, for scene files, its line and field), without panicking and without
//! leaving an output file or a temporary file behind; and the good paths print and write what
//! they promise.

use serde_json::Value;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};
use tempfile::TempDir;

/// The scene every scene-file case mutates (also the embedded default scene).
const CORNELL: &str = include_str!("../scenes/cornell-glass.toml");

/// A temporary folder with an empty `out/` folder for the images.
struct Sandbox {
    dir: TempDir,
}

impl Sandbox {
    fn new() -> Sandbox {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir(dir.path().join("out")).unwrap();
        Sandbox { dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// The output folder.
    fn out(&self) -> PathBuf {
        self.path("out")
    }

    /// Write `text` as `scene.toml` and return its path.
    fn scene(&self, text: &str) -> PathBuf {
        let path = self.path("scene.toml");
        fs::write(&path, text).unwrap();
        path
    }

    /// The names of the files in the output folder.
    fn out_files(&self) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(self.out())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into())
            .collect();
        names.sort();
        names
    }
}

/// Run the binary with `args`.
fn vitrum<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).output().expect("the vitrum binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `CORNELL` with its one line that starts with `prefix` (ignoring indentation) replaced by
/// `replacement`, and the 1-based number of that line.
fn with_line(prefix: &str, replacement: &str) -> (String, usize) {
    let hits: Vec<usize> = CORNELL
        .lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(prefix))
        .map(|(i, _)| i)
        .collect();
    assert_eq!(hits.len(), 1, "`{prefix}` must start exactly one line of cornell-glass.toml");
    let text: Vec<&str> =
        CORNELL.lines().enumerate().map(|(i, l)| if i == hits[0] { replacement } else { l }).collect();
    (text.join("\n") + "\n", hits[0] + 1)
}

/// Render `scene` (a path, or the default scene when `None`) into the sandbox's output folder
/// as `out/image.exr` plus `out/image.png`, quiet, at 32×32 unless `extra` sets `--resolution`.
fn render(sandbox: &Sandbox, scene: Option<&Path>, extra: &[&str]) -> Output {
    let mut args: Vec<String> = vec!["render".into()];
    args.extend(scene.map(|p| p.display().to_string()));
    for a in ["-o", "out/image.exr", "--png", "out/image.png", "--quiet"] {
        args.push(a.into());
    }
    if !extra.contains(&"--resolution") {
        args.extend(["--resolution".into(), "32x32".into()]);
    }
    args.extend(extra.iter().map(|s| s.to_string()));
    Command::new(env!("CARGO_BIN_EXE_vitrum"))
        .current_dir(sandbox.dir.path())
        .args(&args)
        .output()
        .expect("the vitrum binary runs")
}

/// A refused input: exit code 2, every `needles` in the message on stderr, no panic, and nothing
/// (no image, no temporary file) in the output folder.
fn assert_refused(sandbox: &Sandbox, out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "exit code; stderr:\n{err}");
    assert!(!err.contains("panicked"), "panic:\n{err}");
    for n in needles {
        assert!(err.contains(n), "stderr should contain {n:?}:\n{err}");
    }
    assert!(sandbox.out_files().is_empty(), "files left in the output folder: {:?}", sandbox.out_files());
}

/// Render the scene `text` and expect a refusal whose message names `scene.toml:LINE:`, `field`
/// and every `needles`.
fn assert_scene_error_at(text: &str, line: usize, field: &str, needles: &[&str]) {
    let sandbox = Sandbox::new();
    let scene = sandbox.scene(text);
    let out = render(&sandbox, Some(&scene), &[]);
    let location = format!("scene.toml:{line}:");
    let field = format!("field `{field}`");
    let mut all = vec![location.as_str(), field.as_str()];
    all.extend_from_slice(needles);
    assert_refused(&sandbox, &out, &all);
}

/// Replace the line of the Cornell scene starting with `prefix` by `replacement` and expect a
/// refusal that names that line, `field` and every `needles`.
fn assert_scene_error(prefix: &str, replacement: &str, field: &str, needles: &[&str]) {
    let (text, line) = with_line(prefix, replacement);
    assert_scene_error_at(&text, line, field, needles);
}

// ---- scene files -------------------------------------------------------------------------

#[test]
fn missing_scene_file_names_the_path() {
    let sandbox = Sandbox::new();
    let out = render(&sandbox, Some(&sandbox.path("no-such-scene.toml")), &[]);
    assert_refused(&sandbox, &out, &["no-such-scene.toml", "cannot read the scene file"]);
}

#[test]
fn toml_syntax_error() {
    let (text, line) = with_line("ior = 1.52", "ior = 1.52 ]");
    let sandbox = Sandbox::new();
    let out = render(&sandbox, Some(&sandbox.scene(&text)), &[]);
    // A syntax error belongs to no field: the message goes straight after the position.
    let location = format!("scene.toml:{line}:12: TOML syntax error");
    assert_refused(&sandbox, &out, &[&location]);
}

#[test]
fn unknown_field_in_a_sphere() {
    assert_scene_error("radius = 0.4", "radiu = 0.4", "objects[5].radiu", &["unknown field `radiu`"]);
}

#[test]
fn unknown_field_without_spaces() {
    assert_scene_error("radius = 0.4", "radiu=0.4", "objects[5].radiu", &["unknown field `radiu`"]);
}

#[test]
fn unknown_field_in_a_material() {
    assert_scene_error("color = 0.73", "colr = 0.73", "materials.white.colr", &["unknown field `colr`"]);
}

#[test]
fn unknown_field_in_an_inline_texture() {
    assert_scene_error(
        "texture = {",
        r#"texture = { type = "checker", color1 = 0.75, color2 = 0.25, sise = 0.25 }"#,
        "materials.floor.texture.sise",
        &["unknown field `sise`"],
    );
}

#[test]
fn unknown_field_in_a_light() {
    assert_scene_error("intensity = 5.0", "intensitty = 5.0", "lights[0].intensitty", &["unknown field"]);
}

#[test]
fn wrong_type_of_sphere_radius() {
    assert_scene_error(
        "radius = 0.4",
        r#"radius = "big""#,
        "objects[5].radius",
        &["invalid type", "\"big\""],
    );
}

#[test]
fn array_given_for_sphere_radius_is_told_apart_from_the_centre_array() {
    assert_scene_error("radius = 0.4", "radius = [0.4]", "objects[5].radius", &["invalid type: sequence"]);
}

#[test]
fn wrong_type_of_light_intensity_explains_colours() {
    assert_scene_error(
        "intensity = 5.0",
        r#"intensity = "bright""#,
        "lights[0].intensity",
        &["a colour: one number (grey) or [r, g, b]"],
    );
}

#[test]
fn wrong_type_of_cylinder_flag() {
    assert_scene_error("caps = true", r#"caps = "yes""#, "objects[6].caps", &["invalid type", "boolean"]);
}

#[test]
fn wrong_type_of_material_ior() {
    assert_scene_error(
        "ior = 1.52",
        "ior = true",
        "materials.glass.ior",
        &["invalid type", "refractive index"],
    );
}

#[test]
fn unknown_glass_name_lists_the_known_glasses() {
    assert_scene_error(
        "ior = 1.52",
        r#"ior = "high""#,
        "materials.glass.ior",
        &["unknown glass `high`", "bk7"],
    );
}

#[test]
fn wrong_type_of_camera_fov() {
    assert_scene_error("fov = 39.0", r#"fov = "wide""#, "camera.fov", &["invalid type"]);
}

#[test]
fn wrong_length_of_sphere_center() {
    assert_scene_error("center = [-0.42", "center = [0.0, 1.0]", "objects[5].center", &["invalid length 2"]);
}

#[test]
fn unknown_shape() {
    assert_scene_error(
        r#"shape = "sphere""#,
        r#"shape = "spere""#,
        "objects[5].shape",
        &["`spere`", "`sphere`"],
    );
}

#[test]
fn missing_required_field_names_the_object() {
    // A missing key has no line of its own: the message points at the object's `[[objects]]`.
    let (text, _) = with_line("radius = 0.4", "# no radius");
    let name_line = 1 + text.lines().position(|l| l == r#"name = "glass sphere""#).unwrap();
    let header_line = name_line - 1;
    assert_eq!(text.lines().nth(header_line - 1), Some("[[objects]]"));
    assert_scene_error_at(&text, header_line, "objects[5]", &["missing field `radius`"]);
}

#[test]
fn negative_sphere_radius() {
    assert_scene_error("radius = 0.4", "radius = -0.4", "objects[5].radius", &["greater than 0", "-0.4"]);
}

#[test]
fn zero_ior() {
    assert_scene_error("ior = 1.52", "ior = 0", "materials.glass.ior", &["greater than 0"]);
    assert_scene_error("ior = 1.52", "ior = 0.0", "materials.glass.ior", &["greater than 0"]);
}

#[test]
fn negative_ior() {
    assert_scene_error("ior = 1.52", "ior = -1.5", "materials.glass.ior", &["greater than 0", "-1.5"]);
}

#[test]
fn nan_radius() {
    assert_scene_error("radius = 0.4", "radius = nan", "objects[5].radius", &["NaN", "finite"]);
}

#[test]
fn infinite_radius() {
    assert_scene_error("radius = 0.4", "radius = inf", "objects[5].radius", &["inf", "finite"]);
    assert_scene_error("radius = 0.4", "radius = -inf", "objects[5].radius", &["-inf", "finite"]);
}

#[test]
fn nan_inside_an_array() {
    assert_scene_error(
        "position = [0.0, 1.0, 3.8]",
        "position = [0.0, nan, 3.8]",
        "camera.position[1]",
        &["NaN"],
    );
}

#[test]
fn huge_number() {
    assert_scene_error("radius = 0.4", "radius = 1e40", "objects[5].radius", &["too large"]);
}

#[test]
fn negative_colour() {
    assert_scene_error("intensity = 5.0", "intensity = -5.0", "lights[0].intensity", &["0 or greater"]);
}

#[test]
fn zero_resolution() {
    assert_scene_error(
        "resolution = [800, 800]",
        "resolution = [0, 64]",
        "camera.resolution",
        &["at least 1"],
    );
}

#[test]
fn resolution_that_would_exhaust_memory_is_refused_before_allocating() {
    let start = Instant::now();
    assert_scene_error(
        "resolution = [800, 800]",
        "resolution = [60000, 60000]",
        "camera.resolution",
        &["too large"],
    );
    assert!(start.elapsed() < Duration::from_secs(10), "took {:?}", start.elapsed());
}

#[test]
fn negative_resolution() {
    assert_scene_error(
        "resolution = [800, 800]",
        "resolution = [-8, 8]",
        "camera.resolution[0]",
        &["invalid value"],
    );
}

#[test]
fn camera_up_parallel_to_the_view_direction() {
    assert_scene_error("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, -2.0]", "camera.up", &["parallel"]);
}

#[test]
fn unknown_material_lists_the_defined_ones() {
    assert_scene_error(
        r#"material = "floor""#,
        r#"material = "flor""#,
        "objects[0].material",
        &["unknown material `flor`", "floor, glass, green, red, white"],
    );
}

#[test]
fn unknown_integrator_in_the_scene_file() {
    assert_scene_error(
        r#"integrator = "whitted""#,
        r#"integrator = "pathtracer""#,
        "render.integrator",
        &["unknown integrator `pathtracer`", "raycast", "whitted"],
    );
}

// ---- command-line options ----------------------------------------------------------------

/// Render the default scene with `args` and expect a refusal naming every `needles`.
fn assert_option_error(args: &[&str], needles: &[&str]) {
    let sandbox = Sandbox::new();
    let out = render(&sandbox, None, args);
    assert_refused(&sandbox, &out, needles);
}

#[test]
fn unknown_integrator_option() {
    assert_option_error(&["-i", "nope"], &["unknown integrator `nope`", "raycast", "whitted"]);
}

#[test]
fn zero_samples_per_pixel() {
    assert_option_error(&["--spp", "0"], &["--spp 0"]);
}

#[test]
fn negative_samples_per_pixel() {
    assert_option_error(&["--spp", "-1"], &["--spp", "-1"]);
}

#[test]
fn zero_resolution_option() {
    assert_option_error(&["--resolution", "0x10"], &["--resolution", "0x10", "at least 1"]);
}

#[test]
fn malformed_resolution_option() {
    assert_option_error(&["--resolution", "abc"], &["--resolution", "abc", "WIDTHxHEIGHT"]);
}

#[test]
fn huge_resolution_option() {
    assert_option_error(&["--resolution", "60000x60000"], &["--resolution", "too large"]);
}

#[test]
fn zero_threads() {
    assert_option_error(&["--threads", "0"], &["--threads 0"]);
}

#[test]
fn reflectance_out_of_range() {
    assert_option_error(&["--reflectance", "2"], &["--reflectance 2", "[0, 1]"]);
    assert_option_error(&["--reflectance", "-0.5"], &["--reflectance -0.5", "[0, 1]"]);
    assert_option_error(&["--reflectance", "nan"], &["--reflectance NaN", "[0, 1]"]);
}

#[test]
fn non_positive_time() {
    assert_option_error(&["--time", "0"], &["--time 0"]);
    assert_option_error(&["--time", "-1"], &["--time -1"]);
}

#[test]
fn output_into_a_missing_folder() {
    let sandbox = Sandbox::new();
    let out = vitrum(&[
        "render",
        "-o",
        sandbox.path("out/missing/image.exr").to_str().unwrap(),
        "--resolution",
        "32x32",
    ]);
    assert_refused(&sandbox, &out, &["missing/image.exr", "does not exist"]);
    assert!(!sandbox.path("out/missing").exists());
}

#[test]
fn png_into_a_missing_folder() {
    let sandbox = Sandbox::new();
    let out = vitrum(&[
        "render",
        "-o",
        sandbox.path("out/image.exr").to_str().unwrap(),
        "--png",
        sandbox.path("out/missing/image.png").to_str().unwrap(),
        "--resolution",
        "32x32",
    ]);
    assert_refused(&sandbox, &out, &["missing/image.png", "does not exist"]);
}

#[test]
fn output_with_a_wrong_extension() {
    let sandbox = Sandbox::new();
    let out =
        vitrum(&["render", "-o", sandbox.path("out/image.png").to_str().unwrap(), "--resolution", "32x32"]);
    assert_refused(&sandbox, &out, &["image.png", ".exr"]);
    let out = vitrum(&[
        "render",
        "-o",
        sandbox.path("out/image.exr").to_str().unwrap(),
        "--png",
        sandbox.path("out/image.jpg").to_str().unwrap(),
        "--resolution",
        "32x32",
    ]);
    assert_refused(&sandbox, &out, &["image.jpg", ".png"]);
}

// ---- good paths --------------------------------------------------------------------------

#[test]
fn integrators_lists_raycast_and_whitted() {
    let out = vitrum(&["integrators"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let names: Vec<String> =
        stdout(&out).lines().filter_map(|l| l.split_whitespace().next().map(String::from)).collect();
    assert!(names.contains(&"raycast".to_string()), "{names:?}");
    assert!(names.contains(&"whitted".to_string()), "{names:?}");
}

#[test]
fn info_describes_the_default_scene() {
    let out = vitrum(&["info"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("<embedded default scene>"), "{text}");
    assert!(
        text.lines().any(|l| l.starts_with("bvh") && l.contains("CwBvh") && l.contains("primitives")),
        "{text}"
    );
    assert!(text.lines().any(|l| l.starts_with("effect") && l.contains("textures")), "{text}");
    assert!(text.contains("glass sphere"), "{text}");
}

#[test]
fn info_json_describes_the_bvh_and_effects() {
    let sandbox = Sandbox::new();
    // The same scene from a file, so its name is the path.
    let scene = sandbox.scene(CORNELL);
    let out = vitrum(&["info".as_ref(), "--json".as_ref(), scene.as_os_str()]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let info: Value = serde_json::from_str(&stdout(&out)).expect("one JSON object");
    assert_eq!(info["scene"], scene.display().to_string());
    assert_eq!(info["resolution"], serde_json::json!([800, 800]));
    assert_eq!(info["objects"].as_array().unwrap().len(), 7);
    let lights = info["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 1);
    assert!(lights[0]["power_watts"][0].as_f64().unwrap() > 0.0);
    let bvh = &info["bvh"];
    assert!(bvh["nodes"].as_u64().unwrap() >= 1, "{bvh}");
    assert_eq!(bvh["primitives"], 9, "5 quads, 1 sphere, a capped cylinder (3): {bvh}");
    assert!(bvh["depth"].as_u64().unwrap() >= 1, "{bvh}");
    let effects = info["effects"].as_array().unwrap();
    let textures =
        effects.iter().find(|e| e["effect"] == "textures").expect("the checker floor is a texture");
    assert!(textures["reason"].as_str().unwrap().contains("floor"), "{textures}");
    for name in ["raycast", "whitted"] {
        assert!(textures["integrators"][name].is_string(), "{textures}");
    }
}

#[test]
fn render_json_summary_and_exr_metadata() {
    let sandbox = Sandbox::new();
    let out = render(&sandbox, None, &["--json", "--spp", "2", "--seed", "7"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stderr(&out).is_empty(), "--quiet and no warnings: {}", stderr(&out));
    let text = stdout(&out);
    assert_eq!(text.lines().count(), 1, "one JSON object on one line: {text}");
    let summary: Value = serde_json::from_str(&text).expect("valid JSON");
    assert_eq!(summary["integrator"], "whitted");
    assert_eq!(summary["spp"], 2);
    assert_eq!(summary["seed"], 7);
    assert_eq!((summary["width"].as_u64(), summary["height"].as_u64()), (Some(32), Some(32)));
    assert!(summary["seconds"].as_f64().is_some_and(|s| s >= 0.0), "{summary}");
    let rays = &summary["rays"];
    let count = |k: &str| rays[k].as_u64().unwrap_or_else(|| panic!("rays.{k} in {summary}"));
    assert_eq!(count("primary"), 32 * 32 * 2, "one camera ray per pixel and sample");
    assert!(count("refracted") > 0 && count("reflected") > 0 && count("shadow") > 0, "{rays}");
    assert_eq!(count("total"), count("primary") + count("reflected") + count("refracted") + count("shadow"));

    let (image, meta) =
        vitrum::output::exr::read_exr(&sandbox.path("out/image.exr")).expect("a readable EXR");
    assert_eq!((image.width, image.height), (32, 32));
    assert_eq!(image.non_finite_count(), 0);
    for key in [
        "vitrum:integrator",
        "vitrum:spp",
        "vitrum:rays",
        "vitrum:scene",
        "vitrum:effects",
        "renderTimeSeconds",
    ] {
        assert!(meta.contains_key(key), "metadata {key} missing: {meta:?}");
    }
    assert_eq!(meta["vitrum:integrator"], "whitted");
    assert_eq!(meta["vitrum:spp"], "2");
    assert_eq!(meta["vitrum:seed"], "7");
    assert!(meta["vitrum:rays"].contains(&format!("primary={}", count("primary"))), "{meta:?}");
    assert!(meta["vitrum:scene"].starts_with("<embedded default scene>"), "{meta:?}");
    assert!(meta["vitrum:effects"].contains("textures"), "{meta:?}");
    assert!(meta["renderTimeSeconds"].parse::<f64>().is_ok_and(|s| s >= 0.0), "{meta:?}");
    assert_eq!(sandbox.out_files(), ["image.exr", "image.png"], "no temporary files left");
}

#[test]
fn png_preview_has_the_requested_size() {
    let sandbox = Sandbox::new();
    let out = render(&sandbox, None, &["--resolution", "40x24", "-i", "raycast"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let png = image::open(sandbox.path("out/image.png")).expect("a decodable PNG");
    assert_eq!((png.width(), png.height()), (40, 24));
    let (exr, meta) = vitrum::output::exr::read_exr(&sandbox.path("out/image.exr")).unwrap();
    assert_eq!((exr.width, exr.height), (40, 24));
    assert_eq!(meta["vitrum:integrator"], "raycast");
}

#[test]
fn render_of_a_scene_file_names_it_in_the_metadata() {
    let sandbox = Sandbox::new();
    let scene = sandbox.scene(CORNELL);
    let out = render(&sandbox, Some(&scene), &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let (_, meta) = vitrum::output::exr::read_exr(&sandbox.path("out/image.exr")).unwrap();
    assert!(meta["vitrum:scene"].contains("scene.toml"), "{meta:?}");
}
