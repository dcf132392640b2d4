//! What stops a run, as types: a blow-up ([`Unstable`], naming the quantity, the particle and
//! the step), a case that is invalid or does not fit the machine, an I/O failure, or another
//! failure. `mesorheo run` takes its exit code from the variant ([`Error::exit_code`]), never
//! from the message's words.

use std::fmt;

/// The words every blow-up diagnosis carries (a force, a position or a moment sum that is not
/// finite, a particle beyond the neighbour list's reach, a fluid heating without bound), so a
/// reader of a log finds them all with one search.
pub const UNSTABLE: &str = "the run is unstable";

/// The quantity a blow-up detector found out of range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// A pair force not finite or beyond the fixed-point sums' range.
    PairForce,
    /// A pair's momentum-flux term not finite or beyond range.
    MomentumFlux,
    /// The moment sums of a corrected derivative (MSPH) not finite.
    MomentSums,
    /// A density zero, negative or not finite.
    Density,
    /// A particle moved beyond the neighbour list's reach, or its position is not finite.
    Displacement,
    /// A particle's peculiar kinetic energy beyond any thermal value.
    KineticEnergy,
    /// The fluid's kinetic temperature beyond the thermostat's bound.
    Temperature,
    /// A dumbbell connector beyond its spring's domain (or a runaway Hookean one).
    Connector,
    /// A per-particle state variable of a model (a polymer stress, a conformation) not finite.
    ModelState,
}

impl fmt::Display for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Quantity::PairForce => "pair force",
            Quantity::MomentumFlux => "momentum flux",
            Quantity::MomentSums => "moment sums",
            Quantity::Density => "density",
            Quantity::Displacement => "displacement",
            Quantity::KineticEnergy => "kinetic energy",
            Quantity::Temperature => "temperature",
            Quantity::Connector => "connector",
            Quantity::ModelState => "model state",
        })
    }
}

/// A blow-up: what was out of range, on which particle (its global id, when one is to blame),
/// at which step, and the diagnosis a user reads (which contains [`UNSTABLE`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct Unstable {
    /// What was found out of range.
    pub quantity: Quantity,
    /// The particle it was found on (its global id), if one is to blame.
    pub particle: Option<u64>,
    /// The step at which it was found.
    pub step: u64,
    /// The diagnosis, with the values and what to change.
    pub message: String,
}

impl Unstable {
    /// A blow-up of `quantity`; `message` must say [`UNSTABLE`] (checked in debug builds).
    pub fn new(quantity: Quantity, particle: Option<u64>, step: u64, message: String) -> Self {
        debug_assert!(message.contains(UNSTABLE), "{message}");
        Self {
            quantity,
            particle,
            step,
            message,
        }
    }
}

/// Why a run stopped before its end.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The run blew up (exit code 4).
    #[error(transparent)]
    Unstable(#[from] Unstable),
    /// The case asks for something impossible (exit code 2).
    #[error("{0}")]
    InvalidCase(String),
    /// The case does not fit the machine: memory, or the slabs of the rank count (exit code 2).
    #[error("{0}")]
    DoesNotFit(String),
    /// A file or directory could not be read or written (exit code 1).
    #[error("{context}: {source}")]
    Io {
        /// What was being read or written, and where.
        context: String,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// Anything else: a corrupt checkpoint, a library or communication failure (exit code 1).
    #[error("{0}")]
    Failed(String),
}

impl Error {
    /// The exit code of `mesorheo run` for this error: 2 an invalid case or one that does not
    /// fit, 4 a blow-up, 1 anything else (3 is a failed reference check, not an error).
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::InvalidCase(_) | Error::DoesNotFit(_) => 2,
            Error::Unstable(_) => 4,
            Error::Io { .. } | Error::Failed(_) => 1,
        }
    }

    /// The blow-up, if this is one.
    pub fn unstable(&self) -> Option<&Unstable> {
        match self {
            Error::Unstable(u) => Some(u),
            _ => None,
        }
    }

    /// An I/O error with what was being done.
    pub fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        Error::Io {
            context: context.into(),
            source,
        }
    }
}

/// The message-only errors of the layers that do not yet classify theirs: a failure.
impl From<String> for Error {
    fn from(message: String) -> Self {
        Error::Failed(message)
    }
}

impl From<&str> for Error {
    fn from(message: &str) -> Self {
        Error::Failed(message.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_follow_the_variant_not_the_words() {
        let blow_up = Error::from(Unstable::new(
            Quantity::Density,
            Some(7),
            12,
            format!("particle 7 has density ρ = -1 at step 12: {UNSTABLE}"),
        ));
        assert_eq!(blow_up.exit_code(), 4);
        assert_eq!(blow_up.unstable().map(|u| u.particle), Some(Some(7)));
        // A message that happens to carry the words is still a plain failure.
        assert_eq!(
            Error::from(format!("not a blow-up: {UNSTABLE}")).exit_code(),
            1
        );
        assert_eq!(Error::InvalidCase("dt < 0".into()).exit_code(), 2);
        assert_eq!(Error::DoesNotFit("2 TiB".into()).exit_code(), 2);
        let io = Error::io(
            "writing out/summary.json",
            std::io::Error::other("disk full"),
        );
        assert_eq!(io.exit_code(), 1);
        assert_eq!(io.to_string(), "writing out/summary.json: disk full");
    }
}
