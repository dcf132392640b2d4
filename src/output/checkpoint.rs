//! Checkpoints: the complete state of a run in one HDF5 file, in global-id order, so a run can
//! continue bitwise identically on any rank count (rust-stack.md §4.5).
//!
//! Layout (`format = "mesorheo-checkpoint"`, `format_version = 1`):
//!
//! ```text
//! /                         attributes: format, format_version, code_version, step, rebuild_step,
//!                           time, dt, le_offset, dimension, particles, seed, case (TOML echo),
//!                           checksum (hex)
//! /particles/id             [N]      u64   global ids 0..N−1, sorted
//! /particles/position       [N, D]   f64   as integrated (may be up to skin/2 outside the box
//!                                          between neighbour-list builds)
//! /particles/velocity       [N, D]   f64
//! /particles/force          [N, D]   f64   forces of the step (not recomputed at restart)
//! /particles/velocity_half  [N, D]   f64   integrator scratch v + ½Δt f/m
//! /particles/image          [N, D]   i32   periodic crossings
//! /particles/fields/<name>  [N, w]   f64   every registered fixed-width field, including
//!                                          list_reference_position (list-build positions)
//! /particles/var/<name>/count [N]    u64   every registered variable-length field …
//! /particles/var/<name>/value [ΣN_i] f64   … concatenated in id order
//! /observables/step         [S]      u64   sampled time series (so averages continue)
//! /observables/<name>       [S]      f64
//! /observables/velocity_profile [S, bins]
//! ```
//!
//! No random-number state is stored: the noise is keyed by (seed, step, ids). The checksum
//! combines a hash of every particle's words (order-independent, so any rank count computes the
//! same) with the scalar attributes; a reader recomputes it and refuses a file that differs.
//! The file is written as `NAME.h5.tmp`, flushed to disk and renamed, so a crash during the
//! write leaves the previous checkpoint untouched.

use super::collective_ok;
use super::shared_file::{SharedFile, read_attr, read_attr_str, read_block};
use crate::comm::{Comm, U64Op};
use crate::config::Case;
use crate::diagnostics::Series;
use crate::domain::id_block;
use crate::particles::Particles;
use crate::sim::{LIST_REFERENCE_FIELD, Simulation, hash_words};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Value of the `format` attribute.
pub const FORMAT: &str = "mesorheo-checkpoint";
/// Value of the `format_version` attribute.
pub const FORMAT_VERSION: u64 = 1;

/// Checkpoints this process has started writing (for the fault-injection hook).
static WRITES: AtomicU64 = AtomicU64::new(0);

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

/// Hash of one particle's complete record (the `pack_owned` words).
fn particle_hash<const D: usize>(p: &Particles<D>, i: usize, scratch: &mut Vec<f64>) -> u64 {
    scratch.clear();
    p.pack_owned(i, scratch);
    let words: Vec<u64> = scratch.iter().map(|x| x.to_bits()).collect();
    hash_words(&words)
}

/// Order-independent checksum of the particles of every rank plus the scalar metadata
/// (collective).
fn checksum<const D: usize>(p: &Particles<D>, comm: &dyn Comm, scalars: &[u64]) -> u64 {
    let mut scratch = Vec::new();
    let (mut sum, mut xor) = (0u64, 0u64);
    for i in 0..p.n_owned {
        let h = particle_hash(p, i, &mut scratch);
        sum = sum.wrapping_add(h);
        xor ^= h.rotate_left(29).wrapping_mul(0xD6E8_FEB8_6659_FD93);
    }
    let mut s = [sum];
    let mut x = [xor];
    comm.allreduce_u64(&mut s, U64Op::Sum);
    comm.allreduce_u64(&mut x, U64Op::Xor);
    let mut words = vec![s[0], x[0]];
    words.extend_from_slice(scalars);
    hash_words(&words)
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
    for p in &series.profile {
        words.extend(p.iter().map(|x| x.to_bits()));
    }
    hash_words(&words)
}

/// Writes the checkpoint of the current step into `dir` and keeps the newest `keep`
/// (collective). Returns the path.
pub fn write<const D: usize>(
    sim: &Simulation<'_, D>,
    dir: &Path,
    keep: usize,
) -> Result<PathBuf, String> {
    let comm = sim.comm();
    let (rank, size) = (comm.rank(), comm.size());
    let total = sim.total_particles;
    let mine = super::id_ordered(&sim.checkpoint_particles(), total, comm)?;
    let block = id_block(total, size, rank);
    let case_toml = toml::to_string(&sim.case).map_err(|e| format!("cannot echo the case: {e}"))?;
    let scalars = [
        sim.step,
        sim.rebuild_step(),
        total,
        D as u64,
        FORMAT_VERSION,
        text_hash(&case_toml),
        series_hash(&sim.series),
    ];
    let sum = checksum(&mine, comm, &scalars);
    super::create_dir_collective(dir, comm)?;
    let path = dir.join(file_name(sim.step));
    let tmp = dir.join(format!("{}.tmp", file_name(sim.step)));
    let nth = WRITES.fetch_add(1, Ordering::SeqCst) + 1;
    let mut f = SharedFile::create(&tmp, comm)?;
    let n = total as usize;
    let (start, rows) = (block.start as usize, (block.end - block.start) as usize);
    f.attr_str("/", "format", FORMAT)?;
    f.attr("/", "format_version", &FORMAT_VERSION)?;
    f.attr_str("/", "code_version", env!("CARGO_PKG_VERSION"))?;
    f.attr("/", "step", &sim.step)?;
    f.attr("/", "rebuild_step", &sim.rebuild_step())?;
    f.attr("/", "time", &sim.time())?;
    f.attr("/", "dt", &sim.dt())?;
    f.attr("/", "le_offset", &sim.sim_box.le_offset(sim.step, sim.dt()))?;
    f.attr("/", "dimension", &(D as u64))?;
    f.attr("/", "particles", &total)?;
    f.attr("/", "seed", &sim.case.seed)?;
    f.attr_str("/", "case", &case_toml)?;
    f.attr_str("/", "checksum", &format!("{sum:016x}"))?;
    f.group("particles")?;
    f.group("particles/fields")?;
    f.group("particles/var")?;
    f.dataset::<u64>("particles/id", &[n], false)?;
    f.write("particles/id", &[start], &[rows], &mine.gid)?;
    let vectors: [(&str, &Vec<[f64; D]>); 4] = [
        ("position", &mine.pos),
        ("velocity", &mine.vel),
        ("force", &mine.force),
        ("velocity_half", &mine.vel_half),
    ];
    for (name, data) in vectors {
        let ds = format!("particles/{name}");
        f.dataset::<f64>(&ds, &[n, D], false)?;
        f.write(&ds, &[start, 0], &[rows, D], data.as_flattened())?;
    }
    f.dataset::<i32>("particles/image", &[n, D], false)?;
    f.write(
        "particles/image",
        &[start, 0],
        &[rows, D],
        mine.image.as_flattened(),
    )?;
    if std::env::var("MESORHEO_FAULT").as_deref() == Ok(&format!("abort-in-checkpoint:{nth}")) {
        tracing::error!(
            "fault injection: aborting in the middle of writing {}",
            tmp.display()
        );
        std::process::abort();
    }
    // HDF5 lists group members by name; the registration order (which the digest and the
    // restart's field layout follow) is kept in attributes.
    let order = |names: Vec<&str>| names.join("\n");
    f.attr_str(
        "particles/fields",
        "order",
        &order(mine.extra.iter().map(|x| x.name.as_str()).collect()),
    )?;
    f.attr_str(
        "particles/var",
        "order",
        &order(mine.var.iter().map(|x| x.name.as_str()).collect()),
    )?;
    for field in &mine.extra {
        let ds = format!("particles/fields/{}", field.name);
        f.dataset::<f64>(&ds, &[n, field.width], false)?;
        f.write(&ds, &[start, 0], &[rows, field.width], &field.data)?;
    }
    for field in &mine.var {
        let counts: Vec<u64> = field.data.iter().map(|v| v.len() as u64).collect();
        let my_len: u64 = counts.iter().sum();
        let all = comm.allgather(&[f64::from_bits(my_len)]);
        let lens: Vec<u64> = all.iter().map(|v| v[0].to_bits()).collect();
        let offset: u64 = lens[..rank].iter().sum();
        let grand: u64 = lens.iter().sum();
        let base = format!("particles/var/{}", field.name);
        f.group(&base)?;
        f.dataset::<u64>(&format!("{base}/count"), &[n], false)?;
        f.write(&format!("{base}/count"), &[start], &[rows], &counts)?;
        f.dataset::<f64>(&format!("{base}/value"), &[grand as usize], false)?;
        let flat: Vec<f64> = field.data.concat();
        f.write(
            &format!("{base}/value"),
            &[offset as usize],
            &[flat.len()],
            &flat,
        )?;
    }
    write_series(&mut f, &sim.series, rank == 0)?;
    f.close()?;
    let mut done = Ok(());
    if rank == 0 {
        done = publish(&tmp, &path, sim.step, dir, keep);
    }
    collective_ok(comm, done, "checkpoint")?;
    Ok(path)
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
    Ok(())
}

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
        if name == "step" {
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
    Ok(series)
}

/// A checkpoint as read by one rank.
pub struct Restored<const D: usize> {
    /// The case echoed in the file.
    pub case: Case,
    /// This rank's share of the particles (with all fields; [`LIST_REFERENCE_FIELD`] last).
    pub particles: Particles<D>,
    /// Total particle count.
    pub total: u64,
    /// Step of the checkpoint.
    pub step: u64,
    /// Step of the last neighbour-list build.
    pub rebuild_step: u64,
    /// Sampled series up to the checkpoint.
    pub series: Series,
}

/// The case echoed in a checkpoint, and its dimension (any rank, independent).
pub fn read_case(path: &Path) -> Result<Case, String> {
    let f = open(path)?;
    let text = read_attr_str(&f, "/", "case")?;
    crate::config::parse(
        &text,
        &PathBuf::from(format!("{} (case echo)", path.display())),
    )
    .map_err(|e| e.to_string())
}

/// The `format` attribute of a mesorheo HDF5 file (what kind of checkpoint it is).
pub fn format_of(path: &Path) -> Result<String, String> {
    let f = super::h5_options()
        .open(path)
        .map_err(|e| format!("{}: not a readable HDF5 file ({e})", path.display()))?;
    read_attr_str(&f, "/", "format")
        .map_err(|_| format!("{}: not a mesorheo checkpoint", path.display()))
}

fn open(path: &Path) -> Result<hdf5::File, String> {
    open_as(path, FORMAT, FORMAT_VERSION)
}

/// Opens a mesorheo HDF5 file and checks its `format` and `format_version` attributes.
pub(crate) fn open_as(path: &Path, expected: &str, version: u64) -> Result<hdf5::File, String> {
    let f = super::h5_options()
        .open(path)
        .map_err(|e| format!("{}: not a readable HDF5 file ({e})", path.display()))?;
    let format = read_attr_str(&f, "/", "format")
        .map_err(|_| format!("{}: not a mesorheo checkpoint", path.display()))?;
    if format != expected {
        return Err(format!(
            "{}: format is {format:?}, expected {expected:?}",
            path.display()
        ));
    }
    let found: u64 = read_attr(&f, "/", "format_version")?;
    if found != version {
        return Err(format!(
            "{}: {expected} format version {found}, this mesorheo reads version {version}",
            path.display()
        ));
    }
    Ok(f)
}

/// Reads and verifies a checkpoint (collective; every rank returns the same verdict). Each rank
/// reads one block of ids; [`Simulation::from_checkpoint`] sends the particles to their owners.
pub fn read<const D: usize>(path: &Path, comm: &dyn Comm) -> Result<Restored<D>, String> {
    let local = read_local::<D>(path, comm);
    let (local, scalars) = match local {
        Ok((r, s)) => (Ok(r), s),
        Err(e) => (Err(e), Vec::new()),
    };
    let mut failed = [if local.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut failed);
    let restored = match local {
        Err(e) => return Err(e),
        Ok(_) if failed[0] > 0.0 => {
            return Err(format!("{}: unreadable on another rank", path.display()));
        }
        Ok(r) => r,
    };
    // Checksum (collective); the stored value travels as the last scalar.
    let (stored, scalars) = scalars.split_last().expect("read_local returns 8 scalars");
    let sum = checksum(&restored.particles, comm, scalars);
    if sum != *stored {
        return Err(format!(
            "{}: checksum mismatch (stored {stored:016x}, computed {sum:016x}): the file is corrupt",
            path.display()
        ));
    }
    Ok(restored)
}

fn read_local<const D: usize>(
    path: &Path,
    comm: &dyn Comm,
) -> Result<(Restored<D>, Vec<u64>), String> {
    let f = open(path)?;
    let dim: u64 = read_attr(&f, "/", "dimension")?;
    if dim != D as u64 {
        return Err(format!(
            "{}: the checkpoint is {dim}-dimensional",
            path.display()
        ));
    }
    let total: u64 = read_attr(&f, "/", "particles")?;
    let step: u64 = read_attr(&f, "/", "step")?;
    let rebuild_step: u64 = read_attr(&f, "/", "rebuild_step")?;
    let case_text = read_attr_str(&f, "/", "case")?;
    let stored_checksum = read_attr_str(&f, "/", "checksum")?;
    let case = read_case(path)?;
    let block = id_block(total, comm.size(), comm.rank());
    let (start, rows) = (block.start as usize, (block.end - block.start) as usize);
    let mut p = Particles::<D>::default();
    let ids: Vec<u64> = read_block(&f, "particles/id", &[start], &[rows])?;
    if !ids.iter().copied().eq(block.clone()) {
        return Err(format!(
            "{}: /particles/id is not 0..{total} in order: the file is corrupt",
            path.display()
        ));
    }
    let vec_field = |name: &str| -> Result<Vec<[f64; D]>, String> {
        let flat: Vec<f64> = read_block(&f, &format!("particles/{name}"), &[start, 0], &[rows, D])?;
        Ok(flat
            .chunks_exact(D)
            .map(|c| {
                let mut a = [0.0; D];
                a.copy_from_slice(c);
                a
            })
            .collect())
    };
    p.gid = ids;
    p.pos = vec_field("position")?;
    p.vel = vec_field("velocity")?;
    p.force = vec_field("force")?;
    p.vel_half = vec_field("velocity_half")?;
    let image: Vec<i32> = read_block(&f, "particles/image", &[start, 0], &[rows, D])?;
    p.image = image
        .chunks_exact(D)
        .map(|c| {
            let mut a = [0; D];
            a.copy_from_slice(c);
            a
        })
        .collect();
    p.n_owned = rows;
    // Fields in their registration order (stored as an attribute).
    let names = |group: &str| -> Result<Vec<String>, String> {
        let members = f
            .group(group)
            .and_then(|g| g.member_names())
            .map_err(|e| format!("{}: {group}: {e}", path.display()))?;
        let order = read_attr_str(&f, group, "order")?;
        let listed: Vec<String> = order
            .split('\n')
            .filter(|n| !n.is_empty())
            .map(str::to_owned)
            .collect();
        let (mut a, mut b) = (members.clone(), listed.clone());
        a.sort();
        b.sort();
        if a != b {
            return Err(format!(
                "{}: {group} holds {members:?} but its order attribute lists {listed:?}: the file is corrupt",
                path.display()
            ));
        }
        Ok(listed)
    };
    let fixed = names("particles/fields")?;
    if fixed.last().map(String::as_str) != Some(LIST_REFERENCE_FIELD) {
        return Err(format!(
            "{}: the last field must be {LIST_REFERENCE_FIELD}: the file is corrupt",
            path.display()
        ));
    }
    for name in fixed {
        let ds = format!("particles/fields/{name}");
        let width = f
            .dataset(&ds)
            .map(|d| d.shape().get(1).copied().unwrap_or(0))
            .map_err(|e| format!("{}: {ds}: {e}", path.display()))?;
        if width == 0 {
            return Err(format!("{}: {ds} is not [N, width]", path.display()));
        }
        let k = p.register_extra(&name, width);
        p.extra[k].data = read_block(&f, &ds, &[start, 0], &[rows, width])?;
    }
    for name in names("particles/var")? {
        let base = format!("particles/var/{name}");
        let all_counts: Vec<u64> =
            read_block(&f, &format!("{base}/count"), &[0], &[total as usize])?;
        let offset: u64 = all_counts[..start].iter().sum();
        let counts = &all_counts[start..start + rows];
        let len: u64 = counts.iter().sum();
        let flat: Vec<f64> = read_block(
            &f,
            &format!("{base}/value"),
            &[offset as usize],
            &[len as usize],
        )?;
        let k = p.register_var(&name);
        let mut at = 0usize;
        p.var[k].data = counts
            .iter()
            .map(|&c| {
                let v = flat[at..at + c as usize].to_vec();
                at += c as usize;
                v
            })
            .collect();
    }
    let series = read_series(&f)?;
    let scalars = vec![
        step,
        rebuild_step,
        total,
        D as u64,
        FORMAT_VERSION,
        text_hash(&case_text),
        series_hash(&series),
        u64::from_str_radix(&stored_checksum, 16).map_err(|_| {
            format!(
                "{}: checksum attribute {stored_checksum:?} is not hexadecimal",
                path.display()
            )
        })?,
    ];
    Ok((
        Restored {
            case,
            particles: p,
            total,
            step,
            rebuild_step,
            series,
        },
        scalars,
    ))
}
