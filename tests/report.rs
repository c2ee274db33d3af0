//! `vitrum report` and the report files of `compare` and `converge`, without a browser (the
//! browser tests are `tests/report_browser.rs`): the folder layout, the page's sections, tabs and
//! table rows, its JSON, the data files' size, and bad input leaving nothing behind.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the vitrum binary.
fn vitrum(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).output().unwrap()
}

/// A shipped scene file.
fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name).display().to_string()
}

/// The JSON the page carries for its viewers.
fn page_data(page: &str) -> serde_json::Value {
    let start = page.find("<script type=\"application/json\" id=\"vitrum-data\">").expect("the data element");
    let text = &page[start..];
    let text = &text[text.find('>').unwrap() + 1..text.find("</script>").unwrap()];
    serde_json::from_str(text).unwrap()
}

/// The sorted names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    names.sort();
    names
}

#[test]
fn a_report_of_two_scenes_has_a_section_and_a_folder_for_each() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    // The same scene twice under one file name: the folders are made unique.
    let copy: PathBuf = dir.path().join("sub");
    fs::create_dir(&copy).unwrap();
    fs::copy(scene("soft-shadows.toml"), copy.join("soft-shadows.toml")).unwrap();
    let status = vitrum(&[
        "report",
        &scene("soft-shadows.toml"),
        copy.join("soft-shadows.toml").to_str().unwrap(),
        &scene("cornell-glass.toml"),
        "-i",
        "path,whitted",
        "--spp",
        "2",
        "--reference-spp",
        "4",
        "--resolution",
        "24x16",
        "--cache",
        dir.path().join("cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    assert_eq!(
        names(&out),
        ["cornell-glass", "data", "index.html", "report.css", "report.js", "soft-shadows", "soft-shadows-2"]
    );
    for folder in ["cornell-glass", "soft-shadows", "soft-shadows-2"] {
        assert_eq!(
            names(&out.join(folder)),
            ["compare.csv", "compare.md", "compare.png", "path.exr", "reference.exr", "whitted.exr"],
            "{folder}"
        );
    }
    // Three images per scene (reference, path, whitted), 24×16 pixels of 6 bytes in base64.
    let data = names(&out.join("data"));
    assert_eq!(data.len(), 9, "{data:?}");
    let encoded = (24 * 16 * 6usize).div_ceil(3) * 4;
    for name in &data {
        let text = fs::read_to_string(out.join("data").join(name)).unwrap();
        assert!(text.starts_with("vitrumReport.image(\"s"), "{name}");
        let base64 = text.split('"').nth(3).unwrap();
        assert_eq!(base64.len(), encoded, "{name}");
    }
    let page = fs::read_to_string(out.join("index.html")).unwrap();
    assert_eq!(page.matches("<section class=\"scene\"").count(), 3);
    assert_eq!(page.matches("<button class=\"tab\"").count(), 3 * 3);
    assert_eq!(page.matches("<tbody>").count(), 3);
    assert_eq!(page.matches("<tr><td data-value=\"path\">").count(), 3);
    // Every data script is loaded, after the viewer.
    let viewer = page.find("<script src=\"report.js\">").unwrap();
    for name in &data {
        let at = page.find(&format!("<script src=\"data/{name}\">")).unwrap_or_else(|| panic!("{name}"));
        assert!(at > viewer);
    }
    let json = page_data(&page);
    let sections = json["sections"].as_array().unwrap();
    assert_eq!(sections.len(), 3);
    assert_eq!(sections[2]["scene"], "cornell-glass.toml");
    assert_eq!((sections[0]["width"].as_u64(), sections[0]["height"].as_u64()), (Some(24), Some(16)));
    let layers: Vec<&str> =
        sections[1]["layers"].as_array().unwrap().iter().map(|l| l["key"].as_str().unwrap()).collect();
    assert_eq!(layers, ["s1-reference", "s1-path", "s1-whitted"]);
    // The page names no file outside its folder: every src and href is relative.
    for attribute in ["src=\"", "href=\""] {
        for part in page.split(attribute).skip(1) {
            let target = &part[..part.find('"').unwrap()];
            assert!(
                !target.contains("://") && !target.starts_with('/') && !target.contains(".."),
                "{target}"
            );
        }
    }
}

#[test]
fn converge_writes_its_plots_into_the_same_kind_of_page() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("conv");
    let status = vitrum(&[
        "converge",
        &scene("soft-shadows.toml"),
        "-i",
        "path,light",
        "--spp-max",
        "4",
        "--reference-spp",
        "8",
        "--resolution",
        "24x16",
        "--cache",
        dir.path().join("cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let page = fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("<div class=\"convergence\"></div>"));
    let json = page_data(&page);
    let curves = json["sections"][0]["convergence"].as_array().unwrap();
    // Checkpoints at 1, 2 and 4 spp for each method, as converge.csv has them.
    let csv = fs::read_to_string(out.join("converge.csv")).unwrap();
    for curve in curves {
        let method = curve["method"].as_str().unwrap();
        let points = curve["points"].as_array().unwrap();
        let rows: Vec<Vec<&str>> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|c| c[0] == method)
            .collect();
        assert_eq!(points.len(), rows.len(), "{method}");
        for (point, row) in points.iter().zip(&rows) {
            assert_eq!(point[0].as_f64().unwrap(), row[1].parse::<f64>().unwrap());
            assert_eq!(point[2].as_f64().unwrap(), row[6].parse::<f64>().unwrap(), "{method} relMSE");
            // The relMSE's 95% interval for the plot's error bar, around the point when it has one.
            let (relmse, high) = (point[2].as_f64().unwrap(), point[4].as_f64());
            if let Some(high) = high {
                assert!(point[3].as_f64().unwrap() <= relmse && relmse <= high, "{method}: {point}");
            }
        }
        // With 4 samples or more (4 replicas of the 8 with a sample), path's points have their interval.
        if method == "path" {
            assert!(
                points.iter().filter(|p| p[0].as_f64().unwrap() >= 4.0).all(|p| p[4].is_f64()),
                "{points:?}"
            );
        }
    }
    assert_eq!(curves.len(), 2);
    assert_eq!(names(&out.join("data")), ["s0-light.js", "s0-path.js", "s0-reference.js"]);
}

#[test]
fn bad_input_exits_2_and_leaves_no_report_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let missing = dir.path().join("missing.toml");
    let broken = dir.path().join("broken.toml");
    fs::write(&broken, "[camera]\nposition = [0.0, 0.0\n").unwrap();
    let file = dir.path().join("a-file");
    fs::write(&file, "").unwrap();
    // Each fails in planning, after the first scene's plan succeeded and the folder was made.
    for args in [
        vec!["report", &scene("soft-shadows.toml") as &str, missing.to_str().unwrap(), "--spp", "1"],
        vec!["report", &scene("soft-shadows.toml") as &str, broken.to_str().unwrap(), "--spp", "1"],
        vec!["report", &scene("soft-shadows.toml") as &str, "-i", "path,nosuch", "--spp", "1"],
        vec!["report", &scene("soft-shadows.toml") as &str, "--spp", "1", "--cache", file.to_str().unwrap()],
    ] {
        let mut args = args.clone();
        args.extend(["--out", out.to_str().unwrap()]);
        let status = vitrum(&args);
        assert_eq!(status.status.code(), Some(2), "{args:?}: {}", String::from_utf8_lossy(&status.stderr));
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
    let nowhere = dir.path().join("no/such/folder");
    let status =
        vitrum(&["report", &scene("soft-shadows.toml"), "--spp", "1", "--out", nowhere.to_str().unwrap()]);
    assert_eq!(status.status.code(), Some(2));
    let text = String::from_utf8_lossy(&status.stderr);
    assert!(text.contains("does not exist"), "{text}");
}

#[test]
fn a_page_that_cannot_be_published_leaves_no_page_and_no_data() {
    // `report.js` is taken by a folder: the commit fails before the page; the renders' files
    // published before it may stay, the page and its data folder may not.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    fs::create_dir_all(out.join("report.js")).unwrap();
    let status = vitrum(&[
        "compare",
        &scene("soft-shadows.toml"),
        "-i",
        "whitted",
        "--spp",
        "1",
        "--reference-spp",
        "2",
        "--resolution",
        "16x12",
        "--cache",
        dir.path().join("cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(status.status.code(), Some(1), "{}", String::from_utf8_lossy(&status.stderr));
    let left = names(&out);
    assert!(!left.iter().any(|n| n == "index.html" || n == "data"), "{left:?}");
    // No staged temporary file either.
    assert!(!left.iter().any(|n| n.contains(".tmp-")), "{left:?}");
}

/// `vitrum report` with `extra` options (scenes among them) into `out`, and unless they say
/// otherwise at 24×16 against 4-spp `path` references cached in `dir/cache`.
fn small_report(dir: &Path, out: &Path, extra: &[&str]) -> Output {
    let cache = dir.join("cache").display().to_string();
    let mut args = vec!["report", "--out", out.to_str().unwrap(), "--quiet"];
    for (option, default) in [
        ("--reference-spp", "4"),
        ("--reference-method", "path"),
        ("--resolution", "24x16"),
        ("--cache", &cache),
    ] {
        if !extra.contains(&option) {
            args.extend([option, default]);
        }
    }
    args.extend(extra);
    vitrum(&args)
}

/// The rows of a CSV file (without quoted fields) as maps from the header's names to the fields.
fn csv_rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| header.iter().map(|h| h.to_string()).zip(l.split(',').map(String::from)).collect())
        .collect()
}

/// The `data-value`s of the cells of every row of the page's table that starts at `start`.
fn table_values(page: &str, start: &str) -> Vec<Vec<String>> {
    let table = &page[page.find(start).unwrap_or_else(|| panic!("no {start}"))..];
    let body = &table[table.find("<tbody>").unwrap()..table.find("</tbody>").unwrap()];
    body.split("<tr>")
        .skip(1)
        .map(|row| {
            row.split("data-value=\"").skip(1).map(|c| c[..c.find('"').unwrap()].to_string()).collect()
        })
        .collect()
}

/// Runs `small_report` into `out` with each of `cases` (options, text the message must hold):
/// each must exit 2 with that text and leave no `out`.
fn assert_refused(dir: &Path, out: &Path, cases: &[(Vec<&str>, &str)]) {
    for (args, needle) in cases {
        let status = small_report(dir, out, args);
        let text = String::from_utf8_lossy(&status.stderr);
        assert_eq!(status.status.code(), Some(2), "{args:?}: {text}");
        assert!(text.contains(needle), "{args:?}: `{needle}` not in {text}");
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
}

#[test]
fn regions_have_their_tables_in_the_page_with_the_numbers_of_compare_regions_csv() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let scene = scene("soft-shadows.toml");
    let regions = ["--region", "floor=8,10,8,6", "--region", "0,0,4,4"];
    let status = small_report(
        dir.path(),
        &out,
        &[&[&scene as &str, "-i", "path,whitted", "--spp", "2"][..], &regions].concat(),
    );
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let page = fs::read_to_string(out.join("index.html")).unwrap();
    let csv = csv_rows(&out.join("soft-shadows/compare-regions.csv"));
    assert_eq!(csv.len(), 4);
    for (caption, name) in [
        ("Region floor: x 8, y 10, 8 × 6 pixels", "floor"),
        ("Region 0-0-4-4: x 0, y 0, 4 × 4 pixels", "0-0-4-4"),
    ] {
        let rows = table_values(&page, caption);
        let expected: Vec<_> = csv.iter().filter(|r| r["region"] == name).collect();
        assert_eq!(rows.len(), expected.len(), "{name}");
        for (row, line) in rows.iter().zip(expected) {
            // The method, then relMSE, relMSE 99.9%, SSIM and HDR-FLIP as the CSV writes them.
            assert_eq!(row[0], line["method"]);
            for (cell, column) in [(6, "rel_mse"), (7, "rel_mse_trimmed"), (9, "ssim"), (10, "flip")] {
                assert_eq!(row[cell], line[column], "{name} {column}");
            }
        }
    }
    // The whole image's table comes first, and the viewer outlines the regions.
    assert_eq!(table_values(&page, "<table class=\"results\">")[0][0], "path");
    assert!(page.find("<table class=\"results\">") < page.find("<table class=\"results region\">"));
    assert_eq!(page.matches("<table class=\"results region\">").count(), 2);
    assert!(page.contains("class=\"regions\" checked"));
    let json = page_data(&page);
    assert_eq!(
        json["sections"][0]["regions"][0],
        serde_json::json!({"name": "floor", "x": 8, "y": 10, "width": 8, "height": 6})
    );
}

#[test]
fn a_report_lays_out_a_previous_reports_renders_against_reference_files() {
    let dir = tempfile::tempdir().unwrap();
    let first = dir.path().join("first");
    let scenes = [scene("soft-shadows.toml"), scene("cornell-glass.toml")];
    let status =
        small_report(dir.path(), &first, &[&scenes[0], &scenes[1], "-i", "path,whitted", "--spp", "2"]);
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    // Again from the files: soft-shadows against its copied reference, cornell-glass against the
    // cached one; `-i` picks the renders and their order. Without --resolution the renders' size
    // is the cached reference's too: it is read from the cache, not rendered at the scene's size.
    let second = dir.path().join("second");
    let renders = first.to_str().unwrap();
    let reference = format!("soft-shadows={}", first.join("soft-shadows/reference.exr").display());
    let cache = dir.path().join("cache");
    let cached = names(&cache);
    let status = vitrum(&[
        "report",
        &scenes[0],
        &scenes[1],
        "-i",
        "whitted,path",
        "--renders",
        renders,
        "--reference",
        &reference,
        "--reference-spp",
        "4",
        "--reference-method",
        "path",
        "--cache",
        cache.to_str().unwrap(),
        "--out",
        second.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    assert_eq!(names(&cache), cached);
    for folder in ["soft-shadows", "cornell-glass"] {
        let before = csv_rows(&first.join(folder).join("compare.csv"));
        let after = csv_rows(&second.join(folder).join("compare.csv"));
        let methods: Vec<&str> = after.iter().map(|r| r["method"].as_str()).collect();
        assert_eq!(methods, ["whitted", "path"], "{folder}");
        for row in &after {
            let was = before.iter().find(|b| b["method"] == row["method"]).unwrap();
            for column in ["spp", "mse", "rel_mse", "ssim"] {
                assert_eq!(row[column], was[column], "{folder} {} {column}", row["method"]);
            }
        }
    }
    let page = fs::read_to_string(second.join("index.html")).unwrap();
    assert!(page.contains("<dd>path, 4 spp (reference.exr)</dd>"), "the reference file is named");
    assert!(page.contains("<dd>precomputed renders</dd>"));
    // With `all`, the renders that are there; a report of one scene takes a bare reference.
    let third = dir.path().join("third");
    let reference = first.join("cornell-glass/reference.exr");
    let status = small_report(
        dir.path(),
        &third,
        &[&scenes[1], "--renders", renders, "--reference", reference.to_str().unwrap()],
    );
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let rows = csv_rows(&third.join("cornell-glass/compare.csv"));
    assert_eq!(rows.len(), 2, "{rows:?}");
}

#[test]
fn bad_references_and_renders_exit_2_naming_the_argument_and_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let first = dir.path().join("first");
    let (a, b) = (scene("soft-shadows.toml"), scene("cornell-glass.toml"));
    let status = small_report(dir.path(), &first, &[&a, &b, "-i", "path", "--spp", "1"]);
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let renders = first.to_str().unwrap();
    let good = first.join("soft-shadows/reference.exr").display().to_string();
    let named = format!("soft-shadows={good}");
    let unknown = format!("nosuch={good}");
    let missing = format!("soft-shadows={}", dir.path().join("missing.exr").display());
    let nowhere = dir.path().join("nowhere").display().to_string();
    let other = dir.path().join("other.toml");
    fs::copy(&a, &other).unwrap();
    let other = other.to_str().unwrap();
    let out = dir.path().join("bad");
    assert_refused(
        dir.path(),
        &out,
        &[
            (vec![&a, &b, "--spp", "1", "--reference", &unknown], "--reference nosuch="),
            (vec![&a, &b, "--spp", "1", "--reference", &good], "name the one it is for"),
            (vec![&a, &b, "--spp", "1", "--reference", &named, "--reference", &named], "two references"),
            (vec![&a, &b, "--spp", "1", "--reference", &missing], "--reference"),
            (vec![&a, "--spp", "1", "--reference", &named, "--resolution", "16x12"], "--reference"),
            (vec![&a, "--renders", &nowhere], "--renders"),
            (vec![&a, other, "--renders", renders], "no folder `other`"),
            (vec![&a, "-i", "path,whitted", "--renders", renders], "soft-shadows/whitted.exr"),
            (vec![&a, "--renders", renders, "--resolution", "16x12"], "--renders"),
            (vec![&a, "--renders", renders, "--spp", "2"], "--spp"),
        ],
    );
    // Reporting into the folder the renders come from would replace them.
    let status = small_report(dir.path(), &first, &[&a, "--renders", renders]);
    assert_eq!(status.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&status.stderr).contains("is the --out folder"));
}

#[test]
fn a_report_takes_masks_repeated_runs_and_columns_as_compare_does() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let mask = dir.path().join("glass.png");
    image::GrayImage::from_fn(24, 16, |x, y| image::Luma([if (x + y) % 3 == 0 { 255 } else { 0 }]))
        .save(&mask)
        .unwrap();
    let mask_arg = format!("glass={}", mask.display());
    let scene = scene("soft-shadows.toml");
    let status = small_report(
        dir.path(),
        &out,
        &[&scene, "-i", "path", "--spp", "2", "--mask", &mask_arg, "--repeat", "3", "--columns", "1"],
    );
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let folder = out.join("soft-shadows");
    let page = fs::read_to_string(out.join("index.html")).unwrap();
    // The mask's table, its pixels those of compare-regions.csv.
    let regions = csv_rows(&folder.join("compare-regions.csv"));
    assert_eq!(regions[0]["region"], "glass");
    let selected = (0..16u32).flat_map(|y| (0..24u32).map(move |x| (x + y) % 3 == 0)).filter(|&s| s).count();
    assert_eq!(regions[0]["pixels"], selected.to_string());
    let rows = table_values(&page, "Region glass: mask pixels within x 0, y 0, 24 × 16 pixels");
    assert_eq!(rows[0][6], regions[0]["rel_mse"]);
    // Three runs: compare-runs.csv, and the page's seconds and relMSE are their means with intervals.
    let runs = csv_rows(&folder.join("compare-runs.csv"));
    assert_eq!(runs.len(), 3);
    let table = csv_rows(&folder.join("compare.csv"));
    let main = table_values(&page, "<table class=\"results\">");
    assert_eq!(main[0][2], table[0]["seconds"]);
    assert_eq!(main[0][6], table[0]["rel_mse"]);
    let mean = runs.iter().map(|r| r["rel_mse"].parse::<f64>().unwrap()).sum::<f64>() / 3.0;
    assert!((table[0]["rel_mse"].parse::<f64>().unwrap() - mean).abs() <= 1e-12 * mean);
    assert!(page.contains(&format!("<td data-value=\"{}\">", table[0]["seconds"])));
    // One panel per row: the reference above path.
    let figure = image::open(folder.join("compare.png")).unwrap();
    assert!(figure.height() > figure.width(), "{}x{}", figure.width(), figure.height());
}
