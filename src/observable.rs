//! The observables a run can average (`[diagnostics] observables`).

use serde::{Deserialize, Serialize};

/// Observables a run can average.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Observable {
    /// Kinetic k_BT (profile-unbiased under shear).
    Temperature,
    /// Scalar pressure tr(P)/D.
    Pressure,
    /// Full pressure tensor components (kinetic + conservative + dissipative + random).
    Stress,
    /// η = −⟨P_xy⟩ / γ̇ (needs shear), P the momentum flux: kinetic part plus the pair forces'
    /// virial (every fluid kind; for SPH `crate::models::sph::momentum_flux`, whose P_xy is
    /// the x-momentum crossing planes y = const).
    Viscosity,
    /// N₁ = σ_xx − σ_yy = P_yy − P_xx (needs shear).
    FirstNormalStressDifference,
    /// N₂ = σ_yy − σ_zz = P_zz − P_yy (needs shear, 3D).
    SecondNormalStressDifference,
    /// The SPH fluid particles' own constitutive stress σ̄ = η_s (G + Gᵀ − (2/d) tr G I) + τ
    /// (the thesis's unweighted particle mean, Eq. 3.18; needs an SPH fluid in a sheared box):
    /// `viscosity_constitutive`, `first_normal_stress_difference_constitutive` and, in 3D,
    /// `second_normal_stress_difference_constitutive`. It holds whatever the pair forces do
    /// (the corrected gradient is exact for a linear field): compare it with the flux-based
    /// `viscosity` to see the coupling at work.
    ConstitutiveStress,
    /// Total peculiar momentum Σ m (v − γ̇ (y − L_y/2) x̂).
    Momentum,
    /// Binned mean velocity u_x(y) (needs shear, or walls).
    VelocityProfile,
    /// Force along x per unit area that the fluid exerts on each wall of boundary particles
    /// (needs `[walls]`): `wall_shear_stress_lower`, `wall_shear_stress_upper`.
    WallShearStress,
    /// Binned mean SPH density ρ(y) of the fluid particles (needs `[fluid] kind = "sph"`),
    /// `diagnostics.profile_bins` bins across the box along y.
    DensityProfile,
    /// Mean |tr τ| of the SPH fluid particles' polymer stress (needs `[fluid.polymer]`): the
    /// corotational Maxwell model keeps τ traceless, so this monitors its integration.
    PolymerStressTrace,
    /// The composite (cell) shear viscosity of an SPH suspension (needs `[inclusions]` and
    /// shear): `composite_viscosity` = [Σ_fluid (m/ρ_i) σ_i,xy + Σ_inclusions ∮ (σ·n)_x y dS]
    /// / (V γ̇), the fluid's stress plus the inclusions' traction moments; and
    /// `inclusion_torque`, the mean torque per inclusion about z, ∮ (x − c) × (σ·n) dS. Only a
    /// case that lists it makes the momentum pass accumulate the traction moments.
    CompositeViscosity,
    /// The Green–Kubo shear viscosity η = V/(k_BT) ∫₀^τ ⟨P̃(0):P̃(t)⟩/((D−1)(D+2)) dt from the
    /// equilibrium autocorrelation of the whole pressure tensor, random-force stress included
    /// (needs a DPD fluid at rest, no walls; [`crate::green_kubo`]). τ =
    /// `diagnostics.green_kubo_time`; OUT/green_kubo.csv holds G(t) and its running integral.
    GreenKuboViscosity,
    /// The shear viscosity from the transverse-current autocorrelation of a fluid at rest
    /// ([`crate::transverse_current`]): η_k at k_j = 2πj/L, j = 1 …
    /// `diagnostics.transverse_current_modes` (`transverse_current_viscosity_k1`, …, Maxwell
    /// fits of C⊥(k, t)/C⊥(k, 0)), and `transverse_current_viscosity`, their k → 0 limit η₀
    /// from η_k = η₀ + a k² over the 4 smallest k. OUT/transverse_current.csv holds the
    /// curves and the fits.
    TransverseCurrentViscosity,
    /// The binned shear stress τ_xy(y) = −P_xy(y) of a DPD fluid, `diagnostics.profile_bins`
    /// bins along y: the Irving–Kirkwood volume average over each bin, the kinetic part
    /// −Σ_{i∈b} m V_x V_y (V about the local mean velocity) and the pair part −Σ_pairs r_y F_x
    /// ℓ_b/|r_y| (ℓ_b: the length of the pair's segment inside the bin), over the bin's
    /// volume. The summary lists it as `shear_stress_profile`.
    ShearStressProfile,
    /// The particle mean of the conformation vectors' second moments of a fluid whose particles
    /// carry one (needs `[fluid] kind = "generic_polymer"`): `conformation_xx`,
    /// `conformation_xy`, `conformation_yy` (and the z components in 3D), ⟨Q_aQ_b⟩, and
    /// `conformation_q2`, ⟨Q²⟩.
    Conformation,
    /// The velocity fluctuations of suspended rigid colloids (needs `[fluid.colloids]`, free
    /// bodies; [`crate::rigid_bodies`]): `colloid_velocity_variance`, ⟨(V_α − U_α(Y))²⟩ over the
    /// bodies and the D components, U the imposed streaming velocity γ̇(Y − L_y/2) x̂ at the
    /// body's centre (equipartition: k_BT/M, M = n_cp m); and
    /// `colloid_angular_velocity_variance`, ⟨(ω_α − Ω_α)²⟩ over the bodies and the rotational
    /// components (3 in 3D, z in 2D), Ω = −(γ̇/2) ẑ the imposed flow's rotation (equipartition:
    /// k_BT/I, I the body's moment of inertia about its centre).
    ColloidVelocityVariance,
    /// The radial distribution function of the solvent about the rigid colloids' centres
    /// (needs `[fluid.colloids]`, free or fixed; [`crate::rigid_bodies::rdf`]): g(r) in bins of
    /// `diagnostics.rdf_bin_width` out to `diagnostics.rdf_range`, about each body's cloud
    /// centre (its constituents' mean position), normalised by the ideal-gas count of the
    /// solvent's number density in each shell; summary.json lists it as `colloid_solvent_rdf`,
    /// and `colloid_exclusion_radius`, the outer edge of the last bin with g < 0.01 (Nguyen
    /// 2021 L877; spec §4), with the spread of its block values as the error bar.
    ColloidSolventRdf,
}

impl Observable {
    /// Temperature and pressure: what a thermal fluid reports when nothing is listed.
    pub fn thermal_defaults() -> Vec<Observable> {
        vec![Observable::Temperature, Observable::Pressure]
    }

    /// Whether it is formed from the momentum flux of the pair forces (the pair virial).
    pub fn needs_pair_virial(self) -> bool {
        matches!(
            self,
            Observable::Pressure
                | Observable::Stress
                | Observable::Viscosity
                | Observable::FirstNormalStressDifference
                | Observable::SecondNormalStressDifference
        )
    }

    /// Name in summary.json.
    pub fn name(self) -> &'static str {
        match self {
            Observable::Temperature => "temperature",
            Observable::Pressure => "pressure",
            Observable::Stress => "stress",
            Observable::Viscosity => "viscosity",
            Observable::FirstNormalStressDifference => "first_normal_stress_difference",
            Observable::SecondNormalStressDifference => "second_normal_stress_difference",
            Observable::ConstitutiveStress => "constitutive_stress",
            Observable::Momentum => "momentum",
            Observable::VelocityProfile => "velocity_profile",
            Observable::WallShearStress => "wall_shear_stress",
            Observable::DensityProfile => "density_profile",
            Observable::PolymerStressTrace => "polymer_stress_trace",
            Observable::CompositeViscosity => "composite_viscosity",
            Observable::GreenKuboViscosity => "green_kubo_viscosity",
            Observable::TransverseCurrentViscosity => "transverse_current_viscosity",
            Observable::ShearStressProfile => "shear_stress_profile",
            Observable::Conformation => "conformation",
            Observable::ColloidVelocityVariance => "colloid_velocity_variance",
            Observable::ColloidSolventRdf => "colloid_solvent_rdf",
        }
    }
}

/// The scalars of [`Observable::ColloidVelocityVariance`]: translational, then rotational.
pub const COLLOID_VELOCITY_VARIANCE_NAMES: [&str; 2] = [
    "colloid_velocity_variance",
    "colloid_angular_velocity_variance",
];

/// The scalar series of the colloid–solvent RDF are named this and the bin number (four
/// digits); the summary gathers them into `colloid_solvent_rdf` and derives
/// [`COLLOID_EXCLUSION_RADIUS`] from them.
pub const COLLOID_SOLVENT_RDF_PREFIX: &str = "colloid_solvent_rdf_";

/// The summary's name of the exclusion radius read from the colloid–solvent RDF.
pub const COLLOID_EXCLUSION_RADIUS: &str = "colloid_exclusion_radius";

/// The scalar series of the density profile are named this and the bin number (four digits);
/// the summary gathers them into `density_profile`.
pub const DENSITY_PROFILE_PREFIX: &str = "density_profile_";

/// The scalars of the `constitutive_stress` observable in `dimension` dimensions: η, N₁ (and
/// N₂ in 3D) of the particles' own mean stress.
/// The names of the conformation moments ([`Observable::Conformation`]) in `dimension`
/// dimensions: the upper triangle of ⟨Q_aQ_b⟩, row by row, then ⟨Q²⟩.
pub fn conformation_names(dimension: usize) -> &'static [&'static str] {
    const NAMES_2D: [&str; 4] = [
        "conformation_xx",
        "conformation_xy",
        "conformation_yy",
        "conformation_q2",
    ];
    const NAMES_3D: [&str; 7] = [
        "conformation_xx",
        "conformation_xy",
        "conformation_xz",
        "conformation_yy",
        "conformation_yz",
        "conformation_zz",
        "conformation_q2",
    ];
    if dimension == 3 { &NAMES_3D } else { &NAMES_2D }
}

/// The names of the constitutive viscometric functions ([`Observable::ConstitutiveStress`]) in
/// `dimension` dimensions.
pub fn constitutive_names(dimension: usize) -> &'static [&'static str] {
    const NAMES: [&str; 3] = [
        "viscosity_constitutive",
        "first_normal_stress_difference_constitutive",
        "second_normal_stress_difference_constitutive",
    ];
    if dimension == 3 { &NAMES } else { &NAMES[..2] }
}
