//! One HDF5 file written by every rank: all ranks create the same groups, datasets and
//! attributes, then each writes its own hyperslab
//! (docs/architecture.md, "Output, checkpoints, runs": "all ranks create the same datasets, then
//! each writes its hyperslab; never rank 0 creates metadata").
//!
//! Two transports, one calling sequence:
//! - **MPI-IO** (an `mpirun` run of the `mpi` build): the file is opened collectively with the
//!   MPI-IO driver; metadata calls are collective (identical arguments on every rank) and the
//!   data writes are independent, as hdf5-metno's high-level API does them.
//! - **Turns** (one process: the serial communicator or in-process ranks, which share one HDF5
//!   library guarded by a global lock): rank 0 creates the file, its metadata and its own
//!   hyperslabs; the other ranks keep their hyperslabs and, at [`SharedFile::close`], open the
//!   closed file in turn, in rank order, and write them.
//!
//! Readers open files independently (every rank reads the rows it needs).

use crate::comm::Comm;
use hdf5::{Extent, H5Type, Hyperslab, Selection, SliceOrIndex};
use ndarray::{ArrayViewD, IxDyn};
use std::path::{Path, PathBuf};

/// A buffer waiting for its rank's turn.
enum Pending {
    F64(Vec<f64>),
    F32(Vec<f32>),
    U64(Vec<u64>),
    I32(Vec<i32>),
    U8(Vec<u8>),
}

struct PendingWrite {
    dataset: String,
    start: Vec<usize>,
    shape: Vec<usize>,
    data: Pending,
}

/// Element types a [`SharedFile`] stores.
pub trait Element: H5Type + Copy + 'static {
    /// Wraps a buffer for a deferred write.
    fn pending(data: Vec<Self>) -> PendingBuf;
}

/// Opaque deferred buffer (see [`Element`]).
pub struct PendingBuf(Pending);

macro_rules! element {
    ($($t:ty => $variant:ident),*) => {$(
        impl Element for $t {
            fn pending(data: Vec<Self>) -> PendingBuf {
                PendingBuf(Pending::$variant(data))
            }
        }
    )*};
}
element!(f64 => F64, f32 => F32, u64 => U64, i32 => I32, u8 => U8);

/// An HDF5 file being written by every rank (collective).
pub struct SharedFile<'c> {
    comm: &'c dyn Comm,
    path: PathBuf,
    /// Open on every rank (MPI-IO) or on rank 0 only (turns).
    file: Option<hdf5::File>,
    collective: bool,
    pending: Vec<PendingWrite>,
    /// The first error on this rank. Errors are sticky and reported by [`SharedFile::close`]
    /// (collectively), never returned early: a rank that stopped half-way through a sequence of
    /// collective calls would leave the others waiting forever.
    error: std::cell::RefCell<Option<String>>,
}

fn h5err(path: &Path, what: &str, e: hdf5::Error) -> String {
    format!("{}: {what}: {e}", path.display())
}

/// A hyperslab `start[k] .. start[k] + shape[k]`.
fn hyperslab(start: &[usize], shape: &[usize]) -> Selection {
    let slices: Vec<SliceOrIndex> = start
        .iter()
        .zip(shape)
        .map(|(&s, &n)| SliceOrIndex::SliceCount {
            start: s,
            step: 1,
            count: n,
            block: 1,
        })
        .collect();
    Selection::from(Hyperslab::from(slices))
}

impl<'c> SharedFile<'c> {
    /// Creates (truncates) `path` on every rank (collective).
    pub fn create(path: &Path, comm: &'c dyn Comm) -> Result<Self, String> {
        Self::open_with(path, comm, true)
    }

    /// Opens an existing file for appending (collective).
    pub fn append(path: &Path, comm: &'c dyn Comm) -> Result<Self, String> {
        Self::open_with(path, comm, false)
    }

    fn open_with(path: &Path, comm: &'c dyn Comm, create: bool) -> Result<Self, String> {
        #[cfg(feature = "mpi")]
        if let Some(raw) = comm.raw_mpi() {
            let mut builder = super::h5_options();
            builder.with_fapl(|p| {
                p.mpio(raw, None)
                    .all_coll_metadata_ops(true)
                    .coll_metadata_write(true)
            });
            let file = if create {
                builder.create(path)
            } else {
                builder.open_rw(path)
            }
            .map_err(|e| h5err(path, "cannot open for parallel writing", e));
            let mut failed = [if file.is_err() { 1.0 } else { 0.0 }];
            comm.allreduce_max(&mut failed);
            let (file, error) = match file {
                Err(e) => (None, Some(e)),
                Ok(_) if failed[0] > 0.0 => (
                    None,
                    Some(format!(
                        "{}: cannot be opened on another rank",
                        path.display()
                    )),
                ),
                Ok(f) => (Some(f), None),
            };
            return Ok(Self {
                comm,
                path: path.to_path_buf(),
                file,
                collective: true,
                pending: Vec::new(),
                error: std::cell::RefCell::new(error),
            });
        }
        let mut error = None;
        let file = if comm.rank() == 0 {
            let f = if create {
                super::h5_options().create(path)
            } else {
                super::h5_options().open_rw(path)
            };
            f.map_err(|e| error = Some(h5err(path, "cannot open for writing", e)))
                .ok()
        } else {
            None
        };
        Ok(Self {
            comm,
            path: path.to_path_buf(),
            file,
            collective: false,
            pending: Vec::new(),
            error: std::cell::RefCell::new(error),
        })
    }

    /// Whether this rank runs the metadata calls (every rank under MPI-IO, rank 0 otherwise).
    fn does_metadata(&self) -> bool {
        self.file.is_some() && (self.collective || self.comm.rank() == 0)
    }

    /// The open file, on ranks that run metadata calls.
    pub fn metadata_file(&self) -> Option<&hdf5::File> {
        if self.does_metadata() {
            self.file.as_ref()
        } else {
            None
        }
    }

    /// Creates a group and its parents (collective).
    fn try_group(&self, name: &str) -> Result<(), String> {
        if let Some(f) = self.metadata_file() {
            if f.link_exists(name) {
                return Ok(());
            }
            f.create_group(name)
                .map_err(|e| h5err(&self.path, &format!("cannot create group {name}"), e))?;
        }
        Ok(())
    }

    /// Creates dataset `name` of `shape` (collective). `resizable_first` makes the first
    /// dimension unlimited (a time axis) with chunks of one frame.
    fn try_dataset<T: Element>(
        &self,
        name: &str,
        shape: &[usize],
        resizable_first: bool,
    ) -> Result<(), String> {
        let Some(f) = self.metadata_file() else {
            return Ok(());
        };
        let extents: Vec<Extent> = shape
            .iter()
            .enumerate()
            .map(|(k, &n)| {
                if k == 0 && resizable_first {
                    Extent::resizable(n)
                } else {
                    Extent::from(n)
                }
            })
            .collect();
        let mut builder = f.new_dataset::<T>();
        if resizable_first {
            let mut chunk: Vec<usize> = shape.iter().map(|&n| n.max(1)).collect();
            chunk[0] = 1;
            // Chunks of at most ~1 MiB along the particle axis.
            if chunk.len() > 1 {
                let row: usize = chunk[2..].iter().product::<usize>() * size_of::<T>();
                chunk[1] = chunk[1].min((1 << 20) / row.max(1)).max(1);
            }
            builder = builder.chunk(chunk);
        }
        builder
            .shape(extents)
            .create(name)
            .map_err(|e| h5err(&self.path, &format!("cannot create dataset {name}"), e))?;
        Ok(())
    }

    /// Grows the first dimension of `name` to `len` (collective).
    fn try_resize_first(&self, name: &str, len: usize) -> Result<(), String> {
        let Some(f) = self.metadata_file() else {
            return Ok(());
        };
        let ds = f
            .dataset(name)
            .map_err(|e| h5err(&self.path, &format!("no dataset {name}"), e))?;
        let mut shape = ds.shape();
        shape[0] = len;
        ds.resize(shape)
            .map_err(|e| h5err(&self.path, &format!("cannot resize {name}"), e))
    }

    /// Writes a scalar or string attribute on the object at `on` (collective).
    fn try_attr<T: H5Type>(&self, on: &str, name: &str, value: &T) -> Result<(), String> {
        let Some(f) = self.metadata_file() else {
            return Ok(());
        };
        let what = format!("cannot write attribute {on}@{name}");
        let write = || -> hdf5::Result<()> {
            let loc: hdf5::Location = if on == "/" {
                (***f).clone()
            } else if let Ok(g) = f.group(on) {
                (*g).clone()
            } else {
                (**f.dataset(on)?).clone()
            };
            let a = loc.new_attr::<T>().create(name)?;
            a.write_scalar(value)
        };
        write().map_err(|e| h5err(&self.path, &what, e))
    }

    /// Writes a one-dimensional array attribute (collective).
    fn try_attr_array<T: H5Type>(&self, on: &str, name: &str, values: &[T]) -> Result<(), String> {
        let Some(f) = self.metadata_file() else {
            return Ok(());
        };
        let what = format!("cannot write attribute {on}@{name}");
        let write = || -> hdf5::Result<()> {
            let loc: hdf5::Location = if on == "/" {
                (***f).clone()
            } else {
                (*f.group(on)?).clone()
            };
            let a = loc.new_attr::<T>().shape(values.len()).create(name)?;
            a.write_raw(values)
        };
        write().map_err(|e| h5err(&self.path, &what, e))
    }

    /// Writes an array-of-strings attribute (collective).
    fn try_attr_str_array(&self, on: &str, name: &str, values: &[&str]) -> Result<(), String> {
        let v: Vec<hdf5::types::VarLenUnicode> = values
            .iter()
            .map(|s| s.parse())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("{}: attribute {name}: {e}", self.path.display()))?;
        self.try_attr_array(on, name, &v)
    }

    /// Removes a link (group or dataset) if it exists (collective).
    fn try_unlink(&self, name: &str) -> Result<(), String> {
        if let Some(f) = self.metadata_file()
            && f.link_exists(name)
        {
            f.unlink(name)
                .map_err(|e| h5err(&self.path, &format!("cannot remove {name}"), e))?;
        }
        Ok(())
    }

    /// Writes a string attribute (collective).
    fn try_attr_str(&self, on: &str, name: &str, value: &str) -> Result<(), String> {
        let v: hdf5::types::VarLenUnicode = value
            .parse()
            .map_err(|e| format!("{}: attribute {name}: {e}", self.path.display()))?;
        self.try_attr(on, name, &v)
    }

    fn note(&self, r: Result<(), String>) {
        if let Err(e) = r {
            self.error.borrow_mut().get_or_insert(e);
        }
    }

    /// Whether this rank should still run metadata calls: always under MPI-IO (they are
    /// collective), only while nothing failed otherwise.
    fn proceed(&self) -> bool {
        self.collective || self.error.borrow().is_none()
    }

    /// Creates a group (collective).
    pub fn group(&self, name: &str) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_group(name));
        }
        Ok(())
    }

    /// Creates dataset `name` of `shape` (collective). `resizable_first` makes the first
    /// dimension unlimited (a time axis) with chunks of one frame.
    pub fn dataset<T: Element>(
        &self,
        name: &str,
        shape: &[usize],
        resizable_first: bool,
    ) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_dataset::<T>(name, shape, resizable_first));
        }
        Ok(())
    }

    /// Grows the first dimension of `name` to `len` (collective).
    pub fn resize_first(&self, name: &str, len: usize) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_resize_first(name, len));
        }
        Ok(())
    }

    /// Writes a scalar attribute on the object at `on` (collective).
    pub fn attr<T: H5Type>(&self, on: &str, name: &str, value: &T) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_attr(on, name, value));
        }
        Ok(())
    }

    /// Writes a one-dimensional array attribute (collective).
    pub fn attr_array<T: H5Type>(&self, on: &str, name: &str, values: &[T]) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_attr_array(on, name, values));
        }
        Ok(())
    }

    /// Writes an array-of-strings attribute (collective).
    pub fn attr_str_array(&self, on: &str, name: &str, values: &[&str]) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_attr_str_array(on, name, values));
        }
        Ok(())
    }

    /// Removes a link if it exists (collective).
    pub fn unlink(&self, name: &str) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_unlink(name));
        }
        Ok(())
    }

    /// Writes a string attribute (collective).
    pub fn attr_str(&self, on: &str, name: &str, value: &str) -> Result<(), String> {
        if self.proceed() {
            self.note(self.try_attr_str(on, name, value));
        }
        Ok(())
    }

    /// Writes this rank's hyperslab `start .. start + shape` of dataset `name` (`data` in C
    /// order). Not collective: every rank calls it for its own block (an empty block is fine).
    pub fn write<T: Element>(
        &mut self,
        name: &str,
        start: &[usize],
        shape: &[usize],
        data: &[T],
    ) -> Result<(), String> {
        debug_assert_eq!(shape.iter().product::<usize>(), data.len());
        if self.error.borrow().is_some() {
            return Ok(());
        }
        if self.collective || self.comm.rank() == 0 {
            let r = match self.file.as_ref() {
                Some(f) => write_block(f, &self.path, name, start, shape, data),
                None => Err(format!("{}: not open", self.path.display())),
            };
            self.note(r);
            return Ok(());
        }
        self.pending.push(PendingWrite {
            dataset: name.to_owned(),
            start: start.to_vec(),
            shape: shape.to_vec(),
            data: T::pending(data.to_vec()).0,
        });
        Ok(())
    }

    /// Closes the file; in turns mode the other ranks then write their blocks one after the
    /// other. Collective; every rank returns the same verdict.
    pub fn close(mut self) -> Result<(), String> {
        let mut result = match self.error.borrow_mut().take() {
            Some(e) => Err(e),
            None => Ok(()),
        };
        if let Some(f) = self.file.take()
            && let Err(e) = f.close()
        {
            result = Err(h5err(&self.path, "cannot close", e));
        }
        if !self.collective {
            for turn in 1..self.comm.size() {
                self.comm.barrier();
                if turn == self.comm.rank() && result.is_ok() {
                    result = self.write_pending();
                }
            }
        }
        let mut failed = [if result.is_err() { 1.0 } else { 0.0 }];
        self.comm.allreduce_max(&mut failed);
        match result {
            Err(e) => Err(e),
            Ok(()) if failed[0] > 0.0 => Err(format!(
                "{}: another rank failed to write its part",
                self.path.display()
            )),
            Ok(()) => Ok(()),
        }
    }

    fn write_pending(&mut self) -> Result<(), String> {
        let f = super::h5_options()
            .open_rw(&self.path)
            .map_err(|e| h5err(&self.path, "cannot reopen for writing", e))?;
        for w in std::mem::take(&mut self.pending) {
            let (n, s, sh) = (&w.dataset, &w.start, &w.shape);
            match &w.data {
                Pending::F64(d) => write_block(&f, &self.path, n, s, sh, d)?,
                Pending::F32(d) => write_block(&f, &self.path, n, s, sh, d)?,
                Pending::U64(d) => write_block(&f, &self.path, n, s, sh, d)?,
                Pending::I32(d) => write_block(&f, &self.path, n, s, sh, d)?,
                Pending::U8(d) => write_block(&f, &self.path, n, s, sh, d)?,
            }
        }
        f.close()
            .map_err(|e| h5err(&self.path, "cannot close after writing", e))
    }
}

fn write_block<T: H5Type>(
    f: &hdf5::File,
    path: &Path,
    name: &str,
    start: &[usize],
    shape: &[usize],
    data: &[T],
) -> Result<(), String> {
    let ds = f
        .dataset(name)
        .map_err(|e| h5err(path, &format!("no dataset {name}"), e))?;
    if data.is_empty() {
        return Ok(());
    }
    let view = ArrayViewD::from_shape(IxDyn(shape), data)
        .map_err(|e| format!("{}: {name}: {e}", path.display()))?;
    ds.write_slice(view, hyperslab(start, shape))
        .map_err(|e| h5err(path, &format!("cannot write {name}"), e))
}

/// Reads the hyperslab `start .. start + shape` of dataset `name` (independent).
pub fn read_block<T: H5Type + Copy>(
    f: &hdf5::File,
    name: &str,
    start: &[usize],
    shape: &[usize],
) -> Result<Vec<T>, String> {
    let path = f.filename();
    let ds = f
        .dataset(name)
        .map_err(|e| format!("{path}: no dataset {name}: {e}"))?;
    let have = ds.shape();
    if have.len() != shape.len()
        || start
            .iter()
            .zip(shape)
            .zip(&have)
            .any(|((&s, &n), &h)| s + n > h)
    {
        return Err(format!(
            "{path}: dataset {name} has shape {have:?}, cannot read {shape:?} at {start:?}"
        ));
    }
    if shape.contains(&0) {
        return Ok(Vec::new());
    }
    let a: ndarray::ArrayD<T> = ds
        .read_slice(hyperslab(start, shape))
        .map_err(|e| format!("{path}: cannot read {name}: {e}"))?;
    Ok(a.iter().copied().collect())
}

/// Reads a scalar attribute of the object at `on`.
pub fn read_attr<T: H5Type>(f: &hdf5::File, on: &str, name: &str) -> Result<T, String> {
    let path = f.filename();
    let loc: hdf5::Location = if on == "/" {
        (***f).clone()
    } else if let Ok(g) = f.group(on) {
        (*g).clone()
    } else {
        (**f.dataset(on)
            .map_err(|e| format!("{path}: no object {on}: {e}"))?)
        .clone()
    };
    loc.attr(name)
        .and_then(|a| a.read_scalar::<T>())
        .map_err(|e| format!("{path}: attribute {on}@{name}: {e}"))
}

/// Reads a string attribute.
pub fn read_attr_str(f: &hdf5::File, on: &str, name: &str) -> Result<String, String> {
    read_attr::<hdf5::types::VarLenUnicode>(f, on, name).map(|s| s.as_str().to_owned())
}
