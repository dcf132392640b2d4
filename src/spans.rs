//! Locating keys in the case text, so every error can say file:line:column.

use std::fmt;
use std::path::Path;
use toml_edit::{Document, Item, Value};

/// A case-file error: where, which key, what is wrong and what would be valid.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseError {
    /// File name.
    pub file: String,
    /// 1-based line (0 when the file could not be read).
    pub line: usize,
    /// 1-based column.
    pub column: usize,
    /// Dotted key path (`fluid.gamma`, `reference[1].tolerance`).
    pub key: String,
    /// What is wrong and what would be valid.
    pub message: String,
}

impl fmt::Display for CaseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.column)?;
        }
        if self.key.is_empty() {
            write!(f, ": {}", self.message)
        } else {
            write!(f, ": `{}`: {}", self.key, self.message)
        }
    }
}

impl std::error::Error for CaseError {}

/// One step of a key path.
#[derive(Clone, Debug, PartialEq)]
pub enum Segment {
    /// Table key.
    Key(String),
    /// Array index.
    Index(usize),
}

/// Renders a path as `a.b[2].c`.
pub fn render(path: &[Segment]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Segment::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Segment::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// Parses a path rendered by [`render`] (`a.b[2].c`) back into its segments.
pub fn parse_key_path(key: &str) -> Vec<Segment> {
    let mut out = Vec::new();
    for part in key.split('.') {
        let mut rest = part;
        if let Some(open) = rest.find('[') {
            if open > 0 {
                out.push(Segment::Key(rest[..open].to_owned()));
            }
            rest = &rest[open..];
            while let Some(close) = rest.find(']') {
                if let Ok(i) = rest[1..close].parse() {
                    out.push(Segment::Index(i));
                }
                rest = &rest[close + 1..];
                if !rest.starts_with('[') {
                    break;
                }
            }
        } else if !rest.is_empty() {
            out.push(Segment::Key(rest.to_owned()));
        }
    }
    out
}

/// The parsed document with spans.
pub struct SpanIndex<'a> {
    source: &'a str,
    file: String,
    doc: Document<&'a str>,
}

impl<'a> SpanIndex<'a> {
    /// Parses the text for spans; a TOML syntax error is reported here.
    pub fn new(source: &'a str, path: &Path) -> Result<Self, CaseError> {
        let file = path.display().to_string();
        match Document::parse(source) {
            Ok(doc) => Ok(Self { source, file, doc }),
            Err(e) => {
                let (line, column) = e
                    .span()
                    .map(|s| line_col(source, s.start))
                    .unwrap_or((1, 1));
                let text = source
                    .lines()
                    .nth(line.saturating_sub(1))
                    .unwrap_or("")
                    .trim();
                Err(CaseError {
                    file,
                    line,
                    column,
                    key: String::new(),
                    message: format!("invalid TOML: {} (in `{text}`)", e.message().trim()),
                })
            }
        }
    }

    /// An error at a key path (or at the nearest existing parent).
    pub fn error(&self, path: &[Segment], message: impl Into<String>) -> CaseError {
        let (line, column) = self.locate(path);
        CaseError {
            file: self.file.clone(),
            line,
            column,
            key: render(path),
            message: message.into(),
        }
    }

    /// Line and column of the deepest existing element of `path`.
    pub fn locate(&self, path: &[Segment]) -> (usize, usize) {
        let (_, best) = self.walk(path);
        best.map(|b| line_col(self.source, b)).unwrap_or((1, 1))
    }

    /// Follows `path`; returns how many segments exist and the byte offset of the deepest one.
    fn walk(&self, path: &[Segment]) -> (usize, Option<usize>) {
        let mut node = Node::Table(self.doc.as_table());
        let mut best = None;
        for (depth, seg) in path.iter().enumerate() {
            let next = match (node, seg) {
                (Node::Table(t), Segment::Key(k)) => {
                    if let Some(sp) = t.key(k).and_then(|key| key.span()) {
                        best = Some(sp.start);
                    }
                    t.get(k).map(Node::Item)
                }
                (Node::Item(Item::Table(t)), Segment::Key(k)) => {
                    if let Some(sp) = t.key(k).and_then(|key| key.span()) {
                        best = Some(sp.start);
                    }
                    t.get(k).map(Node::Item)
                }
                (Node::Item(Item::Value(Value::InlineTable(t))), Segment::Key(k)) => {
                    if let Some(sp) = t.key(k).and_then(|key| key.span()) {
                        best = Some(sp.start);
                    }
                    t.get(k).map(Node::Value)
                }
                (Node::Value(Value::InlineTable(t)), Segment::Key(k)) => {
                    if let Some(sp) = t.key(k).and_then(|key| key.span()) {
                        best = Some(sp.start);
                    }
                    t.get(k).map(Node::Value)
                }
                (Node::Item(Item::ArrayOfTables(a)), Segment::Index(i)) => {
                    a.get(*i).map(Node::Table)
                }
                (Node::Item(Item::Value(Value::Array(a))), Segment::Index(i))
                | (Node::Value(Value::Array(a)), Segment::Index(i)) => a.get(*i).map(Node::Value),
                _ => None,
            };
            match next {
                Some(n) => {
                    if let Some(sp) = n.span() {
                        best = Some(sp);
                    }
                    node = n;
                }
                None => return (depth, best),
            }
        }
        (path.len(), best)
    }

    /// A TOML-level error from the deserialiser's parser.
    pub fn syntax_error(&self, e: &toml::de::Error) -> CaseError {
        let (line, column) = e
            .span()
            .map(|s| line_col(self.source, s.start))
            .unwrap_or((1, 1));
        CaseError {
            file: self.file.clone(),
            line,
            column,
            key: String::new(),
            message: e.message().trim().to_owned(),
        }
    }

    /// A structural error (unknown key, missing key, wrong type) from serde.
    pub fn serde_error(&self, e: &serde_path_to_error::Error<toml::de::Error>) -> CaseError {
        let span = e.inner().span();
        self.structural_error(&segments(e.path()), e.inner().message(), span)
    }

    /// A structural error at `path` (relative to the document root) with serde's message.
    pub fn structural_error(
        &self,
        path: &[Segment],
        raw: &str,
        span: Option<std::ops::Range<usize>>,
    ) -> CaseError {
        let raw = raw.trim();
        let message = explain(raw);
        let mut path = path.to_vec();
        // Point at the offending key itself when serde names it.
        if let Some(name) = backticked_after(raw, "unknown field") {
            if path.last() != Some(&Segment::Key(name.clone())) {
                path.push(Segment::Key(name));
            }
            return self.error(&path, message);
        }
        if let Some(name) = backticked_after(raw, "missing field") {
            let mut err = self.error(&path, message);
            path.push(Segment::Key(name));
            err.key = render(&path);
            return err;
        }
        let (line, column) = match (path.is_empty(), span) {
            (true, Some(s)) => line_col(self.source, s.start),
            _ => self.locate(&path),
        };
        CaseError {
            file: self.file.clone(),
            line,
            column,
            key: render(&path),
            message,
        }
    }
}

#[derive(Clone, Copy)]
enum Node<'d> {
    Table(&'d toml_edit::Table),
    Item(&'d Item),
    Value(&'d Value),
}

impl Node<'_> {
    fn span(&self) -> Option<usize> {
        match self {
            Node::Table(t) => t.span().map(|s| s.start),
            Node::Item(i) => i.span().map(|s| s.start),
            Node::Value(v) => v.span().map(|s| s.start),
        }
    }
}

/// serde_path_to_error's path as our segments.
pub fn segments(path: &serde_path_to_error::Path) -> Vec<Segment> {
    let mut out = Vec::new();
    for seg in path.iter() {
        match seg {
            serde_path_to_error::Segment::Map { key } => out.push(Segment::Key(key.clone())),
            serde_path_to_error::Segment::Seq { index } => out.push(Segment::Index(*index)),
            _ => {}
        }
    }
    out
}

fn backticked_after(msg: &str, prefix: &str) -> Option<String> {
    let rest = msg.strip_prefix(prefix)?.trim_start();
    let rest = rest.strip_prefix('`')?;
    let end = rest.find('`')?;
    Some(rest[..end].to_owned())
}

/// serde's messages with the vocabulary of a case file.
fn explain(raw: &str) -> String {
    if raw.starts_with("unknown variant") {
        return raw
            .replace("unknown variant", "unknown choice")
            .replace("expected one of", "valid choices are")
            .replace(", expected", ", valid choices are");
    }
    if raw.starts_with("unknown field") {
        return raw
            .replace("unknown field", "unknown key")
            .replace("expected one of", "valid keys here are")
            .replace(", expected", ", the valid key here is")
            .replace("there are no fields", "this table takes no keys");
    }
    raw.replace("missing field", "missing required key")
        .replace(
            "wanted string or table",
            "expected one of the listed names (a string)",
        )
}

/// 1-based line and column of a byte offset.
pub fn line_col(source: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(source.len());
    let before = &source[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rendered_key_path_parses_back_to_its_segments() {
        let path = vec![
            Segment::Key("reference".into()),
            Segment::Index(2),
            Segment::Key("tolerance".into()),
        ];
        assert_eq!(render(&path), "reference[2].tolerance");
        assert_eq!(parse_key_path(&render(&path)), path);
        let nested = vec![
            Segment::Key("box".into()),
            Segment::Key("lengths".into()),
            Segment::Index(1),
        ];
        assert_eq!(parse_key_path(&render(&nested)), nested);
        assert_eq!(
            parse_key_path("fluid.polymer.b"),
            vec![
                Segment::Key("fluid".into()),
                Segment::Key("polymer".into()),
                Segment::Key("b".into())
            ]
        );
    }
}
