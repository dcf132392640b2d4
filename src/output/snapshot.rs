//! Snapshot series: `OUT/snapshots.h5` in the H5MD layout (de Buyl et al., CPC 185 (2014) 1546)
//! with an XDMF sidecar `OUT/snapshots.xdmf` so ParaView opens it directly.
//!
//! ```text
//! /h5md                        version = [1, 1]; author/, creator/ (name, version)
//! /parameters                  attributes: case (TOML echo), shear_rate
//! /particles/fluid/id          [N]        u64  global ids (rows are in id order in every frame)
//! /particles/fluid/box         attributes dimension, boundary; edges [D]
//! /particles/fluid/box/lees_edwards_offset/{step, time, value}   offset s(t) of each frame
//! /particles/fluid/<field>/{step [F], time [F], value [F, N, D]}  position, velocity, force (f64),
//!                                                               image (i32)
//! /observables/<name>/{step [S], time [S], value [S] or [S, bins]}  sampled series (at the end)
//! ```
//!
//! Every rank writes the rows of its global-id block into the shared datasets (see
//! [`super::shared_file`]), so a file does not depend on the rank count. Each frame opens and
//! closes the file, so a crash loses at most the frame being written; a restart drops frames
//! written after its checkpoint.

use super::shared_file::{SharedFile, read_block};
use crate::config::SnapshotField;
use crate::diagnostics::Series;
use crate::domain::id_block;
use crate::geometry::Boundary;
use crate::particles::Particles;
use crate::sim::Simulation;
use std::path::{Path, PathBuf};

/// File name of the snapshot series.
pub const FILE: &str = "snapshots.h5";
/// File name of its XDMF sidecar.
pub const XDMF: &str = "snapshots.xdmf";
/// H5MD particle group.
pub const GROUP: &str = "particles/fluid";

/// Appends frames to `OUT/snapshots.h5`.
pub struct SnapshotWriter {
    path: PathBuf,
    xdmf: PathBuf,
    fields: Vec<SnapshotField>,
    /// (step, time) of every frame in the file.
    frames: Vec<(u64, f64)>,
}

fn field_dataset(f: SnapshotField) -> String {
    format!("{GROUP}/{}", f.name())
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
        let mut writer = Self {
            path: out.join(FILE),
            xdmf: out.join(XDMF),
            fields: sim.case.output.snapshot_fields.clone(),
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
                writer.create(sim)?;
            }
        } else {
            writer.create(sim)?;
        }
        Ok(writer)
    }

    fn create<const D: usize>(&mut self, sim: &Simulation<'_, D>) -> Result<(), String> {
        let comm = sim.comm();
        let n = sim.total_particles as usize;
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
        f.group(GROUP)?;
        let bx = format!("{GROUP}/box");
        f.group(&bx)?;
        f.attr("/", "dimension", &(D as i32))?;
        f.attr(&bx, "dimension", &(D as i32))?;
        let boundary: Vec<&str> = sim
            .sim_box
            .boundaries
            .iter()
            .map(|b| match b {
                Boundary::Periodic => "periodic",
                Boundary::Wall => "none",
            })
            .collect();
        f.attr_str_array(&bx, "boundary", &boundary)?;
        f.dataset::<f64>(&format!("{bx}/edges"), &[D], false)?;
        let root = comm.rank() == 0;
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
        let block = id_block(sim.total_particles, comm.size(), comm.rank());
        let ids: Vec<u64> = block.clone().collect();
        f.dataset::<u64>(&format!("{GROUP}/id"), &[n], false)?;
        f.write(
            &format!("{GROUP}/id"),
            &[block.start as usize],
            &[ids.len()],
            &ids,
        )?;
        for &field in &self.fields {
            let g = field_dataset(field);
            f.group(&g)?;
            f.dataset::<u64>(&format!("{g}/step"), &[0], true)?;
            f.dataset::<f64>(&format!("{g}/time"), &[0], true)?;
            match field {
                SnapshotField::Image => {
                    f.dataset::<i32>(&format!("{g}/value"), &[0, n, D], true)?
                }
                _ => f.dataset::<f64>(&format!("{g}/value"), &[0, n, D], true)?,
            }
        }
        f.close()
    }

    fn time_series(&self) -> Vec<String> {
        let mut v = vec![format!("{GROUP}/box/lees_edwards_offset")];
        v.extend(self.fields.iter().map(|&f| field_dataset(f)));
        v
    }

    fn reopen<const D: usize>(&mut self, sim: &Simulation<'_, D>) -> Result<(), String> {
        let comm = sim.comm();
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
            let g = format!("{GROUP}/box/lees_edwards_offset");
            let steps: Vec<u64> = read_block(&f, &format!("{g}/step"), &[0], &[len])?;
            let times: Vec<f64> = read_block(&f, &format!("{g}/time"), &[0], &[len])?;
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
        // Only the core fields travel (a model's ensembles are not part of a frame).
        let mine: Particles<D> =
            super::id_ordered(&sim.particles.owned_core(), sim.total_particles, comm)?;
        let n = sim.total_particles as usize;
        let block = id_block(sim.total_particles, comm.size(), comm.rank());
        let (start, rows) = (block.start as usize, mine.n_owned);
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
        let le = format!("{GROUP}/box/lees_edwards_offset/value");
        let offset = sim.sim_box.le_offset(sim.step, sim.dt());
        let k = usize::from(root);
        f.write(&le, &[frame], &[k], &[offset][..k])?;
        for &field in &self.fields {
            let ds = format!("{}/value", field_dataset(field));
            let shape = [1, rows, D];
            let at = [frame, start, 0];
            match field {
                SnapshotField::Position => f.write(&ds, &at, &shape, mine.pos.as_flattened())?,
                SnapshotField::Velocity => f.write(&ds, &at, &shape, mine.vel.as_flattened())?,
                SnapshotField::Force => f.write(&ds, &at, &shape, mine.force.as_flattened())?,
                SnapshotField::Image => f.write(&ds, &at, &shape, mine.image.as_flattened())?,
            }
        }
        f.close()?;
        self.frames.push((sim.step, sim.time()));
        let written = if root {
            write_atomically(&self.xdmf, &xdmf::<D>(FILE, n, &self.fields, &self.frames))
        } else {
            Ok(())
        };
        super::collective_ok(comm, written, "XDMF sidecar")
    }

    /// Writes the sampled observables (H5MD `/observables`) and the sidecar (collective).
    pub fn finish<const D: usize>(&mut self, sim: &Simulation<'_, D>) -> Result<(), String> {
        let comm = sim.comm();
        let mut f = SharedFile::append(&self.path, comm)?;
        f.unlink("observables")?;
        write_observables(&mut f, &sim.series, sim.dt(), comm.rank() == 0)?;
        f.close()?;
        if comm.rank() == 0 {
            let text = xdmf::<D>(
                FILE,
                sim.total_particles as usize,
                &self.fields,
                &self.frames,
            );
            write_atomically(&self.xdmf, &text)?;
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

/// The XDMF 3 sidecar: a temporal collection with one polyvertex grid per frame, each reading
/// hyperslab `[frame, :, :]` of the H5MD datasets. Vectors are N × 3 `Vector` attributes in 2D
/// too, as VTK and ParaView need them (an N × 2 one is read as a single tuple of 2N
/// components): a `JOIN($0, $1, 0 * $0)` of the x and y columns and a zero z column, computed
/// by the reader, so the file keeps its two components.
pub fn xdmf<const D: usize>(
    h5_name: &str,
    n: usize,
    fields: &[SnapshotField],
    frames: &[(u64, f64)],
) -> String {
    let total = frames.len();
    let slab = |field: SnapshotField, frame: usize| -> String {
        let (number, precision) = match field {
            SnapshotField::Image => ("Int", 4),
            _ => ("Float", 8),
        };
        format!(
            "        <DataItem ItemType=\"HyperSlab\" Dimensions=\"{n} {D}\" Type=\"HyperSlab\">\n\
             \x20         <DataItem Dimensions=\"3 3\" Format=\"XML\">{frame} 0 0 1 1 1 1 {n} {D}</DataItem>\n\
             \x20         <DataItem Dimensions=\"{total} {n} {D}\" NumberType=\"{number}\" Precision=\"{precision}\" Format=\"HDF\">{h5_name}:/{GROUP}/{}/value</DataItem>\n\
             \x20       </DataItem>\n",
            field.name()
        )
    };
    // One column of a 2D field in frame `frame`, as an N × 1 hyperslab.
    let column = |field: SnapshotField, frame: usize, c: usize| -> String {
        let (number, precision) = match field {
            SnapshotField::Image => ("Int", 4),
            _ => ("Float", 8),
        };
        format!(
            "          <DataItem ItemType=\"HyperSlab\" Dimensions=\"{n} 1\" Type=\"HyperSlab\">\n\
             \x20           <DataItem Dimensions=\"3 3\" Format=\"XML\">{frame} 0 {c} 1 1 1 1 {n} 1</DataItem>\n\
             \x20           <DataItem Dimensions=\"{total} {n} {D}\" NumberType=\"{number}\" Precision=\"{precision}\" Format=\"HDF\">{h5_name}:/{GROUP}/{}/value</DataItem>\n\
             \x20         </DataItem>\n",
            field.name()
        )
    };
    let vector = |field: SnapshotField, frame: usize| -> String {
        if D == 3 {
            slab(field, frame)
        } else {
            format!(
                "        <DataItem ItemType=\"Function\" Function=\"JOIN($0, $1, 0 * $0)\" Dimensions=\"{n} 3\">\n{}{}        </DataItem>\n",
                column(field, frame, 0),
                column(field, frame, 1)
            )
        }
    };
    let mut s = String::from(
        "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
    );
    for (k, &(step, time)) in frames.iter().enumerate() {
        s.push_str(&format!(
            "    <Grid Name=\"step_{step}\" GridType=\"Uniform\">\n      <Time Value=\"{time:e}\"/>\n      \
             <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\"/>\n"
        ));
        s.push_str(&format!(
            "      <Geometry GeometryType=\"{}\">\n",
            if D == 3 { "XYZ" } else { "XY" }
        ));
        s.push_str(&slab(SnapshotField::Position, k));
        s.push_str("      </Geometry>\n");
        s.push_str(&format!(
            "      <Attribute Name=\"id\" AttributeType=\"Scalar\" Center=\"Node\">\n        \
             <DataItem Dimensions=\"{n}\" NumberType=\"UInt\" Precision=\"8\" Format=\"HDF\">{h5_name}:/{GROUP}/id</DataItem>\n      </Attribute>\n"
        ));
        for &field in fields {
            if field == SnapshotField::Position {
                continue;
            }
            s.push_str(&format!(
                "      <Attribute Name=\"{}\" AttributeType=\"Vector\" Center=\"Node\">\n",
                field.name(),
            ));
            s.push_str(&vector(field, k));
            s.push_str("      </Attribute>\n");
        }
        s.push_str("    </Grid>\n");
    }
    s.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    s
}
