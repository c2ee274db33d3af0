//! The TOML text of an imported scene, written line by line so that every line remembers the
//! Mitsuba element it came from (compile errors in the TOML are reported at that element).

use super::xml::Position;
use std::fmt::Write as _;

/// A TOML document under construction, with the source element of every line.
#[derive(Default)]
pub struct TomlWriter {
    text: String,
    /// For each line written (from line 1), the element it was written for.
    origins: Vec<Option<(Position, String)>>,
    /// The element the next lines come from.
    current: Option<(Position, String)>,
}

impl TomlWriter {
    /// The lines written from now on come from `element` at `position`.
    pub fn from(&mut self, position: &Position, element: &str) {
        self.current = Some((position.clone(), element.to_string()));
    }

    /// A line of text as it is.
    pub fn line(&mut self, text: &str) {
        for line in text.split('\n') {
            self.text.push_str(line);
            self.text.push('\n');
            self.origins.push(self.current.clone());
        }
    }

    /// A `# comment` line per line of `text`.
    pub fn comment(&mut self, text: &str) {
        for line in text.split('\n') {
            self.line(&format!("# {line}"));
        }
    }

    /// `[name]` after a blank line.
    pub fn table(&mut self, name: &str) {
        self.line("");
        self.line(&format!("[{name}]"));
    }

    /// `[[name]]` after a blank line.
    pub fn array_table(&mut self, name: &str) {
        self.line("");
        self.line(&format!("[[{name}]]"));
    }

    /// `key = value` with the value already in TOML.
    pub fn raw(&mut self, key: &str, value: &str) {
        self.line(&format!("{key} = {value}"));
    }

    /// `key = "text"`.
    pub fn string(&mut self, key: &str, text: &str) {
        self.raw(key, &toml::Value::String(text.to_string()).to_string());
    }

    /// `key = x` as single precision, the shortest text that reads back to the same f32.
    pub fn number(&mut self, key: &str, x: f64) {
        self.raw(key, &number(x));
    }

    /// `key = [x, y, z]`.
    pub fn vector(&mut self, key: &str, v: [f64; 3]) {
        self.raw(key, &vector(v));
    }

    /// Appends `other`'s lines, each with its element.
    pub fn append(&mut self, other: TomlWriter) {
        self.text.push_str(&other.text);
        self.origins.extend(other.origins);
    }

    /// The text written.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The element line `line` (from 1) was written for.
    pub fn origin(&self, line: usize) -> Option<&(Position, String)> {
        self.origins.get(line.checked_sub(1)?)?.as_ref()
    }
}

/// A number as TOML, rounded to single precision (vitrum's scenes are single precision): the
/// shortest text that reads back to the same f32, always with a decimal point or exponent.
pub fn number(x: f64) -> String {
    let f = x as f32;
    let f = if f == 0.0 { 0.0 } else { f };
    let mut s = format!("{f:?}");
    if !s.contains(['.', 'e', 'E']) {
        s.push_str(".0");
    }
    s
}

/// `[x, y, …]` as TOML numbers.
pub fn vector<const N: usize>(v: [f64; N]) -> String {
    let mut s = String::from("[");
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        let _ = write!(s, "{}", number(*x));
    }
    s.push(']');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_as_the_same_single_precision_value() {
        for x in [0.0, -0.0, 1.0, 0.1, 1e-7, 123456.789, -3.5, 1e20] {
            let text = number(x);
            let back: f32 = text.parse().unwrap();
            assert_eq!(back, x as f32, "{text}");
            assert!(text.contains(['.', 'e']), "{text}");
        }
        assert_eq!(number(-0.0), "0.0");
        assert_eq!(vector([1.0, 2.5, -3.0]), "[1.0, 2.5, -3.0]");
    }

    #[test]
    fn lines_remember_their_element() {
        let mut w = TomlWriter::default();
        w.line("# head");
        let at = Position { file: "a.xml".into(), line: 3, column: 5 };
        w.from(&at, "<shape type=\"sphere\">");
        w.array_table("objects");
        w.number("radius", 2.0);
        assert_eq!(w.text(), "# head\n\n[[objects]]\nradius = 2.0\n");
        assert_eq!(w.origin(1), None);
        assert_eq!(w.origin(4).unwrap().0, at);
    }
}
