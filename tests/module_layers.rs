//! The layers of the crate, read from its source files (docs/architecture.md, "Layers"): the
//! render drivers (`src/render/`) hold the contract they drive (`render::Integrator`,
//! `render::Progression`) and never name the methods (`integrators/`), which implement it and
//! may use the drivers' pieces; the scene layer names neither; the table of methods
//! (`src/methods.rs`) names nothing of the crate. So `render` and `integrators` form no cycle.
//!
//! A module is named by a path (`crate::integrators`, `vitrum::integrators`, `super::integrators`,
//! `super::super::integrators`) or inside a grouped import (`use crate::{integrators, …}`), in
//! code: comments, string literals and the unit tests at the end of a file
//! (`#[cfg(test)] mod tests`) are not read.

use std::path::{Path, PathBuf};

/// The code of a Rust source: without comments, string and character literals, and its
/// `#[cfg(test)] mod tests` module.
fn code(source: &str) -> String {
    let source = match source.find("#[cfg(test)]\nmod tests") {
        Some(at) => &source[..at],
        None => source,
    };
    let bytes = source.as_bytes();
    let mut out = String::with_capacity(source.len());
    let mut i = 0;
    while i < bytes.len() {
        let rest = &source[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
        } else if rest.starts_with("/*") {
            i += rest.find("*/").map_or(rest.len(), |e| e + 2);
        } else if rest.starts_with('"') {
            // Skip to the closing quote, past escaped characters.
            let mut j = i + 1;
            while j < bytes.len() && bytes[j] != b'"' {
                j += if bytes[j] == b'\\' { 2 } else { 1 };
            }
            out.push_str("\"\"");
            i = j + 1;
        } else {
            let c = rest.chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// Whether `code` names the top-level module `module` of the crate.
fn names_module(code: &str, module: &str) -> bool {
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut from = 0;
    while let Some(k) = code[from..].find(module) {
        let (start, end) = (from + k, from + k + module.len());
        from = end;
        let before = code[..start].chars().next_back();
        let after = code[end..].chars().next();
        if before.is_some_and(is_ident) || after.is_some_and(is_ident) {
            continue;
        }
        let prefix = code[..start].trim_end();
        // A path: `crate::module`, `vitrum::module`, `super::module`, `super::super::module`.
        if let Some(path) = prefix.strip_suffix("::") {
            let root = path.rsplit(|c: char| !is_ident(c) && c != ':').next().unwrap_or("");
            if root.split("::").all(|s| s == "super") || root == "crate" || root == "vitrum" {
                return true;
            }
            continue;
        }
        // An item of a grouped import of the crate root: `crate::{a, module, …}`.
        if prefix.ends_with('{') || prefix.ends_with(',') {
            if let Some(open) = prefix.rfind('{') {
                let group = prefix[..open].trim_end();
                let inner = &prefix[open + 1..];
                if (group.ends_with("crate::") || group.ends_with("vitrum::")) && !inner.contains('{') {
                    return true;
                }
            }
        }
    }
    false
}

/// Every `.rs` file under `dir`, recursively.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out.sort();
    out
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The files under `dir` (relative to the crate) whose code names one of `forbidden`.
fn offenders(dir: &str, forbidden: &[&str]) -> Vec<String> {
    let files = if dir.ends_with(".rs") { vec![root().join(dir)] } else { sources(&root().join(dir)) };
    assert!(!files.is_empty(), "{dir}: no sources");
    let mut out = Vec::new();
    for file in files {
        let code = code(&std::fs::read_to_string(&file).unwrap());
        for module in forbidden {
            if names_module(&code, module) {
                out.push(format!("{} names `{module}`", file.strip_prefix(root()).unwrap().display()));
            }
        }
    }
    out
}

#[test]
fn the_checker_finds_every_form_of_naming_a_module_and_ignores_comments_strings_and_tests() {
    for named in [
        "use crate::integrators::Path;",
        "use crate::integrators;",
        "let p = crate::integrators::create(\"path\");",
        "use crate::{geometry::Ray, integrators::Path};",
        "use crate::{integrators, scene};",
        "use super::super::integrators::Path;",
        "use super::integrators;",
        "use vitrum::integrators::create;",
    ] {
        assert!(names_module(&code(named), "integrators"), "{named}");
    }
    for not_named in [
        "// uses crate::integrators::Path\nfn f() {}",
        "/// See [`crate::integrators::Path`].\nfn f() {}",
        "fn f() { println!(\"crate::integrators\"); }",
        "fn f() {}\n#[cfg(test)]\nmod tests {\n    use crate::integrators::create;\n}\n",
        "use crate::render::integrators_like;",
        "use crate::scene::{integrators};",
        "fn integrators() {}",
    ] {
        assert!(!names_module(&code(not_named), "integrators"), "{not_named}");
    }
}

#[test]
fn the_render_drivers_never_name_the_methods() {
    assert_eq!(offenders("src/render", &["integrators"]), Vec::<String>::new());
}

#[test]
fn the_scene_layer_names_neither_the_drivers_nor_the_methods() {
    assert_eq!(offenders("src/scene", &["integrators", "render"]), Vec::<String>::new());
}

#[test]
fn the_table_of_methods_names_nothing_of_the_crate() {
    let code = code(&std::fs::read_to_string(root().join("src/methods.rs")).unwrap());
    assert!(!code.contains("crate::") && !code.contains("super::"), "src/methods.rs is data only");
}

#[test]
fn no_method_or_lane_module_is_longer_than_900_lines() {
    // Small modules with one job (docs/architecture.md): a file that outgrows this is split.
    let mut long = Vec::new();
    for dir in ["integrators", "src/lanes"] {
        let files = sources(&root().join(dir));
        assert!(files.len() > 3, "{dir} holds the modules");
        for file in files {
            let lines = std::fs::read_to_string(&file).unwrap().lines().count();
            if lines > 900 {
                long.push(format!("{} ({lines} lines)", file.display()));
            }
        }
    }
    assert!(long.is_empty(), "longer than 900 lines: {long:?}");
}
