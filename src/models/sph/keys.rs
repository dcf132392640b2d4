//! The `[fluid]` keys of the SPH fluid, for the case-file reference (`mesorheo keys`,
//! `docs/case-reference.md`) (also the summation gas's `smoothing_length` and `sound_speed`).

use crate::key_doc::{KeyDoc, key};

/// The keys, in the order of the reference.
pub const KEYS: &[KeyDoc] = &[
    key(
        "fluid.smoothing_length",
        "float > 0",
        "required (sph, summation_gas)",
        "Smoothing length h. Support (the interaction cutoff): h for Lucy, 2h for cubic_spline and wendland_c2, 3h for quintic_spline.",
    ),
    key(
        "fluid.kernel",
        "\"lucy\" | \"cubic_spline\" | \"quintic_spline\" | \"wendland_c2\" | \"truncated_gaussian\"",
        "\"lucy\"",
        "SPH smoothing kernel (sph). Supports: Lucy h, cubic spline and Wendland C2 2h, quintic spline 3h, truncated Gaussian 2h (Murashima & Taniguchi's MSPH kernel, A_d/(h√π)^d (e^{−r²/h²} − e^{−4}); its W′ jumps at 2h).",
    ),
    key(
        "fluid.rest_density",
        "float > 0",
        "1.0",
        "Rest density ρ₀ (sph); particles.mass must be ρ₀ / particles.density within 5 %.",
    ),
    key(
        "fluid.equation_of_state",
        "\"quadratic\" | \"tait\"",
        "\"quadratic\"",
        "sph: p = c₀²ρ²/(2ρ₀) (the thesis's, background pressure ρ₀c₀²/2) or Tait p = (c₀²ρ₀/7)((ρ/ρ₀)⁷ − 1). Near moving walls the quadratic one's background pressure drags the fluid (docs/validation.md).",
    ),
    key(
        "fluid.density",
        "\"summation\" | \"continuity\"",
        "\"summation\"",
        "sph: ρ_i = Σ m_j W_ij every evaluation, or dρ/dt = Σ m_j v_ij·∇W_ij integrated from ρ₀.",
    ),
    key(
        "fluid.viscosity",
        "float ≥ 0",
        "required (sph)",
        "Dynamic viscosity η (sph): of the whole fluid, or of the solvent when [fluid.polymer] adds a polymer stress.",
    ),
    key(
        "fluid.viscous_term",
        "\"nested_summation\" | \"morris\"",
        "\"nested_summation\"",
        "sph: the thesis's two-pass stress σ̄ = η(G + Gᵀ − (2/d) tr G I) from the velocity-gradient estimate, or Morris's direct term (one pass, better damping at the lattice scale).",
    ),
    key(
        "fluid.body_force",
        "array of D floats",
        "none",
        "Body force per unit mass on fluid particles (sph; Poiseuille flow).",
    ),
    key(
        "fluid.morris_regularisation",
        "float ≥ 0",
        "0.0",
        "ε of 1/(r² + εh²) in Morris's term (sph). Not needed by any offered kernel; 0.01 with Lucy weakens the viscosity by ~5 %.",
    ),
    key(
        "fluid.xsph",
        "float in [0, 1]",
        "0.0",
        "XSPH factor ε (sph): particles move with v + ε Σ_j (m_j/ρ̄_ij)(v_j − v_i) W_ij; the momentum equation is unchanged. 0.5 is usual; needs kick_drift_kick.",
    ),
    key(
        "fluid.background_pressure",
        "float",
        "0.0 (sph); 0.02 c_s²ρ₀ (generic_polymer)",
        "Constant p_b added to the equation of state (sph). No continuum pressure gradient changes; it keeps the total stress compressive where a polymer stress pulls (τ_xx > 0 in shear), which the SPH tensile instability feeds on. generic_polymer (only with its transport velocity, fluid.transport_pressure > 0): the momentum equation's pressure is c_s²(ρ − ρ₀) + p_b + k_BTn^d, the ideal gas's rest pressure c_s²ρ₀ moved into the transport velocity; p_b ≥ 0 keeps the particles' (single-dumbbell, fluctuating) polymer tension and density fluctuations from making the pressure tensile (docs/theory/generic_polymer_particle.md §2.7).",
    ),
    key(
        "fluid.transport_pressure",
        "float ≥ 0",
        "0.0 (sph); c_s²ρ₀ (generic_polymer)",
        "Transport-velocity background pressure p_t (sph; Adami, Hu & Adams, J. Comput. Phys. 241 (2013) 292): particles drift with v + ½Δt a_t, a_t = −m p_t Σ_j (1/ρ_i² + 1/ρ_j²) ∇W_ij, which keeps their arrangement uniform like fluid.background_pressure but exchanges no momentum, so the measured stress carries none of the lattice's pressure virial (in sheared CONNFFESSIT flows: N₁ +2.6 % with background_pressure = 5, see docs/theory/sph_maxwell.md §1.14). Their A = ρv(v̂ − v) term is omitted (order Δt p_t). With dumbbell ensembles in shear use p_t ≥ 12 τ_xx (measured at Wi = 4: 6 τ_xx reads η +4 %, 12.5 τ_xx +0.4 %; `check` notes a smaller one). Needs kick_drift_kick and density = \"summation\". generic_polymer: on by default (p_t = c_s²ρ₀, the ideal gas's rest pressure moved out of the momentum equation; the summation density ρ_i = m Σ_j W_ij replaces the continuity density of Eq. 4.60), because the printed form's pressure c_s²ρ on the sheared, disordering arrangement drives non-thermal velocity fluctuations that the Q·∇v term rectifies (T1 fails); 0 runs the printed form (docs/theory/generic_polymer_particle.md §2.7).",
    ),
    key(
        "fluid.velocity_gradient",
        "\"sph\" | \"corrected\"",
        "\"sph\"",
        "The velocity-gradient estimate G_i (sph): \"sph\" is Σ_j (m_j/ρ_j)(v_j − v_i) ⊗ ∇W_ij (Ellero Eq. 3.7), exact for a linear field only on an undisturbed lattice; \"corrected\" is G_i M_i⁻¹ with M_i = Σ_j (m_j/ρ_j)(x_j − x_i) ⊗ ∇W_ij, exact on any arrangement (a particle with det M_i < 10⁻³ keeps G_i). Use \"corrected\" where noise disorders the particles (dumbbell ensembles): there the plain estimate reads the shear rate ~1 % low.",
    ),
    key(
        "fluid.derivatives",
        "\"sph\" | \"msph\"",
        "\"sph\"",
        "The derivative operator of ∇v and ∇·σ (sph). \"sph\": pairwise (the gradient of velocity_gradient, the momentum equation in antisymmetric pair form, momentum conserved pair by pair). \"msph\": Zhang–Batra moment-matrix derivatives (Murashima–Taniguchi), exact for quadratic fields: per particle a 6×6 (2D) or 10×10 (3D) system, factored once per step and reused for v and σ = −pI + σ̄ + τ; a system whose h-scaled condition number exceeds 10⁴ is solved to first order (counted in the summary). Needs kernel = \"truncated_gaussian\", summation density, walls treatment \"mirror\" (or \"layers\", the paper's literal, ill-posed walls), and a Morris viscosity for damping (morris_share, or viscous_term = \"morris\").",
    ),
    key(
        "fluid.morris_share",
        "float in [0, 1)",
        "0.0",
        "With viscous_term = \"nested_summation\" (sph): the share s of η applied by Morris's pairwise term, (1 − s)η by the nested summation. MSPH's two-pass Newtonian stress leaves particle-scale velocity modes undamped; s = 0.1 damps them (docs/theory/msph_dumbbells.md §5.1).",
    ),
    key(
        "fluid.polymer.model",
        "\"corotational_maxwell\" | \"upper_convected_maxwell\" | \"dumbbells\" | \"fene_p\" | \"bddfs\"",
        "required ([fluid.polymer])",
        "A polymer stress τ carried by every particle (sph): the corotational (Jaumann) Maxwell model of Ellero 2004 ch. 3 with its printed sign corrected, dτ/dt = Ωτ − τΩ + (2η_p/λ)D̄ − τ/λ, or the upper-convected Maxwell model dτ/dt = Gτ + τGᵀ + (2η_p/λ)D − τ/λ (Oldroyd-B with fluid.viscosity > 0): τ starts at 0, is advanced by the integrator and checkpointed. \"dumbbells\" (CONNFFESSIT): every fluid particle carries per_particle Brownian dumbbells advanced once per step with the traceless part of its own velocity gradient; τ is their Kramers stress G(⟨QF(Q)⟩ − I), G = η_p/λ; the connectors start at equilibrium and are checkpointed; walls and inclusions carry none. \"fene_p\": the FENE-P closure of FENE dumbbells (needs b), dc/dt = Gc + cGᵀ − (Zc − I)/λ, Z = 1/(1 − tr c/b), τ = (η_p/λ)(Zc − I), advanced in τ; zero-shear polymer viscosity η_p b/(b + D). \"bddfs\": the dumbbells of \"dumbbells\", but each fluid particle stores only their histogram on a Q-grid (cells, q_max) and every step regenerates them uniformly within their cells, advances them with its velocity gradient and histograms them again (BDDFS, docs/theory/polymer_particle_and_bddfs.md §2.4): memory 8 B per occupied cell, a grid diffusion ΔQ²/6 per step that `check` compares with Δt/λ.",
    ),
    key(
        "fluid.polymer.per_particle",
        "integer in [1, 2²⁶]",
        "required (dumbbells, bddfs)",
        "Dumbbells per fluid particle N_d (model = \"dumbbells\" or \"bddfs\"). The stress noise falls as N_d^(−1/2); memory N_d × D × 8 bytes per particle (4 in single precision).",
    ),
    key(
        "fluid.polymer.spring",
        "\"hookean\" | \"fene\"",
        "\"hookean\"",
        "Spring law of the dumbbells (model = \"dumbbells\" or \"bddfs\"). Hookean dumbbells are the Oldroyd-B fluid (η_p = Gλ); FENE needs b, and its zero-shear polymer viscosity is Gλ b/(b + D + 2).",
    ),
    key(
        "fluid.polymer.b",
        "float > 2 (dumbbells), > 0 (fene_p)",
        "required (fene, fene_p)",
        "FENE extensibility b = H Q₀²/k_BT (model = \"dumbbells\" or \"bddfs\" with spring = \"fene\", or model = \"fene_p\").",
    ),
    key(
        "fluid.polymer.scheme",
        "\"euler_maruyama\" | \"heun\" | \"semi_implicit\"",
        "\"heun\" (Hookean), \"semi_implicit\" (FENE)",
        "Stochastic scheme of the dumbbells (model = \"dumbbells\" or \"bddfs\"); FENE needs \"semi_implicit\".",
    ),
    key(
        "fluid.polymer.precision",
        "\"double\" | \"single\"",
        "\"double\"",
        "Storage of the connectors (model = \"dumbbells\"); the arithmetic is double either way.",
    ),
    key(
        "fluid.polymer.noise",
        "\"independent\" | \"configuration_fields\"",
        "\"independent\"",
        "Whose Wiener increments the dumbbells draw (model = \"dumbbells\" or \"bddfs\"; bddfs: its reconstruction offsets too). \"independent\": every particle its own (M·N_d independent dumbbells; the stress noise differs between neighbours, disorders the particles and biases η and N₁ by O(1/N_d), growing with Wi). \"configuration_fields\": dumbbell k of every particle starts from the same connector and gets the same increments (Brownian configuration fields, Hulsen, van Heel & van den Brule 1997): the stress field is smooth, the coupling carries no noise-driven bias, and in homogeneous flow every particle holds the homogeneous-flow ensemble exactly; the mean stress then averages N_d independent dumbbells, not M·N_d, so its error bar is √M larger.",
    ),
    key(
        "fluid.polymer.cells",
        "integer ≥ 2 (n_c^D < 2³²)",
        "required (bddfs)",
        "BDDFS: cells per axis n_c of the histogram grid [−q_max, q_max]^D, ΔQ = 2 q_max/n_c (model = \"bddfs\"). The grid adds the variance ΔQ²/6 per component and step to the physical Δt/λ: the conformation and the stresses come out too large by about r = λΔQ²/(6Δt), which grows as Δt falls; `check` prints r and, beyond 1 %, the n_c that brings it to 1 %. The fluid's small (acoustic) Δt makes fine grids necessary; storage is sparse, so a fine grid costs only its occupied cells (at most N_d).",
    ),
    key(
        "fluid.polymer.q_max",
        "float > 0 (≤ √b for FENE)",
        "required (bddfs, Hookean); √b (FENE)",
        "BDDFS: half-edge Q_max of the histogram grid, in units of √(k_BT/H) (model = \"bddfs\"). A Hookean connector beyond it is counted in the boundary cell (the summary counts these); 6 + 3 Wi keeps them rare.",
    ),
    key(
        "fluid.polymer.viscosity",
        "float > 0",
        "required ([fluid.polymer])",
        "Polymer (zero-shear) viscosity η_p = Gλ. The fluid's zero-shear viscosity is fluid.viscosity + η_p.",
    ),
    key(
        "fluid.polymer.relaxation_time",
        "float > 0",
        "required ([fluid.polymer])",
        "Relaxation time λ; Δt must stay below it and below the elastic-wave limit 0.35 r_s/√(c₀² + η_p/(ρ₀λ)) (the coefficient measured).",
    ),
    key(
        "fluid.polymer.rotation",
        "bool",
        "true",
        "The rotation terms Ωτ − τΩ of the corotational model; false is the thesis's linear variant (SPH2).",
    ),
    key(
        "fluid.sound_speed",
        "float > 0",
        "required (sph, summation_gas)",
        "Sound speed: c₀ of the SPH equation of state; c of the summation gas (p = c² ρ, Δt < 0.25 h/c). SPH time steps are refused beyond the acoustic r_s/c₀, viscous (0.125 r_s²ρ₀/η nested, 0.042 r_s²ρ₀/η Morris) and body-force 0.25√(r_s/|F|) limits (r_s: support).",
    ),
];
