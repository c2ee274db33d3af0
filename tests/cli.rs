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

mod common;

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

    /// Run the binary with `args` in the sandbox.
    fn vitrum(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_vitrum")).current_dir(self.dir.path()).args(args).output().unwrap()
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
    let location = format!("scene.toml:{line}:");
    let field = format!("field `{field}`");
    let mut all = vec![location.as_str(), field.as_str()];
    all.extend_from_slice(needles);
    assert_scene_refused(text, &all);
}

/// Render the scene `text` and expect a refusal whose message holds every `needles`; returns
/// the message.
fn assert_scene_refused(text: &str, needles: &[&str]) -> String {
    let sandbox = Sandbox::new();
    let out = render(&sandbox, Some(&sandbox.scene(text)), &[]);
    assert_refused(&sandbox, &out, needles);
    stderr(&out)
}

/// Replace the line of the Cornell scene starting with `prefix` by `replacement` and expect a
/// refusal that names that line, `field` and every `needles`.
fn assert_scene_error(prefix: &str, replacement: &str, field: &str, needles: &[&str]) {
    let (text, line) = with_line(prefix, replacement);
    assert_scene_error_at(&text, line, field, needles);
}

/// `CORNELL` with each `(prefix, replacement)` applied as by [`with_line`] (a replacement may
/// span several lines), then `extra` appended (more objects, lights or tables).
fn edited(edits: &[(&str, &str)], extra: &str) -> String {
    let mut lines: Vec<String> = CORNELL.lines().map(String::from).collect();
    for (prefix, replacement) in edits {
        let hits: Vec<usize> =
            (0..lines.len()).filter(|&i| lines[i].trim_start().starts_with(prefix)).collect();
        assert_eq!(hits.len(), 1, "`{prefix}` must start exactly one line");
        lines[hits[0]] = replacement.to_string();
    }
    lines.join("\n") + "\n" + extra
}

/// The 1-based number of the one line of `text` that starts with `prefix` (ignoring
/// indentation).
fn line_of(text: &str, prefix: &str) -> usize {
    let hits: Vec<usize> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(prefix))
        .map(|(i, _)| i)
        .collect();
    assert_eq!(hits.len(), 1, "`{prefix}` must start exactly one line of:\n{text}");
    hits[0] + 1
}

/// `CORNELL` with `extra` appended: expect a refusal at the line of `extra` that starts with
/// `at`, naming `field` and every `needles`.
fn assert_extra_error(extra: &str, at: &str, field: &str, needles: &[&str]) {
    let text = edited(&[], extra);
    assert_scene_error_at(&text, line_of(&text, at), field, needles);
}

/// A refused scene whose error belongs to no field (TOML syntax, encoding): the message is
/// `scene.toml:LINE:COLUMN: ` followed by the problem.
fn assert_unfielded_error(bytes: &[u8], line: usize, needles: &[&str]) {
    let sandbox = Sandbox::new();
    let path = sandbox.path("scene.toml");
    fs::write(&path, bytes).unwrap();
    let out = render(&sandbox, Some(&path), &[]);
    let location = format!("scene.toml:{line}:");
    let mut all = vec![location.as_str()];
    all.extend_from_slice(needles);
    assert_refused(&sandbox, &out, &all);
    assert!(!stderr(&out).contains(": field `"), "{}", stderr(&out));
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
    // A syntax error belongs to no field: the message goes straight after the position.
    assert_scene_refused(&text, &[&format!("scene.toml:{line}:12: TOML syntax error")]);
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
        &["expected a number, found the string \"big\""],
    );
}

#[test]
fn array_given_for_sphere_radius_is_told_apart_from_the_centre_array() {
    assert_scene_error(
        "radius = 0.4",
        "radius = [0.4]",
        "objects[5].radius",
        &["expected a number, found a list"],
    );
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
    assert_scene_error(
        "caps = true",
        r#"caps = "yes""#,
        "objects[6].caps",
        &["expected true or false, found the string \"yes\""],
    );
}

#[test]
fn wrong_type_of_material_ior() {
    assert_scene_error(
        "ior = 1.52",
        "ior = true",
        "materials.glass.ior",
        &["expected a refractive index", "found true"],
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
    assert_scene_error("fov = 39.0", r#"fov = "wide""#, "camera.fov", &["expected a number"]);
}

#[test]
fn wrong_length_of_sphere_center() {
    assert_scene_error(
        "center = [-0.42",
        "center = [0.0, 1.0]",
        "objects[5].center",
        &["expected a list of three numbers, found a list of 2 values"],
    );
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
        &["expected a whole number from 0 to 4294967295, found the whole number -8"],
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

// ---- scene files: TOML syntax and encoding ----------------------------------------------

#[test]
fn unterminated_string() {
    let (text, line) = with_line(r#"name = "glass sphere""#, r#"name = "glass sphere"#);
    assert_unfielded_error(text.as_bytes(), line, &["TOML syntax error"]);
}

#[test]
fn key_without_equals_sign() {
    let (text, line) = with_line("radius = 0.4", "radius 0.4");
    assert_unfielded_error(text.as_bytes(), line, &["TOML syntax error"]);
}

#[test]
fn unclosed_array() {
    // The array may go on over the next lines: the parser stops at the first key after it.
    let (text, line) = with_line("center = [-0.42", "center = [-0.42, 0.4, -0.25");
    assert_unfielded_error(text.as_bytes(), line + 1, &["TOML syntax error"]);
}

#[test]
fn duplicate_key() {
    let (text, line) = with_line("radius = 0.4", "radius = 0.4\nradius = 0.5");
    assert_unfielded_error(text.as_bytes(), line + 1, &["TOML syntax error", "duplicate key"]);
}

#[test]
fn table_defined_twice() {
    let text = edited(&[], "[camera]\nfov = 30.0\n");
    let line = CORNELL.lines().count() + 1;
    assert_unfielded_error(text.as_bytes(), line, &["TOML syntax error"]);
}

#[test]
fn invalid_utf8_names_the_line() {
    let (text, line) = with_line(r#"name = "glass sphere""#, r#"name = "glass sphère""#);
    let mut bytes = text.into_bytes();
    let at = bytes.windows(2).position(|w| w == "è".as_bytes()).unwrap();
    bytes[at] = 0xff; // not UTF-8
    assert_unfielded_error(&bytes, line, &["not UTF-8"]);
}

#[test]
fn empty_scene_file() {
    assert_unfielded_error(b"", 1, &["missing field `camera`"]);
}

#[test]
fn binary_garbage_as_scene() {
    let bytes: Vec<u8> = (0..4096u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
    let sandbox = Sandbox::new();
    let path = sandbox.path("scene.toml");
    fs::write(&path, &bytes).unwrap();
    let out = render(&sandbox, Some(&path), &[]);
    assert_refused(&sandbox, &out, &["scene.toml:"]);
}

// ---- scene files: wrong types ------------------------------------------------------------

#[test]
fn resolution_as_a_string() {
    assert_scene_error(
        "resolution = [800, 800]",
        r#"resolution = "800x800""#,
        "camera.resolution",
        &["expected a list of two whole numbers, found the string \"800x800\""],
    );
}

#[test]
fn fractional_samples_per_pixel() {
    assert_scene_error(
        "spp = 1",
        "spp = 1.5",
        "render.spp",
        &["expected a whole number, found the number 1.5"],
    );
}

#[test]
fn material_name_as_a_number() {
    assert_scene_error(
        r#"material = "floor""#,
        "material = 3",
        "objects[0].material",
        &["expected a string, found the whole number 3"],
    );
}

#[test]
fn boolean_colour() {
    assert_scene_error("color = 0.73", "color = true", "materials.white.color", &["a colour"]);
}

#[test]
fn colour_with_two_channels() {
    assert_scene_error(
        "color = [0.63, 0.065, 0.05]",
        "color = [0.63, 0.065]",
        "materials.red.color",
        &["a colour", "found a list of 2 values"],
    );
}

#[test]
fn texture_given_a_number() {
    assert_scene_error(
        "texture = {",
        "texture = 5",
        "materials.floor.texture",
        &["expected a table, found the whole number 5"],
    );
}

#[test]
fn camera_as_an_array_of_tables() {
    assert_scene_error("[camera]", "[[camera]]", "camera[0]", &["found a table"]);
}

#[test]
fn negative_max_depth() {
    assert_scene_error(
        "max_depth = 5",
        "max_depth = -1",
        "render.whitted.max_depth",
        &["expected a whole number from 0 to 4294967295, found the whole number -1"],
    );
}

#[test]
fn negative_seed() {
    let text = edited(&[("spp = 1", "spp = 1\nseed = -3")], "");
    assert_scene_error_at(
        &text,
        line_of(&text, "seed = -3"),
        "render.seed",
        &["expected a whole number from 0 to 18446744073709551615, found the whole number -3"],
    );
}

#[test]
fn samples_per_pixel_beyond_u32() {
    assert_scene_error("spp = 1", "spp = 4294967296", "render.spp", &["found the whole number 4294967296"]);
}

// ---- scene files: values out of range ----------------------------------------------------

#[test]
fn field_of_view_out_of_range() {
    for fov in ["0.0", "180.0", "-10.0", "400"] {
        assert_scene_error("fov = 39.0", &format!("fov = {fov}"), "camera.fov", &["between 0 and 180"]);
    }
}

#[test]
fn glass_roughness_out_of_range() {
    let text = edited(&[("ior = 1.52", "ior = 1.52\nroughness = 1.5")], "");
    assert_scene_error_at(
        &text,
        line_of(&text, "roughness"),
        "materials.glass.roughness",
        &["[0, 1]", "1.5"],
    );
}

#[test]
fn reflectance_out_of_range_in_the_scene_file() {
    let text = edited(&[("background = 0.0", "background = 0.0\nreflectance = 2.0")], "");
    assert_scene_error_at(&text, line_of(&text, "reflectance"), "render.reflectance", &["[0, 1]"]);
}

#[test]
fn zero_samples_per_pixel_in_the_scene_file() {
    assert_scene_error("spp = 1", "spp = 0", "render.spp", &["at least 1"]);
}

#[test]
fn max_depth_too_deep() {
    assert_scene_error("max_depth = 5", "max_depth = 1000", "render.whitted.max_depth", &["at most 256"]);
}

#[test]
fn negative_aperture() {
    let text = edited(&[("fov = 39.0", "fov = 39.0\naperture = -0.1")], "");
    assert_scene_error_at(&text, line_of(&text, "aperture"), "camera.aperture", &["0 or greater"]);
}

#[test]
fn zero_focus_distance() {
    let text = edited(&[("fov = 39.0", "fov = 39.0\naperture = 0.1\nfocus_distance = 0.0")], "");
    assert_scene_error_at(
        &text,
        line_of(&text, "focus_distance"),
        "camera.focus_distance",
        &["greater than 0"],
    );
}

#[test]
fn shutter_closing_before_it_opens() {
    let text = edited(&[("fov = 39.0", "fov = 39.0\nshutter = [1.0, 0.5]")], "");
    assert_scene_error_at(
        &text,
        line_of(&text, "shutter"),
        "camera.shutter",
        &["open must not be after close"],
    );
}

#[test]
fn camera_looking_at_itself() {
    assert_scene_error("look_at = ", "look_at = [0.0, 1.0, 3.8]", "camera.look_at", &["must differ"]);
}

#[test]
fn zero_up_vector() {
    assert_scene_error("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, 0.0]", "camera.up", &["non-zero"]);
}

#[test]
fn zero_cylinder_height() {
    assert_scene_error("height = 0.9", "height = 0.0", "objects[6].height", &["greater than 0"]);
}

#[test]
fn zero_cylinder_axis() {
    assert_scene_error("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]", "objects[6].axis", &["non-zero"]);
}

#[test]
fn negative_absorption() {
    let text = edited(&[("ior = 1.52", "ior = 1.52\nabsorption = [0.0, -1.0, 0.0]")], "");
    assert_scene_error_at(
        &text,
        line_of(&text, "absorption"),
        "materials.glass.absorption",
        &["0 or greater"],
    );
}

#[test]
fn negative_cauchy_index() {
    assert_scene_error(
        "ior = 1.52",
        "ior = { cauchy = [-2.0, 0.0] }",
        "materials.glass.ior",
        &["positive over 380–780 nm"],
    );
}

#[test]
fn abbe_index_below_one() {
    assert_scene_error("ior = 1.52", "ior = { abbe = [0.9, 40.0] }", "materials.glass.ior", &["n_d > 1"]);
}

#[test]
fn both_cauchy_and_abbe() {
    assert_scene_error(
        "ior = 1.52",
        "ior = { cauchy = [1.5, 4000.0], abbe = [1.5, 60.0] }",
        "materials.glass.ior",
        &["exactly one of"],
    );
}

#[test]
fn unknown_ssaa_mode_and_sizes() {
    let cases = [
        ("mode = \"random\"", "render.ssaa.mode", "not one of adaptive, grid"),
        ("grid = 0", "render.ssaa.grid", "1..=64"),
        ("levels = 7", "render.ssaa.levels", "0..=6"),
    ];
    for (line, field, needle) in cases {
        assert_extra_error(&format!("[render.ssaa]\n{line}\n"), line, field, &[needle]);
    }
}

#[test]
fn unknown_spectral_mode_and_sampler() {
    let text = edited(&[("spp = 1", "spp = 1\nspectral = \"maybe\"")], "");
    assert_scene_error_at(&text, line_of(&text, "spectral"), "render.spectral", &["auto, on, off"]);
    let text = edited(&[("spp = 1", "spp = 1\nsampler = \"halton\"")], "");
    assert_scene_error_at(
        &text,
        line_of(&text, "sampler"),
        "render.sampler",
        &["sobol, stratified, independent"],
    );
}

#[test]
fn environment_light_together_with_a_background() {
    let text = edited(
        &[("background = 0.0", "background = 0.5")],
        "[[lights]]\ntype = \"environment\"\nradiance = 0.25\n",
    );
    let line = line_of(&text, "type = \"environment\"") - 1;
    assert_scene_error_at(&text, line, "lights[1]", &["remove `render.background`"]);
}

/// An extra object of material `white` (objects[7]) with the given shape lines.
fn extra_object(shape: &str) -> String {
    format!("[[objects]]\nname = \"extra\"\nmaterial = \"white\"\n{shape}\n")
}

#[test]
fn polygon_with_two_vertices() {
    let extra = extra_object("shape = \"polygon\"\nvertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]");
    assert_extra_error(&extra, "vertices", "objects[7].vertices", &["at least 3 vertices"]);
}

#[test]
fn bad_transforms_exit_2_naming_the_field() {
    let extra = extra_object(
        "shape = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 0.5\ntransform = { matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0] }",
    );
    assert_extra_error(&extra, "transform", "objects[7].transform.matrix", &["singular"]);
    let extra = extra_object(
        "shape = \"quad\"\ncorner = [0.0, 1.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 1.0, 0.0]\ntransform = { scale = -1.0 }",
    );
    assert_extra_error(&extra, "transform", "objects[7].transform.scale", &["greater than 0"]);
}

#[test]
fn non_convex_polygon() {
    let extra = extra_object(
        "shape = \"polygon\"\nvertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.2, 0.2, 0.0], [0.0, 1.0, 0.0]]",
    );
    assert_extra_error(&extra, "vertices", "objects[7].vertices", &["not convex"]);
}

#[test]
fn non_planar_polygon() {
    let extra = extra_object(
        "shape = \"polygon\"\nvertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.5], [0.0, 1.0, 0.0]]",
    );
    assert_extra_error(&extra, "vertices", "objects[7].vertices", &["not planar"]);
}

#[test]
fn quad_object_with_parallel_edges() {
    let extra =
        extra_object("shape = \"quad\"\ncorner = [0.0, 0.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [-2.0, 0.0, 0.0]");
    assert_extra_error(&extra, "u = [1.0, 0.0, 0.0]", "objects[7].u", &["not parallel"]);
}

#[test]
fn hollow_sphere_thicker_than_itself() {
    let extra =
        extra_object("shape = \"hollow_sphere\"\ncenter = [0.0, 0.5, 0.0]\nradius = 0.3\ninner_radius = 0.3");
    assert_extra_error(&extra, "inner_radius", "objects[7].inner_radius", &["smaller than radius"]);
}

#[test]
fn annulus_with_a_hole_larger_than_the_disk() {
    let extra = extra_object(
        "shape = \"disk\"\ncenter = [0.0, 0.5, 0.0]\nnormal = [0.0, 1.0, 0.0]\nradius = 0.3\ninner_radius = 0.5",
    );
    assert_extra_error(&extra, "inner_radius", "objects[7].inner_radius", &["smaller than radius"]);
}

#[test]
fn bowl_thicker_than_its_radius() {
    let extra = extra_object("shape = \"bowl\"\ncenter = [0.0, 0.5, 0.0]\nradius = 0.3\nthickness = 0.4");
    assert_extra_error(&extra, "thickness", "objects[7].thickness", &["smaller than radius"]);
}

#[test]
fn drinking_glass_wall_thicker_than_its_radius() {
    let extra = extra_object(
        "shape = \"drinking_glass\"\nbase = [0.0, 0.0, 0.0]\nradius = 0.2\nheight = 0.5\nwall = 0.25\nbottom = 0.05",
    );
    assert_extra_error(&extra, "wall", "objects[7].wall", &["smaller than radius"]);
}

#[test]
fn drinking_glass_bottom_thicker_than_its_height() {
    let extra = extra_object(
        "shape = \"drinking_glass\"\nbase = [0.0, 0.0, 0.0]\nradius = 0.2\nheight = 0.5\nwall = 0.02\nbottom = 0.6",
    );
    assert_extra_error(&extra, "bottom", "objects[7].bottom", &["smaller than height"]);
}

#[test]
fn colour_and_texture_together() {
    let text = edited(
        &[(
            "texture = {",
            "color = 0.5\ntexture = { type = \"checker\", color1 = 0.75, color2 = 0.25, size = 0.25 }",
        )],
        "",
    );
    assert_scene_error_at(
        &text,
        line_of(&text, "texture"),
        "materials.floor.texture",
        &["either `color` or `texture`"],
    );
}

#[test]
fn zero_checker_size() {
    assert_scene_error(
        "texture = {",
        r#"texture = { type = "checker", color1 = 0.75, color2 = 0.25, size = 0.0 }"#,
        "materials.floor.texture.size",
        &["greater than 0"],
    );
}

#[test]
fn emission_on_a_polygon() {
    let text = edited(&[("color = 0.73", "color = 0.73\nemission = 1.0")], "");
    // The first object made of `white` that cannot emit: none (quads can), so add a polygon.
    let text = text
        + "[[objects]]\nname = \"lamp shade\"\nshape = \"polygon\"\nvertices = [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.5, 0.0]]\nmaterial = \"white\"\n";
    let line = line_of(&text, "name = \"lamp shade\"") + 3;
    assert_scene_error_at(
        &text,
        line,
        "objects[7].material",
        &["emission is supported on spheres, quads, disks, cylinders and meshes"],
    );
}

#[test]
fn moving_emitter() {
    let extra = "[materials.lamp]\ntype = \"diffuse\"\nemission = 2.0\n".to_string()
        + "[[objects]]\nshape = \"sphere\"\ncenter = [0.0, 1.5, 0.0]\nradius = 0.1\nmaterial = \"lamp\"\nvelocity = [0.1, 0.0, 0.0]\n";
    assert_extra_error(&extra, "velocity", "objects[7].velocity", &["cannot move"]);
}

// ---- scene files: missing references ------------------------------------------------------

#[test]
fn object_without_a_material() {
    let (text, _) = with_line(r#"material = "floor""#, "# no material");
    let line = line_of(&text, r#"name = "floor""#) - 1;
    assert_scene_error_at(&text, line, "objects[0]", &["missing field `material`"]);
}

/// A mesh object (objects[7]) reading `file`, relative to the scene's folder.
fn mesh_object(file: &str) -> String {
    format!("[[objects]]\nname = \"mesh\"\nshape = \"mesh\"\nfile = \"{file}\"\nmaterial = \"white\"\n")
}

/// Render the Cornell scene plus a mesh `mesh.obj` with the content `obj` (none when `None`)
/// and expect a refusal at the mesh's `file` line.
fn assert_mesh_error(file: &str, obj: Option<&str>, needles: &[&str]) {
    let sandbox = Sandbox::new();
    if let Some(obj) = obj {
        fs::write(sandbox.path("mesh.obj"), obj).unwrap();
    }
    let text = edited(&[], &mesh_object(file));
    let scene = sandbox.scene(&text);
    let out = render(&sandbox, Some(&scene), &[]);
    let location = format!("scene.toml:{}:", line_of(&text, "file = "));
    let mut all = vec![location.as_str(), "field `objects[7].file`"];
    all.extend_from_slice(needles);
    assert_refused(&sandbox, &out, &all);
}

#[test]
fn missing_mesh_file() {
    assert_mesh_error("no-such-mesh.obj", None, &["cannot read OBJ file", "no-such-mesh.obj"]);
}

#[test]
fn mesh_file_that_is_a_folder() {
    assert_mesh_error("out", None, &["not a regular file"]);
}

#[test]
fn mesh_file_that_is_a_device_is_not_read_forever() {
    let start = Instant::now();
    assert_mesh_error("/dev/zero", None, &["not a regular file"]);
    assert!(start.elapsed() < Duration::from_secs(10), "took {:?}", start.elapsed());
}

#[test]
fn mesh_face_with_a_missing_vertex() {
    assert_mesh_error("mesh.obj", Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), &["out of bounds"]);
}

#[test]
fn mesh_without_triangles() {
    assert_mesh_error("mesh.obj", Some("# nothing\nv 0 0 0\n"), &["no (non-degenerate) triangles"]);
}

#[test]
fn mesh_with_a_nan_vertex() {
    assert_mesh_error("mesh.obj", Some("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), &["not a finite number"]);
}

// ---- scene files: NaN, infinity and huge numbers ------------------------------------------

#[test]
fn nan_colour() {
    assert_scene_error("intensity = 5.0", "intensity = nan", "lights[0].intensity", &["NaN", "finite"]);
}

#[test]
fn negative_nan_index() {
    assert_scene_error("ior = 1.52", "ior = -nan", "materials.glass.ior", &["NaN", "finite"]);
}

#[test]
fn infinite_field_of_view() {
    assert_scene_error("fov = 39.0", "fov = +inf", "camera.fov", &["inf", "finite"]);
}

#[test]
fn nan_inside_an_inline_table() {
    assert_scene_error(
        "texture = {",
        r#"texture = { type = "checker", color1 = 0.75, color2 = 0.25, size = nan }"#,
        "materials.floor.texture.size",
        &["NaN"],
    );
}

#[test]
fn infinite_velocity_component() {
    let text = edited(&[("radius = 0.4", "radius = 0.4\nvelocity = [0.0, inf, 0.0]")], "");
    assert_scene_error_at(&text, line_of(&text, "velocity"), "objects[5].velocity[1]", &["inf", "finite"]);
}

#[test]
fn nan_in_a_nested_array() {
    let extra =
        extra_object("shape = \"polygon\"\nvertices = [[0.0, 0.0, 0.0], [1.0, 0.0, nan], [0.0, 1.0, 0.0]]");
    assert_extra_error(&extra, "vertices", "objects[7].vertices[1][2]", &["NaN"]);
}

#[test]
fn number_within_f32_but_beyond_the_scene_limit() {
    assert_scene_error("radius = 0.4", "radius = 1e16", "objects[5].radius", &["too large", "1e15"]);
    assert_scene_error("intensity = 5.0", "intensity = 3e38", "lights[0].intensity", &["too large", "1e15"]);
}

#[test]
fn huge_integer_where_a_number_is_expected() {
    assert_scene_error(
        "radius = 0.4",
        "radius = 9223372036854775807",
        "objects[5].radius",
        &["too large", "1e15"],
    );
}

#[test]
fn resolution_side_too_large() {
    assert_scene_error(
        "resolution = [800, 800]",
        "resolution = [65537, 1]",
        "camera.resolution",
        &["too large"],
    );
}

#[test]
fn resolution_with_too_many_pixels() {
    assert_scene_error(
        "resolution = [800, 800]",
        "resolution = [8193, 8193]",
        "camera.resolution",
        &["too large"],
    );
}

/// Run `vitrum render` on `scene` with the address space limited to 400 MB (`ulimit -v`):
/// a film of 2²⁶ pixels alone takes gigabytes, so only a refusal *before* allocating can
/// succeed in that space.
fn render_in_400_mb(sandbox: &Sandbox, scene: &Path, resolution: &str) -> Output {
    Command::new("sh")
        .current_dir(sandbox.dir.path())
        .arg("-c")
        .arg(r#"ulimit -v 400000 && exec "$0" render "$1" -o out/image.exr --quiet --resolution "$2""#)
        .arg(env!("CARGO_BIN_EXE_vitrum"))
        .arg(scene)
        .arg(resolution)
        .output()
        .expect("sh runs")
}

#[test]
fn resolution_that_would_exhaust_memory_is_refused_within_400_mb() {
    let sandbox = Sandbox::new();
    // The scene's resolution is refused while the scene compiles, before any image exists.
    let (text, line) = with_line("resolution = [800, 800]", "resolution = [65536, 65536]");
    let scene = sandbox.scene(&text);
    let out = Command::new("sh")
        .current_dir(sandbox.dir.path())
        .arg("-c")
        .arg(r#"ulimit -v 400000 && exec "$0" render "$1" -o out/image.exr --quiet"#)
        .arg(env!("CARGO_BIN_EXE_vitrum"))
        .arg(&scene)
        .output()
        .unwrap();
    let location = format!("scene.toml:{line}:");
    assert_refused(&sandbox, &out, &[&location, "field `camera.resolution`", "too large"]);
    // The same for the command-line override.
    let out = render_in_400_mb(&sandbox, &sandbox.scene(CORNELL), "65536x65536");
    assert_refused(&sandbox, &out, &["--resolution", "too large"]);
    // The control: an image the renderer accepts (exactly 2²⁶ pixels) cannot be rendered in
    // that space, so the limit above would have caught an allocation.
    let out = render_in_400_mb(&sandbox, &sandbox.scene(CORNELL), "8192x8192");
    assert!(!out.status.success(), "a 2^26-pixel render fitted in 400 MB: the test proves nothing");
}

#[test]
fn moving_object_leaving_the_scene_limit() {
    let text = edited(
        &[
            ("fov = 39.0", "fov = 39.0\nshutter = [0.0, 1e15]"),
            ("radius = 0.4", "radius = 0.4\nvelocity = [1e15, 0.0, 0.0]"),
        ],
        "",
    );
    assert_scene_error_at(
        &text,
        line_of(&text, "velocity"),
        "objects[5].velocity",
        &["moves beyond", "1e16"],
    );
}

#[test]
fn mesh_scaled_beyond_the_scene_limit() {
    let sandbox = Sandbox::new();
    fs::write(sandbox.path("mesh.obj"), "v 0 0 0\nv 1e15 0 0\nv 0 1e15 0\nf 1 2 3\n").unwrap();
    let text = edited(&[], &(mesh_object("mesh.obj") + "scale = 100.0\n"));
    let out = render(&sandbox, Some(&sandbox.scene(&text)), &[]);
    let location = format!("scene.toml:{}:", line_of(&text, "file = "));
    assert_refused(&sandbox, &out, &[&location, "field `objects[7].file`", "reaches beyond", "1e16"]);
}

#[test]
fn light_power_that_overflows() {
    let extra = "[[lights]]\ntype = \"sphere\"\ncenter = [0.0, 1.5, 0.0]\nradius = 1e15\nradiance = 1e15\n";
    assert_extra_error(extra, "radiance = 1e15", "lights[1].radiance", &["power", "overflows"]);
    let extra = "[materials.lamp]\ntype = \"diffuse\"\nemission = 1e15\n".to_string()
        + "[[objects]]\nshape = \"sphere\"\ncenter = [0.0, 1.5, 0.0]\nradius = 1e15\nmaterial = \"lamp\"\n";
    assert_extra_error(&extra, "emission", "materials.lamp.emission", &["power", "overflows"]);
}

#[test]
fn environment_map_whose_mean_radiance_overflows() {
    // Finite texels and a finite scale whose product, the mean radiance over the sphere, is not
    // (the mean of texels never exceeds the largest; the scale of 2 takes it past f32): an
    // environment has no power, its mean radiance is what overflows (and the message says so,
    // at the map's `file`).
    let sandbox = Sandbox::new();
    let mut sky = vitrum::image::Image::new(4, 2);
    sky.pixels.iter_mut().for_each(|p| *p = glam::Vec3::splat(3e38));
    vitrum::output::exr::write_exr(&sandbox.path("sky.exr"), &sky, &Default::default()).unwrap();
    let text = map_scene("0").replace("scale = 0.5", "scale = 2.0");
    assert!(text.contains("scale = 2.0"));
    let out = render(&sandbox, Some(&sandbox.scene(&text)), &[]);
    let location = format!("scene.toml:{}:", line_of(&text, "file = "));
    assert_refused(
        &sandbox,
        &out,
        &[
            &location,
            "field `lights[1].file`",
            "mean radiance ([inf, inf, inf] W/(m²·sr)) overflows",
            "`scale`",
        ],
    );
}

// ---- scene files: lights without area ----------------------------------------------------

/// An extra quad light (lights[1]) with edges `u` and `v`.
fn quad_light(u: &str, v: &str) -> String {
    format!("[[lights]]\ntype = \"quad\"\ncorner = [-0.2, 1.95, -0.2]\nu = {u}\nv = {v}\nradiance = 10.0\n")
}

#[test]
fn quad_light_with_parallel_edges() {
    let extra = quad_light("[0.4, 0.0, 0.0]", "[0.8, 0.0, 0.0]");
    assert_extra_error(&extra, "u = [0.4", "lights[1].u", &["not parallel", "area > 0"]);
}

#[test]
fn quad_light_with_a_zero_edge() {
    let extra = quad_light("[0.4, 0.0, 0.0]", "[0.0, 0.0, 0.0]");
    assert_extra_error(&extra, "u = [0.4", "lights[1].u", &["non-zero", "area > 0"]);
}

#[test]
fn quad_light_whose_area_underflows() {
    let extra = quad_light("[1e-20, 0.0, 0.0]", "[0.0, 0.0, 1e-20]");
    assert_extra_error(&extra, "u = [1e-20", "lights[1].u", &["too small", "underflows"]);
}

#[test]
fn sphere_light_of_radius_zero() {
    let extra = "[[lights]]\ntype = \"sphere\"\ncenter = [0.0, 1.5, 0.0]\nradius = 0.0\nradiance = 10.0\n";
    assert_extra_error(extra, "radius = 0.0", "lights[1].radius", &["greater than 0"]);
}

#[test]
fn sphere_light_whose_area_underflows() {
    let extra = "[[lights]]\ntype = \"sphere\"\ncenter = [0.0, 1.5, 0.0]\nradius = 1e-30\nradiance = 10.0\n";
    assert_extra_error(extra, "radius = 1e-30", "lights[1].radius", &["too small", "underflows"]);
}

#[test]
fn emitting_sphere_whose_area_underflows() {
    let extra = "[materials.lamp]\ntype = \"diffuse\"\nemission = 2.0\n".to_string()
        + "[[objects]]\nshape = \"sphere\"\ncenter = [0.0, 1.5, 0.0]\nradius = 1e-30\nmaterial = \"lamp\"\n";
    assert_extra_error(&extra, "radius = 1e-30", "objects[7].radius", &["too small", "underflows"]);
}

#[test]
fn scene_file_that_is_a_device_is_not_read_forever() {
    let sandbox = Sandbox::new();
    let start = Instant::now();
    let out = render(&sandbox, Some(Path::new("/dev/zero")), &[]);
    assert_refused(&sandbox, &out, &["/dev/zero", "larger than 64 MiB"]);
    assert!(start.elapsed() < Duration::from_secs(20), "took {:?}", start.elapsed());
}

#[test]
fn fuzz_regression_inputs_are_refused() {
    // Scenes that once crashed the loader (see fuzz/README.md): all are refused now.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds");
    let mut count = 0;
    for entry in fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let sandbox = Sandbox::new();
        let out = render(&sandbox, Some(&path), &[]);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert_refused(&sandbox, &out, &[&format!("{name}:"), "field `"]);
        count += 1;
    }
    assert!(count >= 5, "{count} regression inputs in {}", dir.display());
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
    // Each method's depth and where it comes from: the scene's `[render.whitted]`, else the default.
    let methods = &info["render"]["methods"];
    assert_eq!(methods["whitted"], serde_json::json!({"max_depth": 5, "from": "scene"}), "{methods}");
    assert_eq!(methods["path"], serde_json::json!({"max_depth": 256, "from": "default"}), "{methods}");
    assert_eq!(methods["raycast"]["max_depth"], Value::Null, "ray casting has no depth: {methods}");
}

#[test]
fn non_finite_exposures_are_refused_by_every_command_that_takes_one() {
    let sandbox = Sandbox::new();
    sandbox.scene(CORNELL);
    // A render part of 8×8 pixels (outside `out/`): what `merge` merges, `diff` and `compare` judge.
    let words = |command: &'static str| command.split(' ').collect::<Vec<_>>();
    let part =
        sandbox.vitrum(&words("render scene.toml --resolution 8x8 --samples 0..2 -o part.exr --quiet"));
    assert_eq!(part.status.code(), Some(0), "{}", stderr(&part));
    let commands = [
        "render scene.toml --resolution 8x8 -o out/image.exr --png out/image.png --quiet",
        "merge part.exr -o out/merged.exr --png out/merged.png",
        "diff part.exr part.exr --error-map out/error.png",
        "compare scene.toml -i raycast --spp 1 --resolution 8x8 --reference part.exr --out out/compare",
        "report scene.toml -i raycast --spp 1 --resolution 8x8 --reference-spp 1 --cache out/cache --out out/report",
    ];
    for command in commands {
        let args = words(command);
        for bad in ["nan", "NaN", "inf", "-inf", "infinity"] {
            let out = sandbox.vitrum(&[&args[..], &["--exposure", bad]].concat());
            // Named: the option, the value and what is allowed.
            assert_refused(
                &sandbox,
                &out,
                &["--exposure", &format!("`{bad}` is not a finite number of stops")],
            );
        }
        // A finite exposure goes through, and writes the outputs.
        let out = sandbox.vitrum(&[&args[..], &["--exposure", "-1.5"]].concat());
        assert_eq!(out.status.code(), Some(0), "{command}: {}", stderr(&out));
        assert!(!sandbox.out_files().is_empty(), "{command} wrote nothing");
        fs::remove_dir_all(sandbox.out()).unwrap();
        fs::create_dir(sandbox.out()).unwrap();
    }
}

#[test]
fn exr_inputs_declaring_too_many_pixels_are_refused_by_every_command_that_reads_one() {
    let sandbox = Sandbox::new();
    sandbox.scene(CORNELL);
    let (width, height) = common::oversized::DECLARED;
    common::oversized::write_exr_declaring(&sandbox.path("huge.exr"), width, height);
    let commands = [
        "merge huge.exr -o out/merged.exr",
        "render --resume huge.exr",
        "compare scene.toml -i raycast --reference huge.exr --out out/compare",
        "compare scene.toml --renders huge.exr --out out/compare",
        "converge scene.toml -i raycast --reference huge.exr --out out/converge",
        "converge scene.toml --renders huge.exr --out out/converge",
    ];
    for command in commands {
        let args: Vec<&str> = command.split(' ').collect();
        let out = common::oversized::vitrum_capped(sandbox.dir.path(), &args);
        common::oversized::assert_refused_as_too_large(&out, "huge.exr");
        assert!(sandbox.out_files().is_empty(), "{command} wrote {:?}", sandbox.out_files());
    }
}

/// A scene with a point light and an environment map (`sky.exr`, 4×2 texels of radiance 2, which
/// the caller writes) turned by `rotation` degrees at scale 0.5: a mean radiance of 1.
fn map_scene(rotation: &str) -> String {
    format!(
        "[camera]\nposition = [0.0, 1.0, 3.0]\nlook_at = [0.0, 0.5, 0.0]\nfov = 40.0\nresolution = [8, 8]\n\
         [materials.white]\ntype = \"diffuse\"\ncolor = 0.5\n\
         [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.5, 0.0]\nradius = 0.5\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\nintensity = 1.0\n\
         [[lights]]\ntype = \"environment\"\nfile = \"sky.exr\"\nscale = 0.5\nrotation = {rotation}\n"
    )
}

#[test]
fn info_shows_an_environment_maps_rotation_as_written_and_its_mean_radiance_as_radiance() {
    let sandbox = Sandbox::new();
    let mut sky = vitrum::image::Image::new(4, 2);
    sky.pixels.iter_mut().for_each(|p| *p = glam::Vec3::splat(2.0));
    vitrum::output::exr::write_exr(&sandbox.path("sky.exr"), &sky, &Default::default()).unwrap();
    // 180 once printed as −180 (the angle recovered from its cosine and sine).
    for rotation in ["180", "180.0", "-90", "270", "540", "0"] {
        let scene = sandbox.path("scene.toml");
        fs::write(&scene, map_scene(rotation)).unwrap();
        let written: f64 = rotation.parse().unwrap();

        let out = sandbox.vitrum(&["info", "scene.toml"]);
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        let text = stdout(&out);
        let map = text.lines().find(|l| l.contains("environment map")).unwrap_or_else(|| panic!("{text}"));
        assert!(map.contains(&format!("rotation {written}°")), "{rotation}: {map}");
        // Integrated in double precision: exactly 1.
        assert!(map.ends_with("mean radiance (1, 1, 1) W/(m²·sr)"), "{map}");
        assert!(!map.contains("power") && !map.contains(" W\n") && !map.ends_with(" W"), "{map}");
        let point = text.lines().find(|l| l.contains("point at")).unwrap_or_else(|| panic!("{text}"));
        assert!(
            point.ends_with(&format!(", power ({p}, {p}, {p}) W", p = 4.0 * std::f32::consts::PI)),
            "{point}"
        );

        let out = sandbox.vitrum(&["info", "--json", "scene.toml"]);
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        let info: Value = serde_json::from_str(&stdout(&out)).expect("one JSON object");
        let (point, map) = (&info["lights"][0], &info["lights"][1]);
        assert_eq!(map["rotation_degrees"].as_f64(), Some(written), "{map}");
        let mean = map["mean_radiance"].as_array().unwrap_or_else(|| panic!("{map}"));
        assert!(mean.len() == 3 && mean.iter().all(|c| (c.as_f64().unwrap() - 1.0).abs() < 1e-6), "{map}");
        assert!(map.get("power_watts").is_none(), "the environment has no finite power: {map}");
        let power = point["power_watts"][0].as_f64().unwrap();
        assert!((power - 4.0 * std::f64::consts::PI).abs() < 1e-5, "{point}");
        assert!(point.get("mean_radiance").is_none(), "{point}");
    }
}

#[test]
fn info_json_gives_a_constant_environment_its_mean_radiance_not_a_power() {
    let sandbox = Sandbox::new();
    let text = map_scene("0").replace("file = \"sky.exr\"\nscale = 0.5\nrotation = 0\n", "radiance = 0.25\n");
    sandbox.scene(&text);
    let out = sandbox.vitrum(&["info", "--json", "scene.toml"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let info: Value = serde_json::from_str(&stdout(&out)).expect("one JSON object");
    let environment = &info["lights"][1];
    assert_eq!(environment["kind"], "environment", "{environment}");
    assert_eq!(environment["mean_radiance"], serde_json::json!([0.25, 0.25, 0.25]), "{environment}");
    assert!(environment.get("power_watts").is_none(), "{environment}");
    let out = sandbox.vitrum(&["info", "scene.toml"]);
    let text = stdout(&out);
    let line = text.lines().find(|l| l.contains("environment,")).unwrap_or_else(|| panic!("{text}"));
    assert!(line.ends_with("radiance (0.25, 0.25, 0.25) W/(m²·sr) from every direction"), "{line}");
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

// ---- per-method settings, depths, error columns ------------------------------------------

#[test]
fn a_depth_in_render_is_refused_with_where_it_goes_now() {
    let text = edited(&[("spp = 1", "spp = 1\nmax_depth = 8")], "");
    assert_scene_error_at(
        &text,
        line_of(&text, "max_depth = 8"),
        "render.max_depth",
        &["set per method", "[render.whitted] max_depth = 5", "[render.path]"],
    );
}

#[test]
fn per_method_tables_refuse_what_the_method_does_not_have() {
    assert_extra_error(
        "[render.path]\nlevels = 2\n",
        "levels",
        "render.path.levels",
        &["unknown field `levels`, expected `max_depth`"],
    );
    assert_extra_error(
        "[render.raycast]\nmax_depth = 2\n",
        "max_depth = 2",
        "render.raycast.max_depth",
        &["[render.raycast] takes no parameters"],
    );
    assert_extra_error(
        "[render.mlt]\nmax_depth = 2\n",
        "[render.mlt]",
        "render.mlt",
        &["unknown method `mlt`", "raycast, whitted, ssaa, distributed, path, light, bpt, ppm, bpm, vcm"],
    );
    // A misspelt key of [render] is no method, and `max_depth` is not offered.
    let text = edited(&[("spp = 1", "spp = 1\nsed = 3")], "");
    let err = assert_scene_refused(&text, &["field `render.sed`: unknown field `sed`, expected one of"]);
    assert!(!err.contains("`max_depth`"), "{err}");
}

#[test]
fn scene_errors_point_at_the_offending_value() {
    // (line prefix, replacement, the column of the message): the value, or the key that is unknown.
    let cases = [
        ("radius = 0.4", r#"radius = "big""#, 10),
        ("radius = 0.4", "radius = -0.4", 10),
        ("center = [-0.42", r#"center = [0.0, "a", 1.0]"#, 16),
        ("fov = 39.0", "fov = 0.0", 7),
        ("max_depth = 5", "max_depth = 1000", 13),
        ("radius = 0.4", "radiu = 0.4", 1),
    ];
    for (prefix, replacement, column) in cases {
        let (text, line) = with_line(prefix, replacement);
        assert_scene_refused(&text, &[&format!("scene.toml:{line}:{column}: field")]);
    }
}

#[test]
fn an_exr_output_named_png_suggests_the_png_option() {
    let sandbox = Sandbox::new();
    let out = vitrum(&[
        "render",
        "--resolution",
        "8x8",
        "--quiet",
        "-o",
        &sandbox.out().join("a.png").display().to_string(),
    ]);
    assert_refused(&sandbox, &out, &["a.png: the output file must end in .exr", "OpenEXR", "--png"]);
}

#[test]
fn the_summary_shows_each_methods_depth() {
    let sandbox = Sandbox::new();
    let run = |extra: &[&str]| {
        let mut args = vec!["render", "--resolution", "8x8", "-o", "out/d.exr"];
        args.extend_from_slice(extra);
        let out = sandbox.vitrum(&args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        out
    };
    // The embedded scene sets the Whitted depth 5; path traces to its own 256.
    for (extra, shown) in [
        (&["-i", "whitted"][..], Some("whitted: 8x8 at 1 spp, max depth 5 in")),
        (&["-i", "path"], Some("path: 8x8 at 1 spp, max depth 256 in")),
        (&["-i", "path", "--max-depth", "3"], Some("max depth 3")),
        (&["-i", "raycast"], None),
    ] {
        let err = stderr(&run(extra));
        match shown {
            Some(text) => assert!(err.contains(text), "{extra:?}: {err}"),
            None => assert!(!err.contains("max depth"), "raycast has no depth: {err}"),
        }
    }
    let json: Value = serde_json::from_str(&stdout(&run(&["-i", "path", "--json"]))).unwrap();
    assert_eq!(json["max_depth"], 256);
    let json: Value = serde_json::from_str(&stdout(&run(&["-i", "raycast", "--json"]))).unwrap();
    assert!(json["max_depth"].is_null());
}

#[test]
fn the_reference_of_cornell_glass_is_rendered_at_full_depth() {
    // `converge` of the default scene (Whitted depth 5): its cached reference (`vcm`: a point
    // light meets glass) records depth 256; with --max-depth the reference follows it.
    let sandbox = Sandbox::new();
    let depths = |extra: &[&str]| -> Vec<u64> {
        let mut args = vec!["converge", "-i", "whitted", "--spp-max", "1", "--reference-spp", "2"];
        args.extend(["--resolution", "8x8", "--cache", "cache", "--out", "cv", "--quiet"]);
        args.extend_from_slice(extra);
        let out = sandbox.vitrum(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        let mut depths: Vec<u64> = fs::read_dir(sandbox.path("cache"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .map(|p| serde_json::from_str::<Value>(&fs::read_to_string(p).unwrap()).unwrap())
            .map(|key| key["max_depth"].as_u64().unwrap())
            .collect();
        depths.sort();
        depths
    };
    assert_eq!(depths(&[]), [256]);
    assert_eq!(depths(&["--max-depth", "4"]), [4, 256]);
}

#[test]
fn merge_radius_comes_from_the_command_line_else_the_scene_else_the_scene_size() {
    // The scene's `[render.vcm]` table sets vcm's radius and α; ppm keeps the default fraction.
    let text = edited(&[], "[render.vcm]\nradius = 0.02\nradius_alpha = 0.5\n");
    let sandbox = Sandbox::new();
    let scene = sandbox.scene(&text);
    let info = vitrum(&["info".as_ref(), scene.as_os_str(), "--json".as_ref()]);
    assert!(info.status.success(), "{}", stderr(&info));
    let info: Value = serde_json::from_str(&stdout(&info)).unwrap();
    let methods = &info["render"]["methods"];
    assert_eq!(methods["vcm"]["radius"].as_f64().unwrap() as f32, 0.02, "{methods}");
    assert_eq!(methods["vcm"]["radius_alpha"].as_f64().unwrap() as f32, 0.5, "{methods}");
    assert_eq!(methods["vcm"]["radius_from"], "scene", "{methods}");
    // 0.0015 of the bounding box's diagonal (the Cornell box is 2 × 2 × 2 plus nothing outside),
    // times the pixel footprint's sqrt(256² / pixels) at the scene's 800 × 800.
    let default = methods["ppm"]["radius"].as_f64().unwrap();
    assert!((default - 0.0015 * 12f64.sqrt() * 256.0 / 800.0).abs() < 1e-6, "{methods}");
    assert!(methods["path"].get("radius").is_none(), "path does not merge: {methods}");

    let summary = |extra: &[&str]| -> Value {
        let mut args = vec!["-i", "vcm", "--spp", "1", "--json", "--resolution", "8x8"];
        args.extend_from_slice(extra);
        let out = render(&sandbox, Some(&scene), &args);
        assert!(out.status.success(), "{}", stderr(&out));
        serde_json::from_str(&stdout(&out)).unwrap()
    };
    let from_scene = summary(&[]);
    assert_eq!(from_scene["merging"]["radius"].as_f64().unwrap() as f32, 0.02);
    let from_cli = summary(&["--radius", "0.05", "--radius-alpha", "0.9"]);
    assert_eq!(from_cli["merging"]["radius"].as_f64().unwrap() as f32, 0.05);
    assert_eq!(from_cli["merging"]["alpha"].as_f64().unwrap() as f32, 0.9);

    for bad in [["--radius", "0"], ["--radius", "-1"], ["--radius-alpha", "0"], ["--radius-alpha", "1.5"]] {
        let sandbox = Sandbox::new();
        let out = render(&sandbox, None, &["-i", "vcm", bad[0], bad[1]]);
        assert_refused(&sandbox, &out, &[bad[0]]);
    }
    for (line, key) in [("radius = -0.1", "radius"), ("radius_alpha = 2.0", "radius_alpha")] {
        let text = edited(&[], &format!("[render.vcm]\n{line}\n"));
        assert_scene_error_at(&text, line_of(&text, line), &format!("render.vcm.{key}"), &[]);
    }
    assert_scene_refused(&edited(&[], "[render.bpt]\nradius = 0.1\n"), &["unknown field `radius`"]);
}

#[test]
fn one_strategy_of_a_bidirectional_method_renders_alone() {
    let sandbox = Sandbox::new();
    let out = render(
        &sandbox,
        None,
        &["-i", "vcm", "--strategy", "merge", "--spp", "1", "--json", "--resolution", "8x8"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let summary: Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(summary["strategy"], "merge");
    for (method, strategy, needle) in [
        ("bpt", "merge", "`bpt` uses only emitter, nee, connect, splat"),
        ("path", "splat", "`path` has no strategies"),
    ] {
        let sandbox = Sandbox::new();
        let out = render(&sandbox, None, &["-i", method, "--strategy", strategy]);
        assert_refused(&sandbox, &out, &[needle]);
    }
}

#[test]
fn info_describes_materials_and_lights_in_words_and_as_data() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scenes =
        ["scenes/cornell-glass.toml", "scenes/glass-of-water.toml", "scenes/hard/glass-of-water-filled.toml"];
    for scene in scenes {
        let file = root.join(scene);
        let out = vitrum(&["info".as_ref(), file.as_os_str()]);
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        let text = stdout(&out);
        for debug in ["Vec3(", "Constant(", "Cauchy {", "Medium {", "Dielectric {", "Diffuse("] {
            assert!(!text.contains(debug), "{scene}: `{debug}` in\n{text}");
        }
    }
    let text = stdout(&vitrum(&["info".as_ref(), root.join(scenes[0]).as_os_str()]));
    let listed =
        |name: &str, says: &str| text.lines().any(|l| l.trim_start().starts_with(name) && l.contains(says));
    assert!(listed("floor ", "diffuse, checker (0.75, 0.75, 0.75)/(0.25, 0.25, 0.25) size 0.25"), "{text}");
    assert!(listed("glass ", "dielectric, inside ior 1.52, outside ior 1, roughness 0"), "{text}");
    assert!(text.contains("point at (0, 1.8, 0), intensity (5, 5, 5) W/sr"), "{text}");
    let text = stdout(&vitrum(&["info".as_ref(), root.join(scenes[1]).as_os_str()]));
    assert!(text.contains("ior bk7 (dispersive: n_d 1.51"), "the named glass: {text}");
    // --json: the same content as data.
    let out = vitrum(&["info".as_ref(), "--json".as_ref(), root.join(scenes[2]).as_os_str()]);
    let info: Value = serde_json::from_str(&stdout(&out)).expect("one JSON object");
    let materials = info["materials"].as_array().unwrap();
    let kinds: Vec<(&str, &str)> =
        materials.iter().map(|m| (m["name"].as_str().unwrap(), m["kind"].as_str().unwrap())).collect();
    assert_eq!(
        kinds,
        [
            ("furnace", "diffuse"),
            ("glass", "dielectric"),
            ("glass (liquid)", "dielectric"),
            ("glass (liquid, inner)", "dielectric"),
            ("glass (liquid surface)", "dielectric"),
            ("glass (inner)", "dielectric"),
        ]
    );
    let surface = &materials[4];
    assert_eq!(
        (surface["inside"]["ior"].as_f64(), surface["outside"]["ior"].as_f64()),
        (Some(1.33), Some(1.0))
    );
    assert!(surface["description"]
        .as_str()
        .unwrap()
        .starts_with("dielectric, inside ior 1.33, outside ior 1"));
    assert_eq!(materials[0]["texture"]["kind"], "constant");
    let lights = info["lights"].as_array().unwrap();
    assert_eq!(lights[0]["kind"], "surface");
    assert_eq!(lights[0]["geometry"]["shape"], "sphere");
    assert_eq!(lights[0]["geometry"]["radius"], 10.0);
}

#[test]
fn a_render_that_needs_more_memory_than_the_machine_has_is_refused_before_allocating() {
    // The memory available is overridden (`VITRUM_AVAILABLE_MEMORY`, bytes). At 2048² the film
    // alone (24 bytes per pixel and replica, and the sum) is 864 MiB: every method is
    // refused under 100 MB, with the estimate in the message and no output written.
    let sandbox = Sandbox::new();
    sandbox.scene(CORNELL);
    let run = |available: &str, args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_vitrum"))
            .current_dir(sandbox.dir.path())
            .env(vitrum::memory::AVAILABLE_OVERRIDE, available)
            .args(args)
            .output()
            .unwrap()
    };
    for integrator in vitrum::integrators::all() {
        let name = integrator.name();
        let args =
            ["render", "scene.toml", "-i", name, "--resolution", "2048x2048", "-o", "out/r.exr", "--quiet"];
        let out = run("100000000", &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
        for named in ["needs about", "MiB", "film", "available", "VITRUM_AVAILABLE_MEMORY"] {
            assert!(stderr.contains(named), "{name}: `{named}` is named: {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(sandbox.out_files().is_empty(), "{name} wrote {:?}", sandbox.out_files());
    }
    // The method's own working memory counts: at 64² the film and outputs of one sample take
    // under 1 MB, which 3 MB holds for `path`, not with `vcm`'s stored light paths and its band
    // of camera estimates.
    let small = |method| {
        [
            "render",
            "scene.toml",
            "-i",
            method,
            "--resolution",
            "64x64",
            "--spp",
            "1",
            "-o",
            "out/r.exr",
            "--quiet",
        ]
    };
    let out = run("3000000", &small("path"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    fs::remove_file(sandbox.out().join("r.exr")).unwrap();
    let out = run("3000000", &small("vcm"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("method ") && !stderr.contains("method 0 MiB"), "{stderr}");
    assert!(sandbox.out_files().is_empty(), "vcm wrote {:?}", sandbox.out_files());
    // An override that is not a number is bad input.
    let out = run("lots", &small("path"));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a number of bytes"));
}

#[test]
fn cylinder_given_by_top_and_by_height_at_once() {
    let extra = extra_object(
        "shape = \"cylinder\"\nbase = [0.0, 0.2, 0.0]\ntop = [0.0, 0.6, 0.0]\nradius = 0.1\nheight = 0.4",
    );
    assert_extra_error(&extra, "top = ", "objects[7].top", &["replaces axis and height"]);
    let extra =
        extra_object("shape = \"cylinder\"\nbase = [0.0, 0.2, 0.0]\ntop = [0.0, 0.2, 0.0]\nradius = 0.1");
    assert_extra_error(&extra, "top = ", "objects[7].top", &["must differ from base"]);
    // Neither: the error is the object's, at its table header.
    let text = edited(&[], &extra_object("shape = \"cylinder\"\nbase = [0.0, 0.2, 0.0]\nradius = 0.1"));
    let header = line_of(&text, "name = \"extra\"") - 1;
    assert_scene_error_at(&text, header, "objects[7]", &["needs `height`", "or `top`"]);
}
