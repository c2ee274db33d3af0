//! Scene-file errors that point at a file, line, column and field.
//!
//! Parsing and validation report a [`FieldPath`] (`objects[2].radius`); this module turns it into
//! a line and column by walking the span-preserving `toml_edit` document, and the other way round
//! for serde's byte-offset errors.

use std::fmt;
use std::ops::Range;
use std::path::PathBuf;
use toml_edit::{ImDocument, Item, Table, Value};

use super::compile::MAX_MAGNITUDE;

/// One step of a path into the scene document.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Segment {
    /// A table key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// A path to a field, shown as `objects[2].radius`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FieldPath(pub Vec<Segment>);

impl FieldPath {
    /// The path extended by a key.
    pub fn key(&self, k: &str) -> FieldPath {
        let mut p = self.clone();
        p.0.push(Segment::Key(k.to_string()));
        p
    }

    /// The path extended by an array index.
    pub fn index(&self, i: usize) -> FieldPath {
        let mut p = self.clone();
        p.0.push(Segment::Index(i));
        p
    }
}

/// `FieldPath` from a dotted literal such as `"camera.fov"`.
impl From<&str> for FieldPath {
    fn from(s: &str) -> FieldPath {
        FieldPath(s.split('.').map(|k| Segment::Key(k.to_string())).collect())
    }
}

impl fmt::Display for FieldPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Segment::Key(k) if i == 0 => write!(f, "{k}")?,
                Segment::Key(k) => write!(f, ".{k}")?,
                Segment::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read the scene file: {source}")]
    Io {
        /// The scene file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The file is not a valid scene.
    #[error("{file}:{line}:{column}: {}{message}", field_prefix(field))]
    Invalid {
        /// The scene file (or `<embedded default scene>`).
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// Which field (empty for errors that belong to no field, such as TOML syntax).
        field: String,
        /// What is wrong and what is allowed.
        message: String,
    },
}

/// "field `x`: " for a named field, nothing otherwise.
fn field_prefix(field: &str) -> String {
    if field.is_empty() {
        String::new()
    } else {
        format!("field `{field}`: ")
    }
}

/// A scene file's text with its parsed spans, for error reporting.
pub struct Source<'a> {
    /// Display name of the file.
    pub name: String,
    /// The text.
    pub text: &'a str,
    doc: Option<ImDocument<&'a str>>,
}

/// A node of the document: a table item or a value inside an inline structure.
#[derive(Clone, Copy)]
enum Node<'a> {
    Item(&'a Item),
    Table(&'a Table),
    Value(&'a Value),
}

/// The keyed children of a table.
fn table_children(t: &Table) -> Vec<(Segment, Node<'_>, Option<Range<usize>>)> {
    t.iter()
        .filter_map(|(k, _)| {
            let (key, item) = t.get_key_value(k)?;
            Some((Segment::Key(k.to_string()), Node::Item(item), key.span()))
        })
        .collect()
}

impl<'a> Node<'a> {
    /// Whether the node is a value (a number, string, array or inline table), not a table
    /// written with a header.
    fn is_value(self) -> bool {
        matches!(self, Node::Item(Item::Value(_)) | Node::Value(_))
    }

    /// Whether the node is a table or array of tables written with headers (its parts may lie
    /// apart in the text).
    fn is_header_table(self) -> bool {
        matches!(self, Node::Item(Item::Table(_) | Item::ArrayOfTables(_)) | Node::Table(_))
    }

    fn span(self) -> Option<Range<usize>> {
        match self {
            Node::Item(i) => match i {
                Item::ArrayOfTables(a) => a.span(),
                Item::Table(t) => t.span(),
                Item::Value(v) => v.span(),
                Item::None => None,
            },
            Node::Table(t) => t.span(),
            Node::Value(v) => v.span(),
        }
    }

    /// Children with their path segment and the span of their key (if keyed).
    fn children(self) -> Vec<(Segment, Node<'a>, Option<Range<usize>>)> {
        let from_value = |v: &'a Value| -> Vec<(Segment, Node<'a>, Option<Range<usize>>)> {
            match v {
                Value::Array(a) => {
                    a.iter().enumerate().map(|(i, v)| (Segment::Index(i), Node::Value(v), None)).collect()
                }
                Value::InlineTable(t) => t
                    .iter()
                    .filter_map(|(k, _)| {
                        let (key, item) = t.get_key_value(k)?;
                        Some((Segment::Key(k.to_string()), Node::Item(item), key.span()))
                    })
                    .collect(),
                _ => Vec::new(),
            }
        };
        match self {
            Node::Item(Item::Table(t)) | Node::Table(t) => table_children(t),
            Node::Item(Item::ArrayOfTables(a)) => {
                a.iter().enumerate().map(|(i, t)| (Segment::Index(i), Node::Table(t), None)).collect()
            }
            Node::Item(Item::Value(v)) | Node::Value(v) => from_value(v),
            Node::Item(Item::None) => Vec::new(),
        }
    }
}

impl<'a> Source<'a> {
    /// Wrap a scene text; spans are available if the text is valid TOML.
    pub fn new(name: impl Into<String>, text: &'a str) -> Source<'a> {
        Source { name: name.into(), text, doc: ImDocument::parse(text).ok() }
    }

    /// 1-based line and column of a byte offset.
    pub fn line_column(&self, offset: usize) -> (usize, usize) {
        let mut offset = offset.min(self.text.len());
        // An offset inside a multi-byte character counts as that character.
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let before = &self.text[..offset];
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        (line, column)
    }

    /// The span of the deepest existing node along `path`: its value for a value (an error
    /// about `radius = "big"` points at `"big"`), else its key where it has one (a table's
    /// header key), else the table.
    pub fn span_of(&self, path: &FieldPath) -> Option<Range<usize>> {
        let doc = self.doc.as_ref()?;
        let mut node = Node::Item(doc.as_item());
        let mut best = None;
        for seg in &path.0 {
            let Some((_, child, key_span)) = node.children().into_iter().find(|(s, _, _)| s == seg) else {
                break;
            };
            best =
                if child.is_value() { child.span().or(key_span) } else { key_span.or_else(|| child.span()) }
                    .or(best);
            node = child;
        }
        best
    }

    /// Whether `path` names a table (with a header, or inline).
    pub fn is_table(&self, path: &FieldPath) -> bool {
        let Some(doc) = self.doc.as_ref() else { return false };
        let mut node = Node::Item(doc.as_item());
        for seg in &path.0 {
            match node.children().into_iter().find(|(s, _, _)| s == seg) {
                Some((_, child, _)) => node = child,
                None => return false,
            }
        }
        match node {
            Node::Item(Item::Table(_)) | Node::Table(_) => true,
            Node::Item(Item::Value(v)) | Node::Value(v) => v.is_inline_table(),
            _ => false,
        }
    }

    /// The path of the deepest node whose key or value contains `offset`. Tables written with
    /// headers are searched through whatever their span: implicit ones (the `materials` of
    /// `[materials.glass]`) have none, and a table's sub-tables (`[render.whitted]` after
    /// `[render]`) lie outside its span.
    pub fn path_at(&self, offset: usize) -> FieldPath {
        fn descend(node: Node<'_>, offset: usize, path: &mut FieldPath) -> bool {
            let contains = |r: &Option<Range<usize>>| r.as_ref().is_some_and(|r| r.contains(&offset));
            for (seg, child, key_span) in node.children() {
                let hit = contains(&key_span) || contains(&child.span());
                if hit || child.span().is_none() || child.is_header_table() {
                    path.0.push(seg);
                    if descend(child, offset, path) || hit {
                        return true;
                    }
                    path.0.pop();
                }
            }
            false
        }
        let mut path = FieldPath::default();
        if let Some(doc) = self.doc.as_ref() {
            descend(Node::Item(doc.as_item()), offset, &mut path);
        }
        path
    }

    /// Start offsets of the keys (or, for array elements, values) inside `range` whose key and
    /// value satisfy `matches`; `value` is `None` for tables. In document order.
    pub fn find_in(
        &self,
        range: Range<usize>,
        matches: impl Fn(Option<&str>, Option<&Value>) -> bool,
    ) -> Vec<usize> {
        let Some(doc) = self.doc.as_ref() else { return Vec::new() };
        let inside = |r: &Option<Range<usize>>| {
            r.as_ref().is_some_and(|r| range.start <= r.start && r.end <= range.end)
        };
        let mut found = Vec::new();
        let mut stack = vec![Node::Item(doc.as_item())];
        while let Some(node) = stack.pop() {
            for (seg, child, key_span) in node.children() {
                let value = match child {
                    Node::Item(Item::Value(v)) | Node::Value(v) => Some(v),
                    _ => None,
                };
                let key = match &seg {
                    Segment::Key(k) => Some(k.as_str()),
                    Segment::Index(_) => None,
                };
                let at = if key_span.is_some() { key_span } else { child.span() };
                if inside(&at) && matches(key, value) {
                    found.extend(at.map(|r| r.start));
                }
                stack.push(child);
            }
        }
        found.sort_unstable();
        found.dedup();
        found
    }

    /// The text with the key at `path` removed (`None` if `path` does not end in a key of a
    /// table that exists).
    pub fn without(&self, path: &FieldPath) -> Option<String> {
        let (Segment::Key(last), parents) = path.0.split_last()? else { return None };
        let mut doc: toml_edit::DocumentMut = self.text.parse().ok()?;
        let mut item = doc.as_item_mut();
        for seg in parents {
            item = match seg {
                Segment::Key(k) => item.get_mut(k.as_str())?,
                Segment::Index(i) => item.get_mut(*i)?,
            };
        }
        item.as_table_like_mut()?.remove(last)?;
        Some(doc.to_string())
    }

    /// An error about `path`, located at its line and column.
    pub fn error_at(&self, path: &FieldPath, message: impl Into<String>) -> SceneError {
        let (line, column) = self.span_of(path).map_or((1, 1), |s| self.line_column(s.start));
        SceneError::Invalid {
            file: self.name.clone(),
            line,
            column,
            field: path.to_string(),
            message: message.into(),
        }
    }

    /// An error at a byte offset (from the TOML parser or serde).
    pub fn error_at_offset(&self, offset: usize, message: impl Into<String>) -> SceneError {
        let (line, column) = self.line_column(offset);
        SceneError::Invalid {
            file: self.name.clone(),
            line,
            column,
            field: self.path_at(offset).to_string(),
            message: message.into(),
        }
    }

    /// Every number in the document that is NaN, infinite, or larger in magnitude than
    /// [`MAX_MAGNITUDE`] (`render.seed` excepted), as an error.
    pub fn check_numbers(&self) -> Result<(), SceneError> {
        let Some(doc) = self.doc.as_ref() else { return Ok(()) };
        let seed = FieldPath::from("render.seed");
        let too_large = |path: &FieldPath, x: String| {
            self.error_at(
                path,
                format!("{x} is too large: numbers in a scene file are limited to ±{MAX_MAGNITUDE:e}"),
            )
        };
        let mut stack = vec![(FieldPath::default(), Node::Item(doc.as_item()))];
        while let Some((path, node)) = stack.pop() {
            let value = match node {
                Node::Item(Item::Value(v)) | Node::Value(v) => Some(v),
                _ => None,
            };
            match value {
                Some(Value::Float(f)) => {
                    let x = *f.value();
                    if !x.is_finite() {
                        return Err(
                            self.error_at(&path, format!("{x} is not allowed: numbers must be finite"))
                        );
                    }
                    if x.abs() > MAX_MAGNITUDE {
                        return Err(too_large(&path, format!("{x:e}")));
                    }
                }
                Some(Value::Integer(i)) if path != seed && (*i.value() as f64).abs() > MAX_MAGNITUDE => {
                    return Err(too_large(&path, i.value().to_string()));
                }
                _ => {}
            }
            for (seg, child, _) in node.children() {
                let mut p = path.clone();
                p.0.push(seg);
                stack.push((p, child));
            }
        }
        Ok(())
    }
}
