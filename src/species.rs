//! Particle species: fluid particles, and the boundary particles of walls and inclusions,
//! each with its mass and its motion.
//!
//! A scene with one species (every particle a free fluid particle of the case's mass) keeps no
//! species at all ([`crate::particles::Particles::species`] is `None`), so it pays nothing for
//! them. Boundary particles are owned, migrated, sent to ghosts and enter every pair sum like
//! fluid particles; what differs:
//!
//! - **frozen** ones are never integrated (they cost no integration arithmetic);
//! - **prescribed** ones move at a constant velocity, r(t+Δt) = r + Δt V, v = V (a moving
//!   wall of a Couette cell), whatever the force on them;
//! - neither is reflected at box walls, and neither counts as fluid in the diagnostics.

/// How particles of a species move.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Motion {
    /// Integrated with the forces (fluid).
    Free,
    /// Never moved.
    Frozen,
    /// Moved at this constant velocity (its first D components).
    Prescribed([f64; 3]),
}

/// One species.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Species {
    /// Name (for logs and outputs).
    pub name: String,
    /// Mass of each particle.
    pub mass: f64,
    /// How its particles move.
    pub motion: Motion,
}

impl Species {
    /// A free fluid species.
    pub fn fluid(mass: f64) -> Self {
        Self {
            name: "fluid".into(),
            mass,
            motion: Motion::Free,
        }
    }

    /// The snapshot group of its particles (`/particles/<group>` in `OUT/snapshots.h5`, one
    /// XDMF grid each, so a viewer shows them apart): `fluid` for a fluid species, else the last
    /// word of its name in lower case ("lower wall" and "upper wall" → `wall`, "inclusion" →
    /// `inclusion`).
    pub fn group(&self) -> String {
        if self.is_fluid() {
            return "fluid".into();
        }
        let word = self.name.split_whitespace().last().unwrap_or("boundary");
        word.chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() {
                    c.to_ascii_lowercase()
                } else {
                    '_'
                }
            })
            .collect()
    }

    /// Whether its particles are fluid (integrated with the forces, counted in diagnostics).
    pub fn is_fluid(&self) -> bool {
        self.motion == Motion::Free
    }
}
