//! The `[fluid]` keys of the GENERIC polymer fluid (`kind = "generic_polymer"`), for the
//! case-file reference (`mesorheo keys`, `docs/case-reference.md`). `smoothing_length`,
//! `sound_speed` and `kt` are shared with the SPH and DPD fluids and documented there.

use crate::key_doc::{KeyDoc, key};

/// The keys, in the order of the reference.
pub const KEYS: &[KeyDoc] = &[
    key(
        "fluid.solvent_viscosity",
        "float > 0",
        "required (generic_polymer without [fluid.si])",
        "GENERIC polymer fluid: solvent shear viscosity η_s. The pair friction uses the dimension-correct coefficients a = (D+2)η_s/D, b = (D+2)(D−2)η_s/D (no bulk viscosity; docs/theory/generic_polymer_particle.md §2).",
    ),
    key(
        "fluid.spring_constant",
        "float > 0",
        "required (generic_polymer without [fluid.si])",
        "GENERIC polymer fluid: Hookean spring constant H of the particle's dumbbell; ⟨Q_aQ_b⟩ = (k_BT/H) δ_ab at rest.",
    ),
    key(
        "fluid.relaxation_time",
        "float > 0",
        "required (generic_polymer without [fluid.si])",
        "GENERIC polymer fluid: dumbbell relaxation time λ_H = ζ/(4H); dQ = Q·∇v dt − Q/(2λ_H) dt + (k_BT/(Hλ_H))^½ dU.",
    ),
    key(
        "fluid.dumbbell_density",
        "float ≥ 0",
        "required (generic_polymer without [fluid.si])",
        "GENERIC polymer fluid: dumbbell number density n^d; the polymer pressure is k_BT n^d 1 − H n^d Q_iQ_i and η_p = n^d k_BT λ_H (0: the Newtonian SDPD fluid).",
    ),
    key(
        "fluid.velocity_noise",
        "bool",
        "true",
        "GENERIC polymer fluid: the SDPD thermal pair noise on the velocities, antisymmetric and momentum conserving, amplitude from the fluctuation–dissipation theorem (false: the thesis's simulations, which drop it).",
    ),
    key(
        "fluid.conformation_drift",
        "\"single_dumbbell\" | \"printed_generic\"",
        "\"single_dumbbell\"",
        "GENERIC polymer fluid: the drift of Q. \"single_dumbbell\": −Q/(2λ_H), Eq. 4.60, FDT consistent. \"printed_generic\": −N^d Q/(2λ_H) with N^d = n^d/d_i, the GENERIC drift of the printed Eq. 4.48 with the entropy 4.47 and the printed noise; it breaks the FDT (⟨Q_a²⟩ = k_BT/(HN^d)) and is kept to show it.",
    ),
    key(
        "fluid.conformation_gradient",
        "\"particle\" | \"smoothed\" | \"corrected\"",
        "\"particle\"",
        "GENERIC polymer fluid: the velocity gradient κ the conformation equation dQ = Q·κ dt + … reads. \"particle\": the particle's own SPH gradient κ_i = (1/d_i) Σ_j ω_ij ⊗ v_ij (Eq. 4.60). \"smoothed\": its Shepard average over the kernel, κ̄_i = Σ_j W_ij κ_j / Σ_j W_ij (self included; one more pair pass), the same continuum gradient with less particle-scale noise, which the multiplicative Q·κ term would otherwise rectify into extra stretching; the momentum equation is unchanged, so the reversible part no longer conserves energy exactly (docs/theory/generic_polymer_particle.md §2.8). \"corrected\": the first-order corrected estimate κ_i = B_i⁻¹ Σ_j ω_ij ⊗ v_ij with B_i = Σ_j ω_ij ⊗ r_ij (CONNFFESSIT's velocity_gradient = \"corrected\"), exact for a linear field on any arrangement, where the particle's own estimate reads a sheared, disordered arrangement's rate ~1 % low (N₁ ∝ γ̇² ~2 % low); the same energy caveat; a particle with det(B_i/d_i) < 10⁻³ keeps its own κ_i and the summary counts it.",
    ),
    key(
        "fluid.explicit_dumbbells",
        "integer ≥ 1",
        "1",
        "GENERIC polymer fluid: Model A, the number N_s of explicit conformation vectors (dumbbells) per particle, each advanced with the particle's velocity gradient, the drift of fluid.conformation_drift and its own FDT noise (one stream per particle and step, keyed by its id); the polymer pressure is k_BT n^d 1 − H n^d ⟨QQ⟩_i, the average over the particle's dumbbells, as in CONNFFESSIT. 1 is Model B (one Q per particle), bit for bit. Cost and memory grow as N_s (docs/theory/generic_polymer_particle.md §6).",
    ),
    key(
        "fluid.si.box_length",
        "float > 0 (m)",
        "required in [fluid.si]",
        "GENERIC polymer fluid in physical units (`mesorheo check` prints the conversion): a `[fluid.si]` table replaces sound_speed, solvent_viscosity, kt, spring_constant, relaxation_time and dumbbell_density (none of which may then be given). `box_length`: L₀, the length unit; the box must be 1 along every axis.",
    ),
    key(
        "fluid.si.relaxation_time",
        "float > 0 (s)",
        "required in [fluid.si]",
        "λ_H, the time unit (λ̄_H = 1); H = ζ/(4λ_H).",
    ),
    key(
        "fluid.si.temperature",
        "float > 0 (K)",
        "required in [fluid.si]",
        "T₀; k̄_BT = k_BT₀λ_H²/(ρ₀L₀⁵).",
    ),
    key(
        "fluid.si.solvent_viscosity",
        "float > 0 (Pa s)",
        "required in [fluid.si]",
        "η_s; η̄_s = η_sλ_H/(ρ₀L₀²).",
    ),
    key(
        "fluid.si.density",
        "float > 0 (kg/m³)",
        "required in [fluid.si]",
        "Solvent mass density ρ₀; ρ₀L₀³ is the mass unit, so particles.mass × particles.density must be 1.",
    ),
    key(
        "fluid.si.dumbbells",
        "float > 0",
        "required in [fluid.si]",
        "Number of dumbbells N^d in the box L₀³; n̄^d = N^d.",
    ),
    key(
        "fluid.si.bead_radius",
        "float > 0 (m)",
        "required in [fluid.si]",
        "Bead radius a; Stokes friction ζ = 6πη_s a.",
    ),
    key(
        "fluid.si.specific_gas_constant",
        "float > 0 (J kg⁻¹ K⁻¹)",
        "required in [fluid.si]",
        "R_s = k_B/m_s of the solvent (the thesis's \"c_p\" = 462): P^s = ρR_sT₀, c̄_s = √(R_sT₀)λ_H/L₀.",
    ),
];
