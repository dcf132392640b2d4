//! The per-particle fields an SPH fluid declares, and the species of its boundary particles
//! (walls and inclusions).

#[allow(unused_imports)]
use super::*;

/// Field names.
pub const DENSITY: &str = "density";
/// dρ/dt (continuity density).
pub const DENSITY_RATE: &str = "density_rate";
/// The Newtonian viscous stress η(G + Gᵀ − (2/d) tr G I), D×D row-major: with the nested
/// summation (it enters the momentum equation), and with Morris's term in a polymer fluid
/// (then only measured: the viscometric observables add it to the polymer stress).
pub const VISCOUS_STRESS: &str = "viscous_stress";
/// The polymer stress τ (`[fluid.polymer]`), packed symmetric ([`maxwell::packed_index`]).
pub const POLYMER_STRESS: &str = "polymer_stress";
/// Its constitutive rate dτ/dt.
pub const POLYMER_STRESS_RATE: &str = "polymer_stress_rate";
/// The XSPH drift correction v̂ − v (D per particle).
pub const XSPH_CORRECTION: &str = "xsph_correction";
/// The velocity gradient G_i^{ab} = ∂v^a/∂x^b (D × D, row-major) of the last evaluation, kept
/// for the dumbbell ensembles (`model = "dumbbells"`), which step with it.
pub const VELOCITY_GRADIENT: &str = "velocity_gradient";
/// A boundary particle's velocity under `[walls] treatment = "mirror"`: 2U − v̂(m_w), the
/// fluid's velocity fitted at its mirror point (D per particle; [`mirror`]).
pub const MIRROR_VELOCITY: &str = "mirror_velocity";
/// An inclusion particle's offset x_j − c from its inclusion's centre (0 for every other
/// particle): constant, since inclusions are fixed.
pub const INCLUSION_OFFSET: &str = "inclusion_offset";
/// An inclusion particle's image velocity relative to its inclusion, w_j = v_j − U, under
/// `[inclusions] images = "fitted"`: the fluid's velocity fitted as a profile vanishing at the
/// surface and continued to the particle's depth (D per particle; [`ImageKernel`]).
pub const INCLUSION_IMAGE_VELOCITY: &str = "inclusion_image_velocity";
/// An inclusion particle's share of its inclusion's traction moment ∮ (σ·n) ⊗ (x − c) dS:
/// Σ_i F_{i→j}^a s_i^b over its fluid neighbours i, the pair force on it times the surface
/// point s_i = R n_i nearest i (relative to the centre), D×D row-major.
pub const INCLUSION_TRACTION_MOMENT: &str = "inclusion_traction_moment";

/// Species indices of a walled scene: the fluid, the wall at 0, the wall at L.
pub const FLUID: u8 = 0;
/// The wall at the lower face.
pub const LOWER_WALL: u8 = 1;
/// The wall at the upper face.
pub const UPPER_WALL: u8 = 2;
/// The boundary particles filling the inclusions.
pub const INCLUSION: u8 = 3;

/// Whether species `s` is one of the two walls.
pub fn is_wall(s: u8) -> bool {
    s == LOWER_WALL || s == UPPER_WALL
}

/// The species of a scene with boundary particles (fluid, lower wall, upper wall, and with
/// inclusions the inclusion particles), every particle of mass `mass`; a wall at rest and
/// the inclusions are frozen (never integrated). Without walls the wall species have no
/// particles.
pub fn boundary_species<const D: usize>(
    walls: Option<&WallsCfg>,
    inclusions: bool,
    mass: f64,
) -> Vec<Species> {
    let frozen = |name: &str| Species {
        name: name.into(),
        mass,
        motion: Motion::Frozen,
    };
    let mut table = match walls {
        Some(w) => wall_species::<D>(w, mass),
        None => vec![
            Species::fluid(mass),
            frozen("lower wall"),
            frozen("upper wall"),
        ],
    };
    if inclusions {
        table.push(frozen("inclusion"));
    }
    table
}

/// The species of a walled scene (fluid, lower wall, upper wall), every particle of mass
/// `mass`; a wall at rest is frozen (never integrated).
pub fn wall_species<const D: usize>(walls: &WallsCfg, mass: f64) -> Vec<Species> {
    let motion = |u: &[f64]| {
        if u.iter().all(|&x| x == 0.0) {
            Motion::Frozen
        } else {
            let mut v = [0.0; 3];
            v[..u.len().min(3)].copy_from_slice(&u[..u.len().min(3)]);
            Motion::Prescribed(v)
        }
    };
    vec![
        Species::fluid(mass),
        Species {
            name: "lower wall".into(),
            mass,
            motion: motion(&walls.lower_velocity),
        },
        Species {
            name: "upper wall".into(),
            mass,
            motion: motion(&walls.upper_velocity),
        },
    ]
}
