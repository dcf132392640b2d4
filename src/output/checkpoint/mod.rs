//! Checkpoints: the complete state of a run in one HDF5 file, in global-id order, so a run can
//! continue bitwise identically on any rank count (docs/architecture.md, "Output, checkpoints,
//! runs"). One format for every scene; what the file holds beside the common part depends on the
//! scene it was written by.
//!
//! Format `"mesorheo-checkpoint"`, `format_version = 2`:
//!
//! ```text
//! /                attributes: format, format_version, scene ("particles" | "homogeneous_flow"),
//!                  code_version, step, time, dt, dimension, particles, seed, case (TOML echo),
//!                  checksum (hex), and the scene's own (below)
//! /observables/step   [S]  u64   sampled time series (so averages continue)
//! /observables/<name> [S]  f64
//! ```
//!
//! - `scene = "particles"` ([`particles`]): `/particles/…` (ids, positions, velocities, forces,
//!   integrator scratch, image counts, every checkpointed field of every model, the variable-
//!   length fields such as dumbbell ensembles) and the attributes `rebuild_step`, `le_offset`.
//! - `scene = "homogeneous_flow"` ([`ensembles`]): `/ensembles/…` (every particle's dumbbell
//!   connectors in their storage precision, control copies, per-particle running sums) and the
//!   attributes `per_particle`, `precision`.
//!
//! Version 1 files (`"mesorheo-checkpoint"` for particle scenes, `"mesorheo-flow-checkpoint"`
//! for homogeneous-flow scenes: the same layouts without the `scene` attribute) are read too,
//! and restart bitwise like version 2 files (tested on files written by the version-1 code, in
//! `tests/data/format_v1`). Any other version is refused with a message naming it.
//!
//! No random-number state is stored: the noise is keyed by (seed, step, ids). The checksum
//! combines an order-independent hash of every particle's words with the scalar attributes; a
//! reader recomputes it and refuses a file that differs. The file is written as `NAME.h5.tmp`,
//! flushed to disk and renamed, so a crash during the write leaves the previous checkpoint
//! untouched.

pub mod ensembles;
pub mod particles;

use super::shared_file::{SharedFile, read_attr, read_attr_str, read_block};
use crate::diagnostics::Series;
use crate::sim::hash_words;
use std::path::{Path, PathBuf};

pub use particles::{Restored, read_case};
// Generic over D: other crates read and write through `crate::facade::Engine` (compiled here once).
pub(crate) use particles::{read, write};

/// Value of the `format` attribute.
pub const FORMAT: &str = "mesorheo-checkpoint";
/// Value of the `format_version` attribute this code writes.
pub const FORMAT_VERSION: u64 = 2;
/// The `format` of version-1 checkpoints of homogeneous-flow scenes.
pub const FLOW_FORMAT_V1: &str = "mesorheo-flow-checkpoint";

/// The kind of scene a checkpoint continues.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneKind {
    /// Particles with positions, velocities and model fields.
    Particles,
    /// Dumbbell ensembles in an imposed homogeneous flow.
    HomogeneousFlow,
}

impl SceneKind {
    /// The value of the `scene` attribute.
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Particles => "particles",
            SceneKind::HomogeneousFlow => "homogeneous_flow",
        }
    }
}

/// Why a checkpoint cannot be used. A restart falls back to the previous checkpoint in every
/// case; a [`CheckpointError::Damaged`] file (one of ours: its `format` attribute, or its name
/// `checkpoint_<step>.h5`, says mesorheo wrote it) is also renamed `NAME.h5.corrupt`, so no
/// later restart picks it again, while an [`CheckpointError::Incompatible`] one (another
/// format, version, scene or dimension: a good file of another kind) and a
/// [`CheckpointError::NotACheckpoint`] (a file mesorheo did not write, such as a case file) are
/// never touched.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckpointError {
    /// Truncated, not HDF5, a dataset missing or of the wrong shape, a checksum mismatch.
    #[error("{path}: {reason}: the file is corrupt")]
    Damaged {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A readable file this run cannot continue from.
    #[error("{path}: {reason}")]
    Incompatible {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// Read on this rank, but another rank could not.
    #[error("{0}: unreadable on another rank")]
    OtherRank(String),
    /// A file mesorheo did not write (not HDF5, or HDF5 that cannot be opened, under a name
    /// that is not a checkpoint's): refused and left exactly as it is.
    #[error("{path}: not a mesorheo checkpoint: {reason}")]
    NotACheckpoint {
        /// The file.
        path: String,
        /// What it is, and what to do instead.
        reason: String,
    },
}

impl CheckpointError {
    /// A damaged file.
    pub fn damaged(path: &Path, reason: impl Into<String>) -> Self {
        Self::Damaged {
            path: path.display().to_string(),
            reason: reason.into(),
        }
    }

    /// A good file of another kind.
    pub fn incompatible(path: &Path, reason: impl Into<String>) -> Self {
        Self::Incompatible {
            path: path.display().to_string(),
            reason: reason.into(),
        }
    }

    /// Whether the file itself is damaged (and should be set aside).
    pub fn is_damaged(&self) -> bool {
        matches!(self, Self::Damaged { .. })
    }

    /// Whether the file is not a checkpoint at all.
    pub fn is_not_a_checkpoint(&self) -> bool {
        matches!(self, Self::NotACheckpoint { .. })
    }

    /// A file that is not a checkpoint, with a hint of what to do with it.
    fn not_a_checkpoint(path: &Path, what: &str) -> Self {
        let hint = if path.extension().is_some_and(|e| e == "toml") {
            format!(
                "it looks like a case file: start it with `mesorheo run {0}` (or `./run case \
                 {0}`); `restart` takes a checkpoint OUT/checkpoints/checkpoint_<step>.h5 or \
                 the directory OUT/checkpoints of an earlier run",
                path.display()
            )
        } else {
            "`restart` takes a checkpoint OUT/checkpoints/checkpoint_<step>.h5 written by \
             `mesorheo run`, or the directory OUT/checkpoints"
                .to_owned()
        };
        Self::NotACheckpoint {
            path: path.display().to_string(),
            reason: format!("{what}; the file is left as it is; {hint}"),
        }
    }
}

/// The HDF5 format signature, at offset 0 or at a user block's end (512, 1024, 2048, …).
const HDF5_SIGNATURE: [u8; 8] = *b"\x89HDF\r\n\x1a\n";

/// Whether `path` carries the HDF5 signature (reads at most a few 8-byte words).
pub fn has_hdf5_signature(path: &Path) -> bool {
    use std::io::{Read, Seek, SeekFrom};
    let Ok(mut f) = std::fs::File::open(path) else {
        return false;
    };
    let len = f.metadata().map_or(0, |m| m.len());
    let mut offset = 0u64;
    while offset + 8 <= len {
        let mut word = [0u8; 8];
        if f.seek(SeekFrom::Start(offset)).is_err() || f.read_exact(&mut word).is_err() {
            return false;
        }
        if word == HDF5_SIGNATURE {
            return true;
        }
        offset = if offset == 0 { 512 } else { offset * 2 };
    }
    false
}

/// Whether the file name is one mesorheo gives its checkpoints ([`file_name`]).
pub fn named_like_a_checkpoint(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_prefix("checkpoint_"))
        .and_then(|n| n.strip_suffix(".h5"))
        .is_some_and(|d| d.len() == 12 && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Refuses, without opening it as HDF5, a file that neither carries the HDF5 signature nor a
/// checkpoint's name (a case file passed to `restart` by mistake).
pub fn identify(path: &Path) -> Result<(), CheckpointError> {
    if path.is_file() && !has_hdf5_signature(path) && !named_like_a_checkpoint(path) {
        return Err(CheckpointError::not_a_checkpoint(path, "not an HDF5 file"));
    }
    Ok(())
}

/// An open checkpoint whose format and version this code reads.
pub(crate) struct Opened {
    pub file: hdf5::File,
    pub scene: SceneKind,
    pub version: u64,
}

/// Opens `path` and identifies it: format, version, scene.
pub(crate) fn open(path: &Path) -> Result<Opened, CheckpointError> {
    identify(path)?;
    let file = super::h5_options().open(path).map_err(|e| {
        // Ours only if named like ours: an unreadable file of anyone else is not touched.
        if named_like_a_checkpoint(path) {
            CheckpointError::damaged(path, format!("not a readable HDF5 file ({e})"))
        } else {
            CheckpointError::not_a_checkpoint(
                path,
                &format!("an HDF5 file that cannot be read ({e})"),
            )
        }
    })?;
    let format = read_attr_str(&file, "/", "format").map_err(|_| {
        CheckpointError::incompatible(path, "not a mesorheo checkpoint (no `format` attribute)")
    })?;
    let version: u64 =
        read_attr(&file, "/", "format_version").map_err(|e| CheckpointError::damaged(path, e))?;
    let scene = match (format.as_str(), version) {
        (FORMAT, 1) => SceneKind::Particles,
        (FLOW_FORMAT_V1, 1) => SceneKind::HomogeneousFlow,
        (FORMAT, FORMAT_VERSION) => {
            let scene = read_attr_str(&file, "/", "scene")
                .map_err(|e| CheckpointError::damaged(path, e))?;
            match scene.as_str() {
                "particles" => SceneKind::Particles,
                "homogeneous_flow" => SceneKind::HomogeneousFlow,
                other => {
                    return Err(CheckpointError::incompatible(
                        path,
                        format!("unknown scene {other:?}"),
                    ));
                }
            }
        }
        (FORMAT | FLOW_FORMAT_V1, v) => {
            return Err(CheckpointError::incompatible(
                path,
                format!(
                    "{format} format version {v}; this mesorheo ({}) reads versions 1 and \
                     {FORMAT_VERSION}",
                    env!("CARGO_PKG_VERSION")
                ),
            ));
        }
        (other, _) => {
            return Err(CheckpointError::incompatible(
                path,
                format!("format is {other:?}, not a mesorheo checkpoint"),
            ));
        }
    };
    Ok(Opened {
        file,
        scene,
        version,
    })
}

/// Opens `path` as a checkpoint of `scene` (a readable file of another scene, or of another
/// dimension when `dimension` is given, is incompatible) and returns it with its case echo's
/// text and the name to report the echo's errors under.
pub(crate) fn open_scene(
    path: &Path,
    scene: SceneKind,
    dimension: Option<usize>,
) -> Result<(Opened, String, PathBuf), CheckpointError> {
    let opened = open(path)?;
    if opened.scene != scene {
        return Err(CheckpointError::incompatible(
            path,
            format!("a checkpoint of a {} scene", opened.scene.name()),
        ));
    }
    if let Some(d) = dimension {
        let found: u64 = read_attr(&opened.file, "/", "dimension")
            .map_err(|e| CheckpointError::damaged(path, e))?;
        if found != d as u64 {
            return Err(CheckpointError::incompatible(
                path,
                format!("the checkpoint is {found}-dimensional"),
            ));
        }
    }
    let text =
        read_attr_str(&opened.file, "/", "case").map_err(|e| CheckpointError::damaged(path, e))?;
    let echo = PathBuf::from(format!("{} (case echo)", path.display()));
    Ok((opened, text, echo))
}

/// The scene a checkpoint continues (any rank, independent).
pub fn scene_of(path: &Path) -> Result<SceneKind, CheckpointError> {
    open(path).map(|o| o.scene)
}

/// The attributes every checkpoint carries.
pub(crate) struct Common {
    pub scene: SceneKind,
    pub step: u64,
    pub time: f64,
    pub dt: f64,
    pub dimension: usize,
    pub particles: u64,
    pub seed: u64,
}

impl Common {
    /// Writes them (with the format, its version and the code version) to the root group.
    pub fn write(&self, f: &mut SharedFile) -> Result<(), String> {
        f.attr_str("/", "format", FORMAT)?;
        f.attr("/", "format_version", &FORMAT_VERSION)?;
        f.attr_str("/", "scene", self.scene.name())?;
        f.attr_str("/", "code_version", env!("CARGO_PKG_VERSION"))?;
        f.attr("/", "step", &self.step)?;
        f.attr("/", "time", &self.time)?;
        f.attr("/", "dt", &self.dt)?;
        f.attr("/", "dimension", &(self.dimension as u64))?;
        f.attr("/", "particles", &self.particles)?;
        f.attr("/", "seed", &self.seed)
    }
}

/// File name of the checkpoint of `step`.
pub fn file_name(step: u64) -> String {
    format!("checkpoint_{step:012}.h5")
}

/// Checkpoints in `dir`, newest (highest step) first.
pub fn list(dir: &Path) -> Vec<(u64, PathBuf)> {
    let mut found: Vec<(u64, PathBuf)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let step = name
                .strip_prefix("checkpoint_")?
                .strip_suffix(".h5")?
                .parse()
                .ok()?;
            Some((step, e.path()))
        })
        .collect();
    found.sort_by_key(|f| std::cmp::Reverse(f.0));
    found
}

/// Hash of a text (the case echo).
pub(crate) fn text_hash(text: &str) -> u64 {
    let words: Vec<u64> = text
        .as_bytes()
        .chunks(8)
        .map(|c| {
            let mut b = [0u8; 8];
            b[..c.len()].copy_from_slice(c);
            u64::from_le_bytes(b)
        })
        .collect();
    hash_words(&words) ^ text.len() as u64
}

/// Hash of the sampled series (steps, every scalar series in name order, the profiles).
pub(crate) fn series_hash(series: &Series) -> u64 {
    let mut words: Vec<u64> = series.steps.clone();
    for (name, values) in &series.scalars {
        words.push(text_hash(name));
        words.extend(values.iter().map(|x| x.to_bits()));
    }
    for c in series.green_kubo.iter().chain(&series.transverse_current) {
        let (reals, counts) = c.state();
        words.extend(reals.iter().map(|x| x.to_bits()));
        words.extend(counts);
    }
    for p in &series.profile {
        words.extend(p.iter().map(|x| x.to_bits()));
    }
    hash_words(&words)
}

/// fsync, atomic rename, fsync of the directory, then removal of all but the newest `keep`.
pub(crate) fn publish(
    tmp: &Path,
    path: &Path,
    this: u64,
    dir: &Path,
    keep: usize,
) -> Result<(), String> {
    let sync = |p: &Path| -> std::io::Result<()> { std::fs::File::open(p)?.sync_all() };
    sync(tmp).map_err(|e| format!("cannot flush {}: {e}", tmp.display()))?;
    std::fs::rename(tmp, path)
        .map_err(|e| format!("cannot rename {} to {}: {e}", tmp.display(), path.display()))?;
    // Durability of the rename; some file systems refuse to sync a directory (not fatal).
    let _ = sync(dir);
    // Keep the newest `keep` up to this step; never the one just written, never a later one.
    let older: Vec<(u64, PathBuf)> = list(dir).into_iter().filter(|(s, _)| *s < this).collect();
    for (_, old) in older.into_iter().skip(keep.max(1) - 1) {
        if let Err(e) = std::fs::remove_file(&old) {
            tracing::warn!("cannot remove old checkpoint {}: {e}", old.display());
        }
    }
    // Temporary files left by an interrupted write of an earlier checkpoint.
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if let Some(stem) = name.strip_suffix(".tmp")
            && let Some(step) = stem
                .strip_prefix("checkpoint_")
                .and_then(|n| n.strip_suffix(".h5"))
                .and_then(|n| n.parse::<u64>().ok())
            && step < this
        {
            let _ = std::fs::remove_file(entry.path());
        }
    }
    Ok(())
}

/// Writes the sampled series under `/observables` (rank 0's copy; every rank has the same).
pub(crate) fn write_series(f: &mut SharedFile, series: &Series, root: bool) -> Result<(), String> {
    let s = series.steps.len();
    let rows = if root { s } else { 0 };
    f.group("observables")?;
    f.dataset::<u64>("observables/step", &[s], false)?;
    f.write("observables/step", &[0], &[rows], &series.steps[..rows])?;
    for (name, values) in &series.scalars {
        if values.len() != s {
            return Err(format!(
                "observable {name} has {} samples, expected {s}",
                values.len()
            ));
        }
        let ds = format!("observables/{name}");
        f.dataset::<f64>(&ds, &[s], false)?;
        f.write(&ds, &[0], &[rows], &values[..rows])?;
    }
    if let Some(first) = series.profile.first() {
        let bins = first.len();
        let flat: Vec<f64> = series.profile.concat();
        f.dataset::<f64>("observables/velocity_profile", &[s, bins], false)?;
        let data = if root { &flat[..] } else { &flat[..0] };
        f.write("observables/velocity_profile", &[0, 0], &[rows, bins], data)?;
    }
    write_correlators(f, GREEN_KUBO, &series.green_kubo, root)?;
    write_correlators(f, TRANSVERSE_CURRENT, &series.transverse_current, root)?;
    Ok(())
}

/// Prefixes of the correlator sets' datasets: `observables/{prefix}_reals` and `_counts`, one
/// row per correlator ([`crate::correlator::MultipleTauCorrelator::state`]; every correlator of
/// a set has the same shape).
const GREEN_KUBO: &str = "green_kubo";
const TRANSVERSE_CURRENT: &str = "transverse_current";

/// Writes one set of correlators (nothing for an empty set).
fn write_correlators(
    f: &mut SharedFile,
    prefix: &str,
    set: &[crate::correlator::MultipleTauCorrelator],
    root: bool,
) -> Result<(), String> {
    let Some(first) = set.first() else {
        return Ok(());
    };
    let n = set.len();
    let (reals, counts) = first.state();
    let (nr, nc) = (reals.len(), counts.len());
    let (mut all_reals, mut all_counts) = (Vec::new(), Vec::new());
    for c in set {
        let (r, k) = c.state();
        all_reals.extend(r);
        all_counts.extend(k);
    }
    let rows = if root { n } else { 0 };
    let (reals_ds, counts_ds) = (
        format!("observables/{prefix}_reals"),
        format!("observables/{prefix}_counts"),
    );
    f.dataset::<f64>(&reals_ds, &[n, nr], false)?;
    f.write(&reals_ds, &[0, 0], &[rows, nr], &all_reals[..rows * nr])?;
    f.dataset::<u64>(&counts_ds, &[n, nc], false)?;
    f.write(&counts_ds, &[0, 0], &[rows, nc], &all_counts[..rows * nc])?;
    Ok(())
}

/// Reads one set of correlators (empty when the file has none).
fn read_correlators(
    f: &hdf5::File,
    prefix: &str,
) -> Result<Vec<crate::correlator::MultipleTauCorrelator>, String> {
    let (reals_ds, counts_ds) = (
        format!("observables/{prefix}_reals"),
        format!("observables/{prefix}_counts"),
    );
    if f.dataset(&reals_ds).is_err() {
        return Ok(Vec::new());
    }
    let len = |name: &str| -> Result<Vec<usize>, String> {
        f.dataset(name)
            .map(|d| d.shape())
            .map_err(|e| format!("{}: {name}: {e}", f.filename()))
    };
    let shape = len(&reals_ds)?;
    let count_shape = len(&counts_ds)?;
    if shape.len() != 2 || count_shape.len() != 2 || shape[0] != count_shape[0] {
        return Err(format!(
            "{}: the {prefix} correlators have the shapes {shape:?} and {count_shape:?}",
            f.filename()
        ));
    }
    let reals: Vec<f64> = read_block(f, &reals_ds, &[0, 0], &shape)?;
    let counts: Vec<u64> = read_block(f, &counts_ds, &[0, 0], &count_shape)?;
    (0..shape[0])
        .map(|b| {
            crate::correlator::MultipleTauCorrelator::from_state(
                &reals[b * shape[1]..(b + 1) * shape[1]],
                &counts[b * count_shape[1]..(b + 1) * count_shape[1]],
            )
            .ok_or_else(|| format!("{}: {prefix} correlator {b} is inconsistent", f.filename()))
        })
        .collect()
}

/// Reads the sampled series from `/observables`.
pub(crate) fn read_series(f: &hdf5::File) -> Result<Series, String> {
    let mut series = Series::default();
    let group = f
        .group("observables")
        .map_err(|e| format!("{}: no /observables: {e}", f.filename()))?;
    let names = group
        .member_names()
        .map_err(|e| format!("{}: /observables: {e}", f.filename()))?;
    let len = |name: &str| -> Result<Vec<usize>, String> {
        f.dataset(name)
            .map(|d| d.shape())
            .map_err(|e| format!("{}: {name}: {e}", f.filename()))
    };
    let s = *len("observables/step")?
        .first()
        .ok_or_else(|| format!("{}: /observables/step is not 1-D", f.filename()))?;
    series.steps = read_block(f, "observables/step", &[0], &[s])?;
    for name in names {
        if name == "step" || name.starts_with(GREEN_KUBO) || name.starts_with(TRANSVERSE_CURRENT) {
            continue;
        }
        let ds = format!("observables/{name}");
        if name == "velocity_profile" {
            let shape = len(&ds)?;
            if shape.len() != 2 {
                return Err(format!("{}: {ds} is not [samples, bins]", f.filename()));
            }
            let flat: Vec<f64> = read_block(f, &ds, &[0, 0], &shape)?;
            series.profile = flat.chunks(shape[1].max(1)).map(<[f64]>::to_vec).collect();
        } else {
            series
                .scalars
                .insert(name.clone(), read_block(f, &ds, &[0], &[s])?);
        }
    }
    series.green_kubo = read_correlators(f, GREEN_KUBO)?;
    series.transverse_current = read_correlators(f, TRANSVERSE_CURRENT)?;
    Ok(series)
}

/// The checksum of a file: the particles' hashes (`hashes`, this rank's) combined in an
/// order-independent way — a wrapping sum and an xor of rotated products, reduced over the
/// ranks, so every decomposition gives the same — then hashed with the scalar metadata
/// (collective).
pub(crate) fn combine_checksum(
    hashes: impl Iterator<Item = u64>,
    comm: &dyn crate::comm::Comm,
    scalars: &[u64],
) -> u64 {
    let (mut sum, mut xor) = (0u64, 0u64);
    for h in hashes {
        sum = sum.wrapping_add(h);
        xor ^= h.rotate_left(29).wrapping_mul(0xD6E8_FEB8_6659_FD93);
    }
    let mut s = [sum];
    let mut x = [xor];
    comm.allreduce_u64(&mut s, crate::comm::U64Op::Sum);
    comm.allreduce_u64(&mut x, crate::comm::U64Op::Xor);
    let mut words = vec![s[0], x[0]];
    words.extend_from_slice(scalars);
    hash_words(&words)
}

/// The same verdict on every rank (collective): this rank's error, or
/// [`CheckpointError::OtherRank`] if only another rank failed.
pub(crate) fn agree<T>(
    local: Result<T, CheckpointError>,
    path: &Path,
    comm: &dyn crate::comm::Comm,
) -> Result<T, CheckpointError> {
    let mut failed = [if local.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut failed);
    match local {
        Err(e) => Err(e),
        Ok(_) if failed[0] > 0.0 => Err(CheckpointError::OtherRank(path.display().to_string())),
        Ok(r) => Ok(r),
    }
}
