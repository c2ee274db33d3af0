//! Every command the manual shows is run, so the documentation cannot go stale: the code blocks of
//! README.md, scenes/README.md, scenes/figures.md and the reference pages under docs/ that the
//! README links to.
//!
//! The rules the pages are written to:
//! - ```` ```sh ```` blocks: every line that is neither empty nor a comment is a command (a line
//!   ending in `\` goes on); a trailing `# comment` is dropped. The commands of one page run in
//!   order, through `sh -c`, in one temporary directory per page, where `scenes` is the
//!   repository's scenes directory and `vitrum` is the binary under test, on the PATH.
//! - ```` ```console ```` blocks: a line starting with `$ ` is a command, and the lines after it, up
//!   to the next command, are what it prints (standard output, then standard error). They are
//!   compared line by line with every number masked and runs of spaces made one; a line `…` stands
//!   for any number of lines, a line ending in `…` for any line that starts as it does (what varies
//!   from run to run: a verdict, a cache file's hash), and a last line `[exit N]` for the exit code
//!   N (0 otherwise).
//! - ```` ```toml ```` blocks whose first line is `# file: NAME` are written to NAME, so later commands
//!   of the page read them.
//! - Budgets are capped so that the whole manual runs in about a minute: `--spp`, `--spp-max` and
//!   `--reference-spp` above 16 become 16, `--time` above 0.25 seconds becomes 0.25, a `--resolution`
//!   wider than 128 pixels is scaled down to 128 wide, and `--crop`/`--region` with it; a
//!   `compare`, `converge` or `report` without a reference gets `--reference-spp 16`.
//! - `cargo run --release -- ARGS` runs as `vitrum ARGS`. Lines that build, test or install
//!   (`cargo test`, `cargo bench`, `cargo build`, `cargo install`, …), the Python ones (`pip`,
//!   `python3`: `.ci/run` runs the package's tests, which run the README's Python example), the
//!   cluster ones (`sbatch`, `parallel`, `kubectl`: `tests/slurm_cluster.rs` runs docs/scale-out.md's
//!   GNU parallel line and the Slurm scripts for real) and the ones that open a window are not run;
//!   the test prints each with the reason.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");
const VITRUM: &str = env!("CARGO_BIN_EXE_vitrum");

/// Programs whose lines the test does not run, each with where it is run instead or why not.
const NOT_RUN: &[(&str, &str)] = &[
    ("cargo test", "the command running this test"),
    ("cargo bench", "benchmarks: minutes of measurement, run by hand"),
    ("cargo build", "builds the binary under test"),
    ("cargo install", "installs the binary under test"),
    ("cargo fmt", "run by .ci/run"),
    ("cargo clippy", "run by .ci/run"),
    ("cargo fuzz", "fuzzing runs until stopped"),
    (
        "pip",
        ".ci/run installs the Python package and runs python/tests (the README's Python example included)",
    ),
    ("python3 -m venv", ".ci/run makes the Python package's venv"),
    ("python3 scripts/", "needs Mitsuba 3 or criterion output; run by hand"),
    ("python3", ".ci/run runs the Python package's tests"),
    ("jupyter", ".ci/run executes the example notebook"),
    ("sbatch", "tests/slurm_cluster.rs runs the Slurm scripts on a real cluster"),
    ("srun", "tests/slurm_cluster.rs runs the Slurm scripts on a real cluster"),
    ("parallel", "tests/slurm_cluster.rs runs docs/scale-out.md's GNU parallel line"),
    ("scripts/slurm/", "tests/slurm_cluster.rs runs the Slurm scripts on a real cluster"),
    ("kubectl", "tests/parts.rs runs the Kubernetes manifests' commands"),
    ("xdg-open", "opens a window"),
    ("open", "opens a window"),
    ("tev", "opens a window"),
    ("source", "activates a venv: Python, run by .ci/run"),
    ("git clone", "the fresh clone this manual starts from"),
    ("cd vitrum", "the fresh clone this manual starts from"),
    ("apt-get", "installs system packages (.ci/run does)"),
    ("sudo", "installs system packages (.ci/run does)"),
];

/// The pages whose commands run, each by a test of its own.
const PAGES: &[&str] = &[
    "README.md",
    "scenes/README.md",
    "scenes/figures.md",
    "docs/methods.md",
    "docs/command-line.md",
    "docs/workflow.md",
    "docs/scale-out.md",
    "docs/other-renderers.md",
    "docs/testing.md",
];

/// One step of a page, in order.
#[derive(Debug)]
enum Step {
    /// A command, with what it prints when the page shows it (console blocks).
    Run { line: usize, command: String, expected: Option<Expected> },
    /// A file written from a toml block.
    Write { name: String, text: String },
}

/// What a console block says a command prints.
#[derive(Debug)]
struct Expected {
    lines: Vec<String>,
    code: i32,
}

/// The fenced code blocks of `text`: (info string, line number of the first content line, lines).
fn blocks(text: &str) -> Vec<(String, usize, Vec<&str>)> {
    let mut out = Vec::new();
    let mut open: Option<(String, usize, Vec<&str>, usize)> = None;
    for (n, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        match &mut open {
            None if trimmed.starts_with("```") => {
                open = Some((trimmed[3..].trim().to_owned(), n + 2, Vec::new(), indent));
            }
            Some((_, _, _, _)) if trimmed.starts_with("```") && trimmed.trim() == "```" => {
                let (info, first, lines, _) = open.take().unwrap();
                out.push((info, first, lines));
            }
            Some((_, _, lines, indent)) => lines.push(line.get(*indent..).unwrap_or(line.trim_start())),
            None => {}
        }
    }
    assert!(open.is_none(), "an unclosed code block");
    out
}

/// Drops a trailing `# comment` outside quotes.
fn without_comment(line: &str) -> &str {
    let (mut single, mut double) = (false, false);
    let bytes = line.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        match b {
            b'\'' if !double => single = !single,
            b'"' if !single => double = !double,
            b'#' if !single && !double && (i == 0 || bytes[i - 1].is_ascii_whitespace()) => {
                return line[..i].trim_end();
            }
            _ => {}
        }
    }
    line.trim_end()
}

/// The commands of a shell block's lines, continuation lines joined: (line number, command).
fn commands(first: usize, lines: &[&str]) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in lines.iter().enumerate() {
        let line = without_comment(raw);
        let (text, goes_on) = match line.strip_suffix('\\') {
            Some(head) => (head.trim_end(), true),
            None => (line, false),
        };
        match &mut pending {
            Some((_, command)) => {
                command.push(' ');
                command.push_str(text.trim());
            }
            None if text.trim().is_empty() => continue,
            None => pending = Some((first + i, text.trim().to_owned())),
        }
        if !goes_on {
            out.extend(pending.take());
        }
    }
    out.extend(pending);
    out
}

/// The steps of a page, in order.
fn steps(text: &str) -> Vec<Step> {
    let mut out = Vec::new();
    for (info, first, lines) in blocks(text) {
        match info.as_str() {
            "sh" | "bash" | "shell" => {
                for (line, command) in commands(first, &lines) {
                    out.push(Step::Run { line, command, expected: None });
                }
            }
            "console" => {
                let mut at = 0;
                while at < lines.len() {
                    let Some(head) = lines[at].strip_prefix("$ ") else {
                        assert!(lines[at].trim().is_empty(), "line {}: output before a command", first + at);
                        at += 1;
                        continue;
                    };
                    let mut command_lines = vec![head];
                    at += 1;
                    while command_lines.last().unwrap().trim_end().ends_with('\\') && at < lines.len() {
                        command_lines.push(lines[at]);
                        at += 1;
                    }
                    let (line, command) = commands(first + at - command_lines.len(), &command_lines)
                        .pop()
                        .unwrap_or_else(|| panic!("line {}: an empty command", first + at));
                    let mut printed = Vec::new();
                    while at < lines.len() && !lines[at].starts_with("$ ") {
                        printed.push(lines[at].trim_end().to_owned());
                        at += 1;
                    }
                    while printed.last().is_some_and(|l| l.is_empty()) {
                        printed.pop();
                    }
                    let code = match printed.last().and_then(|l| l.strip_prefix("[exit ")) {
                        Some(n) => {
                            let code = n.trim_end_matches(']').parse().expect("[exit N]");
                            printed.pop();
                            code
                        }
                        None => 0,
                    };
                    out.push(Step::Run { line, command, expected: Some(Expected { lines: printed, code }) });
                }
            }
            "toml" => {
                if let Some(name) = lines.first().and_then(|l| l.strip_prefix("# file: ")) {
                    let text = lines.join("\n") + "\n";
                    out.push(Step::Write { name: name.trim().to_owned(), text });
                }
            }
            _ => {}
        }
    }
    out
}

/// Why a command is not run, if it is not: any of its programs (in a list joined by `&&`, `||`,
/// `;` or `|`) is one the test does not run.
fn not_run(command: &str) -> Option<&'static str> {
    let segments = command.split(['&', '|', ';']).map(str::trim).filter(|s| !s.is_empty());
    let starts = |segment: &str, program: &str| match segment.strip_prefix(program) {
        Some(rest) => rest.is_empty() || rest.starts_with(' ') || program.ends_with('/'),
        None => false,
    };
    segments
        .flat_map(|segment| NOT_RUN.iter().filter(move |(program, _)| starts(segment, program)))
        .map(|(_, why)| *why)
        .next()
}

/// The command as the test runs it: `cargo run --release --` made `vitrum`, and budgets capped.
fn as_run(command: &str) -> String {
    let command = match command.strip_prefix("cargo run --release --") {
        Some(rest) => format!("vitrum{rest}"),
        None => command.to_owned(),
    };
    let mut words: Vec<String> = command.split(' ').map(str::to_owned).collect();
    // The resolution's scale first: the crops and regions follow it.
    let mut scale = 1.0f64;
    for i in 1..words.len() {
        if words[i - 1] == "--resolution" {
            if let Some((w, h)) = words[i].split_once('x') {
                if let (Ok(w), Ok(h)) = (w.parse::<f64>(), h.parse::<f64>()) {
                    if w > 128.0 {
                        scale = 128.0 / w;
                        words[i] = format!("128x{}", ((h * scale).round() as u64).max(1));
                    }
                }
            }
        }
    }
    let scaled = |n: &str| n.parse::<f64>().map(|v| ((v * scale).round() as u64).to_string()).ok();
    for i in 1..words.len() {
        let option = words[i - 1].clone();
        let value = &mut words[i];
        match option.as_str() {
            "--spp" | "--spp-max" | "--reference-spp" if value.parse::<u64>().is_ok_and(|n| n > 16) => {
                *value = "16".into();
            }
            "--time" if value.parse::<f64>().is_ok_and(|s| s > 0.25) => *value = "0.25".into(),
            "--crop" | "--region" if scale < 1.0 => {
                let (name, rect) = match value.split_once('=') {
                    Some((name, rect)) => (format!("{name}="), rect.to_owned()),
                    None => (String::new(), value.clone()),
                };
                let numbers: Option<Vec<String>> = rect.split(',').map(scaled).collect();
                if let Some(mut numbers) = numbers {
                    for n in numbers.iter_mut().skip(2) {
                        if n == "0" {
                            *n = "1".into();
                        }
                    }
                    *value = format!("{name}{}", numbers.join(","));
                }
            }
            _ => {}
        }
    }
    // A sweep without a reference renders one of 1024 samples: capped as a given budget is.
    let sweep = ["compare", "converge", "report"].iter().any(|c| words.get(1).is_some_and(|w| w == c));
    let referenced =
        ["--reference", "--reference-spp", "--renders"].iter().any(|o| words.iter().any(|w| w == o));
    if words[0] == "vitrum" && sweep && !referenced {
        words.push("--reference-spp".into());
        words.push("16".into());
    }
    words.join(" ")
}

/// `line` with every number made `#` and every run of spaces one space (columns widen with their
/// numbers), trailing spaces dropped.
fn masked(line: &str) -> String {
    let line = line.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut out = String::new();
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let starts_number = chars[i].is_ascii_digit()
            || (matches!(chars[i], '-' | '+' | '.')
                && chars.get(i + 1).is_some_and(char::is_ascii_digit)
                && (i == 0 || !chars[i - 1].is_alphanumeric()));
        if !starts_number {
            out.push(chars[i]);
            i += 1;
            continue;
        }
        i += 1;
        while i < chars.len() {
            let c = chars[i];
            let exponent = matches!(c, 'e' | 'E')
                && chars.get(i + 1).is_some_and(|n| n.is_ascii_digit() || *n == '-' || *n == '+');
            if c.is_ascii_digit() || (c == '.' && chars.get(i + 1).is_some_and(char::is_ascii_digit)) {
                i += 1;
            } else if exponent {
                i += 2;
            } else {
                break;
            }
        }
        out.push('#');
    }
    out
}

/// Whether `actual` lines match `expected` (masked; `…` any number of lines).
fn matches(expected: &[String], actual: &[String]) -> bool {
    match expected.split_first() {
        None => actual.is_empty(),
        Some((head, rest)) if head.trim() == "…" => {
            (0..=actual.len()).any(|skip| matches(rest, &actual[skip..]))
        }
        Some((head, rest)) => {
            let line_matches = |a: &String| match head.trim_end().strip_suffix('…') {
                // A line ending in `…`: its start is what the page shows, the rest varies by run.
                Some(start) => masked(a).starts_with(&masked(start)),
                None => masked(a) == masked(head),
            };
            actual.first().is_some_and(line_matches) && matches(rest, &actual[1..])
        }
    }
}

/// Runs every step of the page at `relative`, failing with the page, line and command.
fn run_page(relative: &str) {
    let path = Path::new(ROOT).join(relative);
    let text = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{relative}: {e}"));
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(Path::new(ROOT).join("scenes"), dir.path().join("scenes")).unwrap();
    let bin: PathBuf = Path::new(VITRUM).parent().unwrap().to_path_buf();
    let search = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    let (mut ran, mut skipped) = (0, Vec::new());
    let start = std::time::Instant::now();
    for step in steps(&text) {
        match step {
            Step::Write { name, text } => fs::write(dir.path().join(&name), text).unwrap(),
            Step::Run { line, command, expected } => {
                if let Some(why) = not_run(&command) {
                    skipped.push(format!("{relative}:{line}: not run: {command} ({why})"));
                    continue;
                }
                let run = as_run(&command);
                let began = std::time::Instant::now();
                let out = Command::new("sh")
                    .arg("-c")
                    .arg(&run)
                    .current_dir(dir.path())
                    .env("PATH", &search)
                    .output()
                    .unwrap_or_else(|e| panic!("{relative}:{line}: {run}: {e}"));
                let printed = format!(
                    "{}{}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                );
                let code = out.status.code().unwrap_or(-1);
                let want = expected.as_ref().map_or(0, |e| e.code);
                assert_eq!(
                    code, want,
                    "{relative}:{line}: `{run}` exited with {code}, not {want}:\n{printed}"
                );
                if let Some(expected) = expected {
                    let actual: Vec<String> = printed.lines().map(str::to_owned).collect();
                    assert!(
                        matches(&expected.lines, &actual),
                        "{relative}:{line}: `{run}` printed\n{printed}\nnot what the page shows (numbers masked):\n{}",
                        expected.lines.join("\n")
                    );
                }
                ran += 1;
                let seconds = began.elapsed().as_secs_f64();
                if seconds > 5.0 {
                    eprintln!("{relative}:{line}: {seconds:.1} s: {run}");
                }
            }
        }
    }
    for line in &skipped {
        eprintln!("{line}");
    }
    eprintln!(
        "{relative}: {ran} commands run in {:.1} s, {} not run",
        start.elapsed().as_secs_f64(),
        skipped.len()
    );
}

#[test]
fn the_readme_commands_run_and_print_what_it_shows() {
    run_page("README.md");
}

#[test]
fn the_scene_format_commands_run() {
    run_page("scenes/README.md");
}

#[test]
fn the_thesis_figure_commands_run() {
    run_page("scenes/figures.md");
}

#[test]
fn the_methods_page_commands_run() {
    run_page("docs/methods.md");
}

#[test]
fn the_command_line_page_commands_run() {
    run_page("docs/command-line.md");
}

#[test]
fn the_workflow_page_commands_run() {
    run_page("docs/workflow.md");
}

#[test]
fn the_scale_out_page_commands_run() {
    run_page("docs/scale-out.md");
}

#[test]
fn the_other_renderers_page_commands_run() {
    run_page("docs/other-renderers.md");
}

#[test]
fn the_testing_page_commands_run() {
    run_page("docs/testing.md");
}

#[test]
fn every_page_has_its_test() {
    let source = fs::read_to_string(Path::new(ROOT).join("tests/doc_commands.rs")).unwrap();
    for page in PAGES {
        assert!(source.contains(&format!("run_page(\"{page}\")")), "no test runs {page}");
    }
}

#[test]
fn the_readme_links_every_page_whose_commands_run() {
    let readme = fs::read_to_string(Path::new(ROOT).join("README.md")).unwrap();
    for page in &PAGES[1..] {
        assert!(readme.contains(&format!("({page}")), "README.md does not link {page}");
    }
}

#[test]
fn commands_are_split_capped_and_masked_as_documented() {
    let page = "```sh\nvitrum render a.toml \\\n  --spp 1024 --resolution 400x200  # a comment\n\n# only a comment\n```\n\
                ```console\n$ vitrum diff a.exr b.exr\nrelMSE 1.5e-3 over 400x200 pixels\n…\n[exit 2]\n```\n\
                ```toml\n# file: x.toml\n[camera]\n```\n";
    let steps = steps(page);
    assert_eq!(steps.len(), 3, "{steps:?}");
    let Step::Run { line, command, expected: None } = &steps[0] else { panic!("{steps:?}") };
    assert_eq!((*line, command.as_str()), (2, "vitrum render a.toml --spp 1024 --resolution 400x200"));
    assert_eq!(as_run(command), "vitrum render a.toml --spp 16 --resolution 128x64");
    let Step::Run { expected: Some(expected), .. } = &steps[1] else { panic!("{steps:?}") };
    assert_eq!(expected.code, 2);
    let printed = ["relMSE 0.25 over 128x64 pixels".to_owned(), "a".to_owned(), "b".to_owned()];
    assert!(matches(&expected.lines, &printed));
    assert!(!matches(&expected.lines, &["relMSE 0.25 over 128x64 px".to_owned()]));
    let varies = ["path   12 spp  biased …".to_owned()];
    assert!(matches(&varies, &["path 256 spp biased: bias part 0.1".to_owned()]));
    assert!(!matches(&varies, &["path 256 spp no bias detected".to_owned()]));
    assert_eq!(as_run("vitrum converge s.toml -i path"), "vitrum converge s.toml -i path --reference-spp 16");
    assert_eq!(as_run("vitrum compare s.toml --reference r.exr"), "vitrum compare s.toml --reference r.exr");
    assert!(matches!(&steps[2], Step::Write { name, .. } if name == "x.toml"));
    assert_eq!(
        as_run("vitrum compare s.toml --resolution 400x400 --crop 40,280,160,80 --region c=40,280,160,80 --time 60"),
        "vitrum compare s.toml --resolution 128x128 --crop 13,90,51,26 --region c=13,90,51,26 --time 0.25 \
         --reference-spp 16"
    );
    assert_eq!(as_run("cargo run --release -- render --png render.png"), "vitrum render --png render.png");
    assert_eq!(
        masked("in 0.169 s, 804856 rays, std error 9.553e-3 -> a.exr"),
        "in # s, # rays, std error # -> a.exr"
    );
    assert_eq!(not_run("cargo test --release"), Some("the command running this test"));
    assert_eq!(not_run("vitrum render"), None);
    assert!(not_run("mkdir -p parts && parallel -j 4 vitrum render ::: 1 && vitrum merge").is_some());
    assert!(not_run("scripts/slurm/submit.sh 16 scenes/a.toml ref.exr").is_some());
    assert_eq!(not_run("seq 0 15 | xargs -P 4 -I{} vitrum render s.toml --shard {}/16"), None);
}

/// The anchor GitHub gives a heading: lower case, letters, digits, `-` and `_` kept, spaces made
/// `-`, everything else dropped.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            '-' | '_' => Some(c),
            c if c.is_alphanumeric() => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a Markdown page's headings (outside code blocks), a repeated one numbered as
/// GitHub numbers it.
fn anchors(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut in_code = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
        }
        if in_code || !line.starts_with('#') {
            continue;
        }
        let base = anchor(line.trim_start_matches('#'));
        let seen = out.iter().filter(|a| **a == base || a.starts_with(&format!("{base}-"))).count();
        out.push(if seen == 0 { base } else { format!("{base}-{seen}") });
    }
    out
}

#[test]
fn the_manual_links_resolve() {
    let pages =
        PAGES.iter().copied().chain(["docs/performance.md", "docs/accuracy.md", "docs/architecture.md"]);
    let mut broken = Vec::new();
    for page in pages {
        let text = fs::read_to_string(Path::new(ROOT).join(page)).unwrap();
        let dir = Path::new(page).parent().unwrap();
        for (n, line) in text.lines().enumerate() {
            for part in line.split("](").skip(1) {
                let target = part.split(')').next().unwrap_or_default();
                if target.contains("://") || target.starts_with("mailto:") || target.contains(' ') {
                    continue;
                }
                let (file, fragment) = target.split_once('#').unwrap_or((target, ""));
                let path = if file.is_empty() { PathBuf::from(page) } else { dir.join(file) };
                let full = Path::new(ROOT).join(&path);
                if !full.exists() {
                    broken.push(format!("{page}:{}: {target}: no file {}", n + 1, path.display()));
                    continue;
                }
                let markdown = full.extension().is_some_and(|e| e == "md");
                if !fragment.is_empty() && markdown {
                    let linked = fs::read_to_string(&full).unwrap();
                    if !anchors(&linked).iter().any(|a| a == fragment) {
                        broken.push(format!("{page}:{}: {target}: no heading with that anchor", n + 1));
                    }
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn anchors_are_made_as_github_makes_them() {
    assert_eq!(anchor(" Camera methods at 800×800"), "camera-methods-at-800800");
    assert_eq!(anchor(" `path`: the engines, scene by scene"), "path-the-engines-scene-by-scene");
    assert_eq!(anchor(" Iterations per second at 400²"), "iterations-per-second-at-400²");
    assert_eq!(anchors("# A\n```\n# not a heading\n```\n## A\n"), ["a", "a-1"]);
}
