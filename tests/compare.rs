//! `vitrum compare` end to end: the figure has the size `figure::compose` documents (with and
//! without a crop), the table one row per method in CSV and Markdown, every method its EXR; equal
//! time gives every method at least its time; bad input exits with code 2 before rendering and
//! leaves nothing behind.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tempfile::TempDir;
use vitrum::commands::compare::CSV_HEADER;

/// Render size of every case: small, and not square (so width and height cannot be swapped).
const SIZE: (u32, u32) = (32, 24);
const RESOLUTION: &str = "32x24";

/// A temporary working folder with `out/` for the outputs and a `path` reference render.
struct Sandbox {
    dir: TempDir,
}

impl Sandbox {
    fn new() -> Sandbox {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir(dir.path().join("out")).unwrap();
        let sandbox = Sandbox { dir };
        sandbox.render_reference("ref.exr", RESOLUTION);
        sandbox
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// A 256-sample `path` render of the shipped scene at `resolution`, written to `name` (enough
    /// that its own noise is a small part of a 2-sample render's error).
    fn render_reference(&self, name: &str, resolution: &str) {
        let out = self.vitrum(&[
            "render",
            &scene(),
            "-i",
            "path",
            "--spp",
            "256",
            "--resolution",
            resolution,
            "--quiet",
            "-o",
            name,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
    }

    /// Run the binary in the sandbox (so a default cache folder would land there).
    fn vitrum(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_vitrum"))
            .args(args)
            .current_dir(self.dir.path())
            .output()
            .expect("the vitrum binary runs")
    }

    /// `vitrum compare` of the shipped scene at the test size with `extra` options, and unless
    /// they say otherwise, `ref.exr` as the reference and `out/cmp` as the output folder.
    fn compare(&self, extra: &[&str]) -> Output {
        let scene = scene();
        let mut args = vec!["compare", &scene, "--resolution", RESOLUTION, "--quiet"];
        for (option, default) in [("--reference", "ref.exr"), ("--out", "out/cmp")] {
            if !extra.contains(&option) {
                args.extend([option, default]);
            }
        }
        args.extend(extra);
        self.vitrum(&args)
    }

    /// The names of the files in `folder` (relative to the sandbox), sorted.
    fn files(&self, folder: &str) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(self.path(folder))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into())
            .collect();
        names.sort();
        names
    }
}

/// The shipped thesis scene.
fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glass.toml").display().to_string()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The figure size by the formula of `figure::compose`'s documentation, for `methods` columns
/// after the reference's, all in one row.
fn expected_figure_size(image: (u32, u32), methods: u32, crop: Option<(u32, u32)>) -> (u32, u32) {
    expected_wrapped_figure_size(image, methods, crop, None)
}

/// The figure size with at most `columns` panels per row (the reference's panel first).
fn expected_wrapped_figure_size(
    image: (u32, u32),
    methods: u32,
    crop: Option<(u32, u32)>,
    columns: Option<u32>,
) -> (u32, u32) {
    let panels = methods + 1;
    let per_row = columns.map_or(panels, |c| c.min(panels));
    let rows = panels.div_ceil(per_row);
    let (w, h) = image;
    let column = w.max(160);
    let font = column / 11;
    let line = 5 * font / 4;
    let gap = (column / 40).max(4);
    let bar = font / 2;
    let width = per_row * column + (per_row + 1) * gap;
    let mut row = 2 * h + 3 * line + 3 * gap;
    if let Some((cw, ch)) = crop {
        let zoom = (w / cw).min(h / ch).max(1);
        row += gap + zoom * ch;
    }
    (width, 3 * gap + 3 * line + bar + rows * row)
}

/// The decoded size of a PNG file.
fn png_size(path: &Path) -> (u32, u32) {
    let image = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (image.width(), image.height())
}

/// The first cell of every data row of the CSV and of the Markdown table.
fn table_methods(folder: &Path) -> (Vec<String>, Vec<String>) {
    let csv = fs::read_to_string(folder.join("compare.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    assert_eq!(header, CSV_HEADER);
    // The first nine columns are those of earlier versions, in their order.
    assert!(header
        .starts_with("method,spp,seconds,rays,mrays_per_second,mse,rel_mse,efficiency,non_finite_pixels,"));
    let columns = header.split(',').count();
    let csv_rows: Vec<String> = lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            assert_eq!(cells.len(), columns, "{l}");
            // Numbers, or empty where absent (no efficiency, no split); the note on a missing
            // efficiency and the verdict are words.
            let note = header.split(',').position(|c| c == "efficiency_note").unwrap();
            let numeric = cells[1..columns - 1].iter().enumerate().filter(|(i, _)| i + 1 != note);
            assert!(numeric.clone().all(|(_, c)| c.is_empty() || c.parse::<f64>().is_ok()), "{l}");
            assert_eq!(
                cells[note].is_empty(),
                !cells[7].is_empty(),
                "a note exactly where no efficiency: {l}"
            );
            let verdicts = ["biased", "reference too noisy", "inconclusive", "no bias detected", "unknown"];
            assert!(verdicts.contains(&cells[columns - 1]), "{l}");
            cells[0].to_string()
        })
        .collect();
    let md = fs::read_to_string(folder.join("compare.md")).unwrap();
    let table: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
    assert!(table.len() >= 2 && table[0].contains("relMSE") && table[1].starts_with("|---"), "{md}");
    let md_rows = table[2..].iter().map(|l| l.split('|').nth(1).unwrap().trim().to_string()).collect();
    (csv_rows, md_rows)
}

#[test]
fn equal_samples_write_the_documented_figure_a_table_row_and_an_exr_per_method() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "raycast,whitted,path", "--spp", "2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let folder = sandbox.path("out/cmp");
    assert_eq!(
        sandbox.files("out/cmp"),
        [
            "compare.csv",
            "compare.md",
            "compare.png",
            "data",
            "index.html",
            "path.exr",
            "raycast.exr",
            "reference.exr",
            "report.css",
            "report.js",
            "whitted.exr"
        ]
    );
    // The report's data: the reference and one file per method.
    assert_eq!(
        sandbox.files("out/cmp/data"),
        ["s0-path.js", "s0-raycast.js", "s0-reference.js", "s0-whitted.js"]
    );
    assert_eq!(png_size(&folder.join("compare.png")), expected_figure_size(SIZE, 3, None));
    let (csv, md) = table_methods(&folder);
    assert_eq!(csv, ["raycast", "whitted", "path"]);
    assert_eq!(md, csv);
    let csv = fs::read_to_string(folder.join("compare.csv")).unwrap();
    assert!(csv.lines().skip(1).all(|l| l.split(',').nth(1) == Some("2")), "{csv}");

    let (image, attributes) = vitrum::output::exr::read_exr(&folder.join("whitted.exr")).unwrap();
    assert_eq!((image.width as u32, image.height as u32), SIZE);
    assert_eq!(attributes.get("vitrum:integrator").map(String::as_str), Some("whitted"));
    // `vitrum diff` reproduces every number of the table from the folder's own files: the
    // render against the reference copied beside it, at the exposure the render keeps.
    let rows = csv_rows(&folder);
    for row in &rows {
        let test = folder.join(format!("{}.exr", row["method"]));
        let out = Command::new(env!("CARGO_BIN_EXE_vitrum"))
            .args(["diff", test.to_str().unwrap(), folder.join("reference.exr").to_str().unwrap(), "--json"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for (column, key) in [
            ("mse", "mse"),
            ("rel_mse", "rel_mse"),
            ("psnr_preview", "psnr_preview"),
            ("ssim", "ssim"),
            ("flip", "flip"),
        ] {
            assert_eq!(
                row[column].parse::<f64>().unwrap(),
                v[key].as_f64().unwrap(),
                "{column}: {row:?} vs {v}"
            );
        }
        match row["verdict"].as_str() {
            "unknown" => assert!(v["split"].is_null(), "{v}"),
            verdict => {
                assert_eq!(v["split"]["verdict"], verdict, "{v}");
                for column in ["bias", "bias_se", "variance", "reference_variance", "rel_mse_se"] {
                    // NaN (no standard error) is `NaN` in the CSV and null in JSON.
                    let csv = row[column].parse::<f64>().unwrap();
                    let json = v["split"][column].as_f64().unwrap_or(f64::NAN);
                    assert!(csv == json || (csv.is_nan() && json.is_nan()), "{column}: {csv} vs {json}");
                }
            }
        }
    }
    // Nothing else was written: no temporary files, no reference cache.
    assert_eq!(sandbox.files("out"), ["cmp"]);
    assert!(!sandbox.path(".vitrum-cache").exists());
}

#[test]
fn a_crop_adds_the_magnified_inset_to_the_figure() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "whitted,light", "--spp", "1", "--crop", "8,6,8,6"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let with_crop = png_size(&sandbox.path("out/cmp/compare.png"));
    // k = min(32 / 8, 24 / 6) = 4: a 32×24 inset and one more gap of 4.
    assert_eq!(with_crop, expected_figure_size(SIZE, 2, Some((8, 6))));
    assert_eq!(
        with_crop,
        (expected_figure_size(SIZE, 2, None).0, expected_figure_size(SIZE, 2, None).1 + 28)
    );
    let (csv, md) = table_methods(&sandbox.path("out/cmp"));
    assert_eq!((csv.len(), md.len()), (2, 2));
}

#[test]
fn many_columns_wrap_into_rows_of_the_figure() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "raycast,whitted,light", "--spp", "1", "--columns", "3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The reference and three methods in rows of three: two rows, three columns wide.
    let size = png_size(&sandbox.path("out/cmp/compare.png"));
    assert_eq!(size, expected_wrapped_figure_size(SIZE, 3, None, Some(3)));
    assert!(size.0 < expected_figure_size(SIZE, 3, None).0 && size.1 > expected_figure_size(SIZE, 3, None).1);
    let bad = sandbox.compare(&["-i", "raycast", "--spp", "1", "--columns", "0", "--out", "out/bad"]);
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn equal_time_gives_every_method_whole_passes_for_at_least_its_time() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "whitted,path", "--time", "0.15"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let csv = fs::read_to_string(sandbox.path("out/cmp/compare.csv")).unwrap();
    for line in csv.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let (spp, seconds): (u32, f64) = (cells[1].parse().unwrap(), cells[2].parse().unwrap());
        assert!(spp >= 1 && seconds >= 0.15, "{line}");
    }
    let md = fs::read_to_string(sandbox.path("out/cmp/compare.md")).unwrap();
    assert!(md.contains("equal time"), "{md}");
}

#[test]
fn without_a_reference_file_the_path_reference_is_cached() {
    let sandbox = Sandbox::new();
    let scene = scene();
    let args = [
        "compare",
        &scene,
        "-i",
        "whitted",
        "--spp",
        "1",
        "--resolution",
        RESOLUTION,
        "--reference-spp",
        "4",
    ];
    let run = |out: &str| {
        let mut all = args.to_vec();
        all.extend(["--cache", "cache", "--out", out]);
        let output = sandbox.vitrum(&all);
        assert!(output.status.success(), "{}", stderr(&output));
        stderr(&output)
    };
    // The thesis scene has a point light and smooth glass: its reference is `vcm`, and the run
    // says why.
    let first = run("first");
    assert!(first.contains("reference: vcm, 4 spp, rendered and cached"), "{first}");
    assert!(first.contains("path and bpt cannot find the caustics of a point light"), "{first}");
    assert_eq!(sandbox.files("cache").len(), 2, "the EXR and its key");
    assert!(run("second").contains("read from the cache"));
    // `--reference-method` overrides the choice; the method is part of the cache key.
    let mut named = args.to_vec();
    named.extend(["--reference-method", "path", "--cache", "cache", "--out", "third"]);
    let third = sandbox.vitrum(&named);
    assert!(third.status.success(), "{}", stderr(&third));
    assert!(stderr(&third).contains("reference: path, 4 spp, rendered and cached"), "{}", stderr(&third));
    assert_eq!(sandbox.files("cache").len(), 4, "a second EXR and key");
    for bad in ["nope", "ssaa"] {
        let mut refused = args.to_vec();
        refused.extend(["--reference-method", bad, "--cache", "cache", "--out", "refused"]);
        let out = sandbox.vitrum(&refused);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(stderr(&out).contains(&format!("--reference-method {bad}")), "{}", stderr(&out));
        assert!(!sandbox.path("refused").exists());
    }
    for out in ["first", "second"] {
        assert_eq!(table_methods(&sandbox.path(out)), (vec!["whitted".into()], vec!["whitted".into()]));
    }
}

#[test]
fn bad_input_exits_2_before_rendering_and_leaves_nothing() {
    let sandbox = Sandbox::new();
    sandbox.render_reference("small.exr", "16x16");
    fs::write(sandbox.path("not-an-exr.exr"), "hello").unwrap();
    fs::write(sandbox.path("file"), "keep me").unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["-i", "path,nope"], "nope"),
        (&["-i", "path,path"], "twice"),
        (&["-i", " , "], "integrator"),
        (&["--reference", "small.exr"], "16x16"),
        (&["--reference", "missing.exr"], "missing.exr"),
        (&["--reference", "not-an-exr.exr"], "not-an-exr.exr"),
        (&["--crop", "30,20,8,8"], "32x24"),
        (&["--crop", "1,2,0,4"], "crop"),
        (&["--spp", "0"], "spp"),
        (&["--spp", "-3"], "spp"),
        (&["--time", "-1"], "time"),
        (&["--time", "abc"], "time"),
        (&["--time", "nan"], "time"),
        (&["--time", "1", "--spp", "2"], "spp"),
        (&["--reference-spp", "4"], "reference"),
        (&["--exposure", "nan"], "exposure"),
        (&["--threads", "0"], "thread"),
        (&["--max-depth", "100000"], "max-depth"),
        (&["--out", "file"], "file"),
        (&["--out", "out/missing/cmp"], "missing"),
    ];
    for (extra, needle) in cases {
        let out = sandbox.compare(extra);
        let message = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {message}");
        assert!(message.contains(needle), "{extra:?} should name `{needle}`: {message}");
        assert!(!message.contains("panicked"), "{extra:?}: {message}");
        assert!(sandbox.files("out").is_empty(), "{extra:?} left {:?}", sandbox.files("out"));
    }
    assert_eq!(fs::read_to_string(sandbox.path("file")).unwrap(), "keep me");
    assert!(!sandbox.path(".vitrum-cache").exists());

    // A render that would replace the reference itself is refused too.
    fs::create_dir(sandbox.path("keep")).unwrap();
    fs::copy(sandbox.path("ref.exr"), sandbox.path("keep/path.exr")).unwrap();
    let out = sandbox.compare(&["-i", "whitted,path", "--reference", "keep/path.exr", "--out", "keep"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("over the reference"), "{}", stderr(&out));
    assert_eq!(sandbox.files("keep"), ["path.exr"]);
    assert_eq!(fs::read(sandbox.path("keep/path.exr")).unwrap(), fs::read(sandbox.path("ref.exr")).unwrap());
}

/// The CSV of `folder` as rows of (column name, cell).
fn csv_rows(folder: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let csv = fs::read_to_string(folder.join("compare.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines.map(|l| header.iter().cloned().zip(l.split(',').map(String::from)).collect()).collect()
}

#[test]
fn ssaa_states_its_real_rays_per_pixel_and_is_marked_biased() {
    // ssaa renders one deterministic, adaptive pattern: no variance, so all of its error is bias
    // (it has no efficiency), and its spp is its camera rays per pixel, not a rounded count.
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "ssaa,path", "--spp", "2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let folder = sandbox.path("out/cmp");
    let rows = csv_rows(&folder);
    let ssaa = &rows[0];
    assert_eq!(ssaa["method"], "ssaa");
    let (_, attributes) = vitrum::output::exr::read_exr(&folder.join("ssaa.exr")).unwrap();
    let rays = vitrum::output::exr::parse_rays(&attributes["vitrum:rays"]).unwrap();
    let per_pixel = rays.primary as f64 / f64::from(SIZE.0 * SIZE.1);
    assert_eq!(ssaa["spp"].parse::<f64>().unwrap(), per_pixel, "{ssaa:?}");
    assert!(per_pixel > 1.0 && per_pixel.fract() != 0.0, "{per_pixel}");
    assert_eq!((ssaa["verdict"].as_str(), ssaa["efficiency"].as_str()), ("biased", ""));
    assert_eq!(ssaa["variance"], "0");
    let bias: f64 = ssaa["bias"].parse().unwrap();
    assert!(bias > 3.0 * ssaa["bias_se"].parse::<f64>().unwrap(), "{ssaa:?}");
    // path renders 2 samples, with a variance: its split is there.
    assert_eq!(rows[1]["spp"], "2");
    assert!(rows[1]["variance"].parse::<f64>().unwrap() > 0.0, "{:?}", rows[1]);

    let md = fs::read_to_string(folder.join("compare.md")).unwrap();
    let ssaa_line = md.lines().find(|l| l.starts_with("| ssaa |")).unwrap();
    assert!(ssaa_line.contains(&format!("| {per_pixel:.2} |")) && ssaa_line.contains("| biased |"), "{md}");
    for needle in ["relMSE 99.9%", "PSNR LDR", "SSIM", "bias part", "docs/workflow.md"] {
        assert!(md.contains(needle), "compare.md lacks `{needle}`: {md}");
    }
    // It cites the manual's page, not a DESIGN.md that the repository does not have.
    assert!(!md.contains("DESIGN.md"), "{md}");
}

#[test]
fn regions_are_measured_beside_the_whole_image_as_diff_measures_a_crop() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&[
        "-i",
        "whitted,path",
        "--spp",
        "4",
        "--region",
        "caustic=8,6,8,6",
        "--region",
        "0,0,4,4",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let folder = sandbox.path("out/cmp");
    let csv = fs::read_to_string(folder.join("compare-regions.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.join(","), vitrum::commands::compare::REGIONS_CSV_HEADER);
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let key: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    assert_eq!(
        key,
        [("whitted", "caustic"), ("whitted", "0-0-4-4"), ("path", "caustic"), ("path", "0-0-4-4")]
    );
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for row in &rows {
        assert_eq!(row.len(), header.len(), "{row:?}");
        // `vitrum diff --crop` gives the same numbers over the same rectangle.
        let crop = format!("{},{},{},{}", row[2], row[3], row[4], row[5]);
        let test = folder.join(format!("{}.exr", row[0]));
        let out = Command::new(env!("CARGO_BIN_EXE_vitrum"))
            .args([
                "diff",
                test.to_str().unwrap(),
                folder.join("reference.exr").to_str().unwrap(),
                "--crop",
                &crop,
                "--json",
            ])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for name in ["mse", "rel_mse", "ssim"] {
            let csv: f64 = row[column(name)].parse().unwrap();
            let json = v[name].as_f64().unwrap_or(f64::NAN);
            assert!(csv == json || (csv.is_nan() && json.is_nan()), "{name}: {row:?} vs {v}");
        }
        assert_eq!(row[column("verdict")], v["split"]["verdict"].as_str().unwrap_or("unknown"), "{v}");
    }
    let md = fs::read_to_string(folder.join("compare.md")).unwrap();
    assert!(md.contains("## Regions") && md.contains("| path | caustic (8,6,8,6) | 48 |"), "{md}");

    // A region outside the image, a bad name, or a name given twice: bad input, nothing written.
    for bad in [
        &["--region", "big=30,20,8,8"][..],
        &["--region", "a b=0,0,2,2"],
        &["--region", "x=0,0,2,2", "--region", "x=1,1,2,2"],
    ] {
        let out = sandbox.compare(&[&["-i", "path", "--spp", "2", "--out", "out/bad"][..], bad].concat());
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {}", stderr(&out));
        assert!(!sandbox.path("out/bad").exists(), "{bad:?}");
    }
}

#[test]
fn the_sampler_and_the_replicas_of_the_methods_are_options() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "path", "--spp", "6", "--sampler", "independent", "--replicas", "3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (_, attributes) = vitrum::output::exr::read_exr(&sandbox.path("out/cmp/path.exr")).unwrap();
    // 6 samples in 3 replicas: 2 each.
    assert_eq!(attributes.get("vitrum:replica-samples").map(String::as_str), Some("2,2,2"));
    let independent = sandbox.vitrum(&[
        "render",
        &scene(),
        "-i",
        "path",
        "--spp",
        "6",
        "--sampler",
        "independent",
        "--replicas",
        "3",
        "--resolution",
        RESOLUTION,
        "-o",
        "plain.exr",
        "--quiet",
    ]);
    assert!(independent.status.success(), "{}", stderr(&independent));
    let (a, _) = vitrum::output::exr::read_exr(&sandbox.path("out/cmp/path.exr")).unwrap();
    let (b, _) = vitrum::output::exr::read_exr(&sandbox.path("plain.exr")).unwrap();
    assert_eq!(a.pixels, b.pixels, "compare's render is the render of the same options");
    let bad = sandbox.compare(&["-i", "path", "--spp", "2", "--sampler", "halton", "--out", "out/bad"]);
    assert_eq!(bad.status.code(), Some(2));
    let bad = sandbox.compare(&["-i", "path", "--spp", "2", "--replicas", "0", "--out", "out/bad"]);
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn variants_of_one_method_are_columns_of_their_own() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "path,path[max_depth=1,sampler=independent]", "--spp", "4"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let folder = sandbox.path("out/cmp");
    let rows = csv_rows(&folder);
    let labels: Vec<&str> = rows.iter().map(|r| r["method"].as_str()).collect();
    // The label has a comma: the CSV quotes it.
    assert_eq!(labels[0], "path");
    let csv = fs::read_to_string(folder.join("compare.csv")).unwrap();
    assert!(csv.lines().nth(2).unwrap().starts_with("\"path[max_depth=1,sampler=independent]\",4,"), "{csv}");
    assert!(sandbox.files("out/cmp").contains(&"path-max_depth-1-sampler-independent.exr".to_string()));
    let (variant, attributes) =
        vitrum::output::exr::read_exr(&folder.join("path-max_depth-1-sampler-independent.exr")).unwrap();
    assert_eq!(attributes["vitrum:integrator"], "path");
    assert_eq!(attributes["vitrum:variant"], "path[max_depth=1,sampler=independent]");
    // It is the render of those settings.
    let plain = sandbox.vitrum(&[
        "render",
        &scene(),
        "-i",
        "path",
        "--spp",
        "4",
        "--max-depth",
        "1",
        "--sampler",
        "independent",
        "--resolution",
        RESOLUTION,
        "-o",
        "depth1.exr",
        "--quiet",
    ]);
    assert!(plain.status.success(), "{}", stderr(&plain));
    assert_eq!(variant.pixels, vitrum::output::exr::read_exr(&sandbox.path("depth1.exr")).unwrap().0.pixels);
    let md = fs::read_to_string(folder.join("compare.md")).unwrap();
    assert!(md.contains("| path[max_depth=1,sampler=independent] |"), "{md}");
    // The same method twice without settings of its own is refused.
    let twice = sandbox.compare(&["-i", "vcm,vcm", "--spp", "1", "--out", "out/twice"]);
    assert_eq!(twice.status.code(), Some(2));
    assert!(stderr(&twice).contains("named twice"), "{}", stderr(&twice));
}

/// Writes a `SIZE` PNG mask that is white where `selected(x, y)`.
fn write_mask(path: &Path, selected: impl Fn(u32, u32) -> bool) {
    let mask =
        image::GrayImage::from_fn(SIZE.0, SIZE.1, |x, y| image::Luma([if selected(x, y) { 255 } else { 0 }]));
    mask.save(path).unwrap();
}

#[test]
fn a_mask_restricts_every_metric_to_its_white_pixels() {
    let sandbox = Sandbox::new();
    // A mask that is the rectangle 8,6,8,6 gives that region's numbers; a ring (a rectangle less
    // its centre) counts only its own pixels.
    write_mask(&sandbox.path("box.png"), |x, y| (8..16).contains(&x) && (6..12).contains(&y));
    let ring = |x: u32, y: u32| {
        (4..20).contains(&x) && (4..16).contains(&y) && !((8..16).contains(&x) && (8..12).contains(&y))
    };
    write_mask(&sandbox.path("ring.png"), ring);
    let out = sandbox.compare(&[
        "-i",
        "path",
        "--spp",
        "4",
        "--region",
        "rect=8,6,8,6",
        "--mask",
        "box.png",
        "--mask",
        "hole=ring.png",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let folder = sandbox.path("out/cmp");
    let csv = fs::read_to_string(folder.join("compare-regions.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let names: Vec<&str> = rows.iter().map(|r| r[1]).collect();
    assert_eq!(names, ["rect", "box", "hole"]);
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    // Every metric of the box mask is the rectangle's.
    for name in ["pixels", "mse", "rel_mse", "ssim", "flip", "bias", "bias_se", "verdict"] {
        assert_eq!(rows[0][column(name)], rows[1][column(name)], "{name}");
    }
    // The ring: its bounding box, and only its own pixels.
    let ring_pixels =
        (0..SIZE.1).flat_map(|y| (0..SIZE.0).map(move |x| (x, y))).filter(|&(x, y)| ring(x, y)).count();
    assert_eq!(rows[2][column("pixels")], ring_pixels.to_string());
    assert_eq!(&rows[2][2..6], ["4", "4", "16", "12"]);
    // `vitrum diff --mask` gives the same numbers.
    let diff = sandbox.vitrum(&[
        "diff",
        folder.join("path.exr").to_str().unwrap(),
        folder.join("reference.exr").to_str().unwrap(),
        "--mask",
        "ring.png",
        "--json",
    ]);
    assert!(diff.status.success(), "{}", stderr(&diff));
    let v: serde_json::Value = serde_json::from_slice(&diff.stdout).unwrap();
    for name in ["mse", "rel_mse", "flip"] {
        assert_eq!(rows[2][column(name)].parse::<f64>().unwrap(), v[name].as_f64().unwrap(), "{name}");
    }
    assert_eq!(rows[2][column("verdict")], v["split"]["verdict"].as_str().unwrap());
    let md = fs::read_to_string(folder.join("compare.md")).unwrap();
    assert!(md.contains(&format!("| path | hole (mask in 4,4,16,12) | {ring_pixels} |")), "{md}");

    // A mask of another size, one that selects nothing, a file that is no image, or a name taken
    // by a region: bad input, nothing written.
    image::GrayImage::new(8, 8).save(sandbox.path("small.png")).unwrap();
    write_mask(&sandbox.path("black.png"), |_, _| false);
    fs::write(sandbox.path("text.png"), "not a png").unwrap();
    for bad in [
        &["--mask", "small.png"][..],
        &["--mask", "black.png"],
        &["--mask", "text.png"],
        &["--mask", "missing.png"],
        &["--region", "box=0,0,2,2", "--mask", "box.png"],
    ] {
        let out = sandbox.compare(&[&["-i", "path", "--spp", "2", "--out", "out/bad"][..], bad].concat());
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {}", stderr(&out));
        assert!(stderr(&out).contains("--mask"), "{bad:?}: {}", stderr(&out));
        assert!(!sandbox.path("out/bad").exists(), "{bad:?}");
    }
}

#[test]
fn repeated_runs_give_intervals_over_seeds_and_the_first_run_is_the_plain_render() {
    let sandbox = Sandbox::new();
    let out = sandbox.compare(&["-i", "path,whitted", "--spp", "2", "--repeat", "4", "--seed", "7"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let folder = sandbox.path("out/cmp");
    let runs = fs::read_to_string(folder.join("compare-runs.csv")).unwrap();
    let mut lines = runs.lines();
    assert_eq!(lines.next().unwrap(), vitrum::commands::compare::RUNS_CSV_HEADER);
    let runs: Vec<Vec<String>> = lines.map(|l| l.split(',').map(String::from).collect()).collect();
    assert_eq!(runs.len(), 8, "{runs:?}");
    let path_runs: Vec<&Vec<String>> = runs.iter().filter(|r| r[0] == "path").collect();
    let seeds: Vec<&str> = path_runs.iter().map(|r| r[2].as_str()).collect();
    assert_eq!(seeds, ["7", "8", "9", "10"]);
    let rel: Vec<f64> = path_runs.iter().map(|r| r[5].parse().unwrap()).collect();
    // Independent runs of a noisy method differ.
    assert!(rel.windows(2).all(|w| w[0] != w[1]), "{rel:?}");
    // The table's relMSE is their mean, inside its interval; the first run is the plain render of
    // the seed (the file kept, whose relMSE diff measures).
    let rows = csv_rows(&folder);
    let path = rows.iter().find(|r| r["method"] == "path").unwrap();
    let mean = rel.iter().sum::<f64>() / 4.0;
    let table: f64 = path["rel_mse"].parse().unwrap();
    assert!((table - mean).abs() <= 1e-12 * mean, "{table} vs {mean}");
    let (low, high): (f64, f64) =
        (path["rel_mse_low"].parse().unwrap(), path["rel_mse_high"].parse().unwrap());
    assert!(low < mean && mean < high, "{low} {mean} {high}");
    assert_eq!(path["runs"], "4");
    let (s_low, s_high): (f64, f64) =
        (path["seconds_low"].parse().unwrap(), path["seconds_high"].parse().unwrap());
    assert!(s_low <= path["seconds"].parse::<f64>().unwrap() && s_low <= s_high);
    let diff = sandbox.vitrum(&[
        "diff",
        folder.join("path.exr").to_str().unwrap(),
        folder.join("reference.exr").to_str().unwrap(),
        "--json",
    ]);
    assert!(diff.status.success(), "{}", stderr(&diff));
    let v: serde_json::Value = serde_json::from_slice(&diff.stdout).unwrap();
    assert_eq!(v["rel_mse"].as_f64().unwrap(), rel[0], "run 0 is the file kept");
    let (_, attributes) = vitrum::output::exr::read_exr(&folder.join("path.exr")).unwrap();
    assert_eq!(attributes["vitrum:seed"], "7");
    assert_eq!(runs.iter().filter(|r| r[0] == "whitted").count(), 4);
    let md = fs::read_to_string(folder.join("compare.md")).unwrap();
    assert!(md.contains("rendered 4 times"), "{md}");
    // --repeat 0 and --repeat with --renders are refused.
    let bad = sandbox.compare(&["-i", "path", "--spp", "2", "--repeat", "0", "--out", "out/bad"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(!sandbox.path("out/bad").exists());
}

#[test]
fn a_deliberately_short_reference_is_flagged_in_the_table_on_stderr_and_in_the_page() {
    // glass-in-sky's sun through glass: the reference method is chosen by pilot renders, and a
    // 16-sample reference is far noisier than half a second of path or vcm (its variance part
    // was about 100% of their error when measured, the limit is 10%).
    let sandbox = Sandbox::new();
    let sky = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass-in-sky.toml");
    let out = sandbox.vitrum(&[
        "compare",
        sky.to_str().unwrap(),
        "-i",
        "path,vcm",
        "--time",
        "0.5",
        "--resolution",
        "48x36",
        "--reference-spp",
        "16",
        "--cache",
        "cache",
        "--out",
        "out/sky",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("relative variance × seconds in 0.50 s pilots"), "chosen by measurement: {err}");
    assert!(err.contains("the reference is too noisy to judge the bias of path"), "{err}");
    assert!(err.contains("--reference-spp"), "it says what would do: {err}");
    let folder = sandbox.path("out/sky");
    for row in csv_rows(&folder) {
        assert_eq!(row["verdict"], "reference too noisy", "{row:?}");
        assert!(row["efficiency"].is_empty(), "no efficiency against a noisy reference: {row:?}");
    }
    let md = fs::read_to_string(folder.join("compare.md")).unwrap();
    assert_eq!(md.lines().filter(|l| l.contains("| reference too noisy |")).count(), 2, "{md}");
    let page = fs::read_to_string(folder.join("index.html")).unwrap();
    assert!(page.contains("<td data-value=\"reference too noisy\">"), "the page's table flags it");
}
