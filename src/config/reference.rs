//! The case-file key reference: one table, rendered into `docs/case-reference.md`
//! (`mesorheo keys > docs/case-reference.md`). A test checks that the table lists exactly the
//! keys the structs accept and that the document is up to date.

/// One documented key.
pub struct KeyDoc {
    /// Dotted path; `[]` marks an array of tables.
    pub path: &'static str,
    /// Type and allowed values.
    pub kind: &'static str,
    /// Default, or "required".
    pub default: &'static str,
    /// Meaning.
    pub doc: &'static str,
}

const fn key(
    path: &'static str,
    kind: &'static str,
    default: &'static str,
    doc: &'static str,
) -> KeyDoc {
    KeyDoc {
        path,
        kind,
        default,
        doc,
    }
}

/// Every key of a case file.
pub const KEYS: &[KeyDoc] = &[
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
        "\"auto\" | \"rest\" | \"shear\"",
        "\"auto\"",
        "Mean initial velocity: \"shear\" adds γ̇ (y − L_y/2) along x; \"auto\" does so when box.shear_rate ≠ 0.",
    ),
    key(
        "fluid.kind",
        "\"dpd\" | \"summation_gas\"",
        "required",
        "Fluid model. \"dpd\": dissipative particle dynamics (Groot–Warren). \"summation_gas\": the engine's two-pass test model, an isothermal SPH gas (Lucy kernel, summation density, p = c²ρ).",
    ),
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
        "s in w_D = (1 − r/r_c)^s, w_R = √w_D (2: standard DPD; 0.5: modified).",
    ),
    key(
        "fluid.noise",
        "\"gaussian\" | \"uniform\"",
        "\"gaussian\"",
        "Distribution of θ_ij: standard normal, or √3(2u − 1) (unit variance).",
    ),
    key(
        "fluid.smoothing_length",
        "float > 0",
        "required (summation_gas)",
        "Smoothing length h: support of the Lucy kernel and interaction cutoff.",
    ),
    key(
        "fluid.sound_speed",
        "float > 0",
        "required (summation_gas)",
        "Isothermal sound speed c (p = c² ρ); integrator.dt must stay below 0.25 h/c.",
    ),
    key(
        "integrator.kind",
        "\"groot_warren\" | \"brownian_dynamics\"",
        "required",
        "Time integrator. \"groot_warren\": modified velocity Verlet (particle scenes); \"brownian_dynamics\": the stochastic scheme of polymer.scheme (homogeneous-flow scenes).",
    ),
    key(
        "integrator.dt",
        "float > 0",
        "required",
        "Time step Δt. DPD: refused beyond the dissipative limit m/(γ Σw_D) and the Verlet limit 2/ω (see `check`). Dumbbells: refused beyond λ/2 and beyond rate × Δt = 0.5; Δt ≤ λ/10 advised.",
    ),
    key(
        "integrator.lambda",
        "float in [0, 1]",
        "0.5",
        "Velocity-prediction factor λ (0.5: plain velocity Verlet; 0.65: Groot–Warren).",
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
        "array of \"position\" | \"velocity\" | \"force\" | \"image\"",
        "[\"position\", \"velocity\", \"image\"]",
        "Per-particle fields of each snapshot frame (written in global-id order).",
    ),
    key(
        "diagnostics.observables",
        "array of observable names",
        "[\"temperature\", \"pressure\"]",
        "What to average: \"temperature\", \"pressure\", \"stress\" (full tensor by contribution), \"viscosity\", \"first_normal_stress_difference\", \"second_normal_stress_difference\", \"momentum\", \"velocity_profile\". The shear ones need box.shear_rate ≠ 0. Only what is listed is computed: the pair virial is skipped without \"pressure\", \"stress\" or the stress differences, and only its diagonal is accumulated without \"stress\" or \"viscosity\".",
    ),
    key(
        "diagnostics.profile_bins",
        "integer ≥ 1",
        "10",
        "Bins along y for the velocity profile and the profile-unbiased temperature under shear.",
    ),
    key(
        "diagnostics.blocks",
        "integer ≥ 2",
        "10",
        "Blocks of the block-averaged standard errors.",
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
        "\"dumbbells\"",
        "required (flow scene)",
        "Ensembles of Brownian dumbbells carried by every particle (CONNFFESSIT).",
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
        "Control variates: an equilibrium copy of each ensemble driven by the same noise (×2 memory and work; ×10 smaller error bar at Wi = 0.1, none at Wi = 10).",
    ),
    key(
        "polymer.precision",
        "\"double\" | \"single\"",
        "\"double\"",
        "Storage of the connector vectors; \"single\" halves the memory (arithmetic stays double). Not with variance_reduction.",
    ),
    key(
        "reference[].kind",
        "\"value\" | \"linear_shear_profile\"",
        "required",
        "What the run checks itself against.",
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
        "Largest acceptable metric; for linear_shear_profile, max over bins of |u_x − γ̇(y − L_y/2)| / (γ̇ L_y).",
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
    for k in KEYS {
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
