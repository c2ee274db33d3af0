//! The interactive report in a real headless Chromium (`tests/common/browser.rs`, the DevTools
//! protocol): the page opens from `file://` with no console error and no failed request; number
//! keys switch methods, `+`/`-` and the slider move the exposure, `b` flips, `s` splits, `e`
//! shows error maps; the canvas pixels read back equal the tone-mapped values of the EXR files
//! (±1 of 255, the rounding of the page's double-precision arithmetic against the test's single
//! precision, both from the same half floats); the table equals `compare.csv`; zoom keeps the
//! pixel under the mouse and the readout names it; texts from the scene are shown as text; the
//! same renders give the same files. A missing browser fails these tests (`.ci/run` installs
//! Debian's `chromium`).

mod common;

use common::browser::Browser;
use serde_json::Value;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use vitrum::figure::colormap::error_colour;
use vitrum::image::Image;
use vitrum::metrics::relative_squared_error;
use vitrum::output::exr::read_exr;
use vitrum::output::png::to_srgb8;
use vitrum::report::data::to_half;

/// The object name that must reach the page as text, never as markup.
const HOSTILE: &str = "<script>alert(1)</script>";

/// The time a page may take to become ready; generous for a slow CI machine.
const READY: Duration = Duration::from_secs(120);

/// Runs the vitrum binary; panics with its stderr when it fails.
fn vitrum(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).output().unwrap();
    assert!(out.status.success(), "vitrum {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// The soft-shadows scene with its sphere named [`HOSTILE`].
fn hostile_scene(dir: &Path) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = fs::read_to_string(root.join("scenes/soft-shadows.toml")).unwrap();
    assert!(text.contains("name = \"floor\""));
    let path = dir.join("hostile.toml");
    fs::write(&path, text.replacen("name = \"floor\"", &format!("name = \"{HOSTILE}\""), 1)).unwrap();
    path
}

/// `image` with every channel rounded to a half float, as the page holds it.
fn as_half(image: &Image) -> Image {
    let mut out = image.clone();
    for p in &mut out.pixels {
        *p = glam::Vec3::from_array(p.to_array().map(|c| to_half(c).to_f32()));
    }
    out
}

/// The only EXR in `dir` (the cached reference).
fn only_exr(dir: &Path) -> PathBuf {
    let exrs: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension() == Some("exr".as_ref()))
        .collect();
    assert_eq!(exrs.len(), 1, "{exrs:?}");
    exrs[0].clone()
}

/// The RGB bytes of the first viewer's canvas at the centre of every image pixel, row by row.
fn canvas_pixels(browser: &mut Browser, width: usize, height: usize) -> Vec<u8> {
    let js = format!(
        "(() => {{ const v = vitrumReport.viewers[0]; const c = v.canvas.getContext('2d');
           const out = [];
           for (let y = 0; y < {height}; y++) for (let x = 0; x < {width}; x++) {{
             const p = v.pixelCentre(x, y);
             const d = c.getImageData(Math.floor(p.canvasX), Math.floor(p.canvasY), 1, 1).data;
             out.push(d[0], d[1], d[2]);
           }}
           return out; }})()"
    );
    let value = browser.eval(&js).unwrap();
    value.as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as u8).collect()
}

/// The largest difference between two byte rasters, and where.
fn largest_difference(a: &[u8], b: &[u8]) -> (u8, usize) {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).enumerate().map(|(i, (x, y))| (x.abs_diff(*y), i / 3)).max().unwrap_or((0, 0))
}

/// Asserts that the canvas shows `expected` (RGB bytes) within one code value.
fn assert_shows(browser: &mut Browser, expected: &[u8], width: usize, height: usize, what: &str) {
    let shown = canvas_pixels(browser, width, height);
    let (difference, pixel) = largest_difference(&shown, expected);
    assert!(
        difference <= 1,
        "{what}: pixel ({}, {}) differs by {difference} of 255",
        pixel % width,
        pixel / width
    );
}

/// The first viewer's state.
fn state(browser: &mut Browser) -> Value {
    browser.eval("vitrumReport.viewers[0].state()").unwrap()
}

/// Opens `page`, waits until every viewer has drawn, and checks that nothing went wrong.
fn open_ready(browser: &mut Browser, page: &Path) -> Duration {
    let loaded = browser.open(page).unwrap();
    browser.wait_until("window.vitrumReport && vitrumReport.ready", READY).unwrap();
    assert_eq!(browser.problems(), Vec::<String>::new(), "problems while loading {}", page.display());
    loaded
}

#[test]
fn the_page_shows_the_exr_values_tone_mapped_and_answers_every_control() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = hostile_scene(dir.path());
    let (out, cache) = (dir.path().join("cmp"), dir.path().join("cache"));
    let (width, height) = (48usize, 36usize);
    vitrum(&[
        "compare",
        scene.to_str().unwrap(),
        "-i",
        "path,light,bpt",
        "--spp",
        "4",
        "--reference-spp",
        "16",
        "--resolution",
        &format!("{width}x{height}"),
        "--cache",
        cache.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let image = |path: &Path| as_half(&read_exr(path).unwrap().0);
    let reference = image(&only_exr(&cache));
    let path = image(&out.join("path.exr"));
    let light = image(&out.join("light.exr"));

    let mut browser = Browser::launch_with_size(1000, 900).expect("headless Chromium (.ci/run installs it)");
    open_ready(&mut browser, &out.join("index.html"));
    let start = state(&mut browser);
    let exposure = start["exposure"].as_f64().unwrap() as f32;
    assert_eq!(start["a"], 1, "the first method is shown first: {start}");
    assert!(start["zoom"].as_f64().unwrap() >= 8.0, "the small image is magnified: {start}");
    assert_shows(&mut browser, &to_srgb8(&path, exposure), width, height, "path at the scene's exposure");

    // Number keys switch methods; r shows the reference.
    browser.press("2").unwrap();
    assert_eq!(state(&mut browser)["a"], 2);
    assert_shows(&mut browser, &to_srgb8(&light, exposure), width, height, "light after key 2");
    browser.press("r").unwrap();
    assert_shows(&mut browser, &to_srgb8(&reference, exposure), width, height, "reference after key r");
    browser.press("1").unwrap();

    // + twice is one stop brighter; the slider sets any exposure.
    browser.press("+").unwrap();
    browser.press("+").unwrap();
    assert_eq!(state(&mut browser)["exposure"].as_f64().unwrap() as f32, exposure + 1.0);
    assert_shows(&mut browser, &to_srgb8(&path, exposure + 1.0), width, height, "path after + +");
    browser
        .eval(
            "(() => { const s = document.querySelector('input.exposure'); s.value = '-2.5';
               s.dispatchEvent(new Event('input')); })()",
        )
        .unwrap();
    assert_eq!(state(&mut browser)["exposure"].as_f64().unwrap(), -2.5);
    assert_shows(&mut browser, &to_srgb8(&path, -2.5), width, height, "path at the slider's -2.5 EV");
    browser.press("-").unwrap();
    assert_eq!(state(&mut browser)["exposure"].as_f64().unwrap(), -3.0);

    // Holding b shows image B (the reference) until it is released.
    browser.key_down("b").unwrap();
    assert_eq!(state(&mut browser)["shown"], 0);
    assert_shows(&mut browser, &to_srgb8(&reference, -3.0), width, height, "B while b is held");
    browser.key_up("b").unwrap();
    assert_eq!(state(&mut browser)["shown"], 1);

    // Split: the left half shows A (path), the right half B (the reference).
    browser.press("s").unwrap();
    let split = canvas_pixels(&mut browser, width, height);
    let (path8, reference8) = (to_srgb8(&path, -3.0), to_srgb8(&reference, -3.0));
    let differing =
        path8.chunks(3).zip(reference8.chunks(3)).filter(|(a, b)| largest_difference(a, b).0 > 1).count();
    assert!(
        differing > width * height / 4,
        "A and B must differ for the split to be seen: {differing} pixels"
    );
    // Each column's canvas x, and the split line's (a column on the line itself is skipped).
    let columns = browser
        .eval(&format!(
            "(() => {{ const v = vitrumReport.viewers[0];
               return {{ line: Math.round(v.splitAt * v.canvas.width),
                        xs: [...Array({width}).keys()].map(x => Math.floor(v.pixelCentre(x, 0).canvasX)) }}; }})()"
        ))
        .unwrap();
    let line = columns["line"].as_i64().unwrap();
    let xs: Vec<i64> = columns["xs"].as_array().unwrap().iter().map(|v| v.as_i64().unwrap()).collect();
    assert!(xs[0] < line && xs[width - 1] > line, "the line {line} lies inside the image: {xs:?}");
    for y in 0..height {
        for (x, &cx) in xs.iter().enumerate().filter(|(_, &cx)| cx != line) {
            let expected = if cx < line { &path8 } else { &reference8 };
            let i = 3 * (y * width + x);
            let d = largest_difference(&split[i..i + 3], &expected[i..i + 3]).0;
            assert!(d <= 1, "split: pixel ({x}, {y}) at canvas x {cx} shows the wrong side of {line}");
        }
    }
    browser.press("s").unwrap();

    // e: the error map of path against the reference, on the section's log scale.
    browser.press("e").unwrap();
    let decades = browser.eval("vitrumReport.viewers[0].meta.decades").unwrap();
    let decades = (decades[0].as_i64().unwrap() as i32, decades[1].as_i64().unwrap() as i32);
    let errors = relative_squared_error(&path, &reference).unwrap();
    let expected: Vec<u8> = errors.iter().flat_map(|&e| error_colour(e, decades)).collect();
    assert_shows(&mut browser, &expected, width, height, "the error map of path");
    browser.press("e").unwrap();

    // The wheel zooms by two about the cursor; the readout names the pixel under it.
    browser.press("3").unwrap();
    let (x, y) = (20, 15);
    let centre = browser.eval(&format!("vitrumReport.viewers[0].pixelCentre({x}, {y})")).unwrap();
    let (page_x, page_y) = (centre["pageX"].as_f64().unwrap(), centre["pageY"].as_f64().unwrap());
    browser.mouse_move(page_x, page_y).unwrap();
    let readout = browser.eval("document.querySelector('.readout').dataset.x + ',' + document.querySelector('.readout').dataset.y").unwrap();
    assert_eq!(readout, format!("{x},{y}"));
    let text = browser.eval("document.querySelector('.readout').textContent").unwrap();
    let text = text.as_str().unwrap();
    assert!(text.contains(&format!("pixel ({x}, {y})")), "{text}");
    // The linear values of the method (bpt, tab 3) and of the reference, to the 4 digits shown,
    // and their relative squared error.
    let bpt = image(&out.join("bpt.exr"));
    let triple = |label: &str| -> Vec<f32> {
        let start = text.find(&format!("{label}: (")).unwrap_or_else(|| panic!("{label} in {text}"))
            + label.len()
            + 3;
        let end = start + text[start..].find(')').unwrap();
        text[start..end].split(", ").map(|v| v.parse().unwrap()).collect()
    };
    let (shown, truth) = (triple("bpt"), bpt.get(x, y).to_array());
    let (reference_shown, reference_truth) = (triple("reference"), reference.get(x, y).to_array());
    for c in 0..3 {
        let near = |a: f32, b: f32| (a - b).abs() <= 1e-3 * b.abs().max(1e-30);
        assert!(near(shown[c], truth[c]), "bpt channel {c}: {} against {}", shown[c], truth[c]);
        assert!(near(reference_shown[c], reference_truth[c]), "reference channel {c}");
    }
    let error: f32 = text.rsplit("relative squared error ").next().unwrap().parse().unwrap();
    let expected = relative_squared_error(&bpt, &reference).unwrap()[y * width + x];
    assert!((error - expected).abs() <= 1e-3 * expected.max(1e-30), "error {error} against {expected}");
    let zoom = state(&mut browser)["zoom"].as_f64().unwrap();
    browser.mouse_wheel(page_x, page_y, -100.0).unwrap();
    assert_eq!(state(&mut browser)["zoom"].as_f64().unwrap(), 2.0 * zoom);
    let readout = browser.eval("document.querySelector('.readout').dataset.x + ',' + document.querySelector('.readout').dataset.y").unwrap();
    assert_eq!(readout, format!("{x},{y}"), "the pixel under the cursor stays under it");
    // Dragging pans by the distance dragged (device pixel ratio 1).
    let before = state(&mut browser);
    browser.drag((page_x, page_y), (page_x + 40.0, page_y - 24.0)).unwrap();
    let after = state(&mut browser);
    assert_eq!(after["ox"].as_f64().unwrap(), before["ox"].as_f64().unwrap() + 40.0, "{after}");
    assert_eq!(after["oy"].as_f64().unwrap(), before["oy"].as_f64().unwrap() - 24.0, "{after}");
    // Zoom is shared by the methods: switching keeps it.
    browser.press("3").unwrap();
    assert_eq!(state(&mut browser)["zoom"].as_f64().unwrap(), 2.0 * zoom);
    browser.press("f").unwrap();
    assert_eq!(state(&mut browser)["zoom"].as_f64().unwrap(), zoom);

    // The table holds compare.csv's values exactly, and sorts by a clicked column.
    let csv = fs::read_to_string(out.join("compare.csv")).unwrap();
    let cells = browser
        .eval("[...document.querySelectorAll('table.results tbody tr')].map(r => [...r.cells].map(c => c.dataset.value))")
        .unwrap();
    let cells = cells.as_array().unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let lines: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(cells.len(), lines.len());
    // The page's numeric columns and the CSV columns they show.
    let columns = [
        (1, "spp"),
        (2, "seconds"),
        (3, "rays"),
        (4, "mrays_per_second"),
        (5, "mse"),
        (6, "rel_mse"),
        (7, "rel_mse_trimmed"),
        (8, "psnr"),
        (9, "ssim"),
        (10, "flip"),
        (11, "bias"),
        (12, "efficiency"),
    ];
    for (row, line) in cells.iter().zip(&lines) {
        let fields: Vec<&str> = line.split(',').collect();
        let row: Vec<&str> = row.as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
        assert_eq!(row[0], fields[0]);
        for (k, name) in columns {
            let field = fields[header.iter().position(|h| *h == name).unwrap()];
            let page: Option<f64> = row[k].parse().ok();
            let file: Option<f64> = field.parse().ok();
            assert_eq!(
                page, file,
                "{} column {k} ({name}): page {} against compare.csv {field}",
                fields[0], row[k]
            );
        }
        let verdict = fields[header.len() - 1];
        assert!(row[13].starts_with(verdict), "{}: verdict {} against {verdict}", fields[0], row[13]);
    }
    // Sorting: by number, not by text (efficiency 12.5 after 9.07), empty cells (methods with
    // no efficiency) last either way; the second click reverses.
    let column = |browser: &mut Browser, k: usize| {
        let values = browser
            .eval(&format!(
                "[...document.querySelectorAll('table.results tbody tr')].map(r => r.cells[{k}].dataset.value)"
            ))
            .unwrap();
        values.as_array().unwrap().iter().map(|v| v.as_str().unwrap().to_string()).collect::<Vec<_>>()
    };
    for k in [6, 12, 2] {
        for ascending in [true, false] {
            browser.eval(&format!("document.querySelectorAll('table.results th')[{k}].click()")).unwrap();
            let cells = column(&mut browser, k);
            let numbers: Vec<f64> =
                cells.iter().filter(|c| !c.is_empty()).map(|c| c.parse().unwrap()).collect();
            let ordered = numbers.windows(2).all(|w| if ascending { w[0] <= w[1] } else { w[0] >= w[1] });
            assert!(ordered, "column {k}, ascending {ascending}: {cells:?}");
            let first_empty = cells.iter().position(String::is_empty).unwrap_or(cells.len());
            assert!(cells[first_empty..].iter().all(String::is_empty), "empty cells last: {cells:?}");
        }
    }

    // The hostile object name is text on the page, and no script carries it.
    let shown = browser.eval("document.querySelector('dl.details').textContent").unwrap();
    assert!(shown.as_str().unwrap().contains(HOSTILE), "{shown}");
    let scripts = browser
        .eval("[...document.scripts].filter(s => s.id !== 'vitrum-data' && s.textContent.includes('alert')).length")
        .unwrap();
    assert_eq!(scripts, 0);
    assert_eq!(browser.problems(), Vec::<String>::new());

    // The same renders give the same files: lay out the EXRs again (compare --renders) twice.
    let renders: Vec<String> =
        ["path", "light", "bpt"].iter().map(|m| out.join(format!("{m}.exr")).display().to_string()).collect();
    let again = dir.path().join("again");
    let reference_file = only_exr(&cache).display().to_string();
    let layout = || {
        let mut args = vec![
            "compare",
            "--reference",
            &reference_file,
            "--out",
            again.to_str().unwrap(),
            "--quiet",
            "--renders",
        ];
        args.extend(renders.iter().map(String::as_str));
        args.insert(1, scene.to_str().unwrap());
        vitrum(&args);
        let mut files: Vec<(PathBuf, Vec<u8>)> =
            walk(&again).into_iter().map(|p| (p.clone(), fs::read(&p).unwrap())).collect();
        files.sort();
        files
    };
    let first = layout();
    assert!(first.iter().any(|(p, _)| p.ends_with("index.html")));
    let second = layout();
    let names = |files: &[(PathBuf, Vec<u8>)]| files.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
    assert_eq!(names(&first), names(&second));
    let differing: Vec<&PathBuf> =
        first.iter().zip(&second).filter(|(a, b)| a.1 != b.1).map(|(a, _)| &a.0).collect();
    assert!(differing.is_empty(), "the same renders gave other bytes in {differing:?}");
}

/// Every file below `dir`.
fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(walk(&path));
        } else {
            out.push(path);
        }
    }
    out
}

#[test]
fn a_six_method_800_by_800_report_loads_cleanly() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let started = Instant::now();
    vitrum(&[
        "report",
        root.join("scenes/cornell-glass.toml").to_str().unwrap(),
        "-i",
        "raycast,whitted,path,light,bpt,vcm",
        "--spp",
        "1",
        "--reference-spp",
        "1",
        "--resolution",
        "800x800",
        "--cache",
        dir.path().join("cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let rendered = started.elapsed();
    let files = walk(&out);
    let size: u64 = files.iter().map(|p| fs::metadata(p).unwrap().len()).sum();
    // The viewer's own files: the page, its script and style, and the data (not the scene folder's EXRs).
    let page_size: u64 = files
        .iter()
        .filter(|p| p.parent() == Some(out.as_path()) || p.parent().unwrap().ends_with("data"))
        .map(|p| fs::metadata(p).unwrap().len())
        .sum();
    let data: Vec<&PathBuf> = files.iter().filter(|p| p.parent().unwrap().ends_with("data")).collect();
    // Seven images (six methods and the reference) of 800×800 half-float RGB in base64.
    assert_eq!(data.len(), 7);
    for file in &data {
        let expected = (800 * 800 * 6usize).div_ceil(3) * 4;
        let len = fs::metadata(file).unwrap().len() as usize;
        assert!(len > expected && len < expected + 100, "{}: {len} bytes", file.display());
    }
    let mut browser = Browser::launch_with_size(1280, 1000).expect("headless Chromium (.ci/run installs it)");
    let started = Instant::now();
    let loaded = open_ready(&mut browser, &out.join("index.html"));
    let ready = started.elapsed();
    let tabs = browser.eval("document.querySelectorAll('section.scene button.tab').length").unwrap();
    assert_eq!(tabs, 7);
    for key in ["2", "3", "4", "5", "6", "r", "e", "s"] {
        browser.press(key).unwrap();
    }
    assert_eq!(browser.problems(), Vec::<String>::new());
    eprintln!(
        "6-method 800x800 report: the viewer {:.1} MB ({:.1} MB of image data); with the scene folder's \
         EXRs, figure and tables {} files, {:.1} MB; rendered in {:.1} s; headless Chromium: load event \
         after {:.2} s, viewers ready after {:.2} s",
        page_size as f64 / 1e6,
        data.iter().map(|p| fs::metadata(p).unwrap().len()).sum::<u64>() as f64 / 1e6,
        files.len(),
        size as f64 / 1e6,
        rendered.as_secs_f64(),
        loaded.as_secs_f64(),
        ready.as_secs_f64()
    );
}

/// The README's picture of the report (`docs/images/report.png`): `cargo test --release --test report_browser
/// readme_screenshot -- --ignored` renders cornell-glass with path, bpt and vcm at 64 spp and shows
/// path split against the reference.
#[test]
#[ignore = "writes docs/images/report.png"]
fn readme_screenshot() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    vitrum(&[
        "report",
        "scenes/cornell-glass.toml",
        "-i",
        "path,bpt,vcm",
        "--spp",
        "64",
        "--reference-spp",
        "256",
        "--resolution",
        "400x400",
        "--cache",
        root.join("target/readme-screenshot-cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let mut browser = Browser::launch_with_size(900, 1640).expect("headless Chromium (.ci/run installs it)");
    open_ready(&mut browser, &out.join("index.html"));
    for key in ["s", "-", "-"] {
        browser.press(key).unwrap();
    }
    let centre = browser.eval("vitrumReport.viewers[0].pixelCentre(120, 300)").unwrap();
    browser.mouse_move(centre["pageX"].as_f64().unwrap(), centre["pageY"].as_f64().unwrap()).unwrap();
    browser.screenshot(&root.join("docs/images/report.png")).unwrap();
    assert_eq!(browser.problems(), Vec::<String>::new());
}

#[test]
fn keys_act_on_the_viewer_under_the_mouse_and_a_flip_ends_where_it_began() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = |name: &str| root.join("scenes").join(name).display().to_string();
    vitrum(&[
        "report",
        &scene("soft-shadows.toml"),
        &scene("cornell-glass.toml"),
        "-i",
        "path,whitted",
        "--spp",
        "1",
        "--reference-spp",
        "2",
        "--resolution",
        "32x24",
        "--exposure",
        "0.25",
        "--cache",
        dir.path().join("cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let mut browser = Browser::launch_with_size(1000, 700).expect("headless Chromium (.ci/run installs it)");
    open_ready(&mut browser, &out.join("index.html"));
    let hover = |browser: &mut Browser, viewer: usize| {
        let js = format!(
            "(() => {{ const v = vitrumReport.viewers[{viewer}]; v.canvas.scrollIntoView(); return v.pixelCentre(5, 5); }})()"
        );
        let p = browser.eval(&js).unwrap();
        browser.mouse_move(p["pageX"].as_f64().unwrap(), p["pageY"].as_f64().unwrap()).unwrap();
    };
    let shown = |browser: &mut Browser, viewer: usize| {
        let s = browser.eval(&format!("vitrumReport.viewers[{viewer}].state()")).unwrap();
        (s["a"].as_u64().unwrap(), s["flip"].as_bool().unwrap())
    };
    // The viewers start at --exposure exactly (the slider's steps do not round it).
    for viewer in 0..2 {
        let exposure = browser.eval(&format!("vitrumReport.viewers[{viewer}].state().exposure")).unwrap();
        assert_eq!(exposure.as_f64(), Some(0.25));
    }
    hover(&mut browser, 1);
    browser.press("2").unwrap();
    assert_eq!(shown(&mut browser, 1), (2, false), "the second viewer took the key");
    assert_eq!(shown(&mut browser, 0), (1, false), "the first one did not");
    // Hold b over the first viewer, release it over the second: the first one ends its flip.
    hover(&mut browser, 0);
    browser.key_down("b").unwrap();
    assert_eq!(shown(&mut browser, 0), (1, true));
    hover(&mut browser, 1);
    browser.key_up("b").unwrap();
    assert_eq!(shown(&mut browser, 0), (1, false));
    assert_eq!(shown(&mut browser, 1), (2, false));
    assert_eq!(browser.problems(), Vec::<String>::new());
}

#[test]
fn regions_are_outlined_on_the_viewer_and_their_tables_sort() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/soft-shadows.toml");
    vitrum(&[
        "report",
        scene.to_str().unwrap(),
        "-i",
        "path,whitted,light",
        "--spp",
        "1",
        "--reference-spp",
        "2",
        "--resolution",
        "32x24",
        "--region",
        "floor=10,12,8,6",
        "--cache",
        dir.path().join("cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let mut browser = Browser::launch_with_size(1000, 700).expect("headless Chromium (.ci/run installs it)");
    open_ready(&mut browser, &out.join("index.html"));
    // The canvas just left of the region's left edge, and the region's first pixel.
    let edge_and_inside = |browser: &mut Browser| -> Vec<u64> {
        let js = "(() => { const v = vitrumReport.viewers[0]; const r = v.meta.regions[0];
            const c = v.canvas.getContext('2d');
            const y = Math.floor(v.oy + (r.y + r.height / 2) * v.zoom);
            const edge = c.getImageData(v.ox + r.x * v.zoom - 1, y, 1, 1).data;
            const inside = c.getImageData(Math.floor(v.ox + (r.x + 0.5) * v.zoom), y, 1, 1).data;
            return [edge[0], edge[1], edge[2], inside[0], inside[1], inside[2]]; })()";
        browser.eval(js).unwrap().as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect()
    };
    assert_eq!(state(&mut browser)["outlines"], true);
    let outlined = edge_and_inside(&mut browser);
    assert_eq!(outlined[..3], [255, 212, 0], "the outline is drawn outside the region");
    browser.eval("document.querySelector('input.regions').click()").unwrap();
    assert_eq!(state(&mut browser)["outlines"], false);
    let plain = edge_and_inside(&mut browser);
    assert_ne!(plain[..3], [255, 212, 0], "the outline is gone");
    assert_eq!(plain[3..], outlined[3..], "the region's own pixels are never covered");
    // A click on the region table's relMSE header sorts its rows by their exact values.
    browser.eval("document.querySelectorAll('table.region th')[6].click()").unwrap();
    let values = browser
        .eval("[...document.querySelectorAll('table.region tbody tr')].map(r => Number(r.cells[6].dataset.value))")
        .unwrap();
    let values: Vec<f64> = values.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(values.len(), 3);
    assert!(values.windows(2).all(|w| w[0] <= w[1]), "{values:?}");
    assert_eq!(browser.problems(), Vec::<String>::new());
}
