//! Checkpoints of homogeneous-flow scenes (`scene = "homogeneous_flow"`): every particle's
//! dumbbell ensemble (and its control copy) in global-id order, so the run continues bitwise
//! identically on any rank count.
//!
//! ```text
//! /                        attributes (beside the common ones): per_particle, precision
//!                          ("double", "single", or "histogram" for BDDFS)
//! /ensembles/connectors    [N, N_d·D]  f64 (or f32 with precision = "single"; not with BDDFS)
//! /ensembles/histograms    [N, L]      u64   BDDFS: each particle's occupied cells, packed
//!                                            (cell << 32 | count) by increasing cell, padded
//!                                            with 0 (never an entry: counts are ≥ 1) to the
//!                                            longest row L
//! /ensembles/control       [N, N_d·D]  f64   equilibrium copies (variance reduction only)
//! /ensembles/averages      [N, K]      f64   per-particle sums of the K averaged observables
//!                                            (attribute `samples`: how many samples they hold)
//! ```
//!
//! Ranks hold contiguous id blocks, so each writes and reads its rows directly.

use super::{
    CheckpointError, Common, SceneKind, agree, file_name, open_scene, publish, read_series,
    series_hash, text_hash, write_series,
};
use crate::comm::Comm;
use crate::config::FlowCase;
use crate::diagnostics::Series;
use crate::domain::id_block;
use crate::models::homogeneous_flow::{
    Connectors, ConnectorsRef, HomogeneousEnsembles, ParticleAverages,
};
use crate::output::collective_ok;
use crate::output::shared_file::{SharedFile, read_attr, read_attr_str, read_block};
use crate::sim::hash_words;
use std::path::{Path, PathBuf};

/// Order-independent checksum of every rank's ensembles plus the scalar metadata (collective).
fn checksum(
    gids: &[u64],
    rows: &dyn Fn(usize, &mut Vec<u64>),
    comm: &dyn Comm,
    scalars: &[u64],
) -> u64 {
    let mut words = Vec::new();
    let hashes = gids.iter().enumerate().map(|(i, &g)| {
        words.clear();
        words.push(g);
        rows(i, &mut words);
        hash_words(&words)
    });
    super::combine_checksum(hashes, comm, scalars)
}

/// The words of particle `i` (running sums, connectors, control copy) appended to `out`.
fn push_words(
    q: &ConnectorsRef<'_>,
    control: Option<&[Vec<f64>]>,
    averages: &[Vec<f64>],
    i: usize,
    out: &mut Vec<u64>,
) {
    out.extend(averages[i].iter().map(|x| x.to_bits()));
    match q {
        ConnectorsRef::Double(q) => out.extend(q[i].iter().map(|x| x.to_bits())),
        ConnectorsRef::Single(q) => out.extend(q[i].iter().map(|x| u64::from(x.to_bits()))),
        ConnectorsRef::Histograms(h) => out.extend_from_slice(&h[i]),
    }
    if let Some(c) = control {
        out.extend(c[i].iter().map(|x| x.to_bits()));
    }
}

#[allow(clippy::too_many_arguments)]
fn scalars(
    version: u64,
    step: u64,
    total: u64,
    dim: u64,
    n_d: u64,
    single: bool,
    case: &str,
    series: &Series,
    samples: u64,
) -> Vec<u64> {
    vec![
        samples,
        step,
        total,
        dim,
        n_d,
        u64::from(single),
        version,
        text_hash(case),
        series_hash(series),
    ]
}

/// Writes the checkpoint of the current step into `dir`, keeping the newest `keep`
/// (collective). Returns the path.
pub fn write<const D: usize>(
    e: &HomogeneousEnsembles<'_, D>,
    case: &FlowCase,
    series: &Series,
    averages: &ParticleAverages,
    dir: &Path,
    keep: usize,
    comm: &dyn Comm,
) -> Result<PathBuf, String> {
    let (rank, size) = (comm.rank(), comm.size());
    let total = e.total;
    let block = id_block(total, size, rank);
    let case_toml = toml::to_string(case).map_err(|err| format!("cannot echo the case: {err}"))?;
    let q = e.connectors();
    let single = matches!(q, ConnectorsRef::Single(_));
    let precision = match q {
        ConnectorsRef::Double(_) => "double",
        ConnectorsRef::Single(_) => "single",
        ConnectorsRef::Histograms(_) => "histogram",
    };
    let control = e.control.as_deref();
    let sc = scalars(
        super::FORMAT_VERSION,
        e.step,
        total,
        D as u64,
        e.n_d as u64,
        single,
        &case_toml,
        series,
        averages.samples,
    );
    let av = &averages.sums;
    let sum = checksum(
        &e.gids,
        &|i, out| push_words(&q, control, av, i, out),
        comm,
        &sc,
    );
    crate::output::create_dir_collective(dir, comm)?;
    let path = dir.join(file_name(e.step));
    let tmp = dir.join(format!("{}.tmp", file_name(e.step)));
    let mut f = SharedFile::create(&tmp, comm)?;
    let (n, width) = (total as usize, e.n_d * D);
    let (start, rows) = (block.start as usize, (block.end - block.start) as usize);
    let common = Common {
        scene: SceneKind::HomogeneousFlow,
        step: e.step,
        time: e.time(),
        dt: e.params.dt,
        dimension: D,
        particles: total,
        seed: e.seed,
    };
    common.write(&mut f)?;
    f.attr("/", "per_particle", &(e.n_d as u64))?;
    f.attr_str("/", "precision", precision)?;
    f.attr_str("/", "case", &case_toml)?;
    f.attr_str("/", "checksum", &format!("{sum:016x}"))?;
    f.group("ensembles")?;
    match q {
        ConnectorsRef::Double(q) => {
            f.dataset::<f64>("ensembles/connectors", &[n, width], false)?;
            f.write(
                "ensembles/connectors",
                &[start, 0],
                &[rows, width],
                &q.concat(),
            )?;
        }
        ConnectorsRef::Single(q) => {
            f.dataset::<f32>("ensembles/connectors", &[n, width], false)?;
            f.write(
                "ensembles/connectors",
                &[start, 0],
                &[rows, width],
                &q.concat(),
            )?;
        }
        ConnectorsRef::Histograms(h) => {
            let longest = {
                let mut v = [h.iter().map(Vec::len).max().unwrap_or(0) as f64];
                comm.allreduce_max(&mut v);
                v[0] as usize
            };
            let mut padded = Vec::with_capacity(rows * longest);
            for row in h {
                padded.extend_from_slice(row);
                padded.resize(padded.len() + longest - row.len(), 0);
            }
            f.dataset::<u64>("ensembles/histograms", &[n, longest], false)?;
            f.write(
                "ensembles/histograms",
                &[start, 0],
                &[rows, longest],
                &padded,
            )?;
        }
    }
    if let Some(c) = control {
        f.dataset::<f64>("ensembles/control", &[n, width], false)?;
        f.write(
            "ensembles/control",
            &[start, 0],
            &[rows, width],
            &c.concat(),
        )?;
    }
    let k = av.first().map_or(0, Vec::len);
    let k_all = {
        let mut v = [k as f64];
        comm.allreduce_max(&mut v);
        v[0] as usize
    };
    f.dataset::<f64>("ensembles/averages", &[n, k_all], false)?;
    f.write(
        "ensembles/averages",
        &[start, 0],
        &[rows, k_all],
        &av.concat(),
    )?;
    f.attr("ensembles/averages", "samples", &averages.samples)?;
    write_series(&mut f, series, rank == 0)?;
    f.close()?;
    let mut done = Ok(());
    if rank == 0 {
        done = publish(&tmp, &path, e.step, dir, keep);
    }
    collective_ok(comm, done, "checkpoint")?;
    Ok(path)
}

/// A flow checkpoint as read by one rank (its id block).
pub struct RestoredFlow {
    /// The case echoed in the file.
    pub case: FlowCase,
    /// Step of the checkpoint.
    pub step: u64,
    /// Total particle count.
    pub total: u64,
    /// This rank's connectors.
    pub connectors: Connectors,
    /// This rank's control copies.
    pub control: Option<Vec<Vec<f64>>>,
    /// Sampled series up to the checkpoint.
    pub series: Series,
    /// This rank's per-particle running sums.
    pub averages: ParticleAverages,
}

/// The case echoed in a homogeneous-flow scene's checkpoint (any rank, independent).
pub fn read_case(path: &Path) -> Result<FlowCase, CheckpointError> {
    let (_, text, echo) = open_scene(path, SceneKind::HomogeneousFlow, None)?;
    parse_echo(path, &text, &echo)
}

fn parse_echo(path: &Path, text: &str, echo: &Path) -> Result<FlowCase, CheckpointError> {
    match crate::config::parse_scene(text, echo) {
        Ok(crate::config::CaseScene::HomogeneousFlow(c)) => Ok(*c),
        Ok(crate::config::CaseScene::Particles(_)) => Err(CheckpointError::damaged(
            path,
            "the case echo is not a homogeneous-flow scene",
        )),
        Err(e) => Err(CheckpointError::damaged(
            path,
            format!("unreadable case echo: {e}"),
        )),
    }
}

fn rows_of<T: Copy>(flat: Vec<T>, width: usize) -> Vec<Vec<T>> {
    flat.chunks_exact(width.max(1)).map(<[T]>::to_vec).collect()
}

/// Reads and verifies a flow checkpoint (collective; every rank returns the same verdict).
pub fn read<const D: usize>(path: &Path, comm: &dyn Comm) -> Result<RestoredFlow, CheckpointError> {
    let (r, stored, sc) = agree(read_local::<D>(path, comm), path, comm)?;
    let gids: Vec<u64> = id_block(r.total, comm.size(), comm.rank()).collect();
    let q = match &r.connectors {
        Connectors::Double(q) => ConnectorsRef::Double(q),
        Connectors::Single(q) => ConnectorsRef::Single(q),
        Connectors::Histograms { rows, .. } => ConnectorsRef::Histograms(rows),
    };
    let control = r.control.as_deref();
    let av = &r.averages.sums;
    let sum = checksum(
        &gids,
        &|i, out| push_words(&q, control, av, i, out),
        comm,
        &sc,
    );
    if sum != stored {
        return Err(CheckpointError::damaged(
            path,
            format!("checksum mismatch (stored {stored:016x}, computed {sum:016x})"),
        ));
    }
    Ok(r)
}

fn read_local<const D: usize>(
    path: &Path,
    comm: &dyn Comm,
) -> Result<(RestoredFlow, u64, Vec<u64>), CheckpointError> {
    let (opened, text, echo) = open_scene(path, SceneKind::HomogeneousFlow, Some(D))?;
    let case = parse_echo(path, &text, &echo)?;
    let damaged = |e: String| CheckpointError::damaged(path, e);
    read_ensembles::<D>(&opened.file, opened.version, case, comm).map_err(damaged)
}

/// The ensembles, series and scalars of an identified flow checkpoint (errors: the file is
/// damaged).
fn read_ensembles<const D: usize>(
    f: &hdf5::File,
    version: u64,
    case: FlowCase,
    comm: &dyn Comm,
) -> Result<(RestoredFlow, u64, Vec<u64>), String> {
    let corrupt = |what: String| what;
    let total: u64 = read_attr(f, "/", "particles")?;
    let step: u64 = read_attr(f, "/", "step")?;
    let n_d: u64 = read_attr(f, "/", "per_particle")?;
    let precision = read_attr_str(f, "/", "precision")?;
    let case_text = read_attr_str(f, "/", "case")?;
    let stored = read_attr_str(f, "/", "checksum")?;
    let stored = u64::from_str_radix(&stored, 16)
        .map_err(|_| corrupt(format!("checksum attribute {stored:?} is not hexadecimal")))?;
    if case.flow.particles != total || case.polymer.per_particle as u64 != n_d {
        return Err(corrupt(
            "the particle or dumbbell count differs from the case echo".into(),
        ));
    }
    let block = id_block(total, comm.size(), comm.rank());
    let (start, rows) = (block.start as usize, (block.end - block.start) as usize);
    let width = n_d as usize * D;
    let (single, histograms) = match precision.as_str() {
        "double" => (false, false),
        "single" => (true, false),
        "histogram" => (false, true),
        other => return Err(corrupt(format!("unknown precision {other:?}"))),
    };
    let connectors = if histograms {
        let grid = case
            .polymer
            .histogram_grid()
            .ok_or_else(|| corrupt("BDDFS histograms, but the case echo is not BDDFS".into()))?;
        let longest = f
            .dataset("ensembles/histograms")
            .map(|d| d.shape().get(1).copied().unwrap_or(0))
            .map_err(|e| corrupt(format!("ensembles/histograms: {e}")))?;
        let mut rows_read = rows_of(
            read_block::<u64>(f, "ensembles/histograms", &[start, 0], &[rows, longest])?,
            longest,
        );
        if longest == 0 {
            rows_read = vec![Vec::new(); rows];
        }
        for row in &mut rows_read {
            while row.last() == Some(&0) {
                row.pop();
            }
        }
        let count_ok = rows_read
            .iter()
            .all(|row| crate::models::bddfs::dumbbell_count(row) == n_d);
        if rows_read.len() != rows || !count_ok {
            return Err(corrupt(format!(
                "ensembles/histograms: a row does not hold {n_d} dumbbells"
            )));
        }
        Connectors::Histograms {
            grid,
            rows: rows_read,
        }
    } else if single {
        Connectors::Single(rows_of(
            read_block::<f32>(f, "ensembles/connectors", &[start, 0], &[rows, width])?,
            width,
        ))
    } else {
        Connectors::Double(rows_of(
            read_block::<f64>(f, "ensembles/connectors", &[start, 0], &[rows, width])?,
            width,
        ))
    };
    let control = if case.polymer.variance_reduction {
        Some(rows_of(
            read_block::<f64>(f, "ensembles/control", &[start, 0], &[rows, width])?,
            width,
        ))
    } else {
        None
    };
    let series = read_series(f)?;
    let k = f
        .dataset("ensembles/averages")
        .map(|d| d.shape().get(1).copied().unwrap_or(0))
        .map_err(|e| corrupt(format!("ensembles/averages: {e}")))?;
    let samples: u64 = read_attr(f, "ensembles/averages", "samples")?;
    let averages = ParticleAverages {
        sums: rows_of(
            read_block::<f64>(f, "ensembles/averages", &[start, 0], &[rows, k])?,
            k,
        ),
        samples,
    };
    if averages.sums.len() != rows {
        return Err(corrupt("ensembles/averages has the wrong shape".into()));
    }
    let sc = scalars(
        version, step, total, D as u64, n_d, single, &case_text, &series, samples,
    );
    Ok((
        RestoredFlow {
            case,
            step,
            total,
            connectors,
            control,
            series,
            averages,
        },
        stored,
        sc,
    ))
}
