//! What every blow-up diagnosis says.

/// The words every blow-up diagnosis carries (a force, a position or a moment sum that is not
/// finite, a particle beyond the neighbour list's reach, a fluid heating without bound):
/// `mesorheo run` exits with code 4 on it.
pub const UNSTABLE: &str = "the run is unstable";
