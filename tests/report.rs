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
