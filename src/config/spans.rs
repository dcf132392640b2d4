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
                Err(CaseError {
                    file,
                    line,
                    column,
                    key: String::new(),
                    message: format!("invalid TOML: {}", e.message().trim()),
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
        let mut path: Vec<Segment> = Vec::new();
        for seg in e.path().iter() {
            match seg {
                serde_path_to_error::Segment::Map { key } => path.push(Segment::Key(key.clone())),
                serde_path_to_error::Segment::Seq { index } => path.push(Segment::Index(*index)),
                _ => {}
            }
        }
        let raw = e.inner().message().trim().to_owned();
        let message = explain(&raw);
        // Point at the offending key itself when serde names it.
        if let Some(name) = backticked_after(&raw, "unknown field") {
            let mut p = path.clone();
            p.push(Segment::Key(name));
            let (line, column) = self.locate(&p);
            return CaseError {
                file: self.file.clone(),
                line,
                column,
                key: render(&p),
                message,
            };
        }
        if let Some(name) = backticked_after(&raw, "missing field") {
            let mut err = self.error(&path, message);
            let mut p = path.clone();
            p.push(Segment::Key(name));
            err.key = render(&p);
            return err;
        }
        if raw.starts_with("unknown variant") && !path.is_empty() {
            // Internally tagged tables report the variant at the table; point at `kind`.
            let mut p = path.clone();
            if self.locate_exact(&[&p[..], &[Segment::Key("kind".into())]].concat()) {
                p.push(Segment::Key("kind".into()));
            }
            return self.error(&p, message);
        }
        let (line, column) = if path.is_empty() {
            e.inner()
                .span()
                .map(|s| line_col(self.source, s.start))
                .unwrap_or((1, 1))
        } else {
            self.locate(&path)
        };
        CaseError {
            file: self.file.clone(),
            line,
            column,
            key: render(&path),
            message,
        }
    }

    fn locate_exact(&self, path: &[Segment]) -> bool {
        self.walk(path).0 == path.len()
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

fn backticked_after(msg: &str, prefix: &str) -> Option<String> {
    let rest = msg.strip_prefix(prefix)?.trim_start();
    let rest = rest.strip_prefix('`')?;
    let end = rest.find('`')?;
    Some(rest[..end].to_owned())
}

/// serde's messages with the vocabulary of a case file.
fn explain(raw: &str) -> String {
    let s = raw
        .replace("unknown field", "unknown key")
        .replace("missing field", "missing required key")
        .replace("expected one of", "valid keys here are")
        .replace("unknown variant", "unknown choice");
    if s.starts_with("unknown key") && !s.contains("valid keys") {
        format!("{s}; this table takes no further keys")
    } else {
        s
    }
}

/// 1-based line and column of a byte offset.
pub fn line_col(source: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(source.len());
    let before = &source[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}
