//! The case-file key reference: one table, rendered into `docs/case-reference.md`
//! (`mesorheo keys > docs/case-reference.md`). A test checks that the table lists exactly the
//! keys the structs accept and that the document is up to date.

pub use crate::key_doc::KeyDoc;
use crate::key_doc::key;

/// Every key of a case file, in the order of the reference: the general keys, each registered
/// fluid model's own (its `KindTraits::KEYS`, in the registry's order), then the rest.
pub fn keys() -> Vec<&'static KeyDoc> {
    EARLIER_KEYS
        .iter()
        .chain(super::registry::fluid_keys())
        .chain(LATER_KEYS)
        .collect()
}

/// The keys before the fluid model's own (`[box]`, `[particles]`, `fluid.kind`).
const EARLIER_KEYS: &[KeyDoc] = &[
    key(
        "title",
        "string",
        "\"\"",
        "Free text shown in logs and echoed in summary.json.",
    ),
    key(
        "dimension",
        "integer: 2 or 3",
        "required",
        "Spatial dimension of the scene.",
    ),
    key(
        "seed",
        "integer ≥ 0",
        "1",
        "Seed of every random number (pair noise, initial state). Same seed ⇒ bitwise identical run on any rank/thread count.",
    ),
    key(
        "box.lengths",
        "array of D floats > 0",
        "required",
        "Box edge lengths L_x, L_y[, L_z]; the box is [0, L_x) × [0, L_y) [× [0, L_z)].",
    ),
    key(
        "box.boundaries",
        "array of D of \"periodic\" | \"wall\"",
        "all \"periodic\"",
        "Per-axis boundary: periodic images, or specular reflecting walls at 0 and L.",
    ),
    key(
        "box.shear_rate",
        "float",
        "0.0",
        "Lees–Edwards shear rate γ̇ (flow along x, gradient along y; needs x and y periodic). Images above/below slide by s(t) = (γ̇ L_y t) mod L_x with velocity ±γ̇ L_y.",
    ),
    key(
        "decomposition.axis",
        "\"x\" | \"y\" | \"z\"",
        "\"y\"",
        "Slab axis of the domain decomposition. Not \"x\" under shear. Slab width L/ranks must be ≥ cutoff + skin.",
    ),
    key(
        "particles.lattice",
        "\"cubic\" | \"fcc\" | \"random\"",
        "required",
        "Initial arrangement: simple cubic (square in 2D), face-centred cubic (4 per cell; centred square in 2D), or uniform random.",
    ),
    key(
        "particles.density",
        "float > 0",
        "required",
        "Number density n. Lattices use round(L·(n/basis)^(1/D)) cells per axis, so the actual density can differ slightly (`check` prints it).",
    ),
    key("particles.mass", "float > 0", "1.0", "Particle mass m."),
    key(
        "particles.temperature",
        "float ≥ 0",
        "required",
        "k_BT of the initial Maxwellian (centre-of-mass motion removed, rescaled to exactly this value).",
    ),
    key(
        "particles.velocity_profile",
        "\"auto\" | \"rest\" | \"shear\" | \"half_sine\"",
        "\"auto\"",
        "Mean initial velocity: \"shear\" adds γ̇ (y − L_y/2) along x; \"auto\" does so when box.shear_rate ≠ 0; \"half_sine\" adds A sin(πy/L_y) along x inside 0 ≤ y ≤ L_y (a channel's lowest mode).",
    ),
    key(
        "particles.velocity_amplitude",
        "float",
        "1.0",
        "Amplitude A of the \"half_sine\" profile.",
    ),
    key(
        "fluid.kind",
        "\"dpd\" | \"sph\" | \"summation_gas\"",
        "required",
        "Fluid model. \"dpd\": dissipative particle dynamics (Groot–Warren). \"sph\": weakly compressible SPH for Newtonian fluids (Ellero 2004 ch. 2). \"summation_gas\": the engine's two-pass test model, an isothermal SPH gas (Lucy kernel, summation density, p = c²ρ).",
    ),
];

/// The keys after `[fluid]` (the fluid models document their own: [`keys`]).
const LATER_KEYS: &[KeyDoc] = &[
    key(
        "integrator.kind",
        "\"groot_warren\" | \"kick_drift_kick\" | \"heun\" | \"midpoint\" | \"thesis_predictor_corrector\" | \"brownian_dynamics\"",
        "required",
        "Time integrator. \"groot_warren\": modified velocity Verlet (DPD); \"kick_drift_kick\": symplectic velocity Verlet (SPH); \"heun\", \"midpoint\": second-order predictor–correctors, two force evaluations per step (SPH, not under shear); \"thesis_predictor_corrector\": Ellero's Eqs. 2.49–2.50 as printed, first order (to reproduce the text); \"brownian_dynamics\": the stochastic scheme of polymer.scheme (homogeneous-flow scenes).",
    ),
    key(
        "integrator.dt",
        "float > 0",
        "required",
        "Time step Δt. DPD: refused beyond the measured stability limit S((Δt_C⁻ᵖ + Δt_D⁻ᵖ)^(p′/p) + Δt_F^(−p′))^(−1/p′), p = 2.62, p′ = 2.51, S = 0.9 (a margin for the seed scatter of points the fit did not see): Δt_C = α/ω_E from the conservative force, Δt_D (the root of ω_DΔt = c(1 + (KΔt)^q)) from the explicit friction and Δt_F = F r_c/√(k_BT/m) (F = 0.178 in 2D, 0.185 in 3D) from the free flight (neither of the last two with thermostat = \"exponential\"); `check` prints the three parts and docs/validation.md the maps they are fitted to. Dumbbells: the explicit schemes (euler_maruyama, heun) are refused beyond 0.95 × 4λ/(1 + 2λc), c the flow's largest compressive rate (their stability limit with a 5 % margin); semi_implicit is stable at any Δt; beyond λ/2 or rate × Δt = 0.5 `check` and `run` warn (accuracy; measure it with `mesorheo study`); Δt ≤ λ/10 advised.",
    ),
    key(
        "integrator.lambda",
        "float in [0, 1]",
        "0.5",
        "Velocity-prediction factor λ (0.5: plain velocity Verlet; 0.65: Groot–Warren).",
    ),
    key(
        "integrator.thermostat",
        "\"explicit\" | \"exponential\"",
        "\"explicit\"",
        "groot_warren, DPD: how the dissipative and random forces are integrated. \"explicit\": with the conservative force (stable for ω₀Δt < 2, ω₀ = γ n[w_D]/(d m)); \"exponential\" (SETD): the mean-field friction integrated exactly, i.e. friction φγ and noise √φ σ with φ = (1 − e^{−ω₀Δt})/(ω₀Δt), stable at any ω₀Δt and exact in k_BT in the mean-field limit, at the price of a dissipative viscosity φη_D (`check` prints φ); needs lambda = 0.5 and lifts the dissipative time-step limit.",
    ),
    key(
        "walls.axis",
        "\"x\" | \"y\" | \"z\"",
        "\"y\"",
        "Axis whose two box faces are walls of boundary particles (sph; box.boundaries must be \"wall\" there, the lattice \"cubic\").",
    ),
    key(
        "walls.thickness",
        "float ≥ support",
        "two kernel supports",
        "Thickness of each layer of boundary particles (the lattice continued beyond the face).",
    ),
    key(
        "walls.lower_velocity",
        "array of D floats",
        "at rest",
        "Velocity of the wall at 0 (in its plane); a wall at rest is frozen.",
    ),
    key(
        "walls.upper_velocity",
        "array of D floats",
        "at rest",
        "Velocity of the wall at L (in its plane); a Couette plate.",
    ),
    key(
        "walls.treatment",
        "\"layers\" | \"morris\" | \"mirror\"",
        "\"layers\"",
        "Velocity a fluid particle sees for a boundary particle: the wall's (thesis method B; slips by ~1 % of U), or Morris's image U − (d_j/d_i)(v_i − U) (exact for linear profiles). \"mirror\" (fluid.derivatives = \"msph\" only): each boundary particle carries the fluid's values fitted (first-order least squares) at its mirror point m: velocity 2U − v̂(m), density ρ̂(m), stress extrapolated linearly from m; it forms no derivative and carries no dumbbells (docs/theory/msph_dumbbells.md §5.1). The decomposition axis must differ from the wall axis.",
    ),
    key(
        "walls.morris_cap",
        "float ≥ 1",
        "1.5",
        "Cap β_max of Morris's factor β = 1 + d_j/d_i (d_i floored at Δ/2). Below 2r_s/Δ − 1 it clips the first fluid row's images, a partial slip (`check` says so); flat walls keep the factor bounded, so cases/sph_ucm_channel_2d.toml raises it to 6.",
    ),
    key(
        "walls.repulsion_strength",
        "float ≥ 0",
        "c₀²",
        "D of the fluid–wall repulsion D[(r₀/r)⁴ − (r₀/r)²] x_ij/r² for r < r₀.",
    ),
    key(
        "walls.repulsion_range",
        "float ≥ 0",
        "lattice spacing",
        "r₀ of the fluid–wall repulsion (the initial fluid–wall distance, where it vanishes).",
    ),
    key(
        "inclusions.centres",
        "list of D-vectors",
        "required",
        "Centres of rigid, fixed (neither moving nor rotating) inclusions — discs in 2D, spheres in 3D — of an SPH fluid; each lies inside the box and none overlaps another. The lattice sites inside become frozen boundary particles (species \"inclusion\") that see Morris's images of their fluid neighbours and carry their pressure and stress.",
    ),
    key(
        "inclusions.radius",
        "float ≥ lattice spacing",
        "required",
        "Radius R of every inclusion. The viscous time-step limit tightens to 0.025 r_s² ρ₀/η (measured).",
    ),
    key(
        "inclusions.images",
        "`morris` or `fitted`",
        "`morris`",
        "The velocity a fluid particle sees for an inclusion particle. `morris`: Morris's pairwise v_j = U − (d_j/d_i)(v_i − U), capped by `morris_cap` (a partial slip: the disc acts as one of radius R − 0.065Δ). `fitted` (the stock Newtonian cell's setting): the fluid's velocity relative to the inclusion fitted over the particle's fluid neighbours as a profile d·A vanishing at the surface, continued to the particle's depth (exact for a linear profile; no cap; docs/theory/sph_maxwell.md §2.3a). Measured at R = 0.1, Δ = 0.02 (2026-11-28): η_eff +0.04 %, torque −0.24 % against the Stokes cell (`morris`: −0.32 %, −2.63 %), stable at the stock Δt.",
    ),
    key(
        "inclusions.morris_cap",
        "float ≥ 1",
        "1.5",
        "Cap β_max of Morris's extrapolation factor β = 1 + d_j/d_i (v_j = −(d_j/d_i) v_i relative to the inclusion), with `images = \"morris\"`.",
    ),
    key(
        "inclusions.mirror_pressure",
        "bool",
        "true",
        "Whether an inclusion particle carries its fluid neighbour's pressure in their pair (p_j := p_i, the thesis's zero normal gradient) or its own; its stress is always mirrored. With a polymer, its own pressure gives 40× quieter stresses (docs/validation.md).",
    ),
    key(
        "neighbour.skin",
        "float > 0",
        "0.3",
        "Verlet skin; lists are rebuilt when 2·max displacement + LE offset drift > skin.",
    ),
    key(
        "run.steps",
        "integer ≥ 1",
        "required",
        "Number of time steps.",
    ),
    key(
        "run.equilibration",
        "integer < steps",
        "0",
        "Steps before averaging starts.",
    ),
    key(
        "run.sample_every",
        "integer ≥ 1",
        "10",
        "Sampling interval (steps) of the observables.",
    ),
    key(
        "run.progress_seconds",
        "float ≥ 0",
        "10.0",
        "Seconds between progress lines on rank 0 (0: off).",
    ),
    key(
        "run.beyond_stability_limits",
        "bool",
        "false",
        "Run a time step beyond the stability limits instead of refusing it: for stability studies, which measure what the limits estimate (`check` still marks the violated limit; the run logs a warning).",
    ),
    key(
        "output.checkpoint_every",
        "integer ≥ 0",
        "0",
        "Steps between checkpoints in OUT/checkpoints/ (0: none on schedule). A checkpoint is the complete state; `mesorheo restart` continues from it bitwise on any rank count.",
    ),
    key(
        "output.checkpoint_keep",
        "integer ≥ 1",
        "3",
        "Newest checkpoints kept; older ones are deleted.",
    ),
    key(
        "output.checkpoint_at_end",
        "boolean",
        "true",
        "Write a checkpoint when the run ends (also at --until-step and on SIGTERM/SIGUSR1), so it can be extended.",
    ),
    key(
        "output.snapshot_every",
        "integer ≥ 0",
        "0",
        "Steps between snapshot frames in OUT/snapshots.h5 (H5MD, with OUT/snapshots.xdmf for ParaView); 0: none.",
    ),
    key(
        "output.snapshot_fields",
        "array of \"position\" | \"velocity\" | \"force\" | \"image\" | \"unwrapped_position\" | \"species\" | \"density\" | \"pressure\" | \"polymer_stress\" | \"conformation\"",
        "[\"position\", \"velocity\", \"image\"]",
        "Per-particle fields of each snapshot frame, written in global-id order in one H5MD group per kind of particle (/particles/fluid, /particles/wall, /particles/inclusion; one XDMF grid each); \"position\" is required. Every case: position, velocity, force, image (periodic crossings n), unwrapped_position (r + n∘L), species (the species number, written once). The fluid model's, where it offers them (an error lists what a case offers): sph: density, pressure (its equation of state), polymer_stress (τ, with [fluid.polymer]; CONNFFESSIT: the Kramers τ of the particle's dumbbells), conformation (⟨QQ⟩ over the particle's dumbbells, explicit dumbbells only); generic_polymer: density, conformation (Q Q). Tensors are symmetric: the upper triangle row by row, XDMF Tensor6 (padded with zeros in 2D).",
    ),
    key(
        "diagnostics.observables",
        "array of observable names",
        "dpd: [\"temperature\", \"pressure\"]; summation_gas: [\"temperature\", \"momentum\"]; sph: [\"momentum\"], plus \"viscosity\", \"first_normal_stress_difference\" (and \"second_normal_stress_difference\" in 3D) under shear; generic_polymer: [\"temperature\", \"momentum\", \"conformation\"], plus \"constitutive_stress\", \"viscosity\", \"first_normal_stress_difference\" under shear",
        "What to average: \"temperature\", \"pressure\", \"stress\" (full tensor by contribution), \"viscosity\", \"first_normal_stress_difference\", \"second_normal_stress_difference\", \"momentum\", \"velocity_profile\" (under shear, or across [walls]), \"wall_shear_stress\" (force along x per unit area the fluid exerts on each wall: wall_shear_stress_lower, _upper; needs [walls]), \"density_profile\" (the SPH density of the fluid per bin along y, diagnostics.profile_bins bins; needs sph), \"shear_stress_profile\" (DPD: the shear stress τ_xy = −P_xy per bin along y, diagnostics.profile_bins bins, the Irving–Kirkwood slab average: kinetic part about the local mean velocity, each pair's r_y F_x shared among the bins its segment crosses; listed as shear_stress_profile in summary.json; computes the full virial on sample steps and one more pass over the pairs), \"polymer_stress_trace\" (mean |tr τ| of the fluid particles; needs [fluid.polymer]), \"composite_viscosity\" (an SPH suspension's cell stress, the fluid's Σ (m/ρ)σ_xy plus the inclusions' traction moments ∮ (σ·n)_x y dS, over Vγ̇; also gives inclusion_torque, the mean torque per inclusion; needs [inclusions] and shear), \"transverse_current_viscosity\" (DPD at rest in a cubic box: η_k at k_j = 2πj/L from Maxwell fits of the transverse-current autocorrelation, as transverse_current_viscosity_k1 …, and their k → 0 limit η₀ as transverse_current_viscosity, jackknife errors over the blocks; OUT/transverse_current.csv holds the curves and the fits), \"green_kubo_viscosity\" (DPD at rest: η from the equilibrium autocorrelation of the whole pressure tensor, random-force stress included, integrated to diagnostics.green_kubo_time; sampled every step after equilibration, with the full virial each step; OUT/green_kubo.csv holds G(t) and its running integral). \"constitutive_stress\" (sph: the fluid particles' own stress σ̄ = viscous + polymer, their unweighted mean, as viscosity_constitutive, first_normal_stress_difference_constitutive and in 3D second_normal_stress_difference_constitutive; it holds whatever the pair forces do, so compare it with the flux-based ones; generic_polymer: the particle-averaged polymer stress −k_BTn^d 1 + Hn^d⟨QQ⟩, Eq. 4.68, under shear). \"conformation\" (generic_polymer: the particle means ⟨Q_aQ_b⟩ as conformation_xx, conformation_xy, conformation_yy (… _zz in 3D) and ⟨Q²⟩ as conformation_q2; at rest or under shear). \"colloid_velocity_variance\" (DPD with [fluid.colloids], free bodies: ⟨(V_α − U_α)²⟩ over the bodies and components about the imposed streaming velocity at the centre, and colloid_angular_velocity_variance, ⟨(ω_α − Ω_α)²⟩ about the imposed rotation Ω = −(γ̇/2) ẑ; equipartition k_BT/M and k_BT/I). \"colloid_solvent_rdf\" (DPD with [fluid.colloids], free or fixed: the solvent's g(r) about each body's cloud centre, its constituents' mean position, in bins of diagnostics.rdf_bin_width out to diagnostics.rdf_range, normalised by the ideal-gas count n_S V_shell of the exact shell volume; listed as colloid_solvent_rdf in summary.json, with colloid_exclusion_radius, the outer edge of the last bin with g < 0.01, Nguyen 2021 L877, its error the spread of the blocks' radii; one distance per solvent particle and body per sample). For every fluid, \"pressure\", \"stress\", \"viscosity\" and the normal stress differences are the momentum flux: the kinetic part about the local streaming velocity plus Σ_pairs F_ij ⊗ ℓ_ij of the pair forces the integrator applies, over the box volume (sph: pressure, Morris or nested-summation viscous term, polymer stress, wall repulsion, parts pressure, viscous and polymer in \"stress\"; a fluid–inclusion pair's lever is the fluid particle's offset from the inclusion centre, so in a suspension it is the whole cell's stress, the inclusions' interior and the couple that holds them included; not with fluid.derivatives = \"msph\", whose stresses are not pair forces; dpd with [fluid.colloids]: plus the tie springs' constraint virial Σ sym[(r_i − R) ⊗ F_S] of every constituent i about its body's centre R, part constraint in \"stress\"; generic_polymer: the pressure with the background pressure p_b, the polymer term (k_BTn^d − Hn^dQQ)/d² and the friction with its pair noise, parts pressure, polymer and viscous in \"stress\", docs/theory/generic_polymer_particle.md §8). The shear ones need box.shear_rate ≠ 0. Only what is listed is computed: the pair virial is skipped without \"pressure\", \"stress\" or the stress differences, and only its diagonal is accumulated without \"stress\" or \"viscosity\".",
    ),
    key(
        "diagnostics.profile_bins",
        "integer ≥ 1",
        "10",
        "Bins along y for the velocity profile and the profile-unbiased temperature under shear.",
    ),
    key(
        "diagnostics.rdf_bin_width",
        "number > 0",
        "0.02",
        "Bin width Δr of \"colloid_solvent_rdf\" (the solvent's g(r) about the colloids' cloud centres). The exclusion radius is read to this resolution (the outer edge of the last bin with g < 0.01).",
    ),
    key(
        "diagnostics.rdf_range",
        "number in (0, half the smallest box edge]",
        "half the smallest box edge",
        "Outer radius of \"colloid_solvent_rdf\": ⌊rdf_range/rdf_bin_width⌋ bins from r = 0. Keep it where g has reached the bulk: every bin with g < 0.01 inside it counts towards the exclusion radius.",
    ),
    key(
        "diagnostics.blocks",
        "integer ≥ 2",
        "10",
        "Blocks of the block-averaged standard errors.",
    ),
    key(
        "diagnostics.green_kubo_time",
        "number > 0",
        "2.0",
        "Upper limit τ of the Green–Kubo integral η = V/(k_BT) ∫₀^τ C(t) dt (\"green_kubo_viscosity\"): long enough for the stress autocorrelation to have decayed (OUT/green_kubo.csv shows the running integral's plateau), short enough not to integrate noise; each block of the run after equilibration must last at least 2τ.",
    ),
    key(
        "diagnostics.transverse_current_modes",
        "integer 2 … 100",
        "4",
        "Wavenumbers k_j = 2πj/L, j = 1 … this, of \"transverse_current_viscosity\" (along every axis of the cubic box, both transverse components). Each mode's C⊥(k, t)/C⊥(k, 0) is fitted with the Maxwell model over the lags where it exceeds 0.05; η₀ is extrapolated from η_k = η₀ + a k² over the 4 smallest k. One correlator per mode and block.",
    ),
    key(
        "diagnostics.transverse_current_every",
        "integer ≥ 1",
        "5",
        "Steps between two samples of the transverse currents (each costs about D·modes complex products per particle; the thesis samples every 5 steps at Δt = 0.001). The largest k's decay ρ/(η_k k²) must span several samples.",
    ),
    key(
        "diagnostics.transverse_current_time",
        "number ≥ 16 × transverse_current_every × Δt",
        "5.0",
        "Longest lag of the transverse-current autocorrelation (time units): long enough for C⊥(k₁, t) to fall below 0.05 (about 3ρ/(η k₁²)); each of the ≥ 2 blocks after equilibration must last at least twice as long.",
    ),
    key(
        "flow.kind",
        "\"rest\" | \"simple_shear\" | \"shear_reversal\" | \"planar_elongation\" | \"uniaxial_elongation\"",
        "required (flow scene)",
        "A `[flow]` table makes the case a homogeneous-flow scene: every particle sees the same velocity gradient κ (κ_xy = γ̇; reversal: −γ̇ from reverse_at on; planar: diag(ε̇, −ε̇, 0); uniaxial (3D): diag(ε̇, −ε̇/2, −ε̇/2)). Such a scene has [polymer] instead of [box], [particles], [fluid].",
    ),
    key(
        "flow.rate",
        "float ≠ 0 (0 at rest)",
        "0.0",
        "Shear rate γ̇ or elongation rate ε̇; Wi = rate × polymer.relaxation_time.",
    ),
    key(
        "flow.reverse_at",
        "float > 0",
        "required (shear_reversal)",
        "Time at which the shear rate changes sign.",
    ),
    key(
        "flow.particles",
        "integer ≥ 2",
        "required (flow scene)",
        "Particles, each carrying polymer.per_particle dumbbells; error bars come from their spread.",
    ),
    key(
        "polymer.kind",
        "\"dumbbells\" | \"bddfs\"",
        "required (flow scene)",
        "Ensembles of Brownian dumbbells carried by every particle (CONNFFESSIT). \"bddfs\": each particle stores only a histogram of its N_d connectors on a Q-grid (polymer.cells, polymer.q_max) and every step regenerates them uniformly within their cells, advances them with polymer.scheme and histograms them again (Brownian Dynamics with Distribution Function Storing, Ellero ch. 5; docs/theory/polymer_particle_and_bddfs.md §2.4): memory 8 B per occupied cell instead of N_d × D × 8 B, at the price of a grid diffusion ΔQ²/6 per step that `check` compares with Δt/λ.",
    ),
    key(
        "polymer.spring",
        "\"hookean\" | \"fene\"",
        "required (dumbbells)",
        "Spring law F(Q) = Q or Q/(1 − Q²/b) (Q in units of √(k_BT/H)).",
    ),
    key(
        "polymer.b",
        "float > 2",
        "required (fene)",
        "FENE extensibility b = H Q₀²/k_BT; |Q| < √b always (semi-implicit scheme).",
    ),
    key(
        "polymer.relaxation_time",
        "float > 0",
        "required (dumbbells)",
        "λ = ζ/(4H). Hookean: η_p = G λ, Ψ₁ = 2 G λ².",
    ),
    key(
        "polymer.modulus",
        "float > 0",
        "1.0",
        "G = n k_BT; stresses τ = G(⟨Q F(Q)⟩ − I) are reported in its units.",
    ),
    key(
        "polymer.per_particle",
        "integer ≥ 1",
        "required (dumbbells)",
        "Dumbbells per particle N_d; the stress noise falls as N_d^(−1/2). Memory N × N_d × D × 8 bytes (`check` prints it).",
    ),
    key(
        "polymer.scheme",
        "\"euler_maruyama\" | \"heun\" | \"semi_implicit\"",
        "\"heun\" (hookean), \"semi_implicit\" (fene)",
        "Stochastic scheme: Euler–Maruyama (weak order 1), stochastic Heun/SRK2 (order 2), Öttinger's semi-implicit predictor–corrector (order 2, required for FENE).",
    ),
    key(
        "polymer.variance_reduction",
        "bool",
        "false",
        "Control variates: an equilibrium copy of each ensemble driven by the same noise (×2 memory and work; ×10 smaller error bar at Wi = 0.1, none at Wi = 10). Not with bddfs.",
    ),
    key(
        "polymer.precision",
        "\"double\" | \"single\"",
        "\"double\"",
        "Storage of the connector vectors; \"single\" halves the memory (arithmetic stays double). Not with variance_reduction, not with bddfs.",
    ),
    key(
        "polymer.cells",
        "integer ≥ 2 (n_c^D < 2³²)",
        "required (bddfs)",
        "BDDFS: cells per axis n_c of the histogram grid [−q_max, q_max]^D, ΔQ = 2 q_max/n_c. The grid adds the variance ΔQ²/6 per component and step (binning and uniform reconstruction, ΔQ²/12 each) to the physical Δt/λ: the stresses and ⟨Q²⟩ come out too large by about r = λΔQ²/(6Δt), which grows as Δt falls; `check` prints r and, beyond 1 %, the n_c that brings it to 1 %. Storage is sparse, so a fine grid costs only its occupied cells.",
    ),
    key(
        "polymer.q_max",
        "float > 0 (fene: ≤ √b)",
        "√b (fene); required (hookean)",
        "BDDFS: half-edge of the histogram grid, in units of √(k_BT/H). A connector beyond it (Hookean, or FENE with q_max < √b) is counted in the nearest boundary cell; the summary warns with the count.",
    ),
    key(
        "reference[].kind",
        "\"value\" | \"linear_shear_profile\" | \"startup_profile\" | \"double_poiseuille_profile\" | \"double_poiseuille_stress\"",
        "required",
        "What the run checks itself against. double_poiseuille_profile: the time-averaged binned u_x(y) of a DPD fluid driven by a reverse body force against u_x = ρ g s (L_y/2 − |s|)/(2η), s = y − L_y/2 (each bin against the solution's bin mean). double_poiseuille_stress: the binned shear stress (observable shear_stress_profile) of the same flow against the momentum balance τ_xy = ρ g (L_y/4 − |s|), whatever η.",
    ),
    key(
        "reference[].name",
        "string",
        "required",
        "Short name printed with PASS/FAIL.",
    ),
    key(
        "reference[].observable",
        "scalar observable name",
        "required (value)",
        "A name from summary.json `observables` (e.g. \"temperature\", \"stress_total_xy\").",
    ),
    key(
        "reference[].value",
        "float",
        "required (value)",
        "Expected value (analytic or published).",
    ),
    key(
        "reference[].metric",
        "\"relative_error\" | \"absolute_error\"",
        "required (value)",
        "How the time average is compared with `value`.",
    ),
    key(
        "reference[].tolerance",
        "float > 0",
        "required",
        "Largest acceptable metric; for linear_shear_profile, max over bins of |u_x − γ̇(y − L_y/2)| / (γ̇ L_y); for startup_profile, max over bins of |u_x − u(y, t)| / scale at each time (scale: the plate velocity, or the steady centre velocity F L²/(8ν₀), or with a polymer the centre velocity at the last listed time if larger); for double_poiseuille_profile, max over bins of |u_x − u_exact| / u_max, u_max = ρ g L_y²/(32η); for double_poiseuille_stress, max over bins of |τ_xy − τ_exact| / τ_max, τ_max = ρ g L_y/4.",
    ),
    key(
        "reference[].viscosity",
        "float > 0",
        "fluid.physical.viscosity",
        "double_poiseuille_profile: the η of the analytic solution.",
    ),
    key(
        "reference[].solution",
        "\"couette\" | \"poiseuille\" | \"viscoelastic_relaxation\"",
        "required (startup_profile)",
        "The series solution (src/analytic.rs) of the case's channel, with its wall velocity, body force, η/ρ₀ and width. With a polymer, \"couette\" and \"poiseuille\" are the Oldroyd-B start-up series with η_s = fluid.viscosity, η_p and λ: exact for the upper-convected Maxwell fluid and Hookean dumbbells (N_d → ∞) in unidirectional flow, O(De²) from the corotational fluid's.",
    ),
    key(
        "reference[].positions",
        "array of floats",
        "every bin",
        "startup_profile: the wall-normal coordinates whose bins alone are compared (e.g. the two centre rows); default every bin.",
    ),
    key(
        "reference[].times",
        "array of floats",
        "required (startup_profile)",
        "Sampled times (multiples of Δt · run.sample_every) at which the binned u_x(y) is compared; one check each.",
    ),
    key(
        "reference[].source",
        "string",
        "\"\"",
        "Where the reference value comes from.",
    ),
];

/// The Markdown reference.
pub fn render_markdown() -> String {
    let mut s = String::from(
        "# Case-file reference\n\n\
         Generated by `mesorheo keys` from `src/config/reference.rs`; a test fails if this file, \
         that table and the parser disagree. A case file is TOML; unknown keys, missing keys, \
         wrong types and impossible values are refused with file:line:column, the key and what \
         would be valid. `mesorheo check CASE` prints the derived numbers.\n\n\
         | key | type | default | meaning |\n|---|---|---|---|\n",
    );
    for k in keys() {
        s.push_str(&format!(
            "| `{}` | {} | {} | {} |\n",
            k.path,
            k.kind.replace('|', "\\|"),
            k.default.replace('|', "\\|"),
            k.doc.replace('|', "\\|")
        ));
    }
    s
}
