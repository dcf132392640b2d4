//! Corpus of malformed case files: every file in `tests/bad_cases/` must be rejected by
//! `mesorheo::config::load_scene` (either kind of scene) with an error that
//! - contains every `# expect: <substring>` line of the file,
//! - reports the line given by the file's `# at: <line>` header,
//! - reports the column of the offending token on that line: by default the value after the
//!   line's `=` (or column 1 on a line without one: a table header that lacks a key); a
//!   `# token: <text>` header names the token instead (its last occurrence on the line: an
//!   array element, a duplicate), `# col: <n>` gives the column outright (a syntax error at the
//!   end of a line);
//! - names the file;
//!
//! and the corpus holds exactly `CORPUS_SIZE` files, the count the README states.
//!
//! All failures are collected and reported together.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Files in the corpus (the README's count: update both when adding one).
const CORPUS_SIZE: usize = 212;

/// Expectations read from a bad case's header comments.
struct Expectation {
    substrings: Vec<String>,
    lines: Vec<usize>,
    /// The offending token, when it is not the line's value.
    token: Option<String>,
    /// The column, when no token names it.
    column: Option<usize>,
}

impl Expectation {
    /// 1-based column (in characters) the error must point at on `text`, the `# at:` line.
    fn column(&self, text: &str) -> usize {
        let chars_before = |byte: usize| text[..byte].chars().count() + 1;
        if let Some(c) = self.column {
            return c;
        }
        if let Some(token) = &self.token {
            return text.rfind(token.as_str()).map_or(0, chars_before);
        }
        match text.find('=') {
            Some(eq) => {
                let rest = &text[eq + 1..];
                chars_before(eq + 1 + (rest.len() - rest.trim_start().len()))
            }
            None => 1,
        }
    }
}

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("bad_cases")
}

fn corpus() -> Vec<PathBuf> {
    let dir = corpus_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .map(|entry| entry.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

/// Parses `# expect:` and `# at:` comment lines; errors describe a malformed header.
fn expectation(source: &str) -> Result<Expectation, String> {
    let mut substrings = Vec::new();
    let mut lines = Vec::new();
    let (mut token, mut column) = (None, None);
    for line in source.lines() {
        let Some(comment) = line.trim_start().strip_prefix('#') else {
            continue;
        };
        let comment = comment.trim_start();
        if let Some(s) = comment.strip_prefix("expect:") {
            let s = s.trim();
            if s.is_empty() {
                return Err("empty `# expect:` line".into());
            }
            substrings.push(s.to_owned());
        } else if let Some(s) = comment.strip_prefix("at:") {
            let n = s
                .trim()
                .parse::<usize>()
                .map_err(|e| format!("`# at:` line is not a line number ({:?}: {e})", s.trim()))?;
            lines.push(n);
        } else if let Some(s) = comment.strip_prefix("token:") {
            token = Some(s.trim().to_owned());
        } else if let Some(s) = comment.strip_prefix("col:") {
            let n = s
                .trim()
                .parse::<usize>()
                .map_err(|e| format!("`# col:` line is not a column ({:?}: {e})", s.trim()))?;
            column = Some(n);
        }
    }
    if substrings.is_empty() {
        return Err("no `# expect:` line".into());
    }
    match lines.len() {
        0 => Err("no `# at:` line".into()),
        1 => Ok(Expectation {
            substrings,
            lines,
            token,
            column,
        }),
        n => Err(format!("{n} `# at:` lines; give exactly one")),
    }
}

/// Checks one file; returns a description of every mismatch.
fn check(path: &Path) -> Vec<String> {
    let mut problems = Vec::new();
    let source = match std::fs::read_to_string(path) {
        Ok(s) => s,
        Err(e) => return vec![format!("cannot read the file: {e}")],
    };
    let exp = match expectation(&source) {
        Ok(exp) => exp,
        Err(e) => return vec![format!("malformed header: {e}")],
    };
    let expected_line = exp.lines[0];
    let result = std::panic::catch_unwind(|| mesorheo::config::load_scene(path, &[]));
    let err = match result {
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("(non-string payload)");
            return vec![format!("load panicked: {msg}")];
        }
        Ok(Ok(_)) => {
            return vec![format!(
                "accepted as valid; expected an error at line {expected_line} containing {:?}",
                exp.substrings
            )];
        }
        Ok(Err(err)) => err,
    };
    let shown = err.to_string();
    for s in &exp.substrings {
        if !shown.contains(s.as_str()) {
            problems.push(format!("message lacks {s:?}"));
        }
    }
    if err.line != expected_line {
        problems.push(format!("line {} instead of {expected_line}", err.line));
    } else {
        let text = source
            .lines()
            .nth(expected_line.wrapping_sub(1))
            .unwrap_or("");
        let expected_column = exp.column(text);
        if err.column != expected_column {
            problems.push(format!(
                "column {} instead of {expected_column} (on {text:?})",
                err.column
            ));
        }
    }
    let name = path.file_name().unwrap().to_string_lossy();
    if !shown.contains(name.as_ref()) {
        problems.push(format!("message does not name the file {name:?}"));
    }
    if !problems.is_empty() {
        problems.push(format!("actual error: {shown}"));
    }
    problems
}

#[test]
fn every_bad_case_is_rejected_with_a_located_helpful_error() {
    let files = corpus();
    assert!(
        files.len() == CORPUS_SIZE,
        "tests/bad_cases holds {} case files, not {CORPUS_SIZE}: update CORPUS_SIZE and the \
         README's count",
        files.len()
    );
    let mut report = String::new();
    let mut failing = 0;
    for path in &files {
        let problems = check(path);
        if problems.is_empty() {
            continue;
        }
        failing += 1;
        let name = path.file_name().unwrap().to_string_lossy();
        let _ = writeln!(report, "{name}:");
        for p in problems {
            let _ = writeln!(report, "    {p}");
        }
    }
    assert!(
        failing == 0,
        "{failing} of {} bad cases failed:\n{report}",
        files.len()
    );
}

#[test]
fn expectation_headers_are_parsed() {
    let exp = expectation("# expect: a\n#expect: b\n# at: 7\nx = 1\n").unwrap();
    assert_eq!(exp.substrings, ["a", "b"]);
    assert_eq!(exp.lines, [7]);
    assert!(expectation("# at: 3\n").is_err());
    assert!(expectation("# expect: a\n").is_err());
    assert!(expectation("# expect: a\n# at: x\n").is_err());
    assert!(expectation("# expect: a\n# at: 1\n# at: 2\n").is_err());
    // Columns: the value, a named token's last occurrence, a header line, an explicit one.
    let exp = expectation("# expect: a\n# at: 1\n").unwrap();
    assert_eq!(exp.column("lengths = [8.0, 1.0]"), 11);
    assert_eq!(exp.column("  a =   2"), 9);
    assert_eq!(exp.column("[fluid]"), 1);
    let exp = expectation("# expect: a\n# at: 1\n# token: \"t\"\n").unwrap();
    assert_eq!(exp.column("o = [\"t\", \"t\"]"), 11);
    let exp = expectation("# expect: a\n# at: 1\n# col: 18\n").unwrap();
    assert_eq!(exp.column("lattice = \"random"), 18);
}

/// An error in a `--set` override is pointed at the override, and an error in the file at its
/// line in the file on disk, even when an override added a key above it (which shifts the lines
/// of the edited text). Fails if the location is taken from the edited text again (mutation:
/// `locate_override` returning its argument unchanged: "(with --set overrides):39:13" and a
/// `dt` line one below the file's).
#[test]
fn an_error_from_a_set_override_points_at_the_override_and_a_file_error_at_the_file() {
    let stock = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/default.toml");
    let err = mesorheo::config::load_scene(&stock, &["fluid.viscosity=-1".to_owned()])
        .expect_err("a negative viscosity is refused");
    let shown = err.to_string();
    assert!(
        shown.starts_with(&format!(
            "{} (--set fluid.viscosity=-1): `fluid.viscosity`",
            stock.display()
        )),
        "{shown}"
    );

    // An invalid time step in the file, below [fluid], and an override that adds a key to
    // [fluid]: the error names the file's own line of `dt`.
    let text = std::fs::read_to_string(&stock).expect("stock case");
    let text = text.replacen("dt = 3.0e-3", "dt = -3.0e-3", 1);
    let line = 1 + text
        .lines()
        .position(|l| l.starts_with("dt = -3"))
        .expect("dt line");
    let dir = tempfile::tempdir().expect("temp dir");
    let case = dir.path().join("bad_dt.toml");
    std::fs::write(&case, &text).expect("write case");
    let err = mesorheo::config::load_scene(&case, &["fluid.xsph=0.0".to_owned()])
        .expect_err("a negative time step is refused");
    assert_eq!(
        (err.file.as_str(), err.line, err.key.as_str()),
        (case.to_str().expect("utf-8"), line, "integrator.dt"),
        "{err}"
    );
}
