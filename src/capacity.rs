//! Whether a case fits a rank count and a node: particles per rank (the neighbour list's 31-bit
//! indices), memory per rank against what the node has free, and the node's memory probes.
//! Checked by the run before anything is allocated, and reported by `check`.

use crate::config::Case;
use crate::geometry::ball_volume;

/// The value of the line `key:` of a /proc file given in kB, in bytes (None where the file or
/// the line is missing).
fn proc_bytes(file: &str, key: &str) -> Option<f64> {
    let text = std::fs::read_to_string(file).ok()?;
    let line = text
        .lines()
        .find(|l| l.strip_prefix(key).is_some_and(|r| r.starts_with(':')))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Bytes of MemAvailable on this node (None where /proc/meminfo is missing).
pub fn available_memory() -> Option<f64> {
    proc_bytes("/proc/meminfo", "MemAvailable")
}

/// This process's peak resident memory in bytes (VmHWM of /proc/self/status; None where it is
/// missing).
pub fn peak_resident_memory() -> Option<f64> {
    proc_bytes("/proc/self/status", "VmHWM")
}

/// Bytes per owned particle (core fields) and per neighbour entry / pair.
const BYTES_CORE: f64 = 8.0 + 4.0 * 8.0 * 3.0 + 4.0 * 3.0;

/// Largest rank count whose slabs are at least cutoff + skin wide.
pub fn max_ranks(case: &Case) -> usize {
    let axis = case.decomposition.axis.index();
    let range = case.cutoff() + case.neighbour.skin;
    (case.domain.lengths[axis] / range).floor().max(1.0) as usize
}

/// Most particles (owned and ghosts) one rank supports: the neighbour list keeps 31-bit
/// indices (the top bit of each entry marks pairs near at the build).
pub const MAX_PARTICLES_PER_RANK: f64 = (crate::neighbour::NEAR_AT_BUILD - 1) as f64;

/// Estimated (owned, ghost) particles per rank on `ranks` ranks: n/ranks owned; ghosts the
/// layers cutoff + skin thick on both slab faces (on one rank, the periodic self-images on
/// every face).
pub fn particles_per_rank(case: &Case, ranks: usize) -> (f64, f64) {
    let (_, n) = case.lattice_counts();
    let range = case.cutoff() + case.neighbour.skin;
    let slab = case.domain.lengths[case.decomposition.axis.index()] / ranks as f64;
    let owned = n as f64 / ranks as f64;
    let ghosts = if ranks == 1 {
        // self-images on every periodic face
        n as f64 * (2.0 * range * case.domain.lengths.iter().map(|l| 1.0 / l).sum::<f64>())
    } else {
        owned * 2.0 * range / slab
    };
    (owned, ghosts)
}

/// Refuses a rank count whose ranks would hold more particles than the neighbour list indexes
/// (before anything is allocated), naming the rank count that fits.
pub fn check_particles_per_rank(case: &Case, ranks: usize) -> Result<(), String> {
    let (owned, ghosts) = particles_per_rank(case, ranks);
    if owned + ghosts < MAX_PARTICLES_PER_RANK {
        return Ok(());
    }
    let fits = (ranks..=max_ranks(case)).find(|&r| {
        let (o, g) = particles_per_rank(case, r);
        o + g < MAX_PARTICLES_PER_RANK
    });
    Err(format!(
        "about {:.3e} particles ({owned:.3e} owned + {ghosts:.3e} ghosts) per rank on {ranks} \
         rank(s): at most 2^31 − 1 = {MAX_PARTICLES_PER_RANK:.0} fit one rank (31-bit neighbour \
         indices); {}",
        owned + ghosts,
        match fits {
            Some(r) => format!("run on at least {r} ranks"),
            None => format!(
                "even the {} ranks the slabs allow are too few: shrink the box or the density",
                max_ranks(case)
            ),
        }
    ))
}

/// Estimated bytes one rank needs on `ranks` ranks: the particles' core arrays (positions,
/// velocities, forces, ids, …) and the fluid model's fields, the ghosts, the neighbour list
/// (cutoff + skin; SPH adds its full list and the interleaved rows of its lanes, 4 bytes per
/// directed entry each) and the dumbbell ensembles a fluid particle carries. `tests/extremes.rs`
/// compares it with the measured peak of 3·10⁵-particle DPD and SPH runs.
pub fn rank_memory(case: &Case, ranks: usize) -> f64 {
    let dim = case.dimension;
    let (_, n) = case.lattice_counts();
    let volume: f64 = case.domain.lengths.iter().product();
    let density = n as f64 / volume;
    let list_neighbours = density * ball_volume(dim, case.cutoff() + case.neighbour.skin);
    let (owned, ghosts) = particles_per_rank(case, ranks);
    let bytes_entry = 8.0;
    let bytes_pair = 8.0 + (dim as f64 + 4.0) * 8.0;
    let memory = case.fluid.model().memory(case);
    let (model, full_lists) = (memory.numbers_per_particle, memory.full_lists);
    owned * (BYTES_CORE + 8.0 * model)
        + ghosts * (8.0 + 2.0 * 8.0 * dim as f64 + 8.0 * model)
        + owned * list_neighbours * (bytes_entry + 0.5 * bytes_pair + full_lists * 4.0)
        + owned * memory.ensemble_bytes
}

/// Refuses a rank count whose ranks would need more memory than `available` bytes (this node's
/// MemAvailable; no check when unknown), before anything is allocated, naming the rank count
/// that fits or, when no rank count does, the largest box that fits one rank.
pub fn check_rank_memory(case: &Case, ranks: usize, available: Option<f64>) -> Result<(), String> {
    let Some(available) = available else {
        return Ok(());
    };
    let gib = 1024.0 * 1024.0 * 1024.0;
    let need = rank_memory(case, ranks);
    // Leave a tenth for the rest of the process (buffers, output, MPI).
    let budget = 0.9 * available;
    if need <= budget {
        return Ok(());
    }
    let max = max_ranks(case);
    let fits = (ranks..=max).find(|&r| rank_memory(case, r) <= budget);
    // One rank's memory grows like the particle count, i.e. the box volume.
    let one = rank_memory(case, ranks.max(1));
    let scale = (budget / one).powf(1.0 / case.dimension as f64);
    let smaller: Vec<String> = case.domain.lengths[..case.dimension]
        .iter()
        .map(|l| format!("{:.4}", l * scale))
        .collect();
    Err(format!(
        "one rank needs about {:.2} GiB on {ranks} rank(s) but this machine has {:.2} GiB \
         available; {}",
        need / gib,
        available / gib,
        match fits {
            Some(r) => format!(
                "run on at least {r} ranks (with one rank per node like this one), or shrink the \
                 box to about [{}] on {ranks} rank(s)",
                smaller.join(", ")
            ),
            None => format!(
                "even the {max} ranks the slabs allow are too few: shrink the box to about [{}] \
                 (or lower the density)",
                smaller.join(", ")
            ),
        }
    ))
}
