//! Renders in parts, against the real binary: a render killed outright (SIGKILL) at any moment
//! leaves only complete checkpoints, and resuming one gives the bits of the uninterrupted
//! render; shards rendered by separate processes in parallel (`xargs -P`) merge into the single
//! render; parts of different renders are refused.
//!
//! The tests take a lock so that they run one at a time: the kill test times its kills from a
//! reference run.

mod common;
use common::entries;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::sync::Mutex;
use std::thread::sleep;
use std::time::Instant;
use vitrum::image::Image;
use vitrum::output::exr::read_exr;
use vitrum::output::film::read_part;

/// One test at a time (each spawns renders that use both cores).
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// `vitrum ARGS` in `dir`.
fn vitrum(dir: &Path, args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vitrum"));
    cmd.current_dir(dir).args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    cmd
}

/// Run `vitrum ARGS` in `dir` to the end.
fn run(dir: &Path, args: &[&str]) -> Output {
    vitrum(dir, args).output().unwrap()
}

/// Run `vitrum ARGS` in `dir`; panics unless it succeeds.
fn ok(dir: &Path, args: &[&str]) {
    let out = run(dir, args);
    assert!(out.status.success(), "vitrum {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// Pixels as raw bits (NaN and -0.0 compare exactly).
fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

/// The beauty image of an EXR in `dir`.
fn image(dir: &Path, name: &str) -> Image {
    read_exr(&dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}")).0
}

/// The render every test splits: the default scene, small, fixed seed.
const BASE: [&str; 6] = ["render", "--resolution", "128x128", "--seed", "11", "--quiet"];

fn with_base<'a>(args: &[&'a str]) -> Vec<&'a str> {
    BASE.iter().copied().chain(args.iter().copied()).collect()
}

#[test]
fn resume_after_sigkill_at_any_moment_equals_the_uninterrupted_render() {
    let _serial = serial();
    // The bidirectional methods at fewer samples (an iteration costs more) and fewer kills.
    let all_fractions = [0.05, 0.2, 0.35, 0.5, 0.65, 0.8, 0.95];
    let few_fractions = [0.15, 0.35, 0.55, 0.75];
    let cases: [(&str, u32, &[f64]); 6] = [
        ("path", 160, &all_fractions),
        ("light", 160, &all_fractions),
        ("vcm", 40, &few_fractions),
        ("ppm", 40, &few_fractions),
        ("pssmlt", 40, &few_fractions),
        ("mmlt", 40, &few_fractions),
    ];
    for (method, samples, fractions) in cases {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let spp = &samples.to_string();
        let start = Instant::now();
        ok(dir, &with_base(&["-i", method, "--spp", spp, "-o", "full.exr"]));
        let full_time = start.elapsed();
        let full = bits(&image(dir, "full.exr"));

        let args = with_base(&["-i", method, "--spp", spp, "-o", "out.exr", "--checkpoint", "0"]);
        let (mut cut_short, mut killed) = (0, Vec::new());
        for &fraction in fractions {
            let _ = std::fs::remove_file(dir.join("out.exr"));
            let mut child = vitrum(dir, &args).spawn().unwrap();
            killed.push(child.id());
            sleep(full_time.mul_f64(fraction));
            child.kill().unwrap(); // SIGKILL (no effect if it has already finished)
            child.wait().unwrap();
            // Beside the output, at most the temporary files of killed renders.
            for name in entries(dir) {
                let pid = name.strip_prefix(".out.exr.tmp-").and_then(|r| r.split_once('-')).map(|(p, _)| p);
                let ours = pid.and_then(|p| p.parse().ok()).is_some_and(|p: u32| killed.contains(&p));
                assert!(
                    ["full.exr", "out.exr"].contains(&name.as_str()) || ours,
                    "{method}: stray file {name}"
                );
            }
            if !dir.join("out.exr").exists() {
                continue; // killed before its first checkpoint
            }
            // A checkpoint is always a complete, valid part of the render.
            let part = read_part(&dir.join("out.exr"))
                .unwrap_or_else(|e| panic!("{method}, kill at {fraction}: corrupt checkpoint: {e}"))
                .part;
            let done = part.info.samples.as_range().expect("one range");
            assert_eq!((done.start, part.info.target.clone()), (0, 0..samples), "{method}");
            if done.end < samples {
                cut_short += 1;
                ok(dir, &["render", "--resume", "out.exr", "--quiet"]);
            }
            assert!(
                bits(&image(dir, "out.exr")) == full,
                "{method}: resumed after {} of {samples} samples, the image differs from the uninterrupted one",
                done.end
            );
        }
        assert!(cut_short >= 2, "{method}: at least two kills cut the render short ({cut_short})");
    }
}

/// Largest relative difference between two images' channels.
fn max_relative_difference(a: &Image, b: &Image) -> f64 {
    let rel = |x: f32, y: f32| ((x - y).abs() as f64) / (y.abs() as f64).max(1e-30);
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| [rel(p.x, q.x), rel(p.y, q.y), rel(p.z, q.z)])
        .fold(0.0, f64::max)
}

#[test]
fn shards_rendered_by_parallel_processes_merge_into_the_single_render() {
    let _serial = serial();
    let binary = env!("CARGO_BIN_EXE_vitrum");
    for method in ["path", "light", "vcm", "ppm", "pssmlt", "mmlt"] {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        // 10 samples in 4 shards: 2, 3, 2, 3 samples (uneven, so the weights matter).
        ok(dir, &with_base(&["-i", method, "--spp", "10", "-o", "single.exr"]));
        let script = format!(
            "seq 0 3 | xargs -P 4 -I{{}} '{binary}' render --resolution 128x128 --seed 11 --quiet -i {method} \
             --spp 10 --shard {{}}/4 -o part-{{}}.exr"
        );
        let status = Command::new("sh").arg("-c").arg(&script).current_dir(dir).status().unwrap();
        assert!(status.success(), "{script}");
        let parts: Vec<String> = (0..4).map(|i| format!("part-{i}.exr")).collect();
        for (i, p) in parts.iter().enumerate() {
            let samples = read_part(&dir.join(p)).unwrap().part.info.samples.to_string();
            assert_eq!(samples, ["0..2", "2..5", "5..7", "7..10"][i], "{method} {p}");
        }
        let mut merge: Vec<&str> = vec!["merge"];
        merge.extend(parts.iter().rev().map(String::as_str)); // any order
        merge.extend(["-o", "merged.exr"]);
        ok(dir, &merge);

        let (merged, merged_meta) = read_exr(&dir.join("merged.exr")).unwrap();
        let (single, single_meta) = read_exr(&dir.join("single.exr")).unwrap();
        assert_eq!(merged_meta["vitrum:spp"], "10");
        assert_eq!(merged_meta["vitrum:samples"], "0..10");
        assert_eq!(
            merged_meta["vitrum:rays"], single_meta["vitrum:rays"],
            "{method}: the same rays were traced"
        );
        // Partial sums round differently from one running sum (see `vitrum::parts`): equal
        // within f64 summation rounding, far below an f32 ulp of most pixels.
        let worst = max_relative_difference(&merged, &single);
        let same = bits(&merged).iter().zip(bits(&single)).filter(|(a, b)| **a == *b).count();
        eprintln!(
            "{method}: {same} of {} pixels bit-identical, worst relative difference {worst:e}",
            single.pixels.len()
        );
        assert!(worst <= 1e-6, "{method}: merged differs from the single render by {worst:e}");
        assert!(merged.pixels.iter().any(|p| p.max_element() > 0.0), "not a black image");
    }
}

#[test]
fn parts_of_different_renders_are_refused() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/soft-shadows.toml");
    // Shard settings (24x24, seed 1, 4 spp) unless `extra` gives its own.
    let part = |name: &str, extra: &[&str]| {
        let mut args = vec!["render", "--quiet", "-o", name];
        for (option, value) in [("--resolution", "24x24"), ("--seed", "1"), ("--spp", "4")] {
            if !extra.contains(&option) {
                args.extend([option, value]);
            }
        }
        args.extend_from_slice(extra);
        ok(dir, &args);
    };
    part("a.exr", &["--shard", "0/2"]);
    part("seed.exr", &["--shard", "1/2", "--seed", "2"]);
    part("integrator.exr", &["--shard", "1/2", "-i", "light"]);
    part("resolution.exr", &["--shard", "1/2", "--resolution", "16x16"]);
    part("scene.exr", &[scene, "--shard", "1/2"]);
    part("depth.exr", &["--shard", "1/2", "--max-depth", "3"]);
    part("sampler.exr", &["--shard", "1/2", "--sampler", "independent"]);
    part("overlap.exr", &["--samples", "1..3"]);
    part("plain.exr", &[]);
    part("strat-a.exr", &["--shard", "0/2", "--sampler", "stratified"]);
    part("strat-b.exr", &["--samples", "2..4", "--spp", "9", "--sampler", "stratified"]);
    let cases = [
        (["a.exr", "seed.exr"], "its seed is 2, not 1"),
        (["a.exr", "integrator.exr"], "its integrator is light, not whitted"),
        (["a.exr", "resolution.exr"], "its resolution is 16x16, not 24x24"),
        (["a.exr", "scene.exr"], "its scene is"),
        (["a.exr", "depth.exr"], "its max-depth is 3"),
        (["a.exr", "sampler.exr"], "its sampler is independent, not sobol"),
        (["a.exr", "overlap.exr"], "holds the sample indices 1..2"),
        (["a.exr", "plain.exr"], "not a render part"),
        (["strat-a.exr", "strat-b.exr"], "plan"),
    ];
    for (files, expected) in cases {
        let out = run(dir, &["merge", files[0], files[1], "-o", "merged.exr"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{files:?}: {stderr}");
        assert!(stderr.contains(expected) && stderr.contains(files[1]), "{files:?}: {stderr}");
        assert!(!dir.join("merged.exr").exists(), "{files:?}: no output written");
    }
    // The right pair merges; a resume with other settings is refused as well.
    part("b.exr", &["--shard", "1/2"]);
    ok(dir, &["merge", "a.exr", "b.exr", "-o", "x.exr"]);
    let refused = |args: &[&str], expected: &str| {
        let out = run(dir, args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    };
    refused(&["render", "--resume", "a.exr", "--seed", "3"], "rendered with seed 1; these options give 3");
    // A shard cannot grow into its neighbours' samples.
    refused(&["render", "--resume", "a.exr", "--spp", "8"], "it is the shard 0..2 of a 4-sample render");
    // Parts that differ only in the spectral mode, not in whether wavelengths are traced (the
    // default scene does not disperse: `auto` traces none), are parts of one render.
    part("off.exr", &["--shard", "1/2", "--spectral", "off"]);
    ok(dir, &["merge", "a.exr", "off.exr", "-o", "y.exr"]);
    part("on.exr", &["--shard", "1/2", "--spectral", "on"]);
    refused(&["merge", "a.exr", "on.exr", "-o", "z.exr"], "its wavelengths is yes, not no");
    assert!(entries(dir).iter().all(|n| !n.starts_with('.')), "no temporary files: {:?}", entries(dir));
}

#[test]
fn render_parts_refuse_bad_input_with_exit_code_2() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let cases: [(&[&str], &str); 6] = [
        (&["-i", "ssaa", "--shard", "0/2"], "`ssaa` cannot be rendered in parts"),
        (&["--spp", "3", "--shard", "0/4"], "--shard 0/4: empty"),
        (&["--shard", "2/2"], "expected I/N"),
        (&["--samples", "4..2"], "expected a sample range"),
        (&["--samples", "0..9", "--spp", "8"], "beyond the --spp 8 samples"),
        (&["--checkpoint", "-1"], "--checkpoint -1"),
    ];
    for (args, expected) in cases {
        let mut all = vec!["render", "--resolution", "16x16", "--quiet", "-o", "out.exr"];
        all.extend_from_slice(args);
        let out = run(dir, &all);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(entries(dir).is_empty(), "{args:?}: nothing written");
    }
    // A finished part resumed without a larger --spp has nothing to do, successfully (a
    // cluster job restarted after it finished), and is left as it was.
    ok(dir, &["render", "--resolution", "16x16", "--quiet", "-o", "out.exr", "--samples", "0..2"]);
    let before = std::fs::read(dir.join("out.exr")).unwrap();
    let out = run(dir, &["render", "--resume", "out.exr"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("already holds all its samples 0..2: nothing to render"));
    assert!(std::fs::read(dir.join("out.exr")).unwrap() == before);
    // More samples than it holds but fewer than asked for earlier are no resume.
    let out = run(dir, &["render", "--resume", "out.exr", "--spp", "2"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("asks for no more"));
}

#[test]
fn converge_and_compare_measure_precomputed_shard_results() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    fn with<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        ["render", "--resolution", "32x32", "--quiet"].into_iter().chain(extra.iter().copied()).collect()
    }
    // The reference from two shards, the renders from other processes.
    for shard in ["0/2", "1/2"] {
        let name = format!("ref-{}.exr", &shard[..1]);
        ok(dir, &with(&["-i", "path", "--spp", "64", "--shard", shard, "-o", &name]));
    }
    let out = run(
        dir,
        &["merge", "ref-0.exr", "ref-1.exr", "-o", "ref.exr", "--variance", "--json", "--png", "ref.png"],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((summary["spp"].as_u64(), summary["samples"].as_str()), (Some(64), Some("0..64")));
    let channels = vitrum::output::exr::read_exr_channels(&dir.join("ref.exr")).unwrap().channels;
    assert!(channels["variance.R"].iter().all(|v| v.is_finite() && *v >= 0.0), "variance channels");
    assert!(channels["samples"].iter().all(|&n| n == 64.0));
    assert_eq!(::image::open(dir.join("ref.png")).unwrap().width(), 32);
    for (method, spp) in [("path", "2"), ("path", "8"), ("light", "8")] {
        let name = format!("{method}-{spp}.exr");
        ok(dir, &with(&["-i", method, "--spp", spp, "--seed", "3", "-o", &name]));
    }
    let renders = ["--renders", "path-8.exr", "path-2.exr", "light-8.exr"];
    let mut converge = vec!["converge", "--reference", "ref.exr", "--out", "cv", "--quiet"];
    converge.extend(renders);
    ok(dir, &converge);
    let csv = std::fs::read_to_string(dir.join("cv/converge.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let keys: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    assert_eq!(keys, [("path", "2"), ("path", "8"), ("light", "8")], "{csv}");
    // Each row's relMSE is what `vitrum diff` measures for that file.
    for row in &rows {
        let file = format!("{}-{}.exr", row[0], row[1]);
        let out = run(dir, &["diff", &file, "ref.exr", "--json"]);
        let diff: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let rel_mse: f64 = row[6].parse().unwrap();
        assert_eq!(rel_mse, diff["rel_mse"].as_f64().unwrap(), "{file}");
    }
    ok(
        dir,
        &[
            "compare",
            "--reference",
            "ref.exr",
            "--out",
            "cmp",
            "--quiet",
            "--renders",
            "path-8.exr",
            "light-8.exr",
        ],
    );
    let table = std::fs::read_to_string(dir.join("cmp/compare.csv")).unwrap();
    assert_eq!(table.lines().count(), 3, "a header and one row per method:\n{table}");
    assert!(dir.join("cmp/compare.png").exists());
    // Two renders of one method, or of another size, are refused.
    let out = run(
        dir,
        &["compare", "--reference", "ref.exr", "--out", "cmp2", "--renders", "path-8.exr", "path-2.exr"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("are both `path` renders"));
    ok(dir, &["render", "--resolution", "16x16", "--quiet", "-i", "path", "--spp", "2", "-o", "small.exr"]);
    let out = run(
        dir,
        &["converge", "--reference", "ref.exr", "--out", "cv3", "--renders", "path-8.exr", "small.exr"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("16x16, not the 32x32"));
    // A render of another scene is refused.
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/soft-shadows.toml");
    ok(dir, &with(&[scene, "-i", "path", "--spp", "2", "-o", "other.exr"]));
    let out = run(dir, &["converge", "--reference", "ref.exr", "--out", "cv2", "--renders", "other.exr"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("rendered from another scene"));
}

#[test]
fn the_slurm_array_script_renders_resumes_and_merges_the_shards() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let scripts = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/slurm");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/soft-shadows.toml");
    let options = ["-i", "light", "--spp", "7", "--resolution", "32x32", "--seed", "2"];
    // What Slurm runs for array task `index` of 3 (the #SBATCH lines are comments to bash).
    let task = |index: u32| {
        let mut cmd = Command::new("bash");
        cmd.arg(format!("{scripts}/render-shard.sbatch")).args(["3", scene, "parts"]).args(options);
        cmd.current_dir(dir).env("VITRUM", env!("CARGO_BIN_EXE_vitrum"));
        cmd.env("SLURM_ARRAY_TASK_ID", index.to_string()).env("SLURM_ARRAY_TASK_COUNT", "3");
        cmd.env("SLURM_ARRAY_TASK_MIN", "0").stdout(Stdio::piped()).stderr(Stdio::piped());
        cmd
    };
    // Task 2 rerun alone (`sbatch --array=2`): Slurm counts 1 task in that submission.
    let mut rerun = task(2);
    rerun.env("SLURM_ARRAY_TASK_COUNT", "1").env("SLURM_ARRAY_TASK_MIN", "2");
    let tasks: Vec<_> = [task(0).spawn().unwrap(), task(1).spawn().unwrap(), rerun.spawn().unwrap()].into();
    for t in tasks {
        let out = t.wait_with_output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    // A requeued task whose shard is done does nothing, and succeeds.
    let before = std::fs::read(dir.join("parts/part-1-of-3.exr")).unwrap();
    let out = task(1).output().unwrap();
    assert!(out.status.success() && String::from_utf8_lossy(&out.stderr).contains("nothing to render"));
    assert!(std::fs::read(dir.join("parts/part-1-of-3.exr")).unwrap() == before);

    let merge = Command::new("bash")
        .arg(format!("{scripts}/merge.sbatch"))
        .args(["3", "parts", "merged.exr"])
        .current_dir(dir)
        .env("VITRUM", env!("CARGO_BIN_EXE_vitrum"))
        .output()
        .unwrap();
    assert!(merge.status.success(), "{}", String::from_utf8_lossy(&merge.stderr));
    let mut single = vec!["render", scene, "-o", "single.exr", "--quiet"];
    single.extend(options);
    ok(dir, &single);
    let (merged, meta) = read_exr(&dir.join("merged.exr")).unwrap();
    assert_eq!(meta["vitrum:samples"], "0..7");
    let worst = max_relative_difference(&merged, &image(dir, "single.exr"));
    assert!(worst <= 1e-6, "merged differs from the single render by {worst:e}");
}

/// The shell script of the container named `container` in a Kubernetes manifest: the block
/// scalar under its `args:` (`- |`), dedented, or the one-line `args` item.
fn container_script(manifest: &str, container: &str) -> String {
    let start = manifest.find(&format!("- name: {container}")).expect("the container");
    let rest = &manifest[start..];
    let args = rest.find("args:").expect("args");
    let mut lines = rest[args..].lines().skip(1);
    let first = lines.next().expect("an args item");
    if let Some(one_line) = first.trim().strip_prefix("- ").filter(|l| *l != "|") {
        return one_line.to_string();
    }
    let body: Vec<&str> =
        lines.take_while(|l| l.starts_with("              ") || l.trim().is_empty()).collect();
    body.iter().map(|l| l.get(14..).unwrap_or("")).collect::<Vec<_>>().join("\n")
}

#[test]
fn the_kubernetes_indexed_job_commands_render_resume_and_merge() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let k8s = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/kubernetes");
    let scenes = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes");
    let results = dir.join("results");
    // The manifests' commands, with the volume and image paths pointed here and the render made
    // small (the options' structure is left as written).
    let local = |script: String| {
        script
            .replace("/results", results.to_str().unwrap())
            .replace("/vitrum/scenes", scenes)
            .replace("--spp 65536", "--spp 32 --resolution 24x24")
    };
    let render = local(container_script(
        &std::fs::read_to_string(format!("{k8s}/render-shards.yaml")).unwrap(),
        "render",
    ));
    let merge =
        local(container_script(&std::fs::read_to_string(format!("{k8s}/merge.yaml")).unwrap(), "merge"));
    assert!(
        render.contains("--shard \"$JOB_COMPLETION_INDEX/16\"") && render.contains("--resume"),
        "{render}"
    );
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_vitrum")).parent().unwrap().to_str().unwrap().to_string();
    let path = format!("{bin_dir}:{}", std::env::var("PATH").unwrap_or_default());
    let pod = |index: u32| {
        let out = Command::new("sh")
            .arg("-c")
            .arg(&render)
            .env("JOB_COMPLETION_INDEX", index.to_string())
            .env("PATH", &path)
            .output()
            .unwrap();
        assert!(out.status.success(), "pod {index}: {}", String::from_utf8_lossy(&out.stderr));
        out
    };
    for index in 0..16 {
        pod(index);
    }
    // A restarted pod finds its finished part and does nothing.
    assert!(String::from_utf8_lossy(&pod(7).stderr).contains("nothing to render"));
    let out = Command::new("sh").arg("-c").arg(&merge).env("PATH", &path).output().unwrap();
    assert!(out.status.success(), "merge: {}", String::from_utf8_lossy(&out.stderr));
    let merged = results.join("cornell-glass-path-65536.exr");
    let (image, meta) = read_exr(&merged).unwrap();
    assert_eq!(meta["vitrum:samples"], "0..32");
    let single = [
        "render",
        &format!("{scenes}/cornell-glass.toml"),
        "-i",
        "path",
        "--spp",
        "32",
        "--resolution",
        "24x24",
    ];
    let mut single = single.to_vec();
    single.extend(["-o", "single.exr", "--quiet"]);
    ok(dir, &single);
    assert!(max_relative_difference(&image, &self::image(dir, "single.exr")) <= 1e-6);
}

#[test]
fn a_part_stopped_by_sigint_resumes_to_a_larger_spp_equal_to_a_plain_render_of_it() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let base = ["render", "--resolution", "32x32", "--seed", "4", "-i", "path", "--quiet"];
    let mut args = base.to_vec();
    args.extend(["--spp", "1000000", "--checkpoint", "60", "-o", "part.exr"]);
    let child = vitrum(dir, &args).spawn().unwrap();
    sleep(std::time::Duration::from_millis(700));
    assert!(Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", String::from_utf8_lossy(&out.stderr));
    let file = read_part(&dir.join("part.exr")).unwrap();
    let done = file.part.info.samples.as_range().unwrap();
    assert!(done.start == 0 && done.end >= 2 && done.end < 1_000_000, "{done:?}");
    let note = &file.attributes["vitrum:interrupted"];
    assert_eq!(note, &format!("SIGINT after the samples 0..{} of 0..1000000", done.end));
    // Continue to a few more samples than were done: a plain render of that many, bit for bit
    // (the Sobol' sampler does not depend on the planned count).
    let spp = (done.end + 3).to_string();
    ok(dir, &["render", "--resume", "part.exr", "--spp", &spp, "--quiet"]);
    let mut plain = base.to_vec();
    plain.extend(["--spp", &spp, "-o", "plain.exr"]);
    ok(dir, &plain);
    assert!(bits(&image(dir, "part.exr")) == bits(&image(dir, "plain.exr")));
    let resumed = read_part(&dir.join("part.exr")).unwrap();
    assert_eq!(resumed.part.info.samples.to_string(), format!("0..{spp}"));
    assert!(!resumed.attributes.contains_key("vitrum:interrupted"));
}

#[test]
fn an_edited_mesh_is_another_scene_and_a_resume_finds_its_scene_from_any_folder() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let scenes = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes");
    let work = dir.join("scene");
    std::fs::create_dir_all(work.join("meshes")).unwrap();
    std::fs::copy(format!("{scenes}/shapes-gallery.toml"), work.join("gallery.toml")).unwrap();
    for e in std::fs::read_dir(format!("{scenes}/meshes")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), work.join("meshes").join(e.file_name())).unwrap();
    }
    let shard = |i: &str| {
        let out = format!("../s{}.exr", &i[..1]);
        ok(
            &work,
            &[
                "render",
                "gallery.toml",
                "--resolution",
                "24x24",
                "--spp",
                "4",
                "--shard",
                i,
                "-o",
                &out,
                "--quiet",
            ],
        );
    };
    shard("0/2");
    // Move one vertex of every mesh the scene reads (the TOML text stays the same).
    for e in std::fs::read_dir(work.join("meshes")).unwrap() {
        let path = e.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        let mut moved = false;
        let lines: Vec<String> = text
            .lines()
            .map(|l| match l.strip_prefix("v ") {
                Some(xyz) if !moved => {
                    moved = true;
                    let mut c: Vec<f64> = xyz.split_whitespace().map(|v| v.parse().unwrap()).collect();
                    c[0] += 0.01;
                    format!("v {} {} {}", c[0], c[1], c[2])
                }
                _ => l.to_string(),
            })
            .collect();
        assert!(moved, "{}: no vertex", path.display());
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    }
    shard("1/2");
    let out = run(dir, &["merge", "s0.exr", "s1.exr", "-o", "m.exr"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("its scene is"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The part was rendered from `scene/gallery.toml` relative to `scene/`; resumed from `dir`
    // (with the meshes restored) it finds the scene by its recorded absolute path.
    for e in std::fs::read_dir(format!("{scenes}/meshes")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), work.join("meshes").join(e.file_name())).unwrap();
    }
    let out = run(dir, &["render", "--resume", "s0.exr", "--quiet"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn a_time_budget_killed_mid_way_resumes_the_rest_of_its_time() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let args = [
        "render",
        "--resolution",
        "32x32",
        "-i",
        "path",
        "--time",
        "2",
        "--checkpoint",
        "0.05",
        "-o",
        "t.exr",
        "--quiet",
    ];
    let mut child = vitrum(dir, &args).spawn().unwrap();
    sleep(std::time::Duration::from_millis(700));
    child.kill().unwrap();
    child.wait().unwrap();
    let before = read_part(&dir.join("t.exr")).expect("a checkpoint after 0.7 s");
    assert_eq!(before.part.info.time_budget, Some(2.0));
    assert!(before.part.film.seconds < 2.0, "killed before its budget was spent");
    ok(dir, &["render", "--resume", "t.exr", "--quiet"]);
    let after = read_part(&dir.join("t.exr")).unwrap();
    assert!(
        after.part.film.seconds >= 2.0,
        "the rest of the budget was rendered: {}",
        after.part.film.seconds
    );
    assert!(after.part.film.samples > before.part.film.samples);
    // Spent: resuming again does nothing.
    let out = run(dir, &["render", "--resume", "t.exr"]);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stderr).contains("nothing to render"));
}

/// The `column` of the CSV `text`'s data rows, found by its header name.
fn csv_column(text: &str, column: &str) -> Vec<String> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let at = header.iter().position(|h| *h == column).unwrap_or_else(|| panic!("no {column}: {text}"));
    lines.map(|l| l.split(',').nth(at).unwrap().to_string()).collect()
}

#[test]
fn a_merge_that_leaves_a_gap_is_refused_and_allow_gaps_records_what_it_holds() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    // 16 samples in 4 shards of 4; shard 2 (samples 8..12) is lost.
    let base = ["render", "--resolution", "24x24", "--seed", "5", "-i", "path", "--spp", "16", "--quiet"];
    for i in 0..4 {
        let (shard, name) = (format!("{i}/4"), format!("part-{i}.exr"));
        let mut args = base.to_vec();
        args.extend(["--shard", &shard, "-o", &name]);
        ok(dir, &args);
    }
    let out = run(dir, &["merge", "part-0.exr", "part-1.exr", "part-3.exr", "-o", "gap.exr"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("the samples 8..12 of 0..16") && stderr.contains("--allow-gaps"), "{stderr}");
    assert!(!dir.join("gap.exr").exists(), "nothing written");
    // A lost tail is a gap as well.
    let out = run(dir, &["merge", "part-0.exr", "part-1.exr", "-o", "gap.exr"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("the samples 8..16 of 0..16"));

    let out = run(
        dir,
        &["merge", "part-0.exr", "part-1.exr", "part-3.exr", "-o", "gap.exr", "--allow-gaps", "--json"],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("warning: --allow-gaps: the samples 8..12 of 0..16"), "{stderr}");
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((summary["spp"].as_u64(), summary["missing"].as_str()), (Some(12), Some("8..12")));
    let (_, meta) = read_exr(&dir.join("gap.exr")).unwrap();
    assert_eq!(meta["vitrum:spp"], "12", "the samples actually held");
    assert_eq!(meta["vitrum:samples"], "0..8,12..16");
    assert_eq!(meta["vitrum:missing-samples"], "8..12");
    // The lost shard, merged in later, completes the render: the 4-way merge.
    ok(dir, &["merge", "gap.exr", "part-2.exr", "-o", "late.exr"]);
    ok(dir, &["merge", "part-0.exr", "part-1.exr", "part-2.exr", "part-3.exr", "-o", "all.exr"]);
    assert_eq!(read_exr(&dir.join("late.exr")).unwrap().1["vitrum:spp"], "16");
    assert!(max_relative_difference(&image(dir, "late.exr"), &image(dir, "all.exr")) <= 1e-6);

    // `converge --renders` and `compare --renders` count the samples the render holds.
    let measured = [
        ("converge", "converge.csv", &["--reference", "all.exr", "--out", "cv", "--quiet", "--renders"][..]),
        ("compare", "compare.csv", &["--reference", "all.exr", "--out", "cmp", "--quiet", "--renders"][..]),
    ];
    for (command, csv, options) in measured {
        let mut args = vec![command];
        args.extend_from_slice(options);
        args.push("gap.exr");
        ok(dir, &args);
        let folder = if command == "converge" { "cv" } else { "cmp" };
        let text = std::fs::read_to_string(dir.join(folder).join(csv)).unwrap();
        assert_eq!(csv_column(&text, "spp"), ["12"], "{command}: {text}");
    }
}
