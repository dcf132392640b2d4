//! The `[fluid]` keys of the DPD fluid, for the case-file reference (`mesorheo keys`,
//! `docs/case-reference.md`).

use crate::key_doc::{KeyDoc, key};

/// The keys, in the order of the reference.
pub const KEYS: &[KeyDoc] = &[
    key(
        "fluid.a",
        "float ≥ 0",
        "required (dpd)",
        "Conservative repulsion a: F^C = a (1 − r/r_c) e_ij.",
    ),
    key(
        "fluid.gamma",
        "float > 0",
        "required (dpd)",
        "Dissipation γ: F^D = −γ w_D (e_ij·v_ij) e_ij.",
    ),
    key(
        "fluid.kt",
        "float > 0",
        "required (dpd)",
        "Thermostat temperature k_BT; σ = √(2γ k_BT).",
    ),
    key(
        "fluid.cutoff",
        "float > 0",
        "1.0",
        "Cutoff r_c of all three forces. cutoff + neighbour.skin must not exceed half the box on periodic axes.",
    ),
    key(
        "fluid.weight_exponent",
        "float > 0",
        "2.0",
        "s in w_D = (1 − r/r_c)^s, w_R = √w_D (2: standard DPD; 0.5: modified). Set by [fluid.physical] when given.",
    ),
    key(
        "fluid.body_force",
        "array of D floats",
        "none",
        "DPD: a constant acceleration g on every particle (force m g). With it, \"velocity_profile\" bins u_x along y.",
    ),
    key(
        "fluid.body_force_profile",
        "\"uniform\" | \"reverse\"",
        "\"uniform\"",
        "DPD: \"reverse\" applies +g for y ≥ L_y/2 and −g below: the reverse (double) Poiseuille flow of a periodic box.",
    ),
    key(
        "fluid.conservative_exponent",
        "float > 0",
        "1.0",
        "s̄ in w_C = (1 − r/r_c)^s̄ of the conservative force a w_C (1: Groot–Warren). Set by [fluid.physical] when given.",
    ),
    key(
        "fluid.physical.viscosity",
        "float > 0",
        "required in [fluid.physical]",
        "DPD from physical properties (Nguyen 2021; `mesorheo check` prints both sides): a `[fluid.physical]` table replaces a, gamma, weight_exponent and conservative_exponent, which are mapped from it (a raw key given beside it must equal the mapped value). The density and mass come from [particles], k_BT and r_c from [fluid]. `viscosity`: η, imposed as the kinetic-theory dissipative viscosity η̄_D (the measured η differs; measure it).",
    ),
    key(
        "fluid.physical.time_scale_ratio",
        "float > 0",
        "none: classical-water repulsion",
        "α = γ² r_c/(m a), the ratio of the dissipative to the conservative time scale; a = γ² r_c/(α m), and s̄ matches the compressibility. Without it a = 15(κ⁻¹ − 1)k_BT/(π n r_c⁴) (3D; 12(κ⁻¹ − 1)k_BT/(π n r_c³) in 2D) with s̄ = 1.",
    ),
    key(
        "fluid.physical.inverse_compressibility",
        "float > 1",
        "15.9835 (water)",
        "κ⁻¹ = (1/k_BT) ∂p/∂n.",
    ),
    key(
        "fluid.physical.schmidt_number",
        "float > 0",
        "none (s = 1/2)",
        "Sc = η̄_D/(ρD) to impose: fixes the dissipative exponent s (exclusive with particle_diffusion_time); infeasible values are refused with the allowed range.",
    ),
    key(
        "fluid.physical.particle_diffusion_time",
        "float > 0",
        "none (s = 1/2)",
        "τ_P = R²/D to impose (3D only): fixes s instead of a Schmidt number.",
    ),
    key(
        "fluid.soft_start_sweeps",
        "integer ≥ 0",
        "30",
        "Random starts (particles.lattice = \"random\") only: sweeps of overlap removal (capped steepest descent on the shape (1 − r/r_c)^(s̄+1) of the conservative potential) before the run proper, so that the start holds no denser cluster than the fluid does and `check`'s steady-state time-step limit applies (docs/theory/dpd_soft_start.md). Positions only; no steps, done once (a restart does not redo it). 0: the raw uniform placement, for which `check` keeps a margin on the dissipative limit.",
    ),
    key(
        "fluid.noise",
        "\"gaussian\" | \"uniform\"",
        "\"gaussian\"",
        "Distribution of θ_ij: standard normal, or √3(2u − 1) (unit variance).",
    ),
    key(
        "fluid.colloids.shape",
        "\"tetrahedron\" | \"octahedron\" | \"cube\" | \"icosahedron\" | \"dodecahedron\" (3D) | \"cylinder\" (2D)",
        "required in [fluid.colloids]",
        "DPD suspensions (Nguyen 2021 §2.4, §5; docs/theory/colloids.md): a `[fluid.colloids]` table suspends rigid bodies whose reference sites (the vertices of the regular polyhedron, 4/6/8/12/20; the 2D cylinder's 19 sites: centre, 6 at half the radius, 12 at the radius) each carry a constituent, a particle of the fluid tied to its site by a spring −H(r_i − r̄_i); a body moves with the pair force and torque on its constituents. The solvent keeps particles.density; the constituents come on top. The body force (fluid.body_force) drives the solvent only.",
    ),
    key(
        "fluid.colloids.count",
        "integer ≥ 1",
        "one of count, volume_fraction, centres",
        "Number of bodies.",
    ),
    key(
        "fluid.colloids.volume_fraction",
        "float in (0, 1)",
        "one of count, volume_fraction, centres",
        "Particle volume fraction φ = N_C/(N_C + N_S) (the thesis's, L815): N_bodies = round(φ N_S/((1 − φ) n_cp)).",
    ),
    key(
        "fluid.colloids.centres",
        "array of arrays of D floats in [0, L)",
        "one of count, volume_fraction, centres",
        "Explicit body centres. Bodies whose centres are closer than twice the site radius overlap and are refused.",
    ),
    key(
        "fluid.colloids.placement",
        "\"lattice\" | \"random\"",
        "\"lattice\"",
        "Where count/volume_fraction bodies start: the first N cell centres of a k^D lattice (k = ⌈N^{1/D}⌉), or seeded uniform random centres at least min_separation apart.",
    ),
    key(
        "fluid.colloids.min_separation",
        "float ≥ 0",
        "fluid.cutoff",
        "Smallest centre distance of random placement.",
    ),
    key(
        "fluid.colloids.site_radius",
        "float > 0",
        "0.1 n^(−1/3) (3D), 0.075 (8/n)^(1/2) (2D)",
        "Distance of the outermost site from the body centre. 2 × site_radius + r_c must be less than half the smallest box edge.",
    ),
    key(
        "fluid.colloids.spring_stiffness",
        "float > 0",
        "m (0.05/Δt)²",
        "Spring stiffness H of the constituent–site tie; √(H/m)Δt ≤ 0.2 is required (velocity Verlet of the tie), `check` prints it.",
    ),
    key(
        "fluid.colloids.fixed",
        "bool",
        "false",
        "Fixed bodies (V = 0, ω = 0; static sites), as in a cylinder array; the pair force on them is still summed (the drag).",
    ),
];
