//! Files a run writes: checkpoints (complete state, restart on any rank count) and, built on
//! the same parallel writer, snapshots (H5MD + XDMF). Needs the `hdf5` feature.

pub mod checkpoint;
pub mod info;
pub mod shared_file;
pub mod snapshot;

use crate::comm::Comm;

/// Options for every HDF5 file mesorheo opens: HDF5's advisory file locks (`flock`) off.
///
/// The locks protect nothing here and break things:
/// - mesorheo never writes a published file in place. Checkpoints are written to `NAME.tmp`
///   and renamed, and the ranks writing one file are coordinated by the collective protocol of
///   [`shared_file::SharedFile`].
/// - HDF5 opens files without close-on-exec. A process that forks while a file is open (a test
///   harness or a workflow tool running mesorheo in-process) hands the writer's exclusive lock
///   to the child. Until the child exits, a later read of the published file then fails with
///   "unable to lock file, errno = 11". The restart test met exactly this.
/// - On parallel file systems without `flock` (Lustre mounted without `-o flock`) every locked
///   open fails. The usual workaround there is `HDF5_USE_FILE_LOCKING=FALSE`, which HDF5 still
///   honours above this setting.
///
/// HDF5 refuses to open a file a second time in one process with other locking flags ("file
/// locking flag values don't match"), so code that reads a mesorheo file while mesorheo may
/// have it open in the same process (tests, tools) opens it through these options too.
pub fn h5_options() -> hdf5::FileBuilder {
    let mut builder = hdf5::File::with_options();
    builder.with_fapl(|p| p.file_locking(false));
    builder
}
use crate::domain::{id_block, redistribute, sort_by_id};
use crate::particles::Particles;

/// The particles of this rank's global-id block `[N r/P, N (r+1)/P)`, sorted by id, gathered
/// from wherever they live (collective). Every file is written from these blocks, so its
/// content does not depend on the decomposition.
pub(crate) fn id_ordered<const D: usize>(
    owned: &Particles<D>,
    total: u64,
    comm: &dyn Comm,
) -> Result<Particles<D>, String> {
    let (rank, size) = (comm.rank(), comm.size());
    let mut mine = redistribute(owned, comm, |i| {
        let g = owned.gid[i];
        // Balanced blocks: the owner of g is the r with block(r).start ≤ g < block(r).end.
        let mut r = ((u128::from(g) * size as u128) / u128::from(total.max(1))) as usize;
        r = r.min(size - 1);
        while r > 0 && id_block(total, size, r).start > g {
            r -= 1;
        }
        while r + 1 < size && id_block(total, size, r).end <= g {
            r += 1;
        }
        r
    });
    sort_by_id(&mut mine);
    let dense = mine.gid.iter().copied().eq(id_block(total, size, rank));
    let mut bad = [if dense { 0.0 } else { 1.0 }];
    comm.allreduce_max(&mut bad);
    if bad[0] > 0.0 {
        return Err("particle ids are not 0..N−1; cannot write them in id order".into());
    }
    Ok(mine)
}

/// The same verdict on every rank: `local` if it failed here, else an error if it failed on
/// another rank (collective).
pub(crate) fn collective_ok(
    comm: &dyn Comm,
    local: Result<(), String>,
    what: &str,
) -> Result<(), String> {
    let mut failed = [if local.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut failed);
    match local {
        Err(e) => Err(e),
        Ok(()) if failed[0] > 0.0 => Err(format!("{what}: failed on another rank")),
        Ok(()) => Ok(()),
    }
}

/// Creates `dir` (and its parents) on rank 0; every rank returns the same verdict (collective).
pub(crate) fn create_dir_collective(dir: &std::path::Path, comm: &dyn Comm) -> Result<(), String> {
    let made = if comm.rank() == 0 {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))
    } else {
        Ok(())
    };
    collective_ok(comm, made, &format!("creating {}", dir.display()))
}
