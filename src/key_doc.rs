//! One documented case-file key: what `mesorheo keys` renders into `docs/case-reference.md`.
//! The general keys live in `config::reference`, each fluid model's in its own directory.

/// One documented key.
pub struct KeyDoc {
    /// Dotted path; `[]` marks an array of tables.
    pub path: &'static str,
    /// Type and allowed values.
    pub kind: &'static str,
    /// Default, or "required".
    pub default: &'static str,
    /// Meaning.
    pub doc: &'static str,
}

/// A [`KeyDoc`] (a `const fn`, for the tables).
pub const fn key(
    path: &'static str,
    kind: &'static str,
    default: &'static str,
    doc: &'static str,
) -> KeyDoc {
    KeyDoc {
        path,
        kind,
        default,
        doc,
    }
}
