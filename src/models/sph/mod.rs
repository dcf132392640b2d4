//! Weakly compressible SPH for Newtonian fluids (`[fluid] kind = "sph"`), with walls of
//! boundary particles (`[walls]`). Ellero 2004, ch. 2, as distilled with its printed errors
//! corrected in docs/theory/sph_maxwell.md §1–§2; notation x_ij = x_i − x_j, v_ij = v_i − v_j,
//! ∇_i W_ij = W'(r_ij) x_ij / r_ij.
//!
//! ```text
//! density, summation (Eq. 2.29)    ρ_i = Σ_j m_j W_ij              (j = i included)
//! density, continuity (Eq. 2.31)   dρ_i/dt = Σ_j m_j v_ij · ∇_i W_ij
//! quadratic EOS (Eq. 2.35)         p = c₀² ρ² / (2 ρ₀)            (p/ρ² = c₀²/(2ρ₀), constant)
//! Tait EOS (Eq. 2.38)              p = (c₀² ρ₀ / 7) ((ρ/ρ₀)⁷ − 1)
//! velocity gradient (Eq. 3.7 × 2)  G_i^{ab} = ∂v^a/∂x^b ≈ Σ_j (m_j/ρ_j)(v_j^a − v_i^a) ∂_b W_ij
//! Newtonian stress (Eq. 2.40)      σ̄_i = η (G_i + G_iᵀ − (2/d) tr G_i I)        (ζ = 0)
//! momentum (Eq. 2.20, corrected)   dv_i^a/dt = Σ_j m_j [(σ̄_i^{ab}/ρ_i² + σ̄_j^{ab}/ρ_j²)
//!                                                 − (p_i/ρ_i² + p_j/ρ_j²) δ^{ab}] ∂_b W_ij + F^a
//! Morris viscosity (alternative)   dv_i/dt += Σ_j m_j (2η/(ρ_i ρ_j)) (x_ij·∇_i W_ij)/(r_ij² + 0.01h²) v_ij
//! ```
//!
//! With `[fluid.polymer]` every particle also carries a polymer stress τ_i ([`maxwell`]),
//! integrated state advanced with the constitutive rate that the velocity-gradient pass forms
//! from G_i; it joins σ̄ in the momentum equation (σ̄_i → σ̄_i + τ_i). Boundary particles advance
//! their own τ from their own G (method B, the λ → 0 limit of the nested summation's wall
//! stress); with Morris's images a fluid–boundary pair uses the fluid particle's τ for both ends
//! (τ_j := τ_i, zero normal gradient, docs/theory/sph_maxwell.md §2.3). With Morris's viscous term
//! the Newtonian stress η(G + Gᵀ − (2/d) tr G I) of a polymer fluid is still formed, for
//! the observables only.
//!
//! Departures from the printed text (docs/theory/sph_maxwell.md §1.2, §1.12, §2.2): the momentum
//! equation contracts the stress with ∂_b W (the thesis prints ∂_a); the wall repulsion is made to
//! repel; the thesis's first-order predictor–corrector is only one of the integrators
//! ([`crate::integrators`]).
//!
//! The "nested summation" is two gather passes: pass 1 estimates G_i and stores σ̄_i, the
//! engine refreshes the ghosts' σ̄, pass 2 forms the momentum equation. Morris's direct term
//! needs no gradient pass. With summation density a density pass comes first; with continuity
//! density ρ is integrated state ([`ParticleModel::integrated_fields`]).
//!
//! Every pair term is exactly antisymmetric (force) or symmetric (density, dρ/dt) under i ↔ j,
//! so momentum is conserved pair by pair, and every sum is exact ([`crate::fixed_sum`]), so
//! the results are the same bits on any number of ranks and threads.
//!
//! # Walls (`[walls]`, thesis method B and Morris's images)
//! Layers of boundary particles continue the lattice beyond the two faces of the wall axis, at
//! least one kernel support thick (default two, so that every boundary particle a fluid
//! particle sees has a complete summation density). They are species of their own
//! ([`crate::species`]): frozen, or moving at the wall velocity; they enter every sum, are
//! never integrated and never counted as fluid. The momentum pass gives them the reactions of
//! their fluid neighbours (pairs of two boundary particles contribute nothing), so the force
//! on a wall's particles is the force the fluid exerts on that wall (the `wall_shear_stress`
//! observable). Their density is summed like the fluid's (or
//! stays ρ₀ under continuity); with the nested summation they carry the stress of their own
//! velocity-gradient estimate. Two treatments of the velocity a fluid particle i sees for a
//! boundary particle j of a wall moving at U:
//!
//! - `layers` (method B): v_j = U;
//! - `morris` (Morris, Fox & Zhu 1997): v_j = U − (d_j/d_i)(v_i − U), i.e. v_i − v_j = β (v_i − U)
//!   with β = min(1 + d_j/d_i, β_max), d_i ≥ Δ/2 the distances from the wall plane
//!   (docs/theory/sph_maxwell.md §2.3).
//!
//! A Lennard-Jones-like repulsion between fluid and boundary particles closer than r₀
//! (docs/theory/sph_maxwell.md §2.2, Eq. 2.47, with the sign that repels),
//! a_i = D [(r₀/r)⁴ − (r₀/r)²] x_ij / r², keeps fluid out of the wall; r₀ defaults to the lattice
//! spacing (the initial fluid–wall distance, where the force vanishes) and D to c₀².

pub mod kernels;
mod lanes;
pub mod mirror;
mod momentum_flux;
pub mod msph;
pub mod polymer;
mod spec;
pub mod time_step;
mod validate;

use crate::fixed_sum::Scale;
use crate::models::gather::{
    BATCH, BatchTerms, FullList, GatherKernel, PairBatch, Parity, ScatterBuffers, SymmetricKernel,
    gather, gather_in_lanes, pair_by_pair, scatter,
};
use crate::models::interface::{
    FieldKind, FieldSpec, Integrated, ParticleModel, PassContext, PassOutput, PassSpec,
};
use crate::neighbour::NeighbourList;
use crate::particles::{FieldFlags, Particles};
use crate::simd::Isa;
use crate::species::{Motion, Species};
use crate::with_kernel;
use kernels::{Kernel, KernelKind};
use mirror::{FitFallbacks, MirrorWalls};
pub use momentum_flux::SPH_STRESS_PARTS;
use msph::{Local, MomentKernel, unknowns};
use polymer::{ConstitutiveLaw, PolymerCfg, packed_index, packed_width};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// `[fluid] kind = "sph"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SphCfg {
    /// Smoothing kernel.
    #[serde(default)]
    pub kernel: KernelKind,
    /// Smoothing length h (the support is h for Lucy, 2h for the cubic spline and Wendland C2,
    /// 3h for the quintic spline).
    pub smoothing_length: f64,
    /// Rest density ρ₀.
    #[serde(default = "one")]
    pub rest_density: f64,
    /// Reference speed of sound c₀.
    pub sound_speed: f64,
    /// Equation of state.
    #[serde(default)]
    pub equation_of_state: EquationOfState,
    /// How the density is obtained.
    #[serde(default)]
    pub density: DensityMethod,
    /// Dynamic (shear) viscosity η of the Newtonian part: the whole fluid's, or the solvent's
    /// when a `[fluid.polymer]` adds a polymer stress (0 for the thesis's Maxwell fluid).
    pub viscosity: f64,
    /// Discretisation of the viscous stress.
    #[serde(default)]
    pub viscous_term: ViscousTerm,
    /// Body force per unit mass F (D components; Poiseuille flow), default none.
    #[serde(default)]
    pub body_force: Vec<f64>,
    /// Regularisation ε of 1/(r² + ε h²) in Morris's viscous term (default 0, as LAMMPS's
    /// `sph/taitwater/morris`). Every kernel offered has a finite W'(r)/r at r = 0, so nothing
    /// needs regularising; Morris et al. (1997) use 0.01 with h the smoothing length of a
    /// quintic of support 3h. With Lucy, whose h *is* the support, ε = 0.01 weakens the
    /// nearest-neighbour coupling at h = 2.5Δ by 6 % and the measured viscosity by ~4 %.
    #[serde(default)]
    pub morris_regularisation: f64,
    /// XSPH factor ε (Monaghan 1989): particles move with v̂_i = v_i + ε Σ_j (m_j/ρ̄_ij)
    /// (v_j − v_i) W_ij, ρ̄_ij = (ρ_i + ρ_j)/2, instead of v_i (the momentum equation is
    /// unchanged). Default 0 (off); 0.5 is usual. Needs `kick_drift_kick`.
    #[serde(default)]
    pub xsph: f64,
    /// A constant background pressure p_b added to the equation of state (default 0). It
    /// changes no pressure gradient of the continuum; in SPH it keeps the total stress
    /// compressive where a polymer stress pulls (τ_xx > 0 in shear), which the tensile
    /// instability otherwise feeds on.
    #[serde(default)]
    pub background_pressure: f64,
    /// The velocity-gradient estimate: `sph` (default, the thesis's Eq. 3.7) or `corrected`
    /// (first-order kernel-gradient correction, exact for a linear velocity field on any
    /// particle arrangement).
    #[serde(default)]
    pub velocity_gradient: GradientEstimate,
    /// The derivative operator of the velocity gradient and of the stress divergence: `sph`
    /// (default; pairwise, antisymmetric momentum) or `msph` (Zhang–Batra moment-matrix
    /// derivatives, [`msph`]; needs the truncated Gaussian kernel).
    #[serde(default)]
    pub derivatives: Derivatives,
    /// With `viscous_term = "nested_summation"`: the share s ∈ [0, 1) of η applied by Morris's
    /// pairwise operator, (1 − s) η by the nested summation (default 0). MSPH's two-pass
    /// Newtonian stress does not damp particle-scale velocity modes (docs/theory/msph_dumbbells.md
    /// §5.1); s = 0.1 does.
    #[serde(default)]
    pub morris_share: f64,
    /// A polymer stress carried by every particle and advanced by its constitutive equation
    /// ([`maxwell`]); default none (a Newtonian fluid).
    #[serde(default)]
    pub polymer: Option<PolymerCfg>,
}

/// `[fluid] derivatives`
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Derivatives {
    /// Pairwise SPH: the velocity gradient of `velocity_gradient`, the momentum equation in
    /// its antisymmetric pair form (momentum conserved pair by pair).
    #[default]
    Sph,
    /// Modified SPH (Zhang & Batra 2004; Murashima & Taniguchi): ∇v and ∇·σ, σ = −pI + σ̄ + τ,
    /// from each particle's 6 × 6 (2D) or 10 × 10 (3D) moment system, exact for quadratic
    /// fields on any arrangement ([`msph`]). Not pairwise: momentum is conserved only as far
    /// as the derivatives are exact.
    Msph,
}

fn one() -> f64 {
    1.0
}

/// `[fluid] equation_of_state`
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum EquationOfState {
    /// p = c₀² ρ² / (2 ρ₀) (the thesis's Eq. 2.35).
    #[default]
    Quadratic,
    /// p = (c₀² ρ₀ / 7)((ρ/ρ₀)⁷ − 1) (Tait, γ = 7).
    Tait,
}

/// `[fluid] density`
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum DensityMethod {
    /// ρ_i = Σ_j m_j W_ij, every evaluation (the thesis's default; mass exactly conserved).
    #[default]
    Summation,
    /// dρ_i/dt = Σ_j m_j v_ij · ∇_i W_ij, integrated (ρ starts at ρ₀).
    Continuity,
}

/// `[fluid] velocity_gradient`
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum GradientEstimate {
    /// G_i = Σ_j (m_j/ρ_j)(v_j − v_i) ⊗ ∇_i W_ij (Ellero Eq. 3.7 × 2): exact for a linear field
    /// only where the lattice sum M_i = Σ_j (m_j/ρ_j)(x_j − x_i) ⊗ ∇_i W_ij is the identity
    /// (an undisturbed lattice); on a disordered arrangement its mean falls below I.
    #[default]
    Sph,
    /// G_i M_i⁻¹ (Randles & Libersky 1996; Bonet & Lok 1999): exact for any linear velocity
    /// field on any arrangement whose M_i is invertible; where M_i is nearly singular
    /// (det M_i < 10⁻³, a sparse neighbourhood) the uncorrected G_i is kept.
    Corrected,
}

/// `[fluid] viscous_term`
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum ViscousTerm {
    /// The thesis's two-pass scheme: σ̄ from the velocity-gradient estimate, then its divergence.
    #[default]
    NestedSummation,
    /// Morris, Fox & Zhu (1997): one pass, a direct approximation of η∇²v.
    Morris,
}

/// `[walls]`: boundary-particle walls at the two faces of one axis.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WallsCfg {
    /// The wall axis (its box boundaries must be "wall").
    #[serde(default = "axis_y")]
    pub axis: crate::geometry::Axis,
    /// Thickness of each boundary layer (default: two kernel supports).
    #[serde(default)]
    pub thickness: Option<f64>,
    /// Velocity of the wall at 0 (D components; default at rest).
    #[serde(default)]
    pub lower_velocity: Vec<f64>,
    /// Velocity of the wall at L (D components; default at rest).
    #[serde(default)]
    pub upper_velocity: Vec<f64>,
    /// The velocity fluid particles see for boundary particles.
    #[serde(default)]
    pub treatment: WallTreatment,
    /// Cap β_max of Morris's extrapolation factor β = 1 + d_j/d_i.
    #[serde(default = "beta_max")]
    pub morris_cap: f64,
    /// Strength D of the fluid–wall repulsion (default c₀²).
    #[serde(default)]
    pub repulsion_strength: Option<f64>,
    /// Range r₀ of the fluid–wall repulsion (default: the lattice spacing).
    #[serde(default)]
    pub repulsion_range: Option<f64>,
}

fn axis_y() -> crate::geometry::Axis {
    crate::geometry::Axis::Y
}
fn beta_max() -> f64 {
    1.5
}

/// `[inclusions]`: rigid, fixed (neither translating nor rotating) inclusions of equal radius
/// — discs in 2D, spheres in 3D — filled with boundary particles that see Morris's images of
/// their fluid neighbours (docs/theory/sph_maxwell.md §2.3, §2.5).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InclusionsCfg {
    /// Centres c_k (D coordinates each); every inclusion lies inside the box.
    pub centres: Vec<Vec<f64>>,
    /// Radius R of every inclusion.
    pub radius: f64,
    /// Cap β_max of Morris's extrapolation factor β = 1 + d_j/d_i.
    #[serde(default = "beta_max")]
    pub morris_cap: f64,
    /// Whether an inclusion particle carries its fluid neighbour's pressure in their pair
    /// (p_j := p_i, the thesis's "von Neumann" condition, docs/theory/sph_maxwell.md §2.3; default)
    /// or its own, from its summation density. Its stress is always mirrored.
    #[serde(default = "yes")]
    pub mirror_pressure: bool,
}

fn yes() -> bool {
    true
}

impl InclusionsCfg {
    /// x − c of the inclusion whose disc holds `x` (|x − c| < R), if any (inclusions lie
    /// inside the box, so no periodic image is needed).
    pub fn offset<const D: usize>(&self, x: &[f64; D]) -> Option<[f64; D]> {
        self.centres.iter().find_map(|c| {
            let o: [f64; D] = std::array::from_fn(|d| x[d] - c[d]);
            let r2: f64 = o.iter().map(|v| v * v).sum();
            (r2 < self.radius * self.radius).then_some(o)
        })
    }

    /// The volume fraction of the inclusions, N πR² / A (2D) or N (4/3)πR³ / V (3D).
    pub fn volume_fraction(&self, lengths: &[f64]) -> f64 {
        let r = self.radius;
        let each = if lengths.len() == 2 {
            std::f64::consts::PI * r * r
        } else {
            4.0 / 3.0 * std::f64::consts::PI * r * r * r
        };
        self.centres.len() as f64 * each / lengths.iter().product::<f64>()
    }
}

/// `[walls] treatment`
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum WallTreatment {
    /// Boundary particles carry the wall velocity (thesis method B).
    #[default]
    Layers,
    /// Morris's extrapolated image velocity, v_j = U − (d_j/d_i)(v_i − U), capped.
    Morris,
    /// The working MSPH wall of docs/theory/msph_dumbbells.md §5.1 (needs `derivatives = "msph"`):
    /// a boundary particle w carries values fitted (first-order moving least squares over
    /// the fluid) at its mirror point m_w: the velocity 2U − v̂(m_w), the density ρ̂(m_w), and
    /// the stress extrapolated linearly from m_w to x_w; it forms no derivative of its own.
    Mirror,
}

impl SphCfg {
    /// The kernel support (the interaction cutoff).
    pub fn support(&self) -> f64 {
        self.kernel.support_factor() * self.smoothing_length
    }

    /// p/ρ² at density ρ.
    #[inline(always)]
    fn pressure_over_rho2(eos: EquationOfState, c2: f64, rho0: f64, rho: f64) -> f64 {
        match eos {
            EquationOfState::Quadratic => c2 / (2.0 * rho0),
            EquationOfState::Tait => {
                let x = rho / rho0;
                let x2 = x * x;
                let x7 = x2 * x2 * x2 * x;
                c2 * rho0 / 7.0 * (x7 - 1.0) / (rho * rho)
            }
        }
    }

    /// Pressure at density ρ.
    pub fn pressure(&self, rho: f64) -> f64 {
        let c2 = self.sound_speed * self.sound_speed;
        Self::pressure_over_rho2(self.equation_of_state, c2, self.rest_density, rho) * rho * rho
            + self.background_pressure
    }
}

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

/// The walls as the pair kernels see them.
#[derive(Clone, Copy, Debug)]
struct WallGeometry<const D: usize> {
    axis: usize,
    /// Coordinates of the lower and upper wall planes.
    planes: [f64; 2],
    /// Velocities of the lower and upper walls.
    velocity: [[f64; D]; 2],
    morris: bool,
    /// Index of the [`MIRROR_VELOCITY`] field with mirror walls (else `usize::MAX`).
    mirror_velocity: usize,
    beta_max: f64,
    /// Floor of a fluid particle's distance to the wall (Δ/2).
    min_distance: f64,
    /// D and r₀ of the repulsion.
    strength: f64,
    range: f64,
}

/// The inclusions as the pair kernels see them.
#[derive(Clone, Copy, Debug)]
struct InclusionGeometry {
    radius: f64,
    /// Whether the momentum pass accumulates the traction moments (only when measured).
    traction_moments: bool,
    mirror_pressure: bool,
    beta_max: f64,
    /// Floor of a fluid particle's distance to the surface (Δ/2).
    min_distance: f64,
    /// Index of the [`INCLUSION_OFFSET`] field.
    offset: usize,
}

impl InclusionGeometry {
    /// For fluid particle i and inclusion particle j with x_ij = x_i − x_j: the vector from
    /// the centre to i, x_ij + o_j, and its length.
    #[inline(always)]
    fn centre_to_fluid<const D: usize>(
        &self,
        p: &Particles<D>,
        j: usize,
        x: &[f64; D],
    ) -> ([f64; D], f64) {
        let o = &p.extra[self.offset].data[j * D..(j + 1) * D];
        let ric: [f64; D] = std::array::from_fn(|d| x[d] + o[d]);
        let dist = ric.iter().map(|v| v * v).sum::<f64>().sqrt();
        (ric, dist)
    }

    /// The surface point R n_i (relative to the centre) nearest fluid particle i, for the
    /// pair of i and inclusion particle j with x_ij = x_i − x_j.
    #[inline(always)]
    fn surface_point<const D: usize>(&self, p: &Particles<D>, j: usize, x: &[f64; D]) -> [f64; D] {
        let (ric, dist) = self.centre_to_fluid(p, j, x);
        std::array::from_fn(|d| self.radius * ric[d] / dist)
    }
}

/// Every boundary the pair kernels know: walls and inclusions.
#[derive(Clone, Copy, Debug, Default)]
struct Boundaries<const D: usize> {
    walls: Option<WallGeometry<D>>,
    inclusions: Option<InclusionGeometry>,
}

impl<const D: usize> Boundaries<D> {
    fn any(&self) -> bool {
        self.walls.is_some() || self.inclusions.is_some()
    }

    /// The velocity fluid particle i sees for boundary particle j of species `sj`, with
    /// x_ij = x_i − x_j.
    ///
    /// Inclusion (docs/theory/sph_maxwell.md §2.3, a circle of centre c and radius R): with
    /// o_j = x_j − c, n = (x_ij + o_j)/|x_ij + o_j|, d_i = |x_ij + o_j| − R ≥ Δ/2, d_j = R − o_j·n,
    /// v_j = U − (d_j/d_i)(v_i − U), i.e. v_i − v_j = β (v_i − U), β = min(1 + d_j/d_i, β_max),
    /// with U = v_j as stored: the inclusion's velocity (0 in the box, the Lees–Edwards image
    /// velocity for an image across the sheared boundary).
    #[inline(always)]
    fn seen_velocity(
        &self,
        p: &Particles<D>,
        i: usize,
        j: usize,
        sj: u8,
        x: &[f64; D],
    ) -> [f64; D] {
        if sj == INCLUSION {
            let Some(inc) = &self.inclusions else {
                return p.vel[j];
            };
            let (ric, dist) = inc.centre_to_fluid(p, j, x);
            let o = &p.extra[inc.offset].data[j * D..(j + 1) * D];
            let o_dot_n = (0..D).map(|d| o[d] * ric[d]).sum::<f64>() / dist;
            let (di, dj) = (dist - inc.radius, inc.radius - o_dot_n);
            let beta = (1.0 + dj / di.max(inc.min_distance)).min(inc.beta_max);
            let u = p.vel[j];
            return std::array::from_fn(|d| p.vel[i][d] - beta * (p.vel[i][d] - u[d]));
        }
        match &self.walls {
            Some(w) => w.seen_velocity(p, i, j, sj),
            None => p.vel[j],
        }
    }
}

impl<const D: usize> WallGeometry<D> {
    /// The velocity fluid particle i sees for boundary particle j (species `sj`).
    #[inline(always)]
    fn seen_velocity(&self, p: &Particles<D>, i: usize, j: usize, sj: u8) -> [f64; D] {
        if self.mirror_velocity != usize::MAX {
            let v = &p.extra[self.mirror_velocity].data[j * D..(j + 1) * D];
            return std::array::from_fn(|d| v[d]);
        }
        if !self.morris {
            return p.vel[j];
        }
        let w = (sj - LOWER_WALL) as usize;
        let u = self.velocity[w];
        let (di, dj) = if w == 0 {
            (
                p.pos[i][self.axis] - self.planes[0],
                self.planes[0] - p.pos[j][self.axis],
            )
        } else {
            (
                self.planes[1] - p.pos[i][self.axis],
                p.pos[j][self.axis] - self.planes[1],
            )
        };
        let beta = (1.0 + dj / di.max(self.min_distance)).min(self.beta_max);
        std::array::from_fn(|d| p.vel[i][d] - beta * (p.vel[i][d] - u[d]))
    }
}

/// Pass: summation density, m_j W_ij and the self term m_i W(0).
struct DensityKernel<K> {
    kernel: K,
    mass: f64,
    scales: [Scale; 1],
}

impl<const D: usize, K: Kernel> GatherKernel<D> for DensityKernel<K> {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }
    fn cutoff(&self) -> f64 {
        self.kernel.support()
    }
    #[inline(always)]
    fn pair(&self, _: &Particles<D>, _: usize, _: usize, _: &[f64; D], r: f64, out: &mut [f64]) {
        out[0] = self.mass * self.kernel.w(r);
    }
    fn self_term(&self, _: &Particles<D>, _: usize, out: &mut [f64]) -> bool {
        out[0] = self.mass * self.kernel.w(0.0);
        true
    }
}

impl<const D: usize, K: Kernel> SymmetricKernel<D> for DensityKernel<K> {
    fn parities(&self) -> &[Parity] {
        &[Parity::Even]
    }
}

/// Pass: the velocity gradient G_i^{ab} = Σ_j (m_j/ρ_j)(v_j^a − v_i^a) W'_ij x_ij^b / r_ij and,
/// when `corrected`, the lattice sum M_i^{cb} = Σ_j (m_j/ρ_j)(x_j − x_i)^c W'_ij x_ij^b / r_ij
/// (D × D more outputs) that the finish inverts.
struct GradientKernel<'a, K, const D: usize> {
    kernel: K,
    mass: f64,
    density: &'a [f64],
    boundaries: Boundaries<D>,
    corrected: bool,
    scales: Vec<Scale>,
}

impl<K: Kernel, const D: usize> GatherKernel<D> for GradientKernel<'_, K, D> {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }
    fn cutoff(&self) -> f64 {
        self.kernel.support()
    }
    #[inline(always)]
    fn pair(&self, p: &Particles<D>, i: usize, j: usize, x: &[f64; D], r: f64, out: &mut [f64]) {
        let vj = if self.boundaries.any() && p.species_of(i) == FLUID && p.species_of(j) != FLUID {
            self.boundaries.seen_velocity(p, i, j, p.species_of(j), x)
        } else {
            p.vel[j]
        };
        let s = self.mass / self.density[j] * self.kernel.dw_over_r(r);
        for a in 0..D {
            let dv = s * (vj[a] - p.vel[i][a]);
            for b in 0..D {
                out[a * D + b] = dv * x[b];
            }
        }
        if self.corrected {
            for c in 0..D {
                let dx = -s * x[c];
                for b in 0..D {
                    out[D * D + c * D + b] = dx * x[b];
                }
            }
        }
    }
}

/// Smallest det M_i with which the corrected gradient G_i M_i⁻¹ is formed (M_i ≈ I inside a
/// complete neighbourhood; a particle that sees few neighbours keeps its uncorrected G_i).
pub(crate) const MIN_CORRECTION_DETERMINANT: f64 = 1e-3;

/// Replaces each particle's G_i (the first D² numbers of every `width`-wide row of `sums`) by
/// G_i M_i⁻¹, with M_i the next D² numbers; returns how many rows kept G_i because M_i was
/// nearly singular.
fn apply_gradient_correction<const D: usize>(sums: &mut [f64], width: usize) -> usize {
    let mut kept = 0;
    for row in sums.chunks_exact_mut(width) {
        let m: [[f64; D]; D] =
            std::array::from_fn(|c| std::array::from_fn(|b| row[D * D + c * D + b]));
        let (det, inv) = determinant_and_inverse(&m);
        if !(det > MIN_CORRECTION_DETERMINANT && det.is_finite()) {
            kept += 1;
            continue;
        }
        let g: [[f64; D]; D] = std::array::from_fn(|a| std::array::from_fn(|b| row[a * D + b]));
        for a in 0..D {
            for b in 0..D {
                row[a * D + b] = (0..D).map(|c| g[a][c] * inv[c][b]).sum();
            }
        }
    }
    kept
}

/// det m and m⁻¹ (by cofactors) of a 1 × 1, 2 × 2 or 3 × 3 matrix.
pub(crate) fn determinant_and_inverse<const D: usize>(m: &[[f64; D]; D]) -> (f64, [[f64; D]; D]) {
    let mut inv = [[0.0; D]; D];
    let det = match D {
        1 => {
            inv[0][0] = 1.0 / m[0][0];
            return (m[0][0], inv);
        }
        2 => m[0][0] * m[1][1] - m[0][1] * m[1][0],
        3 => {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        }
        _ => unreachable!("SPH runs in 2 or 3 dimensions"),
    };
    for a in 0..D {
        for b in 0..D {
            // inv[a][b] = cofactor(b, a) / det.
            let cof = if D == 2 {
                let s = if (a + b) % 2 == 0 { 1.0 } else { -1.0 };
                s * m[1 - b][1 - a]
            } else {
                let (r0, r1) = ((b + 1) % 3, (b + 2) % 3);
                let (c0, c1) = ((a + 1) % 3, (a + 2) % 3);
                m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
            };
            inv[a][b] = cof / det;
        }
    }
    (det, inv)
}

/// Pass: the momentum equation (and dρ/dt under continuity), per unit mass times m_i.
struct MomentumKernel<'a, K, const D: usize> {
    kernel: K,
    mass: f64,
    density: &'a [f64],
    /// 1/ρ of every particle.
    inv_density: &'a [f64],
    /// p/ρ² of every particle (owned and ghosts).
    p_over_rho2: &'a [f64],
    /// σ̄ (D² per particle) with the nested summation.
    stress: Option<&'a [f64]>,
    /// σ̄/ρ² (D² per particle, each σ̄ component divided by ρ·ρ), for the lanes
    /// ([`Self::gather_lanes`]) of the nested summation: the very quotients the pair term
    /// forms, formed once per particle.
    stress_over_rho2: Option<&'a [f64]>,
    /// The polymer stress τ (packed, [`packed_width`] per particle).
    polymer: Option<&'a [f64]>,
    /// 2η (Morris's term), or 0.
    two_eta_morris: f64,
    /// 0.01 h².
    regulariser: f64,
    continuity: bool,
    /// ε m (XSPH), or 0.
    xsph_eps_mass: f64,
    /// Whether the pressure and the stresses enter in pair form (not with MSPH derivatives,
    /// whose divergence pass adds them).
    pairwise_stress: bool,
    boundaries: Boundaries<D>,
    scales: Vec<Scale>,
    parities: Vec<Parity>,
}

impl<K: Kernel, const D: usize> SymmetricKernel<D> for MomentumKernel<'_, K, D> {
    fn parities(&self) -> &[Parity] {
        &self.parities
    }

    /// Fluid–fluid batches without a stress field (no walls, no nested summation: the common
    /// weakly compressible scheme) in loops over the batch; anything else pair by pair.
    #[inline(always)]
    fn pair_batch(&self, p: &Particles<D>, batch: &PairBatch<D>, out: &mut BatchTerms) {
        if !self.fluid_only(p) {
            pair_by_pair(self, p, batch, out);
            return;
        }
        let morris = self.two_eta_morris != 0.0;
        let regular = self.regulariser != 0.0;
        match (morris, regular, self.continuity) {
            (true, false, true) => self.fluid_batch::<true, false, true>(p, batch, out),
            (true, false, false) => self.fluid_batch::<true, false, false>(p, batch, out),
            (true, true, true) => self.fluid_batch::<true, true, true>(p, batch, out),
            (true, true, false) => self.fluid_batch::<true, true, false>(p, batch, out),
            (false, _, true) => self.fluid_batch::<false, false, true>(p, batch, out),
            (false, _, false) => self.fluid_batch::<false, false, false>(p, batch, out),
        }
    }
}

impl<K: Kernel, const D: usize> MomentumKernel<'_, K, D> {
    /// Whether every pair of this pass is a fluid–fluid pair with only the pressure, Morris's
    /// term and the density rate (no walls, inclusions, stress fields or XSPH): the scheme that
    /// [`Self::fluid_batch`] and the lanes (`lanes.rs`) compute in vector loops.
    #[inline(always)]
    fn fluid_only(&self, p: &Particles<D>) -> bool {
        !(self.boundaries.any()
            || self.stress.is_some()
            || self.polymer.is_some()
            || p.species.is_some()
            || self.xsph_eps_mass != 0.0
            || !self.pairwise_stress)
    }

    /// [`GatherKernel::pair`] for a batch of fluid–fluid pairs without a stress field, in
    /// loops over the batch (the same operations in the same order: the same bits).
    #[inline(always)]
    fn fluid_batch<const MORRIS: bool, const REGULAR: bool, const CONTINUITY: bool>(
        &self,
        p: &Particles<D>,
        batch: &PairBatch<D>,
        out: &mut BatchTerms,
    ) {
        let n = batch.len.min(BATCH);
        let mut p_sum = [0.0; BATCH];
        let mut inv_product = [0.0; BATCH];
        let mut v = [[0.0; BATCH]; D];
        for k in 0..n {
            let (i, j) = (batch.i[k] as usize, batch.j[k] as usize);
            p_sum[k] = self.p_over_rho2[i] + self.p_over_rho2[j];
            inv_product[k] = self.inv_density[i] * self.inv_density[j];
            for d in 0..D {
                v[d][k] = p.vel[i][d] - p.vel[j][d];
            }
        }
        // Everything the arithmetic loop reads, in locals (so that the compiler sees no
        // aliasing with `out` and vectorises it).
        let (mass, mm) = (self.mass, self.mass * self.mass);
        let (two_eta, regulariser, kernel) = (self.two_eta_morris, self.regulariser, &self.kernel);
        let mut gw = [0.0; BATCH];
        for k in 0..n {
            gw[k] = kernel.dw_over_r(batch.r[k]);
        }
        let mut f = [[0.0; BATCH]; D];
        let mut rate = [0.0; BATCH];
        for k in 0..n {
            let gw = gw[k];
            let pressure = -p_sum[k] * gw;
            let mut s = two_eta * inv_product[k] * gw;
            if REGULAR {
                let r = batch.r[k];
                let r2 = r * r;
                s = s * r2 / (r2 + regulariser);
            }
            let mut vdotx = 0.0;
            for a in 0..D {
                let x = batch.x[a][k];
                let mut fa = pressure * x;
                if MORRIS {
                    fa += s * v[a][k];
                }
                f[a][k] = mm * fa;
                vdotx += v[a][k] * x;
            }
            rate[k] = mass * gw * vdotx;
        }
        for a in 0..D {
            out[a][..n].copy_from_slice(&f[a][..n]);
        }
        if CONTINUITY {
            out[D][..n].copy_from_slice(&rate[..n]);
        }
    }
}

/// The two ends of a pair as the stress terms of the momentum equation see them.
struct StressEnds {
    i: usize,
    j: usize,
    /// The fluid end of a boundary pair (i otherwise).
    fluid_end: usize,
    inclusion_pair: bool,
    /// Whether the boundary end carries the fluid end's polymer stress (Morris's images).
    mirror: bool,
    /// ρ_i², ρ_j².
    rho2: [f64; 2],
}

impl<K: Kernel, const D: usize> MomentumKernel<'_, K, D> {
    /// p_i/ρ_i² + p_j/ρ_j² of a pair, with an inclusion particle carrying its fluid
    /// neighbour's pressure when the inclusions mirror it
    /// (zero normal gradient, docs/theory/sph_maxwell.md §2.3: p_j := p_i).
    #[inline(always)]
    fn pressure_sum(
        &self,
        i: usize,
        j: usize,
        fluid_end: usize,
        inclusion_pair: bool,
        ri2: f64,
        rj2: f64,
    ) -> f64 {
        let mirror_pressure = inclusion_pair
            && self
                .boundaries
                .inclusions
                .is_some_and(|g| g.mirror_pressure);
        if mirror_pressure {
            let pf =
                self.p_over_rho2[fluid_end] * self.density[fluid_end] * self.density[fluid_end];
            pf * (1.0 / ri2 + 1.0 / rj2)
        } else {
            self.p_over_rho2[i] + self.p_over_rho2[j]
        }
    }

    /// The coefficient s of the wall repulsion s x_ij (per m_i m_j) of a fluid–wall pair at
    /// distance r, when it acts: an acceleration of the fluid particle (Eq. 2.48 adds it
    /// without a mass), so the force m_i a_i, divided by the m_j that the common factor
    /// m_i m_j of the pair force brings.
    #[inline(always)]
    fn wall_repulsion(&self, fluid_wall_pair: bool, r: f64) -> Option<f64> {
        let w = self.boundaries.walls.as_ref().filter(|_| fluid_wall_pair)?;
        (r < w.range).then(|| {
            let q2 = (w.range / r) * (w.range / r);
            w.strength * (q2 * q2 - q2) / (r * r) / self.mass
        })
    }

    /// The pair's ends as [`Self::pair_stress`] reads them. Morris's images (walls or
    /// inclusions) carry the fluid end's stress (zero normal gradient, docs/theory/sph_maxwell.md
    /// §2.3): σ̄_j := σ̄_i, τ_j := τ_i; method-B walls carry their own.
    #[inline(always)]
    fn stress_ends(
        &self,
        i: usize,
        j: usize,
        fluid_end: usize,
        boundary_pair: bool,
        inclusion_pair: bool,
        rho2: [f64; 2],
    ) -> StressEnds {
        let mirror =
            inclusion_pair || (boundary_pair && self.boundaries.walls.is_some_and(|w| w.morris));
        StressEnds {
            i,
            j,
            fluid_end,
            inclusion_pair,
            mirror,
            rho2,
        }
    }

    /// Σ_b S^{ab} x_b for every a, S the pair's stress sum of [`Self::pair_stress`] (the
    /// nested summation's σ̄ when `viscous`, and τ): the bits the momentum equation multiplies
    /// by ∂W/r.
    #[inline(always)]
    fn stress_on_pair(&self, e: &StressEnds, x: &[f64; D], viscous: bool) -> [f64; D] {
        std::array::from_fn(|a| {
            let mut t = 0.0;
            for b in 0..D {
                t += self.pair_stress(e, a, b, viscous, true) * x[b];
            }
            t
        })
    }

    /// Component (a, b) of σ̄_i/ρ_i² + σ̄_j/ρ_j² (the nested summation's viscous stress, when
    /// `viscous`) plus τ_i/ρ_i² + τ_j/ρ_j² (the polymer stress, when `polymer`), with the
    /// images' stresses of [`GatherKernel::pair`]. With both parts: the very bits the
    /// momentum equation uses.
    #[inline(always)]
    fn pair_stress(&self, e: &StressEnds, a: usize, b: usize, viscous: bool, polymer: bool) -> f64 {
        let [ri2, rj2] = e.rho2;
        let mut sab = match self.stress.filter(|_| viscous) {
            Some(s) if e.inclusion_pair => {
                s[e.fluid_end * D * D + a * D + b] * (1.0 / ri2 + 1.0 / rj2)
            }
            Some(s) => s[e.i * D * D + a * D + b] / ri2 + s[e.j * D * D + a * D + b] / rj2,
            None => 0.0,
        };
        if let Some(tau) = self.polymer.filter(|_| polymer) {
            let (w, c) = (packed_width(D), packed_index::<D>(a, b));
            sab += if e.mirror {
                tau[e.fluid_end * w + c] * (1.0 / ri2 + 1.0 / rj2)
            } else {
                tau[e.i * w + c] / ri2 + tau[e.j * w + c] / rj2
            };
        }
        sab
    }
}

impl<K: Kernel, const D: usize> GatherKernel<D> for MomentumKernel<'_, K, D> {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }
    fn cutoff(&self) -> f64 {
        self.kernel.support()
    }
    #[inline(always)]
    fn pair(&self, p: &Particles<D>, i: usize, j: usize, x: &[f64; D], r: f64, out: &mut [f64]) {
        let (si, sj) = (p.species_of(i), p.species_of(j));
        if si != FLUID && sj != FLUID {
            // Two boundary particles: nothing the fluid feels, nothing a wall reports.
            out.fill(0.0);
            return;
        }
        let boundary_pair = si != sj;
        // The fluid end of a boundary pair; whether the boundary end is an inclusion particle.
        let fluid_end = if si == FLUID { i } else { j };
        let inclusion_pair = boundary_pair && (si == INCLUSION || sj == INCLUSION);
        // v_ij, with the velocity the fluid end sees for a boundary end.
        let vij: [f64; D] = if boundary_pair && self.boundaries.any() {
            if si == FLUID {
                let vj = self.boundaries.seen_velocity(p, i, j, sj, x);
                std::array::from_fn(|d| p.vel[i][d] - vj[d])
            } else {
                let xji: [f64; D] = std::array::from_fn(|d| -x[d]);
                let vi = self.boundaries.seen_velocity(p, j, i, si, &xji);
                std::array::from_fn(|d| vi[d] - p.vel[j][d])
            }
        } else {
            std::array::from_fn(|d| p.vel[i][d] - p.vel[j][d])
        };
        let mm = self.mass * self.mass;
        let gw = self.kernel.dw_over_r(r); // ∇_i W_ij = gw x_ij
        // Both ends' 1/ρ², for the stresses an inclusion mirrors.
        let (ri2, rj2) = (
            self.density[i] * self.density[i],
            self.density[j] * self.density[j],
        );
        let p_sum = self.pressure_sum(i, j, fluid_end, inclusion_pair, ri2, rj2);
        let pressure = if self.pairwise_stress {
            -p_sum * gw
        } else {
            0.0
        };
        let mut f = [0.0; D];
        for a in 0..D {
            f[a] = pressure * x[a];
        }
        if self.pairwise_stress && (self.stress.is_some() || self.polymer.is_some()) {
            let ends = self.stress_ends(i, j, fluid_end, boundary_pair, inclusion_pair, [ri2, rj2]);
            let t = self.stress_on_pair(&ends, x, true);
            for a in 0..D {
                f[a] += gw * t[a];
            }
        }
        if self.two_eta_morris != 0.0 {
            let mut s = self.two_eta_morris * (self.inv_density[i] * self.inv_density[j]) * gw;
            if self.regulariser != 0.0 {
                let r2 = r * r;
                s = s * r2 / (r2 + self.regulariser);
            }
            for a in 0..D {
                f[a] += s * vij[a];
            }
        }
        if let Some(s) = self.wall_repulsion(boundary_pair && !inclusion_pair, r) {
            for a in 0..D {
                f[a] += s * x[a];
            }
        }
        for a in 0..D {
            out[a] = mm * f[a];
        }
        if self.continuity {
            let mut vdotx = 0.0;
            for a in 0..D {
                vdotx += vij[a] * x[a];
            }
            out[D] = self.mass * gw * vdotx;
        }
        if self.xsph_eps_mass != 0.0 {
            // −ε m W_ij v_ij / ρ̄_ij: odd under i ↔ j to the bit (ρ_i + ρ_j commutes).
            let first = D + usize::from(self.continuity);
            let rho_bar = 0.5 * (self.density[i] + self.density[j]);
            let s = self.xsph_eps_mass * self.kernel.w(r) / rho_bar;
            for a in 0..D {
                out[first + a] = -s * vij[a];
            }
        }
        if let Some(inc) = self.boundaries.inclusions.filter(|g| g.traction_moments) {
            // The traction moment F^a s^b of the pair force on the inclusion end, acting at the
            // surface point s = R n nearest the fluid end (relative to the centre): odd, so
            // the inclusion end receives F_j ⊗ s whichever end i is (n is the same bits from
            // both ends: x_ji = −x_ij exactly).
            let first =
                D + usize::from(self.continuity) + if self.xsph_eps_mass != 0.0 { D } else { 0 };
            let moment = &mut out[first..first + D * D];
            if inclusion_pair {
                let (incl, x_fi): (usize, [f64; D]) = if si == FLUID {
                    (j, *x)
                } else {
                    (i, std::array::from_fn(|d| -x[d]))
                };
                let sp = inc.surface_point(p, incl, &x_fi);
                for a in 0..D {
                    for b in 0..D {
                        moment[a * D + b] = mm * f[a] * sp[b];
                    }
                }
            } else {
                moment.fill(0.0);
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pass {
    Density,
    Gradient,
    Momentum,
    /// Mirror walls: the boundary particles' density and velocity from their mirror points.
    WallMirror,
    /// MSPH: every system assembled and factored, the velocity gradient solved.
    MsphGradient,
    /// Mirror walls: the boundary particles' stresses extrapolated from their mirror points.
    WallStress,
    /// MSPH: ∇·σ, σ = −pI + σ̄ + τ, into the forces.
    MsphDivergence,
}

/// The SPH fluid: parameters, its passes and its field indices.
pub struct SphModel<const D: usize> {
    cfg: SphCfg,
    mass: f64,
    passes: Vec<Pass>,
    boundaries: Boundaries<D>,
    /// The inclusions' layout (to give their particles their offsets).
    inclusions: Option<InclusionsCfg>,
    body_force: [f64; D],
    density: usize,
    rate: Option<usize>,
    stress: Option<usize>,
    xsph: Option<usize>,
    /// The traction moments of the inclusion particles ([`INCLUSION_TRACTION_MOMENT`]).
    traction_moment: Option<usize>,
    /// The constitutive polymer model (none for a Newtonian fluid or dumbbell ensembles).
    polymer: Option<ConstitutiveLaw>,
    /// τ (either kind of polymer), dτ/dt (constitutive) and G (dumbbells).
    polymer_stress: Option<usize>,
    polymer_rate: Option<usize>,
    velocity_gradient: Option<usize>,
    /// Velocity-gradient estimates left uncorrected (det M_i too small) on this rank.
    uncorrected_gradients: u64,
    /// Mirror walls (`[walls] treatment = "mirror"`).
    mirror: Option<MirrorWalls<D>>,
    /// The MSPH systems of the owned particles, from the last gradient pass.
    local: Vec<Local<D>>,
    /// MSPH systems solved to first order / left undetermined on this rank (particle ×
    /// evaluation).
    msph_first_order: u64,
    msph_undetermined: u64,
    /// Mirror fits that fell back (on this rank).
    mirror_fallbacks: FitFallbacks,
    /// Per-particle values of the fields an MSPH pass differentiates (scratch).
    values: Vec<f64>,
    p_over_rho2: Vec<f64>,
    inv_density: Vec<f64>,
    stress_over_rho2: Vec<f64>,
    sums: Vec<f64>,
    scatter: ScatterBuffers,
    /// Whether the momentum pass of this evaluation also forms the momentum flux
    /// ([`momentum_flux`]; the diagnostics asked for the virial).
    flux_wanted: bool,
    /// The momentum flux of the last momentum pass that formed it, for the engine.
    flux: Option<Result<crate::models::pair_loop::Virial, String>>,
}

impl<const D: usize> SphModel<D> {
    /// The fluid of particles of mass `mass`, in a box of edge lengths `lengths` with lattice
    /// spacing `spacing` (the default range of the wall repulsion), with the walls and
    /// inclusions given.
    pub fn new(
        cfg: &SphCfg,
        mass: f64,
        lengths: &[f64; D],
        spacing: f64,
        walls: Option<&WallsCfg>,
        inclusions: Option<&InclusionsCfg>,
    ) -> Self {
        let mut passes = Vec::new();
        if cfg.density == DensityMethod::Summation {
            passes.push(Pass::Density);
        }
        let mirror_walls = walls.is_some_and(|w| w.treatment == WallTreatment::Mirror);
        if cfg.derivatives == Derivatives::Msph {
            if mirror_walls {
                passes.push(Pass::WallMirror);
            }
            passes.push(Pass::MsphGradient);
            let stressed =
                cfg.viscous_term == ViscousTerm::NestedSummation || cfg.polymer.is_some();
            if mirror_walls && stressed {
                passes.push(Pass::WallStress);
            }
            passes.push(Pass::MsphDivergence);
        } else if Self::forms_viscous_stress(cfg, inclusions.is_some()) || cfg.polymer.is_some() {
            passes.push(Pass::Gradient);
        }
        passes.push(Pass::Momentum);
        let mirror = walls.filter(|_| mirror_walls).map(|w| {
            let axis = w.axis.index();
            MirrorWalls {
                axis,
                planes: [0.0, lengths[axis]],
                thickness: w.thickness.unwrap_or(2.0 * cfg.support()) + spacing,
            }
        });
        let walls = walls.map(|w| {
            let axis = w.axis.index();
            let vel = |u: &[f64]| std::array::from_fn(|d| u.get(d).copied().unwrap_or(0.0));
            WallGeometry {
                axis,
                planes: [0.0, lengths[axis]],
                velocity: [vel(&w.lower_velocity), vel(&w.upper_velocity)],
                morris: w.treatment == WallTreatment::Morris,
                mirror_velocity: usize::MAX,
                beta_max: w.morris_cap,
                min_distance: 0.5 * spacing,
                strength: w
                    .repulsion_strength
                    .unwrap_or(cfg.sound_speed * cfg.sound_speed),
                range: w.repulsion_range.unwrap_or(spacing),
            }
        });
        let inclusions_geometry = inclusions.map(|inc| InclusionGeometry {
            radius: inc.radius,
            traction_moments: false,
            mirror_pressure: inc.mirror_pressure,
            beta_max: inc.morris_cap,
            min_distance: 0.5 * spacing,
            offset: usize::MAX,
        });
        Self {
            cfg: cfg.clone(),
            mass,
            passes,
            boundaries: Boundaries {
                walls,
                inclusions: inclusions_geometry,
            },
            inclusions: inclusions.cloned(),
            body_force: std::array::from_fn(|d| cfg.body_force.get(d).copied().unwrap_or(0.0)),
            density: usize::MAX,
            rate: None,
            stress: None,
            xsph: None,
            traction_moment: None,
            polymer: cfg.polymer.as_ref().and_then(ConstitutiveLaw::of),
            polymer_stress: None,
            polymer_rate: None,
            velocity_gradient: None,
            uncorrected_gradients: 0,
            mirror,
            local: Vec::new(),
            msph_first_order: 0,
            msph_undetermined: 0,
            mirror_fallbacks: FitFallbacks::default(),
            values: Vec::new(),
            p_over_rho2: Vec::new(),
            inv_density: Vec::new(),
            stress_over_rho2: Vec::new(),
            sums: Vec::new(),
            scatter: ScatterBuffers::default(),
            flux_wanted: false,
            flux: None,
        }
    }

    /// The same fluid, with the inclusions' traction moments ([`INCLUSION_TRACTION_MOMENT`])
    /// accumulated by the momentum pass when `measure` (the `composite_viscosity` observable);
    /// otherwise no pass spends work on them.
    pub fn with_traction_moments(mut self, measure: bool) -> Self {
        if let Some(g) = &mut self.boundaries.inclusions {
            g.traction_moments = measure;
        }
        self
    }

    /// The stress fields the momentum equation reads (the nested summation's σ̄, the polymer
    /// τ): their ghost copies must be fresh before it.
    fn stress_fields(&self) -> Vec<&'static str> {
        let mut out = Vec::new();
        if self.cfg.viscous_term == ViscousTerm::NestedSummation {
            out.push(VISCOUS_STRESS);
        }
        if self.cfg.polymer.is_some() {
            out.push(POLYMER_STRESS);
        }
        out
    }

    fn measures_traction(&self) -> bool {
        self.boundaries
            .inclusions
            .is_some_and(|g| g.traction_moments)
    }

    /// Whether the fluid forms its Newtonian stress η(G + Gᵀ − (2/d) tr G I): with the nested
    /// summation it enters the momentum equation; with Morris's term it is only measured (the
    /// viscometric observables), when a polymer or inclusions make the run a viscometric one.
    fn forms_viscous_stress(cfg: &SphCfg, inclusions: bool) -> bool {
        cfg.viscous_term == ViscousTerm::NestedSummation
            || ((cfg.polymer.is_some() || inclusions) && cfg.viscosity > 0.0)
    }

    /// Whether the momentum pass gathers its sums in lanes (`lanes.rs`): on a CPU with
    /// AVX-512 (elsewhere the AVX2 scatter is faster than the portable lanes), fluid only, the
    /// pressure, Morris's term and the nested summation's stress in pair form, nothing else
    /// accumulated. (The kernel checks the same at run time and scatters when it does not
    /// hold.)
    fn momentum_in_lanes(&self) -> bool {
        Isa::current().has_avx512()
            && self.passes.contains(&Pass::Momentum)
            && !self.boundaries.any()
            && self.inclusions.is_none()
            && self.polymer_stress.is_none()
            && self.xsph.is_none()
            && self.traction_moment.is_none()
            && self.cfg.derivatives == Derivatives::Sph
    }

    fn typical(&self) -> (f64, f64, f64) {
        let c0 = self.cfg.sound_speed;
        let rho0 = self.cfg.rest_density;
        let dw = with_kernel!(self.cfg.kernel, self.cfg.smoothing_length, D, |k| k
            .max_abs_dw());
        let w0 = with_kernel!(self.cfg.kernel, self.cfg.smoothing_length, D, |k| k.w(0.0));
        let gradient = self.mass / rho0 * c0 * dw;
        let momentum = self.mass * self.mass * (c0 * c0 / rho0) * dw;
        (self.mass * w0, gradient, momentum)
    }

    /// What follows the velocity gradient G_i (`sums`: D² per owned particle, row-major
    /// ∂v^a/∂x^b): the nested summation's Newtonian stress (1 − s) η (G + Gᵀ − (2/d) tr G I),
    /// the dumbbells' κ, the constitutive polymer rate.
    fn finish_gradient(&mut self, p: &mut Particles<D>, sums: &[f64]) {
        if let Some(stress) = self.stress {
            let eta = self.cfg.viscosity * (1.0 - self.cfg.morris_share);
            let out = &mut p.extra[stress].data;
            for (i, g) in sums.chunks_exact(D * D).enumerate() {
                let trace: f64 = (0..D).map(|a| g[a * D + a]).sum();
                for a in 0..D {
                    for b in 0..D {
                        let mut s = g[a * D + b] + g[b * D + a];
                        if a == b {
                            s -= 2.0 / D as f64 * trace;
                        }
                        out[i * D * D + a * D + b] = eta * s;
                    }
                }
            }
        }
        if let Some(g) = self.velocity_gradient {
            // The dumbbells' κ for their next step (row-major ∂v^a/∂x^b).
            p.extra[g].data[..sums.len()].copy_from_slice(sums);
        }
        if let (Some(model), Some(tau), Some(rate)) =
            (self.polymer, self.polymer_stress, self.polymer_rate)
        {
            let w = packed_width(D);
            let mut row = [0.0; 6];
            let mut out = [0.0; 6];
            for (i, g) in sums.chunks_exact(D * D).enumerate() {
                row[..w].copy_from_slice(&p.extra[tau].data[i * w..(i + 1) * w]);
                let g: [[f64; D]; D] =
                    std::array::from_fn(|a| std::array::from_fn(|b| g[a * D + b]));
                model.rate::<D>(&row[..w], &g, &mut out[..w]);
                p.extra[rate].data[i * w..(i + 1) * w].copy_from_slice(&out[..w]);
            }
        }
    }

    /// The MSPH and mirror-wall passes (`[fluid] derivatives = "msph"`,
    /// docs/theory/msph_dumbbells.md §1.3, §1.6, §5.1), with the truncated Gaussian kernel.
    fn run_msph(
        &mut self,
        pass: Pass,
        p: &mut Particles<D>,
        full: &FullList,
    ) -> Result<(), msph::NotFinite> {
        let h = self.cfg.smoothing_length;
        let kernel = kernels::TruncatedGaussian::new(h, D);
        let nu = unknowns(D);
        let n = p.n_owned;
        let fluid_only = self.boundaries.walls.is_none_or(|_| self.mirror.is_some());
        match pass {
            Pass::WallMirror => {
                let Some(mirror) = self.mirror else {
                    return Ok(());
                };
                let (density, velocity) = (
                    self.density,
                    self.boundaries
                        .walls
                        .map_or(usize::MAX, |w| w.mirror_velocity),
                );
                let wall_velocity = self.boundaries.walls.map_or([[0.0; D]; 2], |w| w.velocity);
                let mut fitted: Vec<(usize, [f64; D], f64)> = Vec::new();
                let fallbacks = {
                    let pr = &*p;
                    mirror.fit(
                        &kernel,
                        pr,
                        D + 1,
                        |f, out| {
                            out[0] = pr.extra[density].data[f];
                            out[1..].copy_from_slice(&pr.vel[f]);
                        },
                        |fit| {
                            let u = wall_velocity[fit.side];
                            fitted.push((
                                fit.particle,
                                std::array::from_fn(|d| 2.0 * u[d] - fit.value[1 + d]),
                                fit.value[0],
                            ));
                        },
                    )
                };
                self.mirror_fallbacks.shepard += fallbacks.shepard;
                self.mirror_fallbacks.empty += fallbacks.empty;
                // Boundary particles without a fit keep ρ₀ and their wall's velocity.
                for w in 0..n {
                    let s = p.species_of(w);
                    if is_wall(s) {
                        let u = wall_velocity[usize::from(s == UPPER_WALL)];
                        p.extra[density].data[w] = self.cfg.rest_density;
                        p.extra[velocity].data[w * D..(w + 1) * D].copy_from_slice(&u);
                    }
                }
                for (w, v, rho) in fitted {
                    p.extra[density].data[w] = rho;
                    p.extra[velocity].data[w * D..(w + 1) * D].copy_from_slice(&v);
                }
                Ok(())
            }
            Pass::MsphGradient => {
                // The velocity each particle contributes: a mirror wall's fitted one.
                let mirror_velocity = self
                    .boundaries
                    .walls
                    .map_or(usize::MAX, |w| w.mirror_velocity);
                let mut values = std::mem::take(&mut self.values);
                values.clear();
                for j in 0..p.len() {
                    let s = p.species_of(j);
                    if mirror_velocity != usize::MAX && is_wall(s) {
                        values
                            .extend_from_slice(&p.extra[mirror_velocity].data[j * D..(j + 1) * D]);
                    } else {
                        values.extend_from_slice(&p.vel[j]);
                    }
                }
                let k = MomentKernel {
                    kernel,
                    mass: self.mass,
                    density: &p.extra[self.density].data,
                    values: &values,
                    fields: D,
                    matrix: true,
                    fluid_only,
                };
                let mut sums = std::mem::take(&mut self.sums);
                let r = k.gather(p, full, &mut sums);
                let width = nu * nu + nu * D;
                let result = r.map(|()| {
                    // Per particle: its derivative form and its D² gradient, on the pool.
                    let solved: Vec<(Local<D>, [f64; 9])> = sums
                        .par_chunks_exact(width)
                        .enumerate()
                        .with_min_len(16)
                        .map(|(i, row)| {
                            let mut g = [0.0; 9];
                            if !k.active(p, i) {
                                return (Local::Undetermined, g);
                            }
                            let local = Local::<D>::new(&row[..nu * nu], h);
                            for a in 0..D {
                                let b = &row[nu * nu + a * nu..nu * nu + (a + 1) * nu];
                                let ga = local.gradient(b, values[i * D + a]);
                                g[a * D..(a + 1) * D].copy_from_slice(&ga);
                            }
                            (local, g)
                        })
                        .collect();
                    self.local.clear();
                    let mut gradient = vec![0.0; n * D * D];
                    for (i, (local, g)) in solved.into_iter().enumerate() {
                        if k.active(p, i) {
                            match local {
                                Local::Second { .. } => {}
                                Local::First { .. } => self.msph_first_order += 1,
                                Local::Undetermined => self.msph_undetermined += 1,
                            }
                        }
                        gradient[i * D * D..(i + 1) * D * D].copy_from_slice(&g[..D * D]);
                        self.local.push(local);
                    }
                    gradient
                });
                self.sums = sums;
                self.values = values;
                let gradient = result?;
                self.finish_gradient(p, &gradient);
                Ok(())
            }
            Pass::WallStress => {
                let Some(mirror) = self.mirror else {
                    return Ok(());
                };
                let pw = packed_width(D);
                let polymer = self.polymer_stress;
                let viscous = self
                    .stress
                    .filter(|_| self.cfg.viscous_term == ViscousTerm::NestedSummation);
                let count = polymer.map_or(0, |_| pw) + viscous.map_or(0, |_| D * D);
                let mut fitted: Vec<(usize, Vec<f64>)> = Vec::new();
                let fallbacks = {
                    let pr = &*p;
                    mirror.fit(
                        &kernel,
                        pr,
                        count,
                        |f, out| {
                            let mut k = 0;
                            if let Some(t) = polymer {
                                out[..pw].copy_from_slice(&pr.extra[t].data[f * pw..(f + 1) * pw]);
                                k = pw;
                            }
                            if let Some(v) = viscous {
                                out[k..]
                                    .copy_from_slice(&pr.extra[v].data[f * D * D..(f + 1) * D * D]);
                            }
                        },
                        |fit| {
                            let extrapolated = (0..count)
                                .map(|q| {
                                    fit.value[q]
                                        + (0..D)
                                            .map(|d| fit.slope[q * D + d] * fit.offset[d])
                                            .sum::<f64>()
                                })
                                .collect();
                            fitted.push((fit.particle, extrapolated));
                        },
                    )
                };
                self.mirror_fallbacks.shepard += fallbacks.shepard;
                self.mirror_fallbacks.empty += fallbacks.empty;
                for w in 0..n {
                    let s = p.species_of(w);
                    if is_wall(s) {
                        if let Some(t) = polymer {
                            p.extra[t].data[w * pw..(w + 1) * pw].fill(0.0);
                        }
                        if let Some(v) = viscous {
                            p.extra[v].data[w * D * D..(w + 1) * D * D].fill(0.0);
                        }
                    }
                }
                for (w, values) in fitted {
                    if let Some(t) = polymer {
                        p.extra[t].data[w * pw..(w + 1) * pw].copy_from_slice(&values[..pw]);
                    }
                    if let Some(v) = viscous {
                        let k = polymer.map_or(0, |_| pw);
                        p.extra[v].data[w * D * D..(w + 1) * D * D].copy_from_slice(&values[k..]);
                    }
                }
                Ok(())
            }
            Pass::MsphDivergence => {
                // σ = −pI + σ̄ + τ of every particle, packed symmetric.
                let pw = packed_width(D);
                let polymer = self.polymer_stress;
                let viscous = self
                    .stress
                    .filter(|_| self.cfg.viscous_term == ViscousTerm::NestedSummation);
                let mut values = std::mem::take(&mut self.values);
                values.clear();
                for j in 0..p.len() {
                    let pressure = self.cfg.pressure(p.extra[self.density].data[j]);
                    for a in 0..D {
                        for b in a..D {
                            let mut s = if a == b { -pressure } else { 0.0 };
                            if let Some(t) = polymer {
                                s += p.extra[t].data[j * pw + packed_index::<D>(a, b)];
                            }
                            if let Some(v) = viscous {
                                s += p.extra[v].data[j * D * D + a * D + b];
                            }
                            values.push(s);
                        }
                    }
                }
                // The packed order of (a, b), a ≤ b, as pushed above.
                let order: Vec<(usize, usize)> =
                    (0..D).flat_map(|a| (a..D).map(move |b| (a, b))).collect();
                let k = MomentKernel {
                    kernel,
                    mass: self.mass,
                    density: &p.extra[self.density].data,
                    values: &values,
                    fields: pw,
                    matrix: false,
                    fluid_only,
                };
                let mut sums = std::mem::take(&mut self.sums);
                let r = k.gather(p, full, &mut sums);
                let result = r.map(|()| {
                    let local = &self.local;
                    let divergence: Vec<[f64; D]> = sums
                        .par_chunks_exact(nu * pw)
                        .enumerate()
                        .with_min_len(16)
                        .map(|(i, row)| {
                            let mut div = [0.0; D];
                            let Some(local) = local.get(i) else {
                                return div;
                            };
                            for (q, &(a, b)) in order.iter().enumerate() {
                                let g =
                                    local.gradient(&row[q * nu..(q + 1) * nu], values[i * pw + q]);
                                // ∂_b σ_ab into component a, and ∂_a σ_ba into b.
                                div[a] += g[b];
                                if a != b {
                                    div[b] += g[a];
                                }
                            }
                            div
                        })
                        .collect();
                    for (i, div) in divergence.iter().enumerate() {
                        let m_over_rho = self.mass / p.extra[self.density].data[i];
                        for d in 0..D {
                            p.force[i][d] += m_over_rho * div[d];
                        }
                    }
                });
                self.sums = sums;
                self.values = values;
                result
            }
            _ => unreachable!("not an MSPH pass"),
        }
    }

    fn run<K: Kernel>(
        &mut self,
        kernel: K,
        pass: Pass,
        p: &mut Particles<D>,
        list: &NeighbourList<D>,
        full: &FullList,
    ) -> Result<(), crate::models::gather::PairError> {
        // Bounds of the exact sums. The scales exist to stop a blown-up run (a term not finite
        // or absurdly large) with the pair named; the fixed-point sum resolves 2⁻¹⁰² of its
        // scale, so a headroom of 10⁸ over a term's typical size still resolves it to ~10⁻²³.
        const HEADROOM: f64 = 1e8;
        let (density_scale, gradient_scale, momentum_scale) = self.typical();
        let mut sums = std::mem::take(&mut self.sums);
        let n = p.n_owned;
        let result = match pass {
            Pass::Density => {
                let k = DensityKernel {
                    kernel,
                    mass: self.mass,
                    // Each term is at most m W(0): an exact bound.
                    scales: [Scale::covering(density_scale)],
                };
                scatter(&k, p, list, &mut self.scatter, &mut sums).map(|()| {
                    p.extra[self.density].data[..n].copy_from_slice(&sums);
                })
            }
            Pass::Gradient => {
                let corrected = self.cfg.velocity_gradient == GradientEstimate::Corrected;
                let mut scales = vec![Scale::covering(HEADROOM * gradient_scale); D * D];
                if corrected {
                    // M_i terms: (m/ρ) |W'| r ≤ the gradient terms' bound with r_s for c₀.
                    let lattice = gradient_scale / self.cfg.sound_speed * self.cfg.support();
                    scales.extend(vec![Scale::covering(HEADROOM * lattice); D * D]);
                }
                let width = scales.len();
                let k = GradientKernel {
                    kernel,
                    mass: self.mass,
                    density: &p.extra[self.density].data,
                    boundaries: self.boundaries,
                    corrected,
                    scales,
                };
                // Fluid only, with AVX-512: the vector lanes; otherwise the generic lanes
                // (scalar pair terms, vector fixed-point words); failing both, pair by pair.
                let isa = Isa::current();
                let r = if (isa.has_avx512() && k.gather_lanes(isa, p, full.lanes(), &mut sums))
                    || gather_in_lanes(isa, &k, p, full, &mut sums)
                {
                    Ok(())
                } else {
                    gather(&k, p, full, &mut sums)
                };
                r.map(|()| {
                    if corrected {
                        self.uncorrected_gradients +=
                            apply_gradient_correction::<D>(&mut sums, width) as u64;
                        // The rows become G_i alone, D² wide, for what follows.
                        let mut w = 0;
                        for r in 0..sums.len() / width {
                            for q in 0..D * D {
                                sums[w] = sums[r * width + q];
                                w += 1;
                            }
                        }
                        sums.truncate(w);
                    }
                    self.finish_gradient(p, &sums);
                })
            }
            Pass::Momentum => {
                let c2 = self.cfg.sound_speed * self.cfg.sound_speed;
                let c0_velocity = self.cfg.sound_speed;
                let (eos, rho0) = (self.cfg.equation_of_state, self.cfg.rest_density);
                let density = &p.extra[self.density].data;
                self.p_over_rho2.clear();
                let background = self.cfg.background_pressure;
                // One loop per equation of state, so that each vectorises (the same
                // operations as the match inside the loop).
                if background == 0.0 {
                    match eos {
                        EquationOfState::Tait => {
                            self.p_over_rho2.extend(density.iter().map(|&rho| {
                                SphCfg::pressure_over_rho2(EquationOfState::Tait, c2, rho0, rho)
                            }))
                        }
                        EquationOfState::Quadratic => {
                            self.p_over_rho2.extend(density.iter().map(|&rho| {
                                SphCfg::pressure_over_rho2(
                                    EquationOfState::Quadratic,
                                    c2,
                                    rho0,
                                    rho,
                                )
                            }))
                        }
                    }
                } else {
                    self.p_over_rho2.extend(density.iter().map(|&rho| {
                        SphCfg::pressure_over_rho2(eos, c2, rho0, rho) + background / (rho * rho)
                    }));
                }
                self.inv_density.clear();
                self.inv_density
                    .extend(density.iter().map(|&rho| 1.0 / rho));
                let lanes = self.momentum_in_lanes();
                self.stress_over_rho2.clear();
                if let Some(stress) = self
                    .stress
                    .filter(|_| lanes && self.cfg.viscous_term == ViscousTerm::NestedSummation)
                {
                    let stress = &p.extra[stress].data;
                    self.stress_over_rho2.extend(
                        stress
                            .chunks_exact(D * D)
                            .zip(density)
                            .flat_map(|(s, &rho)| s.iter().map(move |&c| c / (rho * rho))),
                    );
                }
                let continuity = self.rate.is_some();
                let xsph_first = D + usize::from(continuity);
                let moment_first = xsph_first + if self.xsph.is_some() { D } else { 0 };
                let width = moment_first
                    + if self.traction_moment.is_some() {
                        D * D
                    } else {
                        0
                    };
                let mut scales = vec![Scale::covering(HEADROOM * momentum_scale); width];
                let mut parities = vec![Parity::Odd; width];
                if continuity {
                    scales[D] = Scale::covering(HEADROOM * gradient_scale * rho0);
                    parities[D] = Parity::Even;
                }
                // XSPH terms: at most ε (m/ρ) W(0) |v|, |v| bounded by c₀ in any sane run.
                for scale in &mut scales[xsph_first..moment_first] {
                    *scale = Scale::covering(HEADROOM * density_scale / rho0 * c0_velocity);
                }
                // Traction moments: a pair force times a radius.
                let radius = self.inclusions.as_ref().map_or(0.0, |inc| inc.radius);
                for scale in &mut scales[moment_first..] {
                    *scale = Scale::covering(HEADROOM * momentum_scale * radius);
                }
                let k = MomentumKernel {
                    kernel,
                    mass: self.mass,
                    density,
                    inv_density: &self.inv_density,
                    p_over_rho2: &self.p_over_rho2,
                    // With Morris's term a polymer fluid's viscous stress is only measured.
                    stress: self
                        .stress
                        .filter(|_| self.cfg.viscous_term == ViscousTerm::NestedSummation)
                        .map(|s| p.extra[s].data.as_slice()),
                    stress_over_rho2: (!self.stress_over_rho2.is_empty())
                        .then_some(self.stress_over_rho2.as_slice()),
                    polymer: self.polymer_stress.map(|s| p.extra[s].data.as_slice()),
                    two_eta_morris: match self.cfg.viscous_term {
                        ViscousTerm::Morris => 2.0 * self.cfg.viscosity,
                        ViscousTerm::NestedSummation => {
                            2.0 * self.cfg.viscosity * self.cfg.morris_share
                        }
                    },
                    regulariser: self.cfg.morris_regularisation
                        * self.cfg.smoothing_length
                        * self.cfg.smoothing_length,
                    continuity,
                    xsph_eps_mass: self.cfg.xsph * self.mass,
                    pairwise_stress: self.cfg.derivatives == Derivatives::Sph,
                    boundaries: self.boundaries,
                    scales,
                    parities,
                };
                // The momentum flux, on the steps the diagnostics sample (with MSPH derivatives
                // the stresses are not pair forces: validation refuses the flux there).
                let flux = (self.flux_wanted && k.pairwise_stress)
                    .then(|| momentum_flux::momentum_virial(&k, p, list));
                let gathered = lanes && k.gather_lanes(Isa::current(), p, full.lanes(), &mut sums);
                let r = if gathered {
                    Ok(())
                } else {
                    scatter(&k, p, list, &mut self.scatter, &mut sums)
                };
                self.flux = flux;
                r.map(|()| {
                    let mf: [f64; D] = std::array::from_fn(|d| self.mass * self.body_force[d]);
                    let species = p.species.as_deref();
                    for (i, s) in sums.chunks_exact(width).enumerate() {
                        let fluid = species.is_none_or(|sp| sp[i] == FLUID);
                        let f = &mut p.force[i];
                        for d in 0..D {
                            f[d] += s[d];
                            if fluid {
                                f[d] += mf[d];
                            }
                        }
                    }
                    if let Some(rate) = self.rate {
                        let out = &mut p.extra[rate].data;
                        for (i, s) in sums.chunks_exact(width).enumerate() {
                            out[i] = s[D];
                        }
                    }
                    if let Some(xsph) = self.xsph {
                        let out = &mut p.extra[xsph].data;
                        for (i, s) in sums.chunks_exact(width).enumerate() {
                            out[i * D..(i + 1) * D].copy_from_slice(&s[xsph_first..moment_first]);
                        }
                    }
                    if let Some(moment) = self.traction_moment {
                        let out = &mut p.extra[moment].data;
                        for (i, s) in sums.chunks_exact(width).enumerate() {
                            out[i * D * D..(i + 1) * D * D].copy_from_slice(&s[moment_first..]);
                        }
                    }
                })
            }
            Pass::WallMirror | Pass::MsphGradient | Pass::WallStress | Pass::MsphDivergence => {
                unreachable!("MSPH passes run in run_msph")
            }
        };
        self.sums = sums;
        result
    }
}

impl<const D: usize> ParticleModel<D> for SphModel<D> {
    fn name(&self) -> &'static str {
        "sph"
    }

    fn cutoff(&self) -> f64 {
        if self.cfg.derivatives == Derivatives::Msph {
            // MSPH counts the neighbours at exactly r = 2h (W'(2h) ≠ 0).
            self.cfg.support() * (1.0 + 1e-9)
        } else {
            self.cfg.support()
        }
    }

    fn fields(&self) -> Vec<FieldSpec> {
        let mut f = Vec::new();
        if self.cfg.density == DensityMethod::Summation {
            f.push(FieldSpec {
                name: DENSITY,
                kind: FieldKind::Scalar,
                flags: FieldFlags::DERIVED,
            });
        } else {
            f.push(FieldSpec {
                name: DENSITY,
                kind: FieldKind::Scalar,
                flags: FieldFlags::STATE,
            });
            f.push(FieldSpec {
                name: DENSITY_RATE,
                kind: FieldKind::Scalar,
                flags: FieldFlags::STATE,
            });
        }
        if Self::forms_viscous_stress(&self.cfg, self.inclusions.is_some()) {
            f.push(FieldSpec {
                name: VISCOUS_STRESS,
                kind: FieldKind::Tensor,
                flags: FieldFlags::DERIVED,
            });
        }
        match &self.cfg.polymer {
            Some(poly) if poly.is_ensemble() => {
                // τ is the ensembles' Kramers stress, derived anew after every ensemble step
                // (and on restart) from the connectors, which are the state.
                f.push(FieldSpec {
                    name: POLYMER_STRESS,
                    kind: FieldKind::Values(packed_width(D)),
                    flags: FieldFlags::DERIVED,
                });
                // Like the forces: of the last evaluation, used by the next ensemble step, so
                // kept across a restart.
                f.push(FieldSpec {
                    name: VELOCITY_GRADIENT,
                    kind: FieldKind::Tensor,
                    flags: FieldFlags::STATE,
                });
            }
            Some(_) => {
                for name in [POLYMER_STRESS, POLYMER_STRESS_RATE] {
                    // The rate, like the forces: of the last evaluation, used by the next step.
                    f.push(FieldSpec {
                        name,
                        kind: FieldKind::Values(packed_width(D)),
                        flags: FieldFlags::STATE,
                    });
                }
            }
            None => {}
        }
        if self.mirror.is_some() {
            f.push(FieldSpec {
                name: MIRROR_VELOCITY,
                kind: FieldKind::Vector,
                flags: FieldFlags::DERIVED,
            });
        }
        if self.inclusions.is_some() {
            f.push(FieldSpec {
                name: INCLUSION_OFFSET,
                kind: FieldKind::Vector,
                flags: FieldFlags::STATE,
            });
        }
        if self.measures_traction() {
            f.push(FieldSpec {
                name: INCLUSION_TRACTION_MOMENT,
                kind: FieldKind::Tensor,
                flags: FieldFlags::DERIVED,
            });
        }
        if self.cfg.xsph != 0.0 {
            // Like the forces: of the last evaluation, used by the next drift, so kept across a
            // restart.
            f.push(FieldSpec {
                name: XSPH_CORRECTION,
                kind: FieldKind::Vector,
                flags: FieldFlags::STATE,
            });
        }
        f
    }

    fn drift_correction(&self) -> Option<&'static str> {
        (self.cfg.xsph != 0.0).then_some(XSPH_CORRECTION)
    }

    fn passes(&self) -> Vec<PassSpec> {
        let mut density_refreshed = false;
        // The inclusion offsets never change; the ghosts get them before the first pass that
        // sees a boundary velocity (they persist until the next rebuild).
        let mut offsets_refreshed = self.inclusions.is_none();
        self.passes
            .iter()
            .map(|pass| match pass {
                Pass::Density => PassSpec {
                    name: "summation density",
                    ghost_fields: Vec::new(),
                },
                Pass::Gradient => {
                    density_refreshed = true;
                    let mut ghost_fields = vec![DENSITY];
                    if !offsets_refreshed {
                        ghost_fields.push(INCLUSION_OFFSET);
                        offsets_refreshed = true;
                    }
                    PassSpec {
                        name: "velocity gradient",
                        ghost_fields,
                    }
                }
                Pass::Momentum => {
                    let mut ghost_fields = Vec::new();
                    if !density_refreshed {
                        ghost_fields.push(DENSITY);
                    }
                    if !offsets_refreshed {
                        ghost_fields.push(INCLUSION_OFFSET);
                    }
                    if self.cfg.derivatives == Derivatives::Sph {
                        ghost_fields.extend(self.stress_fields());
                    }
                    PassSpec {
                        name: "momentum",
                        ghost_fields,
                    }
                }
                Pass::WallMirror => PassSpec {
                    name: "mirror walls: density and velocity",
                    ghost_fields: vec![DENSITY],
                },
                Pass::MsphGradient => {
                    density_refreshed = true;
                    let mut ghost_fields = vec![DENSITY];
                    if self.mirror.is_some() {
                        ghost_fields.push(MIRROR_VELOCITY);
                    }
                    PassSpec {
                        name: "MSPH velocity gradient",
                        ghost_fields,
                    }
                }
                Pass::WallStress => PassSpec {
                    name: "mirror walls: stress",
                    ghost_fields: self.stress_fields(),
                },
                Pass::MsphDivergence => PassSpec {
                    name: "MSPH stress divergence",
                    ghost_fields: self.stress_fields(),
                },
            })
            .collect()
    }

    fn uses_full_list(&self) -> bool {
        // The velocity-gradient passes gather (their terms carry 1/ρ_j, not symmetric); the
        // density pass scatters from the half list, and so does the momentum pass except in
        // a fluid-only scheme, whose momentum sums are gathered in lanes (`lanes`).
        self.passes.contains(&Pass::Gradient)
            || self.passes.contains(&Pass::MsphGradient)
            || self.momentum_in_lanes()
    }

    fn integrated_fields(&self) -> Vec<Integrated> {
        let mut out = Vec::new();
        if self.cfg.density == DensityMethod::Continuity {
            out.push(Integrated {
                state: DENSITY,
                rate: DENSITY_RATE,
                boundary_particles: false,
            });
        }
        if self.polymer.is_some() {
            out.push(Integrated {
                state: POLYMER_STRESS,
                rate: POLYMER_STRESS_RATE,
                boundary_particles: true,
            });
        }
        out
    }

    fn attach(&mut self, p: &mut Particles<D>, restarted: bool) -> Result<(), String> {
        self.density = p
            .extra_index(DENSITY)
            .ok_or("the density field is not registered")?;
        self.rate = p.extra_index(DENSITY_RATE);
        self.stress = p.extra_index(VISCOUS_STRESS);
        self.xsph = p.extra_index(XSPH_CORRECTION);
        self.traction_moment = p.extra_index(INCLUSION_TRACTION_MOMENT);
        if self.cfg.polymer.is_some() {
            let tau = p
                .extra_index(POLYMER_STRESS)
                .ok_or("the polymer stress field is not registered")?;
            self.polymer_stress = Some(tau);
        }
        if self.polymer.is_some() {
            let rate = p
                .extra_index(POLYMER_STRESS_RATE)
                .ok_or("the polymer stress rate field is not registered")?;
            self.polymer_rate = Some(rate);
        }
        self.velocity_gradient = p.extra_index(VELOCITY_GRADIENT);
        if self.mirror.is_some()
            && let Some(w) = &mut self.boundaries.walls
        {
            w.mirror_velocity = p
                .extra_index(MIRROR_VELOCITY)
                .ok_or("the mirror velocity field is not registered")?;
        }
        if !restarted && self.rate.is_some() {
            // Continuity density starts at ρ₀ (the lattice is uniform).
            p.extra[self.density].data.fill(self.cfg.rest_density);
        }
        if let (Some(inc), Some(geometry)) = (&self.inclusions, &mut self.boundaries.inclusions) {
            let offset = p
                .extra_index(INCLUSION_OFFSET)
                .ok_or("the inclusion offset field is not registered")?;
            geometry.offset = offset;
            if !restarted {
                // The particles inside a disc are its boundary particles (the species the
                // engine gives them follows the same test, [`InclusionsCfg::offset`]).
                for i in 0..p.n_owned {
                    if let Some(o) = inc.offset(&p.pos[i]) {
                        p.extra[offset].data[i * D..(i + 1) * D].copy_from_slice(&o);
                    }
                }
            }
        }
        Ok(())
    }

    fn counted_warnings(&self) -> Vec<(u64, &'static str)> {
        vec![
            (
                self.msph_first_order,
                "{n} MSPH systems (particle × evaluation) were solved to first order only: \
                 their h-scaled moment matrix had a 1-norm condition number above 10⁴ (a \
                 sparse or one-sided neighbourhood)",
            ),
            (
                self.msph_undetermined,
                "{n} MSPH systems (particle × evaluation) determined no derivative at all \
                 (an isolated particle): its gradients were set to zero",
            ),
            (
                self.mirror_fallbacks.shepard,
                "{n} mirror-wall fits (boundary particle × pass) had too few fluid particles \
                 for a linear fit and took their weighted mean",
            ),
            (
                self.mirror_fallbacks.empty,
                "{n} mirror-wall fits (boundary particle × pass) found no fluid particle within \
                 2h of the mirror point and kept ρ₀, the wall velocity and zero stress",
            ),
            (
                self.uncorrected_gradients,
                "{n} velocity-gradient estimates (particle × evaluation) kept the plain SPH form: \
             their moment matrix M_i had det M_i < 10⁻³ (too few neighbours); check the \
             neighbour count or the support",
            ),
        ]
    }

    fn pass(&mut self, pass: usize, ctx: PassContext<'_, D>) -> Result<PassOutput, String> {
        let kind = self.passes[pass];
        let (kernel, h) = (self.cfg.kernel, self.cfg.smoothing_length);
        let (p, list, full) = (ctx.particles, ctx.list, ctx.full);
        if matches!(kind, Pass::Momentum | Pass::MsphDivergence) {
            check_density(p, self.density, ctx.step)?;
        }
        self.flux_wanted = ctx.virial != crate::models::pair_loop::VirialScope::Off;
        match kind {
            Pass::WallMirror | Pass::MsphGradient | Pass::WallStress | Pass::MsphDivergence => {
                self.run_msph(kind, p, full).map_err(|e| e.to_string())
            }
            _ => with_kernel!(kernel, h, D, |k| self.run(k, kind, p, list, full))
                .map_err(|e| e.to_string()),
        }
        .map_err(|e| format!("{e} (SPH pass {kind:?} at step {})", ctx.step))?;
        let virial = self
            .flux
            .take()
            .transpose()
            .map_err(|e| format!("{e} (SPH momentum flux at step {})", ctx.step))?;
        Ok(PassOutput {
            virial,
            ..PassOutput::default()
        })
    }
}

/// Blow-up detector: a fluid particle whose density is zero, negative or not finite (continuity
/// density under too large a step, or a NaN from elsewhere) stops the run before the equation
/// of state turns it into a pressure, naming the particle (the lowest id on this rank).
fn check_density<const D: usize>(
    p: &Particles<D>,
    density: usize,
    step: u64,
) -> Result<(), String> {
    let rho = &p.extra[density].data;
    let bad = (0..p.n_owned)
        .filter(|&i| p.species_of(i) == FLUID && !(rho[i] > 0.0 && rho[i].is_finite()))
        .min_by_key(|&i| p.gid[i]);
    match bad {
        None => Ok(()),
        Some(i) => Err(format!(
            "particle {} has density ρ = {:e} (it must be positive and finite) at step {step}: \
             {} (reduce the time step, or use summation density, which cannot go negative)",
            p.gid[i],
            rho[i],
            crate::error::UNSTABLE
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::gather::{pair_symmetry, scatter_on};
    use crate::neighbour::NeighbourList;
    use crate::rng::{Purpose, StreamKey};
    use crate::simd::Isa;

    fn cfg(viscous_term: ViscousTerm, density: DensityMethod) -> SphCfg {
        SphCfg {
            kernel: KernelKind::WendlandC2,
            smoothing_length: 0.6,
            rest_density: 1.0,
            sound_speed: 10.0,
            equation_of_state: EquationOfState::Tait,
            density,
            viscosity: 0.3,
            viscous_term,
            body_force: Vec::new(),
            morris_regularisation: 0.01,
            xsph: 0.0,
            background_pressure: 0.0,
            velocity_gradient: GradientEstimate::Sph,
            derivatives: Derivatives::Sph,
            morris_share: 0.0,
            polymer: None,
        }
    }

    /// The corrected estimate G_i M_i⁻¹ recovers a linear velocity field v = A x + b exactly
    /// (to round-off) on a random arrangement with random densities, where the plain SPH
    /// estimate is off by several per cent; and the cofactor inverse is an inverse.
    #[test]
    fn corrected_gradient_is_exact_for_a_linear_field_on_a_disordered_arrangement() {
        let key = StreamKey::new(5, Purpose::Test, 4);
        let mut p = random_particles();
        let a: [[f64; 3]; 3] = std::array::from_fn(|r| {
            std::array::from_fn(|c| key.uniform2(2, r as u32, c as u32).0 - 0.5)
        });
        for i in 0..p.n_owned {
            let x = p.pos[i];
            p.vel[i] = std::array::from_fn(|r| 0.3 + (0..3).map(|c| a[r][c] * x[c]).sum::<f64>());
        }
        let density: Vec<f64> = (0..p.n_owned)
            .map(|i| 0.9 + 0.2 * key.uniform2(3, i as u32, 0).0)
            .collect();
        let list = NeighbourList::build(&p, 1.2, 1.2);
        let full = FullList::from_half(&list, p.n_owned);
        let errors = |corrected: bool| -> f64 {
            let width = if corrected { 18 } else { 9 };
            let k = GradientKernel {
                kernel: kernels::WendlandC2::new(0.6, 3),
                // m/ρ ≈ the volume per particle (4³/300), so that M_i ≈ I.
                mass: 0.2,
                density: &density,
                boundaries: Boundaries::default(),
                corrected,
                scales: vec![Scale::covering(1e3); width],
            };
            let mut sums = Vec::new();
            gather(&k, &p, &full, &mut sums).expect("gather");
            if corrected {
                // Particles at the cube's corners see too few neighbours and keep G_i.
                let kept = apply_gradient_correction::<3>(&mut sums, width);
                assert!(kept < p.n_owned / 4, "{kept} of {} kept G_i", p.n_owned);
            }
            // Particles whose whole support (1.2) lies inside the cube of side 4.
            let mut worst: f64 = 0.0;
            for i in (0..p.n_owned).filter(|&i| p.pos[i].iter().all(|&x| (1.2..2.8).contains(&x))) {
                for r in 0..3 {
                    for c in 0..3 {
                        worst = worst.max((sums[i * width + r * 3 + c] - a[r][c]).abs());
                    }
                }
            }
            worst
        };
        let (plain, corrected) = (errors(false), errors(true));
        assert!(
            plain > 0.02,
            "the plain estimate is off by {plain}: the test needs disorder"
        );
        assert!(corrected < 1e-11, "corrected estimate off by {corrected}");
        for m in [
            [[2.0, 0.3, -0.1], [0.5, 1.1, 0.2], [-0.4, 0.7, 0.9]],
            [[1.0, 0.0, 0.0], [0.0, 3.0, 1.0], [0.0, -1.0, 0.5]],
        ] {
            let (det, inv) = determinant_and_inverse(&m);
            assert!(det.abs() > 0.1);
            for r in 0..3 {
                for c in 0..3 {
                    let e: f64 = (0..3).map(|k| m[r][k] * inv[k][c]).sum();
                    assert!((e - f64::from(u8::from(r == c))).abs() < 1e-14, "{m:?}");
                }
            }
        }
        let m2 = [[2.0, 0.3], [0.5, 1.1]];
        let (det, inv) = determinant_and_inverse(&m2);
        assert!((det - 2.05).abs() < 1e-14);
        for r in 0..2 {
            for c in 0..2 {
                let e: f64 = (0..2).map(|k| m2[r][k] * inv[k][c]).sum();
                assert!((e - f64::from(u8::from(r == c))).abs() < 1e-14);
            }
        }
    }

    /// Random particles with random velocities, densities and stresses.
    fn random_particles() -> Particles<3> {
        let key = StreamKey::new(5, Purpose::Test, 2);
        let mut p = Particles::<3>::default();
        for i in 0..300u32 {
            let x = std::array::from_fn(|d| 4.0 * key.uniform2(0, i, d as u32).0);
            let v = std::array::from_fn(|d| key.uniform2(1, i, d as u32).0 - 0.5);
            p.push_owned(u64::from(i), x, v);
        }
        p
    }

    /// The momentum pair term is exactly antisymmetric (both viscous terms, with dρ/dt
    /// symmetric) and the gradient and density terms have the parity their sums need.
    #[test]
    fn pair_terms_have_exact_parity() {
        let key = StreamKey::new(5, Purpose::Test, 3);
        for (viscous, density) in [
            (ViscousTerm::NestedSummation, DensityMethod::Summation),
            (ViscousTerm::Morris, DensityMethod::Continuity),
        ] {
            let mut p = random_particles();
            // Periodic images of the particles near x = 0 (ghosts: rows of the full list
            // reach them only from their owned neighbours' end).
            for i in 0..p.n_owned {
                if p.pos[i][0] < 1.2 {
                    let (g, mut x, v) = (p.gid[i], p.pos[i], p.vel[i]);
                    x[0] += 4.0;
                    p.push_ghost(g, x, v, 0);
                }
            }
            let model_cfg = cfg(viscous, density);
            let mut model = SphModel::<3>::new(&model_cfg, 0.05, &[4.0; 3], 0.2, None, None);
            for spec in model.fields() {
                p.register_field(spec.name, spec.kind.width(3), spec.flags)
                    .expect("new field");
            }
            model.attach(&mut p, false).expect("attach");
            for i in 0..p.len() {
                p.extra[model.density].data[i] = 0.9 + 0.2 * key.uniform2(0, i as u32, 0).0;
                if let Some(s) = model.stress {
                    for c in 0..9 {
                        p.extra[s].data[i * 9 + c] = key.uniform2(1, i as u32, c as u32).0;
                    }
                }
            }
            let list = NeighbourList::build(&p, 1.2, 1.2);
            let density = &p.extra[model.density].data;
            let p_over_rho2: Vec<f64> = density
                .iter()
                .map(|&r| SphCfg::pressure_over_rho2(EquationOfState::Tait, 100.0, 1.0, r))
                .collect();
            let kernel = kernels::WendlandC2::new(0.6, 3);
            let continuity = density_is_continuity(&model_cfg);
            let inv_density: Vec<f64> = density.iter().map(|r| 1.0 / r).collect();
            // σ̄/ρ² per particle, as the pass forms it for the lanes.
            let stress_over_rho2: Option<Vec<f64>> = model.stress.map(|s| {
                p.extra[s]
                    .data
                    .chunks_exact(9)
                    .zip(density)
                    .flat_map(|(s, &rho)| s.iter().map(move |&c| c / (rho * rho)))
                    .collect()
            });
            for regulariser in [0.0036, 0.0] {
                let momentum = MomentumKernel {
                    kernel,
                    mass: 0.05,
                    density,
                    inv_density: &inv_density,
                    p_over_rho2: &p_over_rho2,
                    stress: model.stress.map(|s| p.extra[s].data.as_slice()),
                    stress_over_rho2: stress_over_rho2.as_deref(),
                    polymer: None,
                    two_eta_morris: if viscous == ViscousTerm::Morris {
                        0.6
                    } else {
                        0.0
                    },
                    regulariser,
                    continuity,
                    xsph_eps_mass: 0.0,
                    pairwise_stress: true,
                    boundaries: Boundaries::default(),
                    scales: vec![Scale::covering(1e6); 3 + usize::from(continuity)],
                    parities: {
                        let mut parity = vec![Parity::Odd; 3];
                        if continuity {
                            parity.push(Parity::Even);
                        }
                        parity
                    },
                };
                let checked =
                    pair_symmetry(&momentum, &p, &list, momentum.parities()).expect("parity");
                assert!(checked > 1000, "{checked} pairs");
                // Scattered from the half list (in batches, by the vectorised loops where the
                // kernel has them, portable or AVX2), the sums are gather's to the last bit.
                let full = FullList::from_half(&list, p.n_owned);
                let mut gathered = Vec::new();
                gather(&momentum, &p, &full, &mut gathered).expect("gather");
                assert!(gathered.iter().any(|&x| x != 0.0));
                let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                let avx2 = Isa::avx2_for_test("sph scatter: AVX2 against gather");
                for isa in [Some(Isa::PORTABLE), avx2].into_iter().flatten() {
                    let mut scattered = Vec::new();
                    let mut work = ScatterBuffers::default();
                    scatter_on(isa, &momentum, &p, &list, &mut work, &mut scattered)
                        .expect("scatter");
                    assert_eq!(bits(&gathered), bits(&scattered), "{isa:?}");
                }
                // Gathered in lanes along the full rows (the fluid-only scheme: Morris's term
                // with continuity, or the nested summation's stress), by the portable loops
                // and, where the CPU has it, AVX-512: the same bits.
                let avx512 = Isa::avx512();
                if avx512.is_none() {
                    let _ = Isa::avx2_for_test("sph lanes: AVX-512 (only the portable lanes)");
                }
                for isa in [Some(Isa::PORTABLE), avx512].into_iter().flatten() {
                    let mut lanes = Vec::new();
                    assert!(momentum.gather_lanes(isa, &p, full.lanes(), &mut lanes));
                    assert_eq!(bits(&gathered), bits(&lanes), "{isa:?}");
                }
                // Without σ̄/ρ² the nested summation's lanes decline (the pass scatters).
                if momentum.stress.is_some() {
                    let without = MomentumKernel {
                        stress_over_rho2: None,
                        scales: momentum.scales.clone(),
                        parities: momentum.parities.clone(),
                        ..momentum
                    };
                    assert!(!without.gather_lanes(
                        Isa::PORTABLE,
                        &p,
                        full.lanes(),
                        &mut Vec::new()
                    ));
                }
                // A term beyond its scale: the lanes decline, and the scatter names it.
                let narrow = MomentumKernel {
                    scales: vec![Scale::covering(1e-12); momentum.scales.len()],
                    parities: momentum.parities.clone(),
                    ..momentum
                };
                for isa in [Some(Isa::PORTABLE), avx512].into_iter().flatten() {
                    let mut lanes = Vec::new();
                    assert!(!narrow.gather_lanes(isa, &p, full.lanes(), &mut lanes));
                }
            }
            // The velocity-gradient pass (plain and corrected) in its vector lanes, portable
            // and AVX-512, and in the generic lanes: the gather's bits.
            let full = FullList::from_half(&list, p.n_owned);
            let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for corrected in [false, true] {
                let width = if corrected { 18 } else { 9 };
                let k = GradientKernel {
                    kernel,
                    mass: 0.05,
                    density,
                    boundaries: Boundaries::default(),
                    corrected,
                    scales: vec![Scale::covering(1e3); width],
                };
                let mut gathered = Vec::new();
                gather(&k, &p, &full, &mut gathered).expect("gather");
                assert!(gathered.iter().any(|&x| x != 0.0));
                for isa in [Some(Isa::PORTABLE), Isa::avx2(), Isa::avx512()]
                    .into_iter()
                    .flatten()
                {
                    let mut lanes = Vec::new();
                    assert!(k.gather_lanes(isa, &p, full.lanes(), &mut lanes), "{isa:?}");
                    assert_eq!(bits(&gathered), bits(&lanes), "vector lanes {isa:?}");
                    assert!(gather_in_lanes(isa, &k, &p, &full, &mut lanes), "{isa:?}");
                    assert_eq!(bits(&gathered), bits(&lanes), "generic lanes {isa:?}");
                }
                let narrow = GradientKernel {
                    scales: vec![Scale::covering(1e-9); width],
                    ..k
                };
                assert!(!narrow.gather_lanes(Isa::current(), &p, full.lanes(), &mut Vec::new()));
            }
            let dk = DensityKernel {
                kernel,
                mass: 0.05,
                scales: [Scale::covering(1.0)],
            };
            pair_symmetry(&dk, &p, &list, &[Parity::Even]).expect("even");
        }
    }

    fn density_is_continuity(c: &SphCfg) -> bool {
        c.density == DensityMethod::Continuity
    }

    /// The equations of state: the quadratic one gives p(ρ₀) = ρ₀c₀²/2 and c² = dp/dρ = c₀²
    /// at ρ₀; Tait gives p(ρ₀) = 0 and the same sound speed.
    #[test]
    fn equations_of_state_have_the_stated_sound_speed() {
        for eos in [EquationOfState::Quadratic, EquationOfState::Tait] {
            let mut c = cfg(ViscousTerm::Morris, DensityMethod::Summation);
            c.equation_of_state = eos;
            c.rest_density = 1.3;
            let e = 1e-6;
            let c2 = (c.pressure(1.3 + e) - c.pressure(1.3 - e)) / (2.0 * e);
            assert!((c2 / 100.0 - 1.0).abs() < 1e-8, "{eos:?}: c² = {c2}");
            let p0 = if eos == EquationOfState::Quadratic {
                1.3 * 100.0 / 2.0
            } else {
                0.0
            };
            assert!((c.pressure(1.3) - p0).abs() < 1e-12, "{eos:?}");
        }
    }
}
