//! The headless-Chromium harness (tests/common/browser.rs) on small pages of its own: values and
//! canvas pixels read back, keys, a slider and the mouse reaching the page's listeners, every kind
//! of problem reported (and none on a clean page), a screenshot of the viewport's size, the load
//! time, timeouts that name the method, and no Chromium process or profile left after a drop,
//! also after a panic. A missing browser fails these tests: `.ci/run` installs Chromium.

mod common;

use common::browser::Browser;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Writes an HTML page `name` with `body` into `dir`.
fn page(dir: &Path, name: &str, body: &str) -> PathBuf {
    let path = dir.join(name);
    let html = format!("<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>{name}</title></head>\n<body style=\"margin:0\">\n{body}\n</body></html>\n");
    std::fs::write(&path, html).unwrap();
    path
}

fn launch(width: u32, height: u32) -> Browser {
    Browser::launch_with_size(width, height).expect("headless Chromium must start (.ci/run installs it)")
}

#[test]
fn script_values_canvas_pixels_and_the_load_time_read_back() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = page(
        dir.path(),
        "canvas page.html", // a space, escaped in the file:// URL
        r#"<canvas id="c" width="20" height="10"></canvas>
<script>
window.answer = 42;
const g = document.getElementById('c').getContext('2d');
g.fillStyle = 'rgb(255, 0, 0)'; g.fillRect(0, 0, 10, 10);
g.fillStyle = 'rgb(0, 0, 255)'; g.fillRect(10, 0, 10, 10);
const t0 = performance.now(); while (performance.now() - t0 < 300) {} // the load waits 300 ms
</script>"#,
    );
    let mut b = launch(400, 300);
    let load = b.open(&path).unwrap();
    assert!(load >= Duration::from_millis(300), "the page's script alone takes 300 ms, load took {load:?}");
    assert!(load < Duration::from_secs(30), "{load:?}");
    // The page's own clock starts after the navigation command and ends at its load event.
    let page_load_ms = b.eval("performance.getEntriesByType('navigation')[0].loadEventStart").unwrap();
    assert!(page_load_ms.as_f64().unwrap() <= load.as_secs_f64() * 1e3, "{page_load_ms} ms > {load:?}");

    assert_eq!(b.eval("window.answer").unwrap(), json!(42));
    let pixel = |b: &mut Browser, x: u32| {
        b.eval(&format!(
            "Array.from(document.getElementById('c').getContext('2d').getImageData({x}, 5, 1, 1).data)"
        ))
        .unwrap()
    };
    assert_eq!(pixel(&mut b, 2), json!([255, 0, 0, 255]));
    assert_eq!(pixel(&mut b, 15), json!([0, 0, 255, 255]));
    assert_eq!(b.eval("({a: [1, 'x'], b: null})").unwrap(), json!({"a": [1, "x"], "b": null}));
    assert_eq!(b.eval("new Promise(r => setTimeout(() => r(7), 50))").unwrap(), json!(7));
    assert_eq!(b.eval("undefined").unwrap(), json!(null));
    assert_eq!(b.eval("[innerWidth, innerHeight, devicePixelRatio]").unwrap(), json!([400, 300, 1]));
    let thrown = b.eval("throw new Error('boom in eval')").unwrap_err();
    assert!(thrown.contains("boom in eval"), "{thrown}");
    let rejected = b.eval("Promise.reject(new Error('no promise'))").unwrap_err();
    assert!(rejected.contains("no promise"), "{rejected}");
    // An exception of eval's own is its Err, not a problem of the page.
    assert_eq!(b.problems(), Vec::<String>::new());

    let missing = b.open(&dir.path().join("no such page.html")).unwrap_err();
    assert!(missing.contains("ERR_FILE_NOT_FOUND"), "{missing}");
    assert!(b.open(Path::new("relative.html")).is_err());
}

#[test]
fn keys_a_slider_and_the_mouse_reach_the_page() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = page(
        dir.path(),
        "input.html",
        r#"<div id="box" style="position:absolute; left:100px; top:50px; width:200px; height:100px"></div>
<input id="r" type="range" min="0" max="10" value="5" style="position:absolute; left:10px; top:250px">
<script>
window.keys = []; window.ups = []; window.slider = []; window.moves = []; window.clicks = [];
window.wheel = 0; window.drag = [];
addEventListener('keydown', e => keys.push([e.key, e.code, e.keyCode, e.shiftKey]));
addEventListener('keyup', e => ups.push(e.key));
document.getElementById('r').addEventListener('input', e => slider.push(Number(e.target.value)));
addEventListener('mousemove', e => moves.push([e.clientX, e.clientY, e.buttons]));
addEventListener('wheel', e => { wheel += e.deltaY; });
addEventListener('mousedown', e => drag.push(['down', e.clientX, e.clientY]));
addEventListener('mouseup', e => drag.push(['up', e.clientX, e.clientY]));
document.getElementById('box').addEventListener('click', e => clicks.push([e.offsetX, e.offsetY]));
</script>"#,
    );
    let mut b = launch(400, 300);
    b.open(&path).unwrap();

    b.press("3").unwrap();
    b.key_down("Shift").unwrap();
    b.press("a").unwrap();
    b.key_up("Shift").unwrap();
    for key in ["a", "+", "-", "[", "]", "ArrowLeft", "ArrowRight"] {
        b.press(key).unwrap();
    }
    assert!(b.press("NoSuchKey").is_err());
    b.wait_until("keys.length >= 10", Duration::from_secs(10)).unwrap();
    let keys = json!([
        ["3", "Digit3", 51, false],
        ["Shift", "ShiftLeft", 16, true],
        ["A", "KeyA", 65, true],
        ["a", "KeyA", 65, false],
        ["+", "Equal", 187, false],
        ["-", "Minus", 189, false],
        ["[", "BracketLeft", 219, false],
        ["]", "BracketRight", 221, false],
        ["ArrowLeft", "ArrowLeft", 37, false],
        ["ArrowRight", "ArrowRight", 39, false],
    ]);
    assert_eq!(b.eval("keys").unwrap(), keys);
    assert_eq!(b.eval("ups.slice(0, 4)").unwrap(), json!(["3", "A", "Shift", "a"]));

    // The slider, by keys once focused, and by value and an `input` event.
    b.eval("document.getElementById('r').focus()").unwrap();
    b.press("ArrowRight").unwrap();
    b.press("ArrowRight").unwrap();
    b.press("ArrowLeft").unwrap();
    b.wait_until("slider.length == 3", Duration::from_secs(10)).unwrap();
    assert_eq!(b.eval("slider").unwrap(), json!([6, 7, 6]));
    b.eval("const r = document.getElementById('r'); r.value = 9; r.dispatchEvent(new Event('input'))")
        .unwrap();
    assert_eq!(b.eval("[slider.at(-1), Number(document.getElementById('r').value)]").unwrap(), json!([9, 9]));

    b.mouse_move(123.0, 45.0).unwrap();
    b.wait_until("moves.length > 0", Duration::from_secs(10)).unwrap();
    assert_eq!(b.eval("moves.at(-1)").unwrap(), json!([123, 45, 0]));
    b.click(130.0, 70.0).unwrap();
    b.wait_until("clicks.length > 0", Duration::from_secs(10)).unwrap();
    assert_eq!(b.eval("clicks").unwrap(), json!([[30, 20]]), "offsets within the box at (100, 50)");
    b.mouse_wheel(200.0, 100.0, 120.0).unwrap();
    b.wait_until("wheel != 0", Duration::from_secs(10)).unwrap();
    assert_eq!(b.eval("wheel").unwrap(), json!(120));
    b.eval("drag = []; moves = []").unwrap();
    b.drag((10.0, 20.0), (110.0, 220.0)).unwrap();
    b.wait_until("drag.length == 2", Duration::from_secs(10)).unwrap();
    assert_eq!(b.eval("drag").unwrap(), json!([["down", 10, 20], ["up", 110, 220]]));
    let moves = b.eval("moves").unwrap();
    let moves = moves.as_array().unwrap();
    assert_eq!(moves[0], json!([10, 20, 0]), "the move to the start, before the press");
    assert!(moves.len() == 11 && moves[1..].iter().all(|m| m[2] == 1), "the button held: {moves:?}");
    assert_eq!(moves.last().unwrap(), &json!([110, 220, 1]));
    assert_eq!(b.problems(), Vec::<String>::new());
}

#[test]
fn problems_of_a_page_are_reported_and_a_clean_page_has_none() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let clean = page(
        dir.path(),
        "clean.html",
        "<p>fine</p><script>console.log('just a log'); console.info('info')</script>",
    );
    let console = page(
        dir.path(),
        "console.html",
        "<script>console.error('x'); console.warn('careful', 3); console.assert(1 == 2, 'assertion')</script>",
    );
    let missing =
        page(dir.path(), "missing.html", r#"<script src="missing.js"></script><img src="gone.png">"#);
    let thrown = page(dir.path(), "throw.html", "<script>throw new Error('boom')</script>");
    let rejected = page(dir.path(), "reject.html", "<script>Promise.reject(new Error('unhandled'))</script>");
    let alert = page(dir.path(), "alert.html", "<script>alert('hello')</script>");
    let mut b = launch(400, 300);

    b.open(&clean).unwrap();
    assert_eq!(b.problems(), Vec::<String>::new(), "a clean page, logs and infos included");

    b.open(&console).unwrap();
    let problems = b.problems();
    assert_eq!(problems.len(), 3, "{problems:#?}");
    assert!(problems[0].starts_with("console.error: x (file://") && problems[0].contains("console.html:"));
    assert!(problems[1].starts_with("console.warning: careful 3"), "{problems:#?}");
    assert!(problems[2].contains("assertion"), "{problems:#?}");

    b.clear_problems();
    b.open(&missing).unwrap();
    let problems = b.problems();
    for name in ["missing.js", "gone.png"] {
        assert!(
            problems.iter().any(|p| p.contains(name) && p.contains("ERR_FILE_NOT_FOUND")),
            "{name}: {problems:#?}"
        );
    }

    b.clear_problems();
    b.open(&thrown).unwrap();
    let problems = b.problems();
    assert!(problems.len() == 1 && problems[0].contains("Error: boom"), "{problems:#?}");
    assert!(problems[0].contains("throw.html:"), "{problems:#?}");

    b.clear_problems();
    b.open(&rejected).unwrap();
    b.eval("new Promise(r => setTimeout(r, 50))").unwrap(); // a rejection is reported after a task
    let problems = b.problems();
    assert!(problems.iter().any(|p| p.contains("unhandled")), "{problems:#?}");

    b.clear_problems();
    b.open(&alert).unwrap(); // the load waits for the dialog, which the harness accepts
    assert_eq!(b.problems(), ["dialog (alert): hello"]);

    b.clear_problems();
    b.open(&clean).unwrap();
    assert_eq!(b.problems(), Vec::<String>::new());
}

#[test]
fn a_screenshot_is_a_png_of_the_viewport() {
    if !common::system::may_run_browser() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = page(
        dir.path(),
        "colours.html",
        r#"<div style="width:100%; height:600px; background:rgb(255,0,0)"></div>
<div style="position:absolute; left:40px; top:30px; width:20px; height:10px; background:rgb(0,0,255)"></div>"#,
    );
    let mut b = launch(320, 200);
    b.open(&path).unwrap();
    let shot = dir.path().join("shot.png");
    b.screenshot(&shot).unwrap();
    let bytes = std::fs::read(&shot).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let image = image::open(&shot).unwrap().to_rgb8();
    assert_eq!(image.dimensions(), (320, 200));
    assert_eq!(image.get_pixel(10, 10).0, [255, 0, 0]);
    assert_eq!(image.get_pixel(45, 35).0, [0, 0, 255]);

    // A clip, also below the viewport: blue at its top left corner, red below the page's 200 px.
    let clip = dir.path().join("clip.png");
    b.screenshot_clip(&clip, 40.0, 30.0, 50.0, 400.0).unwrap();
    let image = image::open(&clip).unwrap().to_rgb8();
    assert_eq!(image.dimensions(), (50, 400));
    assert_eq!(image.get_pixel(0, 0).0, [0, 0, 255]);
    assert_eq!(image.get_pixel(30, 5).0, [255, 0, 0]);
    assert_eq!(image.get_pixel(10, 350).0, [255, 0, 0]);
}

#[test]
fn a_hang_is_an_error_naming_the_method_and_the_browser_goes_on() {
    if !common::system::may_run_browser() {
        return;
    }
    let mut b = launch(200, 100);
    b.set_timeout(Duration::from_millis(500));
    let hang = b.eval("new Promise(() => {})").unwrap_err();
    assert!(hang.contains("Runtime.evaluate") && hang.contains("no reply"), "{hang}");
    let never = b.wait_until("false", Duration::from_millis(300)).unwrap_err();
    assert!(never.contains("still false"), "{never}");
    b.set_timeout(Duration::from_secs(30));
    assert_eq!(b.eval("1 + 1").unwrap(), json!(2), "the browser still answers after a hung call");
}

/// The processes in process group `group` or whose command line names `profile` (Chromium's crash
/// handlers, in sessions of their own, name it), as "pid [state] command line".
fn processes_of(group: u32, profile: &Path) -> Vec<String> {
    let profile = profile.to_string_lossy().into_owned();
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else { continue };
        let cmdline = std::fs::read(entry.path().join("cmdline")).unwrap_or_default();
        let cmdline = String::from_utf8_lossy(&cmdline).replace('\0', " ");
        // Fields after the command name in parentheses: state, ppid, pgrp.
        let fields: Vec<&str> =
            stat.rsplit_once(')').map(|(_, f)| f.split_whitespace().collect()).unwrap_or_default();
        if fields.get(2) == Some(&group.to_string().as_str()) || cmdline.contains(&profile) {
            found.push(format!("{} [{}] {cmdline}", entry.file_name().to_string_lossy(), fields[0]));
        }
    }
    found
}

/// Every process that was Chromium's (`before`, from [`processes_of`]) is gone, zombies included.
fn assert_gone(before: &[String]) {
    let left: Vec<&String> =
        before.iter().filter(|p| Path::new("/proc").join(p.split(' ').next().unwrap()).exists()).collect();
    assert!(left.is_empty(), "left after the drop: {left:#?}");
}

#[test]
fn drop_leaves_no_process_and_no_profile_also_after_a_panic() {
    if !common::system::may_run_browser() {
        return;
    }
    let missing = Browser::launch_program(Path::new("/nonexistent/chromium"), 100, 100).err().unwrap();
    assert!(missing.contains("/nonexistent/chromium"), "{missing}");

    let b = launch(200, 100);
    let (pid, profile) = (b.pid(), b.profile_dir().to_owned());
    let before = processes_of(pid, &profile);
    assert!(before.len() > 1, "chromium runs, with its helper processes: {before:#?}");
    assert!(profile.is_dir());
    drop(b);
    assert_gone(&before);
    assert_eq!(processes_of(pid, &profile), Vec::<String>::new());
    assert!(!profile.exists());

    let seen = std::sync::Mutex::new((Vec::new(), PathBuf::new()));
    let result = std::panic::catch_unwind(|| {
        let mut b = launch(200, 100);
        b.eval("1").unwrap();
        let (pid, profile) = (b.pid(), b.profile_dir().to_owned());
        *seen.lock().unwrap() = (processes_of(pid, &profile), profile);
        panic!("a failing test");
    });
    assert!(result.is_err());
    let (before, profile) = seen.into_inner().unwrap();
    assert!(before.len() > 1, "{before:#?}");
    assert_gone(&before);
    assert!(!profile.exists());
}
