//! The `[fluid] kind = "sph"` table and the tables only SPH reads (`[walls]`, `[inclusions]`):
//! the parameter structs and their choices.

#[allow(unused_imports)]
use super::*;

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
    /// Transport-velocity background pressure p_t (Adami, Hu & Adams 2013; default 0, off):
    /// a uniform pressure that acts on the particles' *positions* only. Particles drift with
    /// v̂_i = v_i + ½Δt a^t_i, a^t_i = −m p_t Σ_j (1/ρ_i² + 1/ρ_j²) ∇_i W_ij, which pushes
    /// them towards a uniform arrangement as `background_pressure` does, but never enters
    /// the momentum equation: it exchanges no momentum, so it adds none of the lattice's
    /// anisotropic pressure virial to the measured stress. Needs `kick_drift_kick` and the
    /// summation density (docs/theory/sph_maxwell.md §1.14).
    #[serde(default)]
    pub transport_pressure: f64,
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

pub(super) fn one() -> f64 {
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

pub(super) fn axis_y() -> crate::geometry::Axis {
    crate::geometry::Axis::Y
}
pub(super) fn beta_max() -> f64 {
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
    /// The velocity a fluid particle sees for an inclusion particle (default: Morris's).
    #[serde(default)]
    pub images: InclusionImages,
    /// Cap β_max of Morris's extrapolation factor β = 1 + d_j/d_i (`images = "morris"`).
    #[serde(default = "beta_max")]
    pub morris_cap: f64,
    /// Whether an inclusion particle carries its fluid neighbour's pressure in their pair
    /// (p_j := p_i, the thesis's "von Neumann" condition, docs/theory/sph_maxwell.md §2.3; default)
    /// or its own, from its summation density. Its stress is always mirrored.
    #[serde(default = "yes")]
    pub mirror_pressure: bool,
}

pub(super) fn yes() -> bool {
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

/// `[inclusions] images`: the velocity a fluid particle sees for an inclusion particle j
/// (docs/theory/sph_maxwell.md §2.3).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum InclusionImages {
    /// One velocity per inclusion particle, whichever fluid particle sees it: the fluid's
    /// velocity relative to the inclusion fitted over j's fluid neighbours k (kernel weights)
    /// as a profile that vanishes at the surface and grows linearly with the surface distance,
    /// w = d A, and continued to j's depth: v_j = U − d_j A, d_j = R − |x_j − c| (the
    /// tangential part carried round the circle). Exact for a profile linear in the distance to
    /// the surface, with no cap (Morris's capped factor slips). Set by the stock Newtonian cell
    /// (η_eff +0.04 %, torque −0.24 % against the Stokes cell at R = 0.1, Δ = 0.02;
    /// docs/validation.md); not the default.
    Fitted,
    /// Morris's pairwise extrapolation from the fluid end, v_j = U − (d_j/d_i)(v_i − U) with
    /// β = 1 + d_j/d_i capped at `morris_cap` (the capped factor slips: the disc acts as one of
    /// radius R − 0.065Δ at β_max = 1.5).
    #[default]
    Morris,
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
    pub(super) fn pressure_over_rho2(eos: EquationOfState, c2: f64, rho0: f64, rho: f64) -> f64 {
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
