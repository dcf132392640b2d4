//! Checkpoints of particle scenes (`scene = "particles"`).
//!
//! ```text
//! /                         attributes (beside the common ones): rebuild_step, le_offset
//!                           rigid_bodies (JSON of exact words, when the scene has bodies)
//! /particles/id             [N]      u64   global ids 0..N−1, sorted
//! /particles/position       [N, D]   f64   as integrated (may be up to skin/2 outside the box
//!                                          between neighbour-list builds)
//! /particles/velocity       [N, D]   f64
//! /particles/force          [N, D]   f64   forces of the step (not recomputed at restart)
//! /particles/velocity_half  [N, D]   f64   integrator scratch v + ½Δt f/m
//! /particles/image          [N, D]   i32   periodic crossings
//! /particles/fields/<name>  [N, w]   f64   every checkpointed fixed-width field, then
//!                                          list_reference_position (list-build positions)
//! /particles/var/<name>/count [N]    u64   every variable-length field (an ensemble) …
//! /particles/var/<name>/value [ΣN_i] f64   … concatenated in id order (attribute precision =
//!                                          "single": f32; "words": u64, a BDDFS histogram)
//! /observables/velocity_profile [S, bins]
//! ```
//!
//! Fields derived anew every step (a summation density) are not written.

use super::{
    CheckpointError, Common, SceneKind, agree, file_name, open_scene, publish, read_series,
    series_hash, text_hash, write_series,
};
use crate::comm::Comm;
use crate::config::Case;
use crate::diagnostics::Series;
use crate::domain::id_block;
use crate::output::collective_ok;
use crate::output::shared_file::{SharedFile, read_attr, read_attr_str, read_block};
use crate::particles::{Particles, VarData};
use crate::sim::{LIST_REFERENCE_FIELD, Simulation, hash_words};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Checkpoints this process has started writing (for the fault-injection hook).
static WRITES: AtomicU64 = AtomicU64::new(0);

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
    let hashes = (0..p.n_owned).map(|i| particle_hash(p, i, &mut scratch));
    super::combine_checksum(hashes, comm, scalars)
}

/// Writes the checkpoint of the current step into `dir` and keeps the newest `keep`
/// (collective). Returns the path.
pub(crate) fn write<const D: usize>(
    sim: &mut Simulation<'_, D>,
    dir: &Path,
    keep: usize,
) -> Result<PathBuf, String> {
    let total = sim.total_particles;
    // The ensembles are lent, not copied: only the id-ordered copy exists beside them.
    let lent = sim.lend_checkpoint_particles();
    let mine = crate::output::id_ordered(&lent, total, sim.comm());
    sim.return_checkpoint_particles(lent);
    let mine = mine?;
    let sim = &*sim;
    let comm = sim.comm();
    let (rank, size) = (comm.rank(), comm.size());
    let block = id_block(total, size, rank);
    let case_toml = toml::to_string(&sim.case).map_err(|e| format!("cannot echo the case: {e}"))?;
    // A several-species scene also stores its species table (JSON), in the checksum too.
    let species_table = match &mine.species {
        Some(_) => {
            Some(serde_json::to_string(sim.species()).map_err(|e| format!("species table: {e}"))?)
        }
        None => None,
    };
    let mut scalars = vec![
        sim.step,
        sim.rebuild_step(),
        total,
        D as u64,
        super::FORMAT_VERSION,
        text_hash(&case_toml),
        series_hash(&sim.series),
    ];
    scalars.extend(species_table.as_deref().map(text_hash));
    let rigid_bodies = sim.rigid_bodies().map(|b| b.to_json());
    scalars.extend(rigid_bodies.as_deref().map(text_hash));
    let sum = checksum(&mine, comm, &scalars);
    crate::output::create_dir_collective(dir, comm)?;
    let path = dir.join(file_name(sim.step));
    let tmp = dir.join(format!("{}.tmp", file_name(sim.step)));
    let nth = WRITES.fetch_add(1, Ordering::SeqCst) + 1;
    let mut f = SharedFile::create(&tmp, comm)?;
    let n = total as usize;
    let (start, rows) = (block.start as usize, (block.end - block.start) as usize);
    let common = Common {
        scene: SceneKind::Particles,
        step: sim.step,
        time: sim.time(),
        dt: sim.dt(),
        dimension: D,
        particles: total,
        seed: sim.case.seed,
    };
    common.write(&mut f)?;
    f.attr("/", "rebuild_step", &sim.rebuild_step())?;
    f.attr("/", "le_offset", &sim.sim_box.le_offset(sim.step, sim.dt()))?;
    f.attr_str("/", "case", &case_toml)?;
    f.attr_str("/", "checksum", &format!("{sum:016x}"))?;
    if let Some(table) = &rigid_bodies {
        f.attr_str("/", "rigid_bodies", table)?;
    }
    f.group("particles")?;
    f.group("particles/fields")?;
    f.group("particles/var")?;
    f.dataset::<u64>("particles/id", &[n], false)?;
    f.write("particles/id", &[start], &[rows], &mine.gid)?;
    if let (Some(table), Some(species)) = (&species_table, &mine.species) {
        f.attr_str("/", "species_table", table)?;
        let words: Vec<u64> = species.iter().map(|&s| u64::from(s)).collect();
        f.dataset::<u64>("particles/species", &[n], false)?;
        f.write("particles/species", &[start], &[rows], &words)?;
    }
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
        let counts: Vec<u64> = (0..field.data.len())
            .map(|i| field.data.row_len(i) as u64)
            .collect();
        let my_len: u64 = counts.iter().sum();
        let all = comm.allgather(&[f64::from_bits(my_len)]);
        let lens: Vec<u64> = all.iter().map(|v| v[0].to_bits()).collect();
        let offset: u64 = lens[..rank].iter().sum();
        let grand: u64 = lens.iter().sum();
        let base = format!("particles/var/{}", field.name);
        f.group(&base)?;
        f.dataset::<u64>(&format!("{base}/count"), &[n], false)?;
        f.write(&format!("{base}/count"), &[start], &[rows], &counts)?;
        let value = format!("{base}/value");
        let (at, len) = (&[offset as usize], &[my_len as usize]);
        match &field.data {
            VarData::Double(r) => {
                f.dataset::<f64>(&value, &[grand as usize], false)?;
                f.write(&value, at, len, &r.concat())?;
            }
            VarData::Single(r) => {
                // Stored as it is held: f32 (the attribute tells the reader).
                f.attr_str(&base, "precision", "single")?;
                f.dataset::<f32>(&value, &[grand as usize], false)?;
                f.write(&value, at, len, &r.concat())?;
            }
            VarData::Words(r) => {
                // Words (a BDDFS histogram's packed cells), not numbers: u64.
                f.attr_str(&base, "precision", "words")?;
                f.dataset::<u64>(&value, &[grand as usize], false)?;
                f.write(&value, at, len, &r.concat())?;
            }
        }
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
    /// The species table of a several-species scene (the particles' species are in
    /// `particles.species`).
    pub species: Option<Vec<crate::species::Species>>,
    /// The rigid-body table (exact words as JSON), when the scene suspends bodies.
    pub rigid_bodies: Option<String>,
}

/// The case echoed in a particle scene's checkpoint (any rank, independent).
pub fn read_case(path: &Path) -> Result<Case, CheckpointError> {
    let (_, text, echo) = open_scene(path, SceneKind::Particles, None)?;
    parse_echo(path, &text, &echo)
}

fn parse_echo(path: &Path, text: &str, echo: &Path) -> Result<Case, CheckpointError> {
    crate::config::parse(text, echo)
        .map_err(|e| CheckpointError::damaged(path, format!("unreadable case echo: {e}")))
}

/// Reads and verifies a checkpoint (collective; every rank returns the same verdict). Each rank
/// reads one block of ids; [`Simulation::from_checkpoint`] sends the particles to their owners.
pub(crate) fn read<const D: usize>(
    path: &Path,
    comm: &dyn Comm,
) -> Result<Restored<D>, CheckpointError> {
    let (restored, scalars) = agree(read_local::<D>(path, comm), path, comm)?;
    // Checksum (collective); the stored value travels as the last scalar.
    let (stored, scalars) = scalars
        .split_last()
        .expect("read_local returns the checksum last");
    let sum = checksum(&restored.particles, comm, scalars);
    if sum != *stored {
        return Err(CheckpointError::damaged(
            path,
            format!("checksum mismatch (stored {stored:016x}, computed {sum:016x})"),
        ));
    }
    Ok(restored)
}

fn read_local<const D: usize>(
    path: &Path,
    comm: &dyn Comm,
) -> Result<(Restored<D>, Vec<u64>), CheckpointError> {
    let (opened, text, echo) = open_scene(path, SceneKind::Particles, Some(D))?;
    let case = parse_echo(path, &text, &echo)?;
    let damaged = |e: String| CheckpointError::damaged(path, e);
    read_particles::<D>(path, &opened.file, opened.version, case, comm).map_err(damaged)
}

/// The particles, series and scalars of an identified particle checkpoint (errors: the file
/// is damaged).
fn read_particles<const D: usize>(
    path: &Path,
    f: &hdf5::File,
    version: u64,
    case: Case,
    comm: &dyn Comm,
) -> Result<(Restored<D>, Vec<u64>), String> {
    let total: u64 = read_attr(f, "/", "particles")?;
    let step: u64 = read_attr(f, "/", "step")?;
    let rebuild_step: u64 = read_attr(f, "/", "rebuild_step")?;
    let case_text = read_attr_str(f, "/", "case")?;
    let stored_checksum = read_attr_str(f, "/", "checksum")?;
    let block = id_block(total, comm.size(), comm.rank());
    let (start, rows) = (block.start as usize, (block.end - block.start) as usize);
    let mut p = Particles::<D>::default();
    let ids: Vec<u64> = read_block(f, "particles/id", &[start], &[rows])?;
    if !ids.iter().copied().eq(block.clone()) {
        return Err(format!(
            "{}: /particles/id is not 0..{total} in order: the file is corrupt",
            path.display()
        ));
    }
    let vec_field = |name: &str| -> Result<Vec<[f64; D]>, String> {
        let flat: Vec<f64> = read_block(f, &format!("particles/{name}"), &[start, 0], &[rows, D])?;
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
    let image: Vec<i32> = read_block(f, "particles/image", &[start, 0], &[rows, D])?;
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
        let order = read_attr_str(f, group, "order")?;
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
        p.extra[k].data = read_block(f, &ds, &[start, 0], &[rows, width])?;
    }
    for name in names("particles/var")? {
        let base = format!("particles/var/{name}");
        let all_counts: Vec<u64> =
            read_block(f, &format!("{base}/count"), &[0], &[total as usize])?;
        let offset: u64 = all_counts[..start].iter().sum();
        let counts = &all_counts[start..start + rows];
        let len: u64 = counts.iter().sum();
        let value = format!("{base}/value");
        let (at, len) = (&[offset as usize], &[len as usize]);
        let storage = read_attr_str(f, &base, "precision").unwrap_or_default();
        fn rows_of<T: Copy>(flat: &[T], counts: &[u64]) -> Vec<Vec<T>> {
            let mut at = 0usize;
            counts
                .iter()
                .map(|&c| {
                    let v = flat[at..at + c as usize].to_vec();
                    at += c as usize;
                    v
                })
                .collect()
        }
        let k = p.register_var(&name);
        p.var[k].data = match storage.as_str() {
            "single" => VarData::Single(rows_of(&read_block::<f32>(f, &value, at, len)?, counts)),
            "words" => VarData::Words(rows_of(&read_block::<u64>(f, &value, at, len)?, counts)),
            _ => VarData::Double(rows_of(&read_block::<f64>(f, &value, at, len)?, counts)),
        };
    }
    let series = read_series(f)?;
    let species_table = read_attr_str(f, "/", "species_table").ok();
    let species = match &species_table {
        Some(text) => {
            let words: Vec<u64> = read_block(f, "particles/species", &[start], &[rows])?;
            p.species = Some(words.iter().map(|&w| w as u8).collect());
            Some(
                serde_json::from_str::<Vec<crate::species::Species>>(text)
                    .map_err(|e| format!("species table: {e}"))?,
            )
        }
        None => None,
    };
    let mut scalars = vec![
        step,
        rebuild_step,
        total,
        D as u64,
        version,
        text_hash(&case_text),
        series_hash(&series),
    ];
    scalars.extend(species_table.as_deref().map(text_hash));
    let rigid_bodies = read_attr_str(f, "/", "rigid_bodies").ok();
    scalars.extend(rigid_bodies.as_deref().map(text_hash));
    scalars.push(u64::from_str_radix(&stored_checksum, 16).map_err(|_| {
        format!(
            "{}: checksum attribute {stored_checksum:?} is not hexadecimal",
            path.display()
        )
    })?);
    Ok((
        Restored {
            case,
            particles: p,
            total,
            step,
            rebuild_step,
            series,
            species,
            rigid_bodies,
        },
        scalars,
    ))
}
