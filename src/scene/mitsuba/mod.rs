//! Scenes in Mitsuba's XML format (0.5, 0.6, 2.x, 3.x), read through vitrum's own format.
//!
//! [`xml`] reads the file into objects and properties as Mitsuba 3 does; [`translate`] writes
//! them as vitrum's TOML, with a comment for everything that is not exact; the TOML then takes
//! the one compile step every scene takes ([`crate::scene::compile::load_str`]), so an XML scene
//! and the TOML `vitrum import` writes of it are the same scene by construction. An error of
//! that compile step is reported at the XML element the faulty TOML line was written for.

pub mod spectra;
pub mod toml_writer;
pub mod translate;
pub mod xml;

use super::compile::load_str as load_str_toml;
use super::source::SceneError;
use super::Scene;
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Whether scenes are imported leniently (the command line's `--lenient`).
static LENIENT: AtomicBool = AtomicBool::new(false);

/// Import every Mitsuba scene of this process leniently (`--lenient`): what vitrum lacks is
/// dropped or approximated with a warning instead of refused.
pub fn set_lenient(lenient: bool) {
    LENIENT.store(lenient, Ordering::Relaxed);
}

/// Whether [`set_lenient`] asked for lenient imports.
pub fn lenient() -> bool {
    LENIENT.load(Ordering::Relaxed)
}

/// Whether one-sided diffuse BSDFs are read as two-sided (the command line's `--two-sided`).
static TWO_SIDED: AtomicBool = AtomicBool::new(false);

/// Read every one-sided Mitsuba `diffuse` (one not inside a `twosided`) of this process as
/// two-sided, with a warning (`--two-sided`): the reading other renderers such as Tungsten give
/// scenes converted from Mitsuba.
pub fn set_two_sided(two_sided: bool) {
    TWO_SIDED.store(two_sided, Ordering::Relaxed);
}

/// Whether [`set_two_sided`] asked for two-sided diffuse.
pub fn two_sided() -> bool {
    TWO_SIDED.load(Ordering::Relaxed)
}

/// How a Mitsuba scene is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// Drop or approximate what vitrum lacks, with warnings, instead of refusing it.
    pub lenient: bool,
    /// Read every one-sided `diffuse` as two-sided, with a warning.
    pub two_sided: bool,
}

impl From<bool> for ImportOptions {
    /// `lenient` as given, two-sided as the process asked ([`set_two_sided`], the command
    /// line's `--two-sided`; one-sided otherwise).
    fn from(lenient: bool) -> ImportOptions {
        ImportOptions { lenient, two_sided: two_sided() }
    }
}

/// Whether `path` names a Mitsuba scene (its extension is `.xml`, any case).
pub fn is_mitsuba(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// A Mitsuba scene as vitrum's TOML, with the warnings of what is not exact.
pub struct Imported {
    /// The TOML text.
    pub toml: String,
    /// One sentence per difference, each with its position.
    pub warnings: Vec<String>,
    /// The writer, which knows the element of every line.
    writer: toml_writer::TomlWriter,
}

/// Reads and translates the Mitsuba scene `path` (`lenient`: drop or approximate what vitrum
/// lacks, with warnings) for a TOML file in the folder `toml_dir` (`None`: the XML's own): the
/// files the scene names are written relative to the XML's folder when the TOML sits there,
/// else as the XML's folder joined with them.
pub fn import(
    path: &Path,
    options: impl Into<ImportOptions>,
    toml_dir: Option<&Path>,
) -> Result<Imported, SceneError> {
    let doc = xml::read(path, &HashMap::new()).map_err(invalid)?;
    let xml_dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let same = |d: &Path| match (d.canonicalize(), xml_dir.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    let rebase =
        toml_dir.filter(|d| !same(d)).map(|_| xml_dir.canonicalize().unwrap_or(xml_dir.to_path_buf()));
    let file = |name: &str| match &rebase {
        Some(dir) => dir.join(name).display().to_string(),
        None => name.to_string(),
    };
    let translation = translate::translate(&doc, options.into(), &file).map_err(invalid)?;
    Ok(Imported {
        toml: translation.toml.text().to_string(),
        warnings: translation.warnings,
        writer: translation.toml,
    })
}

/// Compiles Mitsuba scene text named `name` (files it names are looked for in `dir`; it may
/// include nothing), as [`load`] does a file.
pub fn load_str(
    text: &str,
    name: &str,
    dir: Option<&Path>,
    options: impl Into<ImportOptions>,
) -> Result<Scene, SceneError> {
    let doc = xml::read_str(text, name, None, &HashMap::new()).map_err(invalid)?;
    let translation =
        translate::translate(&doc, options.into(), &|f: &str| f.to_string()).map_err(invalid)?;
    let imported = Imported {
        toml: translation.toml.text().to_string(),
        warnings: translation.warnings,
        writer: translation.toml,
    };
    let mut scene = load_str_toml(&imported.toml, name, dir).map_err(|e| imported.at_element(e))?;
    scene.warnings.splice(0..0, imported.warnings.iter().cloned());
    Ok(scene)
}

/// Loads the Mitsuba scene `path` as a compiled scene, its import warnings among the scene's.
pub fn load(path: &Path, options: impl Into<ImportOptions>) -> Result<Scene, SceneError> {
    let imported = import(path, options, None)?;
    let name = path.display().to_string();
    let mut scene =
        load_str_toml(&imported.toml, &name, path.parent()).map_err(|e| imported.at_element(e))?;
    scene.warnings.splice(0..0, imported.warnings.iter().cloned());
    Ok(scene)
}

impl Imported {
    /// A compile error of the TOML moved to the XML element its line was written for.
    fn at_element(&self, error: SceneError) -> SceneError {
        match error {
            SceneError::Invalid { line, field, message, file, column } => match self.writer.origin(line) {
                Some((position, element)) => SceneError::Invalid {
                    file: position.file.to_string(),
                    line: position.line as usize,
                    column: position.column as usize,
                    field: String::new(),
                    message: format!(
                        "{element}: {}{message}",
                        if field.is_empty() { String::new() } else { format!("(as vitrum's `{field}`) ") }
                    ),
                },
                None => SceneError::Invalid { file, line, column, field, message },
            },
            other => other,
        }
    }
}

/// An XML error as a scene error.
fn invalid(e: xml::XmlError) -> SceneError {
    SceneError::Invalid {
        file: e.position.file.to_string(),
        line: e.position.line as usize,
        column: e.position.column as usize,
        field: String::new(),
        message: format!("{}: {}", e.element, e.message),
    }
}
