//! Snapshot series: `OUT/snapshots.h5` in the H5MD layout (de Buyl et al., CPC 185 (2014) 1546)
//! with an XDMF sidecar `OUT/snapshots.xdmf` so ParaView opens it directly.
//!
//! The particles are written in groups, one per kind of particle ([`crate::species::Species::group`]):
//! `fluid`, and in a scene with boundary particles `wall` (both walls) and `inclusion`, so a
//! viewer shows them apart (one XDMF grid each). A group without particles is left out.
//!
//! ```text
//! /h5md                        version = [1, 1]; author/, creator/ (name, version)
//! /parameters                  attributes: case (TOML echo), shear_rate
//! /particles/<group>/id        [N_g]      u64  global ids (rows are in id order in every frame)
//! /particles/<group>/species   [N_g]      i32  species numbers (with "species" in the fields)
//! /particles/<group>/box       attributes dimension, boundary; edges [D]
//! /particles/<group>/box/lees_edwards_offset/{step, time, value}   offset s(t) of each frame
//! /particles/<group>/<field>/{step [F], time [F], value}
//!     vectors [F, N_g, D]: position, velocity, force, unwrapped_position (f64), image (i32)
//!     scalars [F, N_g]: density, pressure (f64)
//!     symmetric tensors [F, N_g, D(D+1)/2], upper triangle row by row (2D: xx, xy, yy;
//!     3D: xx, xy, xz, yy, yz, zz): polymer_stress, conformation (f64)
//! /observables/<name>/{step [S], time [S], value [S] or [S, bins]}  sampled series (at the end)
//! ```
//!
//! The engine writes position, velocity, force, image, unwrapped_position (r + n ∘ L, n the
//! image counts) and species for every case; the other fields are those the case's fluid model
//! offers ([`crate::models::fluid_model::FluidModel::snapshot_quantities`]), whose values its
//! particle models give ([`crate::models::interface::ParticleModel::snapshot_values`]).
//!
//! Every rank writes the rows of its global-id block into the shared datasets (see
//! [`super::shared_file`]), so a file does not depend on the rank count. Each frame opens and
//! closes the file, so a crash loses at most the frame being written; a restart drops frames
//! written after its checkpoint.

use super::shared_file::{SharedFile, read_block};
use crate::config::SnapshotField;
use crate::diagnostics::Series;
use crate::geometry::Boundary;
use crate::models::interface::SnapshotShape;
use crate::particles::{ExtraField, FieldFlags, Particles};
use crate::sim::Simulation;
use std::path::{Path, PathBuf};

/// File name of the snapshot series.
pub const FILE: &str = "snapshots.h5";
/// File name of its XDMF sidecar.
pub const XDMF: &str = "snapshots.xdmf";
/// H5MD group of the fluid particles.
pub const GROUP: &str = "particles/fluid";

/// How a snapshot field is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// D numbers per particle and frame (f64, or i32 for `integer`).
    Vector {
        /// Stored as i32 (the image counts).
        integer: bool,
    },
    /// One f64 per particle and frame.
    Scalar,
    /// A packed symmetric tensor, D(D+1)/2 f64 per particle and frame.
    Tensor,
    /// One i32 per particle, written once (the species).
    Fixed,
}

impl Layout {
    /// Numbers per particle in D dimensions.
    pub fn width(self, dimension: usize) -> usize {
        match self {
            Layout::Vector { .. } => dimension,
            Layout::Scalar | Layout::Fixed => 1,
            Layout::Tensor => dimension * (dimension + 1) / 2,
        }
    }
}

/// A field of the series and its storage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    /// The field.
    pub field: SnapshotField,
    /// Its storage.
    pub layout: Layout,
}

/// A particle group of the series (collective knowledge: every rank holds the totals).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Group {
    /// `fluid`, `wall`, `inclusion`.
    pub name: String,
    /// Particles in the group.
    pub total: usize,
    /// This rank's first row in the group's datasets.
    start: usize,
    /// The rows of this rank's id-ordered block that belong to the group.
    rows: Vec<usize>,
}

/// Appends frames to `OUT/snapshots.h5`.
pub struct SnapshotWriter {
    path: PathBuf,
    xdmf: PathBuf,
    fields: Vec<FieldLayout>,
    groups: Vec<Group>,
    /// (step, time) of every frame in the file.
    frames: Vec<(u64, f64)>,
}

/// The storage of the case's snapshot fields (the model's from its declaration).
fn layouts<const D: usize>(sim: &Simulation<'_, D>) -> Result<Vec<FieldLayout>, String> {
    let offered = sim.case.fluid.model().snapshot_quantities(&sim.case);
    sim.case
        .output
        .snapshot_fields
        .iter()
        .map(|&field| {
            let layout = match field {
                SnapshotField::Image => Layout::Vector { integer: true },
                SnapshotField::Species => Layout::Fixed,
                f if f.is_engine_field() => Layout::Vector { integer: false },
                f => match offered.iter().find(|q| q.name == f.name()) {
                    Some(q) if q.shape == SnapshotShape::Scalar => Layout::Scalar,
                    Some(_) => Layout::Tensor,
                    None => {
                        return Err(format!(
                            "output.snapshot_fields: \"{}\" is not provided by fluid.kind = \"{}\"",
                            f.name(),
                            sim.case.fluid.model().kind()
                        ));
                    }
                },
            };
            Ok(FieldLayout { field, layout })
        })
        .collect()
}

/// The owned particles' core fields and the model fields of the series, in this rank's
/// global-id block, in id order (collective).
fn id_ordered_block<const D: usize>(
    sim: &Simulation<'_, D>,
    fields: &[FieldLayout],
) -> Result<Particles<D>, String> {
    let mut core = sim.particles.owned_core();
    let n = core.n_owned;
    for f in fields {
        if matches!(f.layout, Layout::Scalar | Layout::Tensor) {
            let width = f.layout.width(D);
            let data = sim.snapshot_values(f.field.name()).unwrap_or_default();
            if data.len() != n * width {
                return Err(format!(
                    "no model of this case gives the snapshot field \"{}\" ({} values for {n} \
                     particles × {width})",
                    f.field.name(),
                    data.len()
                ));
            }
            core.extra.push(ExtraField {
                name: f.field.name().to_owned(),
                width,
                flags: FieldFlags {
                    migrates: true,
                    ..FieldFlags::DERIVED
                },
                data,
            });
        }
    }
    super::id_ordered(&core, sim.total_particles, sim.comm())
}

/// The groups of the species table, with this rank's rows of `mine` (its id-ordered block) in
/// each, in the order of their first species; groups without particles left out (collective).
fn groups<const D: usize>(sim: &Simulation<'_, D>, mine: &Particles<D>) -> Vec<Group> {
    let comm = sim.comm();
    let mut names: Vec<String> = Vec::new();
    let of_species: Vec<usize> = sim
        .species()
        .iter()
        .map(|s| {
            let g = s.group();
            names.iter().position(|n| *n == g).unwrap_or_else(|| {
                names.push(g);
                names.len() - 1
            })
        })
        .collect();
    if names.is_empty() {
        names.push("fluid".into());
    }
    let mut rows = vec![Vec::new(); names.len()];
    for k in 0..mine.n_owned {
        let s = mine.species_of(k) as usize;
        rows[of_species.get(s).copied().unwrap_or(0)].push(k);
    }
    let (size, rank) = (comm.size(), comm.rank());
    let mut counts = vec![0.0; names.len() * size];
    for (g, r) in rows.iter().enumerate() {
        counts[g * size + rank] = r.len() as f64;
    }
    comm.allreduce_sum(&mut counts);
    names
        .into_iter()
        .zip(rows)
        .enumerate()
        .map(|(g, (name, rows))| {
            let per_rank = &counts[g * size..(g + 1) * size];
            Group {
                name,
                total: per_rank.iter().sum::<f64>() as usize,
                start: per_rank[..rank].iter().sum::<f64>() as usize,
                rows,
            }
        })
        .filter(|g| g.total > 0)
        .collect()
}

/// The rows `rows` of a field of `width` numbers per particle, in order.
fn select<T: Copy>(data: &[T], width: usize, rows: &[usize]) -> Vec<T> {
    rows.iter()
        .flat_map(|&k| data[k * width..(k + 1) * width].iter().copied())
        .collect()
}

fn field_dataset(group: &str, f: SnapshotField) -> String {
    format!("particles/{group}/{}", f.name())
}

impl SnapshotWriter {
    /// Creates the series, or reopens it on a restart and drops frames after the current step
    /// (collective).
    pub fn open<const D: usize>(
        sim: &Simulation<'_, D>,
        out: &Path,
        restarting: bool,
    ) -> Result<Self, String> {
        let comm = sim.comm();
        super::create_dir_collective(out, comm)?;
        let fields = layouts(sim)?;
        let mine = super::id_ordered(&sim.particles.owned_core(), sim.total_particles, comm)?;
        let groups = groups(sim, &mine);
        let mut writer = Self {
            path: out.join(FILE),
            xdmf: out.join(XDMF),
            fields,
            groups,
            frames: Vec::new(),
        };
        if restarting && writer.path.exists() {
            if let Err(e) = writer.reopen(sim) {
                // A file damaged by a crash must not block a restart from a good checkpoint:
                // keep it aside and start a new series.
                let aside = writer.path.with_extension("h5.damaged");
                let moved = if comm.rank() == 0 {
                    std::fs::rename(&writer.path, &aside)
                        .map_err(|r| format!("{e}; and cannot move it aside: {r}"))
                } else {
                    Ok(())
                };
                super::collective_ok(comm, moved, "snapshot series")?;
                if comm.rank() == 0 {
                    tracing::warn!(
                        "{e}: moved to {} and starting a new snapshot series",
                        aside.display()
                    );
                }
                writer.frames.clear();
                writer.create(sim, &mine)?;
            }
        } else {
            writer.create(sim, &mine)?;
        }
        Ok(writer)
    }

    /// The groups of the series and their sizes.
    pub fn groups(&self) -> impl Iterator<Item = (&str, usize)> {
        self.groups.iter().map(|g| (g.name.as_str(), g.total))
    }

    fn create<const D: usize>(
        &mut self,
        sim: &Simulation<'_, D>,
        mine: &Particles<D>,
    ) -> Result<(), String> {
        let comm = sim.comm();
        let mut f = SharedFile::create(&self.path, comm)?;
        f.group("h5md")?;
        f.attr_array("h5md", "version", &[1i32, 1])?;
        f.group("h5md/author")?;
        f.attr_str("h5md/author", "name", "mesorheo user")?;
        f.group("h5md/creator")?;
        f.attr_str("h5md/creator", "name", "mesorheo")?;
        f.attr_str("h5md/creator", "version", env!("CARGO_PKG_VERSION"))?;
        f.group("parameters")?;
        let case = toml::to_string(&sim.case).map_err(|e| format!("cannot echo the case: {e}"))?;
        f.attr_str("parameters", "case", &case)?;
        f.attr("parameters", "shear_rate", &sim.sim_box.shear_rate)?;
        f.attr("/", "dimension", &(D as i32))?;
        f.group("particles")?;
        let boundary: Vec<&str> = sim
            .sim_box
            .boundaries
            .iter()
            .map(|b| match b {
                Boundary::Periodic => "periodic",
                Boundary::Wall => "none",
            })
            .collect();
        let root = comm.rank() == 0;
        for g in &self.groups {
            let (name, n) = (&g.name, g.total);
            let group = format!("particles/{name}");
            f.group(&group)?;
            let bx = format!("{group}/box");
            f.group(&bx)?;
            f.attr(&bx, "dimension", &(D as i32))?;
            f.attr_str_array(&bx, "boundary", &boundary)?;
            f.dataset::<f64>(&format!("{bx}/edges"), &[D], false)?;
            let edges = if root {
                &sim.sim_box.lengths[..]
            } else {
                &[][..]
            };
            f.write(&format!("{bx}/edges"), &[0], &[edges.len()], edges)?;
            let le = format!("{bx}/lees_edwards_offset");
            f.group(&le)?;
            f.dataset::<u64>(&format!("{le}/step"), &[0], true)?;
            f.dataset::<f64>(&format!("{le}/time"), &[0], true)?;
            f.dataset::<f64>(&format!("{le}/value"), &[0], true)?;
            let ids = select(&mine.gid, 1, &g.rows);
            f.dataset::<u64>(&format!("{group}/id"), &[n], false)?;
            f.write(&format!("{group}/id"), &[g.start], &[ids.len()], &ids)?;
            for fl in &self.fields {
                let ds = field_dataset(name, fl.field);
                let w = fl.layout.width(D);
                if fl.layout == Layout::Fixed {
                    let species: Vec<i32> = g
                        .rows
                        .iter()
                        .map(|&k| i32::from(mine.species_of(k)))
                        .collect();
                    f.dataset::<i32>(&ds, &[n], false)?;
                    f.write(&ds, &[g.start], &[species.len()], &species)?;
                    continue;
                }
                f.group(&ds)?;
                f.dataset::<u64>(&format!("{ds}/step"), &[0], true)?;
                f.dataset::<f64>(&format!("{ds}/time"), &[0], true)?;
                let shape: &[usize] = if fl.layout == Layout::Scalar {
                    &[0, n]
                } else {
                    &[0, n, w]
                };
                match fl.layout {
                    Layout::Vector { integer: true } => {
                        f.dataset::<i32>(&format!("{ds}/value"), shape, true)?
                    }
                    _ => f.dataset::<f64>(&format!("{ds}/value"), shape, true)?,
                }
            }
        }
        f.close()
    }

    /// Every time series of the file (the ones a frame extends).
    fn time_series(&self) -> Vec<String> {
        let mut v = Vec::new();
        for g in &self.groups {
            v.push(format!("particles/{}/box/lees_edwards_offset", g.name));
            v.extend(
                self.fields
                    .iter()
                    .filter(|f| f.layout != Layout::Fixed)
                    .map(|f| field_dataset(&g.name, f.field)),
            );
        }
        v
    }

    fn reopen<const D: usize>(&mut self, sim: &Simulation<'_, D>) -> Result<(), String> {
        let comm = sim.comm();
        let first = format!("particles/{}/box/lees_edwards_offset", self.groups[0].name);
        // Every rank reads the frame steps (independent), then all truncate (collective).
        let frames = (|| -> Result<Vec<(u64, f64)>, String> {
            let f = super::h5_options()
                .open(&self.path)
                .map_err(|e| format!("{}: cannot reopen: {e}", self.path.display()))?;
            // Frames every series holds completely (a crash between resizes leaves some longer).
            let mut len = usize::MAX;
            for g in self.time_series() {
                for part in ["step", "time", "value"] {
                    let shape = f
                        .dataset(&format!("{g}/{part}"))
                        .map_err(|e| format!("{}: {g}/{part}: {e}", self.path.display()))?
                        .shape();
                    len = len.min(shape.first().copied().unwrap_or(0));
                }
            }
            let steps: Vec<u64> = read_block(&f, &format!("{first}/step"), &[0], &[len])?;
            let times: Vec<f64> = read_block(&f, &format!("{first}/time"), &[0], &[len])?;
            Ok(steps.into_iter().zip(times).collect())
        })();
        let mut bad = [if frames.is_err() { 1.0 } else { 0.0 }];
        comm.allreduce_max(&mut bad);
        let frames = match frames {
            Err(e) => return Err(e),
            Ok(_) if bad[0] > 0.0 => {
                return Err(format!(
                    "{}: unreadable on another rank",
                    self.path.display()
                ));
            }
            Ok(fr) => fr,
        };
        // Frames up to the checkpoint, in increasing step order (anything else is a leftover).
        let keep = frames
            .iter()
            .enumerate()
            .take_while(|(k, (s, _))| *s <= sim.step && (*k == 0 || frames[k - 1].0 < *s))
            .count();
        self.frames = frames[..keep].to_vec();
        if keep < frames.len() || self.has_longer_series(keep)? {
            let f = SharedFile::append(&self.path, comm)?;
            for g in self.time_series() {
                for part in ["step", "time", "value"] {
                    f.resize_first(&format!("{g}/{part}"), keep)?;
                }
            }
            f.close()?;
            if comm.rank() == 0 {
                tracing::info!(
                    "{}: dropped {} frame(s) written after step {}",
                    self.path.display(),
                    frames.len() - keep,
                    sim.step
                );
            }
        }
        Ok(())
    }

    /// Whether some time series holds more than `len` frames (collective-safe: every rank reads
    /// the same file).
    fn has_longer_series(&self, len: usize) -> Result<bool, String> {
        let f = super::h5_options()
            .open(&self.path)
            .map_err(|e| format!("{}: cannot reopen: {e}", self.path.display()))?;
        for g in self.time_series() {
            for part in ["step", "time", "value"] {
                if let Ok(d) = f.dataset(&format!("{g}/{part}"))
                    && d.shape().first().copied().unwrap_or(0) > len
                {
                    return Ok(true);
                }
            }
        }
        Ok(false)
    }

    /// Appends the current state as a frame (collective).
    pub fn write_frame<const D: usize>(&mut self, sim: &Simulation<'_, D>) -> Result<(), String> {
        let comm = sim.comm();
        // The core fields and the model fields of the series travel (a model's ensembles are
        // not part of a frame).
        let mine = id_ordered_block(sim, &self.fields)?;
        let frame = self.frames.len();
        let root = comm.rank() == 0;
        let mut f = SharedFile::append(&self.path, comm)?;
        for g in self.time_series() {
            for part in ["step", "time", "value"] {
                f.resize_first(&format!("{g}/{part}"), frame + 1)?;
            }
            let k = usize::from(root);
            f.write(&format!("{g}/step"), &[frame], &[k], &[sim.step][..k])?;
            f.write(&format!("{g}/time"), &[frame], &[k], &[sim.time()][..k])?;
        }
        let offset = sim.sim_box.le_offset(sim.step, sim.dt());
        let k = usize::from(root);
        let lengths = &sim.sim_box.lengths;
        let unwrapped: Vec<[f64; D]> = if self
            .fields
            .iter()
            .any(|f| f.field == SnapshotField::UnwrappedPosition)
        {
            mine.pos
                .iter()
                .zip(&mine.image)
                .map(|(r, n)| std::array::from_fn(|a| r[a] + f64::from(n[a]) * lengths[a]))
                .collect()
        } else {
            Vec::new()
        };
        for g in &self.groups {
            let le = format!("particles/{}/box/lees_edwards_offset/value", g.name);
            f.write(&le, &[frame], &[k], &[offset][..k])?;
            let rows = g.rows.len();
            for fl in &self.fields {
                let ds = format!("{}/value", field_dataset(&g.name, fl.field));
                let w = fl.layout.width(D);
                let (at, shape): (Vec<usize>, Vec<usize>) = if fl.layout == Layout::Scalar {
                    (vec![frame, g.start], vec![1, rows])
                } else {
                    (vec![frame, g.start, 0], vec![1, rows, w])
                };
                let vector = |v: &[[f64; D]]| select(v.as_flattened(), D, &g.rows);
                let values = match fl.field {
                    SnapshotField::Species => continue,
                    SnapshotField::Image => {
                        let v = select(mine.image.as_flattened(), D, &g.rows);
                        f.write(&ds, &at, &shape, &v)?;
                        continue;
                    }
                    SnapshotField::Position => vector(&mine.pos),
                    SnapshotField::Velocity => vector(&mine.vel),
                    SnapshotField::Force => vector(&mine.force),
                    SnapshotField::UnwrappedPosition => vector(&unwrapped),
                    other => {
                        let x = mine
                            .extra_index(other.name())
                            .ok_or_else(|| format!("snapshot field {} lost", other.name()))?;
                        select(&mine.extra[x].data, w, &g.rows)
                    }
                };
                f.write(&ds, &at, &shape, &values)?;
            }
        }
        f.close()?;
        self.frames.push((sim.step, sim.time()));
        let written = if root {
            write_atomically(&self.xdmf, &self.xdmf_text::<D>())
        } else {
            Ok(())
        };
        super::collective_ok(comm, written, "XDMF sidecar")
    }

    fn xdmf_text<const D: usize>(&self) -> String {
        let groups: Vec<(&str, usize)> = self.groups().collect();
        xdmf::<D>(FILE, &groups, &self.fields, &self.frames)
    }

    /// Writes the sampled observables (H5MD `/observables`) and the sidecar (collective).
    pub fn finish<const D: usize>(&mut self, sim: &Simulation<'_, D>) -> Result<(), String> {
        let comm = sim.comm();
        let mut f = SharedFile::append(&self.path, comm)?;
        f.unlink("observables")?;
        write_observables(&mut f, &sim.series, sim.dt(), comm.rank() == 0)?;
        f.close()?;
        if comm.rank() == 0 {
            write_atomically(&self.xdmf, &self.xdmf_text::<D>())?;
        }
        Ok(())
    }
}

fn write_atomically(path: &Path, text: &str) -> Result<(), String> {
    let tmp = path.with_extension("xdmf.tmp");
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// H5MD observables: `/observables/<name>/{step, time, value}`.
fn write_observables(
    f: &mut SharedFile,
    series: &Series,
    dt: f64,
    root: bool,
) -> Result<(), String> {
    let s = series.steps.len();
    let rows = if root { s } else { 0 };
    let times: Vec<f64> = series.steps.iter().map(|&k| k as f64 * dt).collect();
    f.group("observables")?;
    let put = |f: &mut SharedFile, name: &str, shape: &[usize], values: &[f64]| {
        let g = format!("observables/{name}");
        f.group(&g)?;
        f.dataset::<u64>(&format!("{g}/step"), &[s], false)?;
        f.write(&format!("{g}/step"), &[0], &[rows], &series.steps[..rows])?;
        f.dataset::<f64>(&format!("{g}/time"), &[s], false)?;
        f.write(&format!("{g}/time"), &[0], &[rows], &times[..rows])?;
        f.dataset::<f64>(&format!("{g}/value"), shape, false)?;
        let mut mine = shape.to_vec();
        mine[0] = rows;
        let k: usize = mine.iter().product();
        f.write(
            &format!("{g}/value"),
            &vec![0; shape.len()],
            &mine,
            &values[..k],
        )
    };
    for (name, values) in &series.scalars {
        put(f, name, &[s], values)?;
    }
    if let Some(first) = series.profile.first() {
        put(
            f,
            "velocity_profile",
            &[s, first.len()],
            &series.profile.concat(),
        )?;
    }
    Ok(())
}

/// The XDMF 3 sidecar: per particle group ([`Group`]) a temporal collection with one
/// polyvertex grid per frame, each reading hyperslab `[frame, …]` of the group's H5MD datasets.
/// Vectors are N × 3 `Vector` attributes in 2D too, as VTK and ParaView need them (an N × 2
/// one is read as a single tuple of 2N components): a `JOIN($0, $1, 0 * $0)` of the x and y
/// columns and a zero z column, computed by the reader, so the file keeps its two components.
/// Symmetric tensors are `Tensor6` attributes (xx, xy, xz, yy, yz, zz; VTK expands them to
/// 3 × 3), padded in 2D by `JOIN($0, $1, (0 * $0), $2, (0 * $0), (0 * $0))` (the parentheses
/// matter: VTK's Xdmf2 parser mis-reads an unparenthesised `0 * $0` that is not last); scalars
/// and the species are `Scalar` attributes.
pub fn xdmf<const D: usize>(
    h5_name: &str,
    groups: &[(&str, usize)],
    fields: &[FieldLayout],
    frames: &[(u64, f64)],
) -> String {
    let total = frames.len();
    let number = |fl: &FieldLayout| match fl.layout {
        Layout::Vector { integer: true } | Layout::Fixed => ("Int", 4),
        _ => ("Float", 8),
    };
    let mut s = String::from("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n");
    for &(group, n) in groups {
        let path =
            |fl: &FieldLayout| format!("{h5_name}:/particles/{group}/{}/value", fl.field.name());
        // Frame `frame` of a field of width w (stored [T, n, w]) as an n × w hyperslab.
        let slab = |fl: &FieldLayout, frame: usize, w: usize| -> String {
            let (number, precision) = number(fl);
            format!(
                "        <DataItem ItemType=\"HyperSlab\" Dimensions=\"{n} {w}\" Type=\"HyperSlab\">\n\
                 \x20         <DataItem Dimensions=\"3 3\" Format=\"XML\">{frame} 0 0 1 1 1 1 {n} {w}</DataItem>\n\
                 \x20         <DataItem Dimensions=\"{total} {n} {w}\" NumberType=\"{number}\" Precision=\"{precision}\" Format=\"HDF\">{}</DataItem>\n\
                 \x20       </DataItem>\n",
                path(fl)
            )
        };
        // Column c of a field of width w in frame `frame`, as an n × 1 hyperslab.
        let column = |fl: &FieldLayout, frame: usize, w: usize, c: usize| -> String {
            let (number, precision) = number(fl);
            format!(
                "          <DataItem ItemType=\"HyperSlab\" Dimensions=\"{n} 1\" Type=\"HyperSlab\">\n\
                 \x20           <DataItem Dimensions=\"3 3\" Format=\"XML\">{frame} 0 {c} 1 1 1 1 {n} 1</DataItem>\n\
                 \x20           <DataItem Dimensions=\"{total} {n} {w}\" NumberType=\"{number}\" Precision=\"{precision}\" Format=\"HDF\">{}</DataItem>\n\
                 \x20         </DataItem>\n",
                path(fl)
            )
        };
        let join = |function: &str, fl: &FieldLayout, frame: usize, w: usize, width: usize| {
            let columns: String = (0..w).map(|c| column(fl, frame, w, c)).collect();
            format!(
                "        <DataItem ItemType=\"Function\" Function=\"{function}\" Dimensions=\"{n} {width}\">\n{columns}        </DataItem>\n"
            )
        };
        let attribute = |fl: &FieldLayout, frame: usize| -> String {
            let w = fl.layout.width(D);
            let (kind, item) = match fl.layout {
                Layout::Vector { .. } if D == 3 => ("Vector", slab(fl, frame, w)),
                Layout::Vector { .. } => ("Vector", join("JOIN($0, $1, 0 * $0)", fl, frame, w, 3)),
                Layout::Tensor if D == 3 => ("Tensor6", slab(fl, frame, w)),
                Layout::Tensor => (
                    "Tensor6",
                    join(
                        "JOIN($0, $1, (0 * $0), $2, (0 * $0), (0 * $0))",
                        fl,
                        frame,
                        w,
                        6,
                    ),
                ),
                Layout::Scalar => (
                    "Scalar",
                    format!(
                        "        <DataItem ItemType=\"HyperSlab\" Dimensions=\"{n}\" Type=\"HyperSlab\">\n\
                         \x20         <DataItem Dimensions=\"3 2\" Format=\"XML\">{frame} 0 1 1 1 {n}</DataItem>\n\
                         \x20         <DataItem Dimensions=\"{total} {n}\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{}</DataItem>\n\
                         \x20       </DataItem>\n",
                        path(fl)
                    ),
                ),
                Layout::Fixed => (
                    "Scalar",
                    format!(
                        "        <DataItem Dimensions=\"{n}\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">{h5_name}:/particles/{group}/{}</DataItem>\n",
                        fl.field.name()
                    ),
                ),
            };
            format!(
                "      <Attribute Name=\"{}\" AttributeType=\"{kind}\" Center=\"Node\">\n{item}      </Attribute>\n",
                fl.field.name()
            )
        };
        s.push_str(&format!(
            "    <Grid Name=\"{group}\" GridType=\"Collection\" CollectionType=\"Temporal\">\n"
        ));
        let position = FieldLayout {
            field: SnapshotField::Position,
            layout: Layout::Vector { integer: false },
        };
        for (k, &(step, time)) in frames.iter().enumerate() {
            s.push_str(&format!(
                "    <Grid Name=\"{group}_step_{step}\" GridType=\"Uniform\">\n      <Time Value=\"{time:e}\"/>\n      \
                 <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\"/>\n"
            ));
            s.push_str(&format!(
                "      <Geometry GeometryType=\"{}\">\n",
                if D == 3 { "XYZ" } else { "XY" }
            ));
            s.push_str(&slab(&position, k, D));
            s.push_str("      </Geometry>\n");
            s.push_str(&format!(
                "      <Attribute Name=\"id\" AttributeType=\"Scalar\" Center=\"Node\">\n        \
                 <DataItem Dimensions=\"{n}\" NumberType=\"UInt\" Precision=\"8\" Format=\"HDF\">{h5_name}:/particles/{group}/id</DataItem>\n      </Attribute>\n"
            ));
            for fl in fields {
                if fl.field != SnapshotField::Position {
                    s.push_str(&attribute(fl, k));
                }
            }
            s.push_str("    </Grid>\n");
        }
        s.push_str("    </Grid>\n");
    }
    s.push_str("  </Domain>\n</Xdmf>\n");
    s
}
