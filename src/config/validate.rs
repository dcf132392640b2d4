//! Checks of values and of their combinations, after the structure has been parsed.

use super::spans::{Segment, SpanIndex};
use super::*;
use crate::stability;

fn k(s: &str) -> Segment {
    Segment::Key(s.to_owned())
}

fn path(keys: &[&str]) -> Vec<Segment> {
    keys.iter().map(|s| k(s)).collect()
}

/// Largest particle count the 32-bit id fields of the random-number keys support.
pub const MAX_PARTICLES: u64 = u32::MAX as u64;

/// Upper bound for bin and block counts (beyond it memory, not statistics, is the limit).
const MAX_BINS: usize = 100_000;

/// All value checks; the first failure is reported.
pub fn validate(case: &Case, ix: &SpanIndex) -> Result<(), CaseError> {
    let dim = case.dimension;
    let err = |keys: &[&str], msg: String| Err(ix.error(&path(keys), msg));
    if dim != 2 && dim != 3 {
        return err(
            &["dimension"],
            format!("found {dim}; valid values are 2 and 3"),
        );
    }
    // [box]
    let lengths = &case.domain.lengths;
    if lengths.len() != dim {
        return err(
            &["box", "lengths"],
            format!(
                "found {} lengths for a {dim}-dimensional case; give exactly {dim}",
                lengths.len()
            ),
        );
    }
    for (i, l) in lengths.iter().enumerate() {
        if !(l.is_finite() && *l > 0.0) {
            return Err(ix.error(
                &[k("box"), k("lengths"), Segment::Index(i)],
                format!("found {l}; box lengths must be finite and > 0"),
            ));
        }
    }
    if let Some(b) = &case.domain.boundaries
        && b.len() != dim
    {
        return err(
            &["box", "boundaries"],
            format!(
                "found {} boundaries for a {dim}-dimensional case; give exactly {dim}",
                b.len()
            ),
        );
    }
    let boundaries = case.boundaries();
    let shear = case.domain.shear_rate;
    if !shear.is_finite() {
        return err(
            &["box", "shear_rate"],
            format!("found {shear}; must be a finite number"),
        );
    }
    if shear != 0.0 && (boundaries[0] != Boundary::Periodic || boundaries[1] != Boundary::Periodic)
    {
        return err(
            &["box", "shear_rate"],
            "Lees–Edwards shear needs periodic x (flow) and y (gradient) axes; set \
             boundaries[0] and boundaries[1] to \"periodic\" or shear_rate = 0"
                .into(),
        );
    }
    // [decomposition]
    let axis = case.decomposition.axis.index();
    if axis >= dim {
        return err(
            &["decomposition", "axis"],
            "found \"z\" in a 2-dimensional case; valid axes are \"x\" and \"y\"".to_string(),
        );
    }
    if shear != 0.0 && axis == 0 {
        return err(
            &["decomposition", "axis"],
            "slabs along the flow axis x are not supported under Lees–Edwards shear (the rank \
             receiving an image would change with the offset); use \"y\" or \"z\""
                .into(),
        );
    }
    // [particles]
    let p = &case.particles;
    if !(p.density.is_finite() && p.density > 0.0) {
        return err(
            &["particles", "density"],
            format!("found {}; must be > 0", p.density),
        );
    }
    if !(p.mass.is_finite() && p.mass > 0.0) {
        return err(
            &["particles", "mass"],
            format!("found {}; must be > 0", p.mass),
        );
    }
    if !(p.temperature.is_finite() && p.temperature >= 0.0) {
        return err(
            &["particles", "temperature"],
            format!("found {}; must be ≥ 0", p.temperature),
        );
    }
    if !p.velocity_amplitude.is_finite() {
        return err(
            &["particles", "velocity_amplitude"],
            format!("found {}; must be finite", p.velocity_amplitude),
        );
    }
    if p.velocity_profile == VelocityProfile::HalfSine && shear != 0.0 {
        return err(
            &["particles", "velocity_profile"],
            "\"half_sine\" is a channel's mode; it cannot be combined with box.shear_rate ≠ 0"
                .into(),
        );
    }
    if p.velocity_profile == VelocityProfile::Shear && shear == 0.0 {
        return err(
            &["particles", "velocity_profile"],
            "\"shear\" needs box.shear_rate ≠ 0; use \"rest\" or \"auto\"".into(),
        );
    }
    let (_, n) = case.lattice_counts();
    if n == 0 {
        return err(
            &["particles", "density"],
            format!(
                "this density creates no particle in the box {lengths:?}; raise the density or \
                 the box"
            ),
        );
    }
    if n < 2 {
        return err(
            &["particles", "density"],
            format!("this density creates {n} particle(s); a fluid needs at least 2"),
        );
    }
    if shear != 0.0 && n < 2 * case.diagnostics.profile_bins as u64 {
        return err(
            &["diagnostics", "profile_bins"],
            format!(
                "{} bins for {n} particles: the profile-unbiased temperature needs at least 2 \
                 particles per bin; use at most {} bins",
                case.diagnostics.profile_bins,
                n / 2
            ),
        );
    }
    if n > MAX_PARTICLES {
        return err(
            &["particles", "density"],
            format!(
                "the box would hold {:.3e} particles, more than the supported maximum \
                 {MAX_PARTICLES} (32-bit ids key the random numbers); shrink the box or the density",
                n as f64
            ),
        );
    }
    // [fluid]
    let fl = |key: &str| vec![k("fluid"), k(key)];
    match &case.fluid {
        FluidCfg::Dpd(dpd) => {
            if !(dpd.a.is_finite() && dpd.a >= 0.0) {
                return Err(ix.error(
                    &fl("a"),
                    format!("found {}; the repulsion a must be ≥ 0", dpd.a),
                ));
            }
            if !(dpd.gamma.is_finite() && dpd.gamma > 0.0) {
                return Err(ix.error(
                    &fl("gamma"),
                    format!("found {}; the dissipation γ must be > 0", dpd.gamma),
                ));
            }
            if !(dpd.kt.is_finite() && dpd.kt > 0.0) {
                return Err(ix.error(&fl("kt"), format!("found {}; k_BT must be > 0", dpd.kt)));
            }
            if !(dpd.cutoff.is_finite() && dpd.cutoff > 0.0) {
                return Err(ix.error(&fl("cutoff"), format!("found {}; must be > 0", dpd.cutoff)));
            }
            if !(dpd.weight_exponent.is_finite() && dpd.weight_exponent > 0.0) {
                return Err(ix.error(
                &fl("weight_exponent"),
                format!(
                    "found {}; the exponent s of w_D = (1 − r/r_c)^s must be > 0 (2 standard, 0.5 \
                     modified)",
                    dpd.weight_exponent
                ),
            ));
            }
            if !dpd.body_force.is_empty()
                && (dpd.body_force.len() != dim || dpd.body_force.iter().any(|g| !g.is_finite()))
            {
                return Err(ix.error(
                    &fl("body_force"),
                    format!(
                        "found {:?}; give {dim} finite components of the acceleration g",
                        dpd.body_force
                    ),
                ));
            }
            if !(dpd.conservative_exponent.is_finite() && dpd.conservative_exponent > 0.0) {
                return Err(ix.error(
                    &fl("conservative_exponent"),
                    format!(
                        "found {}; the exponent s̄ of w_C = (1 − r/r_c)^s̄ must be > 0 (1 standard)",
                        dpd.conservative_exponent
                    ),
                ));
            }
        }
        FluidCfg::SummationGas(gas) => {
            if !(gas.smoothing_length.is_finite() && gas.smoothing_length > 0.0) {
                return Err(ix.error(
                    &fl("smoothing_length"),
                    format!("found {}; must be > 0", gas.smoothing_length),
                ));
            }
            if !(gas.sound_speed.is_finite() && gas.sound_speed > 0.0) {
                return Err(ix.error(
                    &fl("sound_speed"),
                    format!("found {}; must be > 0", gas.sound_speed),
                ));
            }
        }
        FluidCfg::Sph(sph) => validate_sph(case, sph, ix)?,
    }
    if case.inclusions.is_some() && !matches!(case.fluid, FluidCfg::Sph(_)) {
        return err(
            &["inclusions"],
            "inclusions of boundary particles belong to SPH fluids (kind = \"sph\")".to_string(),
        );
    }
    if case.walls.is_some() && !matches!(case.fluid, FluidCfg::Sph(_)) {
        return err(
            &["walls"],
            "boundary-particle walls belong to SPH fluids (kind = \"sph\"); for reflecting \
             walls set box.boundaries"
                .to_string(),
        );
    }
    // [integrator]
    let dt = case.integrator.dt();
    if !(dt.is_finite() && dt > 0.0) {
        return err(&["integrator", "dt"], format!("found {dt}; must be > 0"));
    }
    if let IntegratorCfg::GrootWarren(gw) = &case.integrator
        && !(gw.lambda.is_finite() && (0.0..=1.0).contains(&gw.lambda))
    {
        return err(
            &["integrator", "lambda"],
            format!(
                "found {}; λ must lie in [0, 1] (0.5 plain velocity Verlet, 0.65 Groot–Warren)",
                gw.lambda
            ),
        );
    }
    let exponential = matches!(
        &case.integrator,
        IntegratorCfg::GrootWarren(gw) if gw.thermostat == crate::config::Thermostat::Exponential
    );
    if exponential {
        if let IntegratorCfg::GrootWarren(gw) = &case.integrator
            && gw.lambda != 0.5
        {
            return err(
                &["integrator", "lambda"],
                format!(
                    "found {} with thermostat = \"exponential\", whose temperature is exact (mean \
                     field) for plain velocity Verlet only: use lambda = 0.5",
                    gw.lambda
                ),
            );
        }
        if !matches!(case.fluid, FluidCfg::Dpd(_)) {
            return err(
                &["integrator", "thermostat"],
                "thermostat = \"exponential\" integrates the DPD friction; this fluid has none \
                 (use \"explicit\")"
                    .to_string(),
            );
        }
    }
    let sph = matches!(case.fluid, FluidCfg::Sph(_));
    let groot_warren = matches!(case.integrator, IntegratorCfg::GrootWarren(_));
    if !sph && !groot_warren {
        return err(
            &["integrator", "kind"],
            "the SPH integrators (kick_drift_kick, heun, midpoint, thesis_predictor_corrector) \
             serve kind = \"sph\" fluids; use kind = \"groot_warren\" for this fluid"
                .to_string(),
        );
    }
    if let FluidCfg::Sph(s) = &case.fluid
        && groot_warren
        && s.density == crate::models::sph::DensityMethod::Continuity
    {
        return err(
            &["integrator", "kind"],
            "groot_warren does not integrate the continuity density; use kick_drift_kick, heun \
             or midpoint"
                .to_string(),
        );
    }
    if case.integrator.stages() > 1 && case.domain.shear_rate != 0.0 {
        return err(
            &["integrator", "kind"],
            "two-stage integrators are not supported under Lees–Edwards shear (the predicted \
             stage would see the images at the wrong offset); use kick_drift_kick"
                .to_string(),
        );
    }
    // [neighbour]
    let skin = case.neighbour.skin;
    if !(skin.is_finite() && skin > 0.0) {
        return err(&["neighbour", "skin"], format!("found {skin}; must be > 0"));
    }
    let range = case.cutoff() + skin;
    for (i, l) in lengths.iter().enumerate() {
        if *l < range {
            return Err(ix.error(
                &[k("box"), k("lengths"), Segment::Index(i)],
                format!(
                    "L = {l} along {} is shorter than cutoff + skin = {range}; the box must be at \
                     least one interaction range wide (twice that on periodic axes)",
                    ["x", "y", "z"][i]
                ),
            ));
        }
    }
    let cutoff_key = match &case.fluid {
        FluidCfg::Dpd(_) => "cutoff",
        FluidCfg::SummationGas(_) | FluidCfg::Sph(_) => "smoothing_length",
    };
    for (i, (l, b)) in lengths.iter().zip(&boundaries).enumerate() {
        if *b == Boundary::Periodic && range > 0.5 * l {
            return Err(ix.error(
                &fl(cutoff_key),
                format!(
                    "cutoff + skin = {range} is larger than half the box along axis {} \
                     (L = {l}); a particle would meet two images of the same neighbour. Use a \
                     box of at least {} or a smaller cutoff/skin",
                    ["x", "y", "z"][i],
                    2.0 * range
                ),
            ));
        }
    }
    // Time-step stability (unless the case asks to run beyond the limits).
    match &case.fluid {
        _ if case.run.beyond_stability_limits => {}
        FluidCfg::Dpd(_) => {
            if let Some(l) = stability::dpd_limits_of(case)
                && dt > l.combined
            {
                let binding = if l.free_flight < l.dissipative.min(l.conservative) {
                    "mostly the free flight's (a thermal particle crossing the cutoff in too few \
                     steps): use a smaller time step"
                } else if l.dissipative < l.conservative {
                    "mostly the dissipative force's: use a smaller time step, a smaller γ, or \
                     thermostat = \"exponential\" (which integrates the friction exactly)"
                } else {
                    "mostly the conservative force's (velocity Verlet in the cage of \
                     neighbours): use a smaller time step or a softer a"
                };
                return err(
                    &["integrator", "dt"],
                    format!(
                        "Δt = {dt} is beyond the measured stability limit of this DPD fluid, \
                         Δt ≤ ((Δt_C⁻ᵖ + Δt_D⁻ᵖ)^(p′/p) + Δt_F^(−p′))^(−1/p′) = {:.4e} (p = {}, p′ = {}) with the \
                         conservative part Δt_C = α/ω_E = {:.4e}, the dissipative part \
                         Δt_D = {:.4e} and the free-flight part Δt_F = {:.4e} (see `mesorheo \
                         check`); the limit is {binding}",
                        l.combined,
                        stability::dpd_fit::NORM_EXPONENT,
                        stability::dpd_fit::FREE_FLIGHT_EXPONENT,
                        l.conservative,
                        l.dissipative,
                        l.free_flight
                    ),
                );
            }
        }
        FluidCfg::SummationGas(gas) => {
            let cfl = stability::cfl_limit(gas.smoothing_length, gas.sound_speed);
            if dt > cfl {
                return err(
                    &["integrator", "dt"],
                    format!(
                        "Δt = {dt} is beyond the acoustic (CFL) limit 0.25 h/c = {cfl:.4e}; use a \
                         smaller time step"
                    ),
                );
            }
        }
        FluidCfg::Sph(s) => {
            let (name, limit) = stability::sph_binding_limit(s, case.inclusions.is_some());
            if dt > limit {
                let all: Vec<String> = stability::sph_limits(s, case.inclusions.is_some())
                    .iter()
                    .map(|(n, l)| format!("{n} = {l:.4e}"))
                    .collect();
                return err(
                    &["integrator", "dt"],
                    format!(
                        "Δt = {dt} is beyond the {name} limit {limit:.4e} (limits: {}); use a \
                         smaller time step",
                        all.join(", ")
                    ),
                );
            }
        }
    }
    // [run]
    validate_run(&case.run, case.diagnostics.blocks, ix)?;
    // [output]
    let o = &case.output;
    if o.checkpoint_keep == 0 {
        return err(
            &["output", "checkpoint_keep"],
            "found 0; keep at least 1 checkpoint (a restart needs one)".to_owned(),
        );
    }
    if o.snapshot_every > 0 && o.snapshot_fields.is_empty() {
        return err(
            &["output", "snapshot_fields"],
            "found an empty list with snapshot_every > 0; name at least one of \
             \"position\", \"velocity\", \"force\", \"image\""
                .to_owned(),
        );
    }
    if o.snapshot_every > 0
        && !o
            .snapshot_fields
            .contains(&crate::config::SnapshotField::Position)
    {
        return err(
            &["output", "snapshot_fields"],
            format!(
                "found {:?} without \"position\"; snapshots need positions (the XDMF \
                 geometry), add \"position\"",
                o.snapshot_fields
                    .iter()
                    .map(|f| f.name())
                    .collect::<Vec<_>>()
            ),
        );
    }
    let mut seen = o.snapshot_fields.clone();
    seen.sort();
    if let Some(w) = seen.windows(2).find(|w| w[0] == w[1]) {
        return err(
            &["output", "snapshot_fields"],
            format!("found {:?} twice; list each field once", w[0].name()),
        );
    }
    // [diagnostics]
    let d = &case.diagnostics;
    if d.profile_bins == 0 || d.profile_bins > MAX_BINS {
        return err(
            &["diagnostics", "profile_bins"],
            format!("found {}; must be between 1 and {MAX_BINS}", d.profile_bins),
        );
    }
    for (i, o) in d.observables.iter().enumerate() {
        if d.observables[..i].contains(o) {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                format!(
                    "\"{}\" is listed twice; list each observable once",
                    o.name()
                ),
            ));
        }
        let needs_shear = matches!(
            o,
            Observable::Viscosity
                | Observable::FirstNormalStressDifference
                | Observable::SecondNormalStressDifference
                | Observable::ConstitutiveStress
                | Observable::VelocityProfile
        );
        let walled_profile = *o == Observable::VelocityProfile
            && (boundaries.contains(&Boundary::Wall) || case.body_forced());
        if needs_shear && shear == 0.0 && !walled_profile {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                format!(
                    "\"{}\" needs shear; set box.shear_rate ≠ 0{}",
                    o.name(),
                    if *o == Observable::VelocityProfile {
                        " (or walls, or a DPD fluid.body_force)"
                    } else {
                        ""
                    }
                ),
            ));
        }
        let needs_virial = matches!(
            o,
            Observable::Pressure
                | Observable::Stress
                | Observable::Viscosity
                | Observable::FirstNormalStressDifference
                | Observable::SecondNormalStressDifference
        );
        // The SPH constitutive stress σ̄ (viscous stress of the nested summation + polymer
        // stress) must be the whole deviatoric stress to be a viscometric measurement.
        let sph_stress = match &case.fluid {
            FluidCfg::Sph(s) => {
                s.viscous_term == crate::models::sph::ViscousTerm::NestedSummation
                    || s.polymer.is_some()
                    || (case.inclusions.is_some() && s.viscosity > 0.0)
            }
            _ => false,
        };
        if *o == Observable::ConstitutiveStress && !sph_stress {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "\"constitutive_stress\" is the SPH particles' own stress σ̄; it needs an SPH \
                 fluid that forms it (fluid.viscous_term = \"nested_summation\", a \
                 [fluid.polymer], or [inclusions]); the momentum flux (\"viscosity\", \
                 \"stress\") is measured for every fluid"
                    .to_string(),
            ));
        }
        let msph = matches!(&case.fluid, FluidCfg::Sph(s)
            if s.derivatives == crate::models::sph::Derivatives::Msph);
        if needs_virial && msph {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                format!(
                    "\"{}\" needs the momentum flux of pair forces, and with fluid.derivatives \
                     = \"msph\" the stresses enter as a per-particle divergence, not as pair \
                     forces; use \"constitutive_stress\" (the particles' own stress), or \
                     fluid.derivatives = \"sph\"",
                    o.name()
                ),
            ));
        }
        if *o == Observable::PolymerStressTrace
            && !matches!(&case.fluid, FluidCfg::Sph(s) if s.polymer.is_some())
        {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "\"polymer_stress_trace\" needs a polymer stress ([fluid.polymer] of an SPH \
                 fluid)"
                    .to_string(),
            ));
        }
        if *o == Observable::CompositeViscosity
            && (case.inclusions.is_none() || case.domain.shear_rate == 0.0)
        {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "\"composite_viscosity\" needs [inclusions] in a sheared box (box.shear_rate \
                 ≠ 0)"
                    .to_string(),
            ));
        }
        if needs_virial && matches!(case.fluid, FluidCfg::SummationGas(_)) {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                format!(
                    "\"{}\" needs the pair virial, which the summation gas does not compute \
                     (the default list has \"pressure\"); list only \"temperature\", \
                     \"momentum\" or \"velocity_profile\"",
                    o.name()
                ),
            ));
        }
        if *o == Observable::ShearStressProfile && !matches!(case.fluid, FluidCfg::Dpd(_)) {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "\"shear_stress_profile\" bins the DPD pair and kinetic stress; it needs [fluid] \
                 kind = \"dpd\""
                    .to_string(),
            ));
        }
        if *o == Observable::DensityProfile && !matches!(case.fluid, FluidCfg::Sph(_)) {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "\"density_profile\" is the SPH density per bin; it needs [fluid] kind = \"sph\""
                    .to_string(),
            ));
        }
        if *o == Observable::WallShearStress && case.walls.is_none() {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "\"wall_shear_stress\" needs [walls] (boundary-particle walls of an SPH fluid)"
                    .to_string(),
            ));
        }
        if *o == Observable::GreenKuboViscosity {
            let at = [k("diagnostics"), k("observables"), Segment::Index(i)];
            if !matches!(case.fluid, FluidCfg::Dpd(_)) {
                return Err(ix.error(
                    &at,
                    "\"green_kubo_viscosity\" correlates the pair virial of a DPD fluid; it needs \
                     [fluid] kind = \"dpd\""
                        .to_string(),
                ));
            }
            if shear != 0.0 || boundaries.contains(&Boundary::Wall) {
                return Err(ix.error(
                    &at,
                    "\"green_kubo_viscosity\" is an equilibrium method: it needs a periodic box \
                     at rest (box.shear_rate = 0, no walls); under shear use \"viscosity\""
                        .to_string(),
                ));
            }
            let tau = d.green_kubo_time;
            let block_time = (case.run.steps.saturating_sub(case.run.equilibration)) as f64
                * case.integrator.dt()
                / d.blocks as f64;
            if !(tau.is_finite() && tau > 0.0) {
                return err(
                    &["diagnostics", "green_kubo_time"],
                    format!(
                        "found {tau}; must be > 0 (the upper limit of the Green–Kubo integral)"
                    ),
                );
            }
            if tau > 0.5 * block_time {
                return err(
                    &["diagnostics", "green_kubo_time"],
                    format!(
                        "found {tau}, but each of the {} blocks of the run after equilibration \
                         lasts only {block_time:.4} time units; the integral needs blocks at \
                         least twice as long as green_kubo_time: lower it, use fewer \
                         diagnostics.blocks, or run longer",
                        d.blocks
                    ),
                );
            }
        }
        if *o == Observable::TransverseCurrentViscosity {
            let at = [k("diagnostics"), k("observables"), Segment::Index(i)];
            let FluidCfg::Dpd(dpd) = &case.fluid else {
                return Err(ix.error(
                    &at,
                    "\"transverse_current_viscosity\" needs a thermal fluid, [fluid] kind = \"dpd\""
                        .to_string(),
                ));
            };
            if shear != 0.0
                || boundaries.contains(&Boundary::Wall)
                || dpd.body_force.iter().any(|&g| g != 0.0)
            {
                return Err(ix.error(
                    &at,
                    "\"transverse_current_viscosity\" is an equilibrium method: it needs a \
                     periodic box at rest (box.shear_rate = 0, no walls, no fluid.body_force); \
                     under shear use \"viscosity\""
                        .to_string(),
                ));
            }
            let lengths = &case.domain.lengths;
            if lengths
                .iter()
                .any(|&l| (l - lengths[0]).abs() > 1e-12 * lengths[0])
            {
                return err(
                    &["box", "lengths"],
                    format!(
                        "found {lengths:?}; \"transverse_current_viscosity\" averages the \
                         wavevectors 2πj/L along every axis and needs a cubic (square) box: \
                         give every edge the same length"
                    ),
                );
            }
            let modes = d.transverse_current_modes;
            if !(2..=100).contains(&modes) {
                return err(
                    &["diagnostics", "transverse_current_modes"],
                    format!(
                        "found {modes}; must be 2 … 100 (wavenumbers 2πj/L, j = 1 … modes; the \
                         k → 0 extrapolation needs at least 2)"
                    ),
                );
            }
            if d.transverse_current_every == 0 {
                return err(
                    &["diagnostics", "transverse_current_every"],
                    "found 0; must be ≥ 1 (steps between samples of the currents)".to_string(),
                );
            }
            let tau = d.transverse_current_time;
            let block_time = (case.run.steps.saturating_sub(case.run.equilibration)) as f64
                * case.integrator.dt()
                / d.blocks as f64;
            let interval = d.transverse_current_every as f64 * case.integrator.dt();
            if !(tau.is_finite() && tau >= 16.0 * interval) {
                return err(
                    &["diagnostics", "transverse_current_time"],
                    format!(
                        "found {tau}; must be at least 16 sampling intervals \
                         (transverse_current_every × Δt = {interval}), the span of the \
                         correlator's first level"
                    ),
                );
            }
            if tau > 0.5 * block_time || d.blocks < 2 {
                return err(
                    &["diagnostics", "transverse_current_time"],
                    format!(
                        "found {tau} with {} blocks of {block_time:.4} time units after \
                         equilibration; the jackknife error bars need ≥ 2 blocks, each at least \
                         twice as long as transverse_current_time: lower it, or run longer",
                        d.blocks
                    ),
                );
            }
        }
        if *o == Observable::SecondNormalStressDifference && dim != 3 {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "the second normal stress difference needs a 3-dimensional case".to_string(),
            ));
        }
    }
    // [[reference]]
    let scalars = super::observables::scalar_names(case);
    for (i, rf) in case.reference.iter().enumerate() {
        let at = |key: &str| vec![k("reference"), Segment::Index(i), k(key)];
        match rf {
            ReferenceCfg::Value(v) => {
                validate_value_reference(v, i, &scalars, "case", ix)?;
            }
            ReferenceCfg::LinearShearProfile(pr) => {
                if shear == 0.0 || !case.wants(Observable::VelocityProfile) {
                    return Err(ix.error(
                        &at("kind"),
                        "a linear_shear_profile reference needs box.shear_rate ≠ 0 and \
                         \"velocity_profile\" among diagnostics.observables"
                            .to_string(),
                    ));
                }
                if !(pr.tolerance.is_finite() && pr.tolerance > 0.0) {
                    return Err(ix.error(
                        &at("tolerance"),
                        format!("found {}; must be > 0", pr.tolerance),
                    ));
                }
            }
            ReferenceCfg::StartupProfile(sp) => validate_startup_reference(case, sp, i, ix)?,
            ReferenceCfg::DoublePoiseuilleProfile(dp) => {
                let reverse_x = driven_in_reverse_along_x(case);
                if !reverse_x || shear != 0.0 || !case.wants(Observable::VelocityProfile) {
                    return Err(ix.error(
                        &at("kind"),
                        "a double_poiseuille_profile reference needs a DPD fluid driven along x \
                         by fluid.body_force with fluid.body_force_profile = \"reverse\", no \
                         shear, and \"velocity_profile\" among diagnostics.observables"
                            .to_string(),
                    ));
                }
                let physical = match &case.fluid {
                    FluidCfg::Dpd(d) => d.physical.as_ref().map(|p| p.viscosity),
                    _ => None,
                };
                match dp.viscosity.or(physical) {
                    Some(eta) if eta.is_finite() && eta > 0.0 => {}
                    Some(eta) => {
                        return Err(ix.error(
                            &at("viscosity"),
                            format!("found {eta}; the viscosity must be > 0"),
                        ));
                    }
                    None => {
                        return Err(ix.error(
                            &at("kind"),
                            "a double_poiseuille_profile reference needs the viscosity of its \
                             solution: give `viscosity` or a [fluid.physical] table"
                                .to_string(),
                        ));
                    }
                }
                if !(dp.tolerance.is_finite() && dp.tolerance > 0.0) {
                    return Err(ix.error(
                        &at("tolerance"),
                        format!("found {}; must be > 0", dp.tolerance),
                    ));
                }
            }
            ReferenceCfg::DoublePoiseuilleStress(ds) => {
                let reverse_x = driven_in_reverse_along_x(case);
                if !reverse_x
                    || shear != 0.0
                    || !case.wants(Observable::ShearStressProfile)
                    || !case.wants(Observable::VelocityProfile)
                {
                    return Err(ix.error(
                        &at("kind"),
                        "a double_poiseuille_stress reference needs a DPD fluid driven along x \
                         by fluid.body_force with fluid.body_force_profile = \"reverse\", no \
                         shear, and \"shear_stress_profile\" and \"velocity_profile\" (the local \
                         mean velocity of the kinetic stress) among diagnostics.observables"
                            .to_string(),
                    ));
                }
                if !(ds.tolerance.is_finite() && ds.tolerance > 0.0) {
                    return Err(ix.error(
                        &at("tolerance"),
                        format!("found {}; must be > 0", ds.tolerance),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Whether the case is a DPD fluid driven along x by a reverse ("double Poiseuille") body force,
/// the flow both double-Poiseuille references need.
fn driven_in_reverse_along_x(case: &Case) -> bool {
    matches!(&case.fluid, FluidCfg::Dpd(d)
        if d.body_force_profile == crate::models::dpd::BodyForceProfile::Reverse
            && d.body_force.first().is_some_and(|&g| g != 0.0)
            && d.body_force[1..].iter().all(|&g| g == 0.0))
}

/// `[inclusions]`: each inside the box (none straddles a boundary, so a sheared image never
/// splits one), none overlapping another or a wall layer, each holding boundary particles.
fn validate_inclusions(case: &Case, ix: &SpanIndex) -> Result<(), CaseError> {
    let Some(inc) = &case.inclusions else {
        return Ok(());
    };
    let dim = case.dimension;
    let ik = |key: &str| vec![k("inclusions"), k(key)];
    let spacing = case.lattice_spacing();
    if !(inc.radius.is_finite() && inc.radius >= spacing) {
        return Err(ix.error(
            &ik("radius"),
            format!(
                "found {}; an inclusion needs a radius of at least the lattice spacing {spacing:.4e} \
                 (it is filled with lattice sites)",
                inc.radius
            ),
        ));
    }
    if !(inc.morris_cap.is_finite() && inc.morris_cap >= 1.0) {
        return Err(ix.error(
            &ik("morris_cap"),
            format!(
                "found {}; the extrapolation factor β = 1 + d_j/d_i is ≥ 1, so its cap must be \
                 ≥ 1 (1.5 is usual)",
                inc.morris_cap
            ),
        ));
    }
    if inc.centres.is_empty() {
        return Err(ix.error(
            &ik("centres"),
            "give at least one centre, e.g. centres = [[0.5, 0.5]]".to_string(),
        ));
    }
    let r = inc.radius;
    for (n, c) in inc.centres.iter().enumerate() {
        let at = vec![k("inclusions"), k("centres"), Segment::Index(n)];
        if c.len() != dim || c.iter().any(|x| !x.is_finite()) {
            return Err(ix.error(
                &at,
                format!(
                    "found {} components; give {dim} finite coordinates",
                    c.len()
                ),
            ));
        }
        for d in 0..dim {
            let l = case.domain.lengths[d];
            if c[d] - r < 0.0 || c[d] + r > l {
                return Err(ix.error(
                    &at,
                    format!(
                        "the inclusion reaches beyond the box along {} ({} ± {r} outside [0, {l}]); \
                         inclusions lie inside the box",
                        ["x", "y", "z"][d],
                        c[d]
                    ),
                ));
            }
        }
        for (m, e) in inc.centres.iter().enumerate().take(n) {
            let d2: f64 = c.iter().zip(e).map(|(a, b)| (a - b) * (a - b)).sum();
            if e.len() == dim && d2 < 4.0 * r * r {
                return Err(ix.error(
                    &at,
                    format!(
                        "overlaps inclusion {m} (centres {:.4} apart, 2R = {})",
                        d2.sqrt(),
                        2.0 * r
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// `[fluid] kind = "sph"` and `[walls]`.
fn validate_sph(
    case: &Case,
    s: &crate::models::sph::SphCfg,
    ix: &SpanIndex,
) -> Result<(), CaseError> {
    let fl = |key: &str| vec![k("fluid"), k(key)];
    let positive = |key: &str, v: f64, what: &str| -> Result<(), CaseError> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(ix.error(&fl(key), format!("found {v}; {what} must be > 0")))
        }
    };
    positive(
        "smoothing_length",
        s.smoothing_length,
        "the smoothing length",
    )?;
    positive("rest_density", s.rest_density, "the rest density ρ₀")?;
    positive("sound_speed", s.sound_speed, "the speed of sound c₀")?;
    if !(s.viscosity.is_finite() && s.viscosity >= 0.0) {
        return Err(ix.error(
            &fl("viscosity"),
            format!("found {}; the viscosity η must be ≥ 0", s.viscosity),
        ));
    }
    if !(s.morris_regularisation.is_finite() && s.morris_regularisation >= 0.0) {
        return Err(ix.error(
            &fl("morris_regularisation"),
            format!(
                "found {}; must be ≥ 0 (Morris et al. use 0.01)",
                s.morris_regularisation
            ),
        ));
    }
    if !(s.xsph.is_finite() && (0.0..=1.0).contains(&s.xsph)) {
        return Err(ix.error(
            &fl("xsph"),
            format!(
                "found {}; the XSPH factor ε must be in [0, 1] (0.5 is usual)",
                s.xsph
            ),
        ));
    }
    if s.xsph != 0.0 && !matches!(case.integrator, IntegratorCfg::KickDriftKick(_)) {
        return Err(ix.error(
            &[k("integrator"), k("kind")],
            format!(
                "XSPH (fluid.xsph = {}) moves the particles in the kick–drift–kick drift only; \
                 use kind = \"kick_drift_kick\" or set fluid.xsph = 0",
                s.xsph
            ),
        ));
    }
    if !(s.morris_share.is_finite() && (0.0..1.0).contains(&s.morris_share)) {
        return Err(ix.error(
            &fl("morris_share"),
            format!(
                "found {}; the share of η given to Morris's term must be in [0, 1) (0.1 damps \
                 MSPH's particle-scale modes)",
                s.morris_share
            ),
        ));
    }
    if s.morris_share != 0.0 && s.viscous_term != crate::models::sph::ViscousTerm::NestedSummation {
        return Err(ix.error(
            &fl("morris_share"),
            "morris_share splits the nested summation's viscosity; with viscous_term = \
             \"morris\" all of η is Morris's already (remove morris_share)"
                .to_string(),
        ));
    }
    if s.derivatives == crate::models::sph::Derivatives::Msph {
        if s.kernel != crate::models::sph::kernels::KernelKind::TruncatedGaussian {
            return Err(ix.error(
                &fl("kernel"),
                format!(
                    "found \"{}\"; MSPH derivatives use the paper's kernel: kernel = \
                     \"truncated_gaussian\" (h = 2Δ in the paper)",
                    s.kernel.name()
                ),
            ));
        }
        if s.density != crate::models::sph::DensityMethod::Summation {
            return Err(ix.error(
                &fl("density"),
                "MSPH derivatives use the summation density (spec msph-dumbbells.md §1.1); \
                 remove density or set it to \"summation\""
                    .to_string(),
            ));
        }
        if s.velocity_gradient != crate::models::sph::GradientEstimate::Sph {
            return Err(ix.error(
                &fl("velocity_gradient"),
                "velocity_gradient chooses among the pairwise SPH estimates; with derivatives \
                 = \"msph\" the MSPH gradient is used (remove velocity_gradient)"
                    .to_string(),
            ));
        }
        if case.inclusions.is_some() {
            return Err(ix.error(
                &fl("derivatives"),
                "MSPH derivatives do not support [inclusions] yet; use derivatives = \"sph\""
                    .to_string(),
            ));
        }
    }
    if !s.background_pressure.is_finite() {
        return Err(ix.error(
            &fl("background_pressure"),
            format!("found {}; must be finite", s.background_pressure),
        ));
    }
    if let Some(poly) = &s.polymer {
        let pl = |key: &str| vec![k("fluid"), k("polymer"), k(key)];
        if !(poly.viscosity.is_finite() && poly.viscosity > 0.0) {
            return Err(ix.error(
                &pl("viscosity"),
                format!(
                    "found {}; the polymer viscosity η_p must be > 0 (leave [fluid.polymer] out \
                     for a Newtonian fluid)",
                    poly.viscosity
                ),
            ));
        }
        if !(poly.relaxation_time.is_finite() && poly.relaxation_time > 0.0) {
            return Err(ix.error(
                &pl("relaxation_time"),
                format!(
                    "found {}; the relaxation time λ must be > 0",
                    poly.relaxation_time
                ),
            ));
        }
        if !poly.rotation
            && poly.model != crate::models::sph::maxwell::PolymerModel::CorotationalMaxwell
        {
            return Err(ix.error(
                &pl("rotation"),
                "switching the rotation terms off is the linear variant of the corotational \
                 model; use model = \"corotational_maxwell\" or leave rotation out"
                    .to_string(),
            ));
        }
        let ensemble_keys = [
            ("per_particle", poly.per_particle.is_some()),
            ("spring", poly.spring.is_some()),
            ("b", poly.b.is_some()),
            ("scheme", poly.scheme.is_some()),
            ("precision", poly.precision.is_some()),
        ];
        if poly.is_ensemble() {
            let Some(n_d) = poly.per_particle else {
                return Err(ix.error(
                    &pl("model"),
                    "model = \"dumbbells\" needs per_particle = N_d, the dumbbells each fluid \
                     particle carries (10²–10⁴ typical)"
                        .to_string(),
                ));
            };
            crate::config::flow::validate_ensemble(
                &[k("fluid"), k("polymer")],
                n_d,
                poly.spring
                    .unwrap_or(crate::config::flow::SpringKind::Hookean),
                poly.b,
                poly.scheme,
                ix,
            )?;
        } else if let Some((key, _)) = ensemble_keys.iter().find(|(_, given)| *given) {
            return Err(ix.error(
                &pl(key),
                format!(
                    "`{key}` describes dumbbell ensembles; it belongs to model = \"dumbbells\" \
                     (remove it for a constitutive model)"
                ),
            ));
        }
    }
    let dim = case.dimension;
    if !s.body_force.is_empty() && s.body_force.len() != dim {
        return Err(ix.error(
            &fl("body_force"),
            format!(
                "found {} components; give {dim} (or leave it out)",
                s.body_force.len()
            ),
        ));
    }
    if s.body_force.iter().any(|f| !f.is_finite()) {
        return Err(ix.error(&fl("body_force"), "components must be finite".to_string()));
    }
    // The mass must make the lattice density ρ₀ (m = ρ₀/n), within 5 %.
    let want = s.rest_density / case.particles.density;
    let m = case.particles.mass;
    if ((m - want) / want).abs() > 0.05 {
        return Err(ix.error(
            &[k("particles"), k("mass")],
            format!(
                "found {m}; an SPH particle carries m = fluid.rest_density / particles.density = \
                 {want:.6e} (within 5 %), so that the initial lattice has density ρ₀"
            ),
        ));
    }
    validate_inclusions(case, ix)?;
    let Some(w) = &case.walls else {
        return Ok(());
    };
    let wk = |key: &str| vec![k("walls"), k(key)];
    let axis = w.axis.index();
    if axis >= dim {
        return Err(ix.error(
            &wk("axis"),
            format!("a {dim}-dimensional case has no axis {axis}"),
        ));
    }
    if case.boundaries()[axis] != Boundary::Wall {
        return Err(ix.error(
            &wk("axis"),
            format!(
                "box.boundaries must be \"wall\" along the wall axis {}",
                ["x", "y", "z"][axis]
            ),
        ));
    }
    if case.particles.lattice != Lattice::Cubic {
        return Err(ix.error(
            &[k("particles"), k("lattice")],
            "walls continue a \"cubic\" lattice beyond the faces; use lattice = \"cubic\""
                .to_string(),
        ));
    }
    if case.domain.shear_rate != 0.0 {
        return Err(ix.error(
            &[k("box"), k("shear_rate")],
            "walls and Lees–Edwards shear do not mix; move the walls instead".to_string(),
        ));
    }
    for key in ["lower_velocity", "upper_velocity"] {
        let u = if key == "lower_velocity" {
            &w.lower_velocity
        } else {
            &w.upper_velocity
        };
        if !u.is_empty() && u.len() != dim {
            return Err(ix.error(
                &wk(key),
                format!(
                    "found {} components; give {dim} (or leave it out for a wall at rest)",
                    u.len()
                ),
            ));
        }
        if u.iter().any(|x| !x.is_finite()) || u.get(axis).is_some_and(|&x| x != 0.0) {
            return Err(ix.error(
                &wk(key),
                "a wall moves in its own plane: finite components, 0 along the wall axis"
                    .to_string(),
            ));
        }
    }
    // A fluid particle sits at least Δ/2 from the plane; the layer at depth (k + ½)Δ is in
    // reach of it only when (k + 1)Δ < support, and W = 0 at the support: one support less
    // one spacing of layers gives it a complete neighbourhood (3 layers of the paper's
    // h = 2Δ truncated Gaussian).
    let spacing = case.lattice_spacing();
    let needed = s.support() - spacing;
    if let Some(t) = w.thickness
        && !(t.is_finite() && t >= needed * (1.0 - 1e-9))
    {
        return Err(ix.error(
            &wk("thickness"),
            format!(
                "found {t}; a wall must be at least one kernel support less one lattice \
                 spacing ({} − {spacing} = {needed}) thick, so that a fluid particle next to \
                 it sees every layer within its support",
                s.support()
            ),
        ));
    }
    // A fluid particle sees one support deep: layers beyond the channel's own width (or two
    // supports, for a narrow channel) only cost memory; an absurd value would overflow the
    // layer count.
    let thickest = case.domain.lengths[w.axis.index()].max(2.0 * s.support());
    if let Some(t) = w.thickness
        && t > thickest
    {
        return Err(ix.error(
            &wk("thickness"),
            format!(
                "found {t}; a wall needs to be only one kernel support thick ({}); at most \
                 {thickest} (the channel width or two supports, whichever is larger) is accepted",
                s.support()
            ),
        ));
    }
    let msph = s.derivatives == crate::models::sph::Derivatives::Msph;
    match w.treatment {
        crate::models::sph::WallTreatment::Mirror if !msph => {
            return Err(ix.error(
                &wk("treatment"),
                "treatment = \"mirror\" is the MSPH wall (spec msph-dumbbells.md §5.1); it \
                 needs fluid.derivatives = \"msph\" (with SPH use \"layers\" or \"morris\")"
                    .to_string(),
            ));
        }
        crate::models::sph::WallTreatment::Morris if msph => {
            return Err(ix.error(
                &wk("treatment"),
                "with fluid.derivatives = \"msph\" use treatment = \"mirror\" (the working \
                 scheme of spec msph-dumbbells.md §5.1) or \"layers\" (the paper's literal \
                 walls, ill-posed); Morris's pairwise images give no single wall value"
                    .to_string(),
            ));
        }
        crate::models::sph::WallTreatment::Mirror if case.decomposition.axis == w.axis => {
            return Err(ix.error(
                &[k("decomposition"), k("axis")],
                "mirror walls fit the fluid beside each boundary particle, so the slabs must be \
                 cut across the channel: choose a decomposition axis other than the wall axis"
                    .to_string(),
            ));
        }
        _ => {}
    }
    if !(w.morris_cap.is_finite() && w.morris_cap >= 1.0) {
        return Err(ix.error(
            &wk("morris_cap"),
            format!("found {}; β_max must be ≥ 1 (1.5 is usual)", w.morris_cap),
        ));
    }
    for (key, v) in [
        ("repulsion_strength", w.repulsion_strength),
        ("repulsion_range", w.repulsion_range),
    ] {
        if let Some(v) = v
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(ix.error(&wk(key), format!("found {v}; must be ≥ 0")));
        }
    }
    Ok(())
}

/// `[[reference]] kind = "startup_profile"`.
fn validate_startup_reference(
    case: &Case,
    sp: &StartupProfileReference,
    i: usize,
    ix: &SpanIndex,
) -> Result<(), CaseError> {
    let at = |key: &str| vec![k("reference"), Segment::Index(i), k(key)];
    let fail = |key: &str, msg: String| Err(ix.error(&at(key), msg));
    let (FluidCfg::Sph(s), Some(w)) = (&case.fluid, &case.walls) else {
        return fail(
            "kind",
            "a startup_profile reference needs an SPH fluid with [walls]".into(),
        );
    };
    if w.axis != Axis::Y || !case.wants(Observable::VelocityProfile) {
        return fail(
            "kind",
            "a startup_profile reference needs walls.axis = \"y\" and \"velocity_profile\" \
             among diagnostics.observables"
                .into(),
        );
    }
    let x = |v: &[f64]| v.first().copied().unwrap_or(0.0);
    let flow_ok = match sp.solution {
        crate::analytic::StartupFlow::Couette => {
            x(&w.upper_velocity) != 0.0 && x(&w.lower_velocity) == 0.0 && x(&s.body_force) == 0.0
        }
        crate::analytic::StartupFlow::Poiseuille => {
            x(&s.body_force) != 0.0 && x(&w.upper_velocity) == 0.0 && x(&w.lower_velocity) == 0.0
        }
        crate::analytic::StartupFlow::ViscoelasticRelaxation => {
            case.particles.velocity_profile == crate::config::VelocityProfile::HalfSine
                && x(&s.body_force) == 0.0
                && x(&w.upper_velocity) == 0.0
                && x(&w.lower_velocity) == 0.0
        }
    };
    if !flow_ok {
        return fail(
            "solution",
            "\"couette\" needs walls.upper_velocity[0] ≠ 0, a lower wall at rest and no body \
             force; \"poiseuille\" needs fluid.body_force[0] ≠ 0 and both walls at rest; \
             \"viscoelastic_relaxation\" needs particles.velocity_profile = \"half_sine\", \
             both walls at rest and no body force"
                .into(),
        );
    }
    if sp.solution == crate::analytic::StartupFlow::Poiseuille
        && let Some(poly) = &s.polymer
    {
        use crate::models::sph::maxwell::PolymerModel;
        let oldroyd_b = match poly.model {
            PolymerModel::UpperConvectedMaxwell => true,
            PolymerModel::Dumbbells => {
                poly.spring
                    .unwrap_or(crate::config::flow::SpringKind::Hookean)
                    == crate::config::flow::SpringKind::Hookean
            }
            PolymerModel::CorotationalMaxwell => false,
        };
        if !oldroyd_b {
            return fail(
                "solution",
                "the start-up Poiseuille series of a polymer fluid is the Oldroyd-B one: it \
                 needs fluid.polymer.model = \"upper_convected_maxwell\" or Hookean \
                 \"dumbbells\""
                    .into(),
            );
        }
    }
    if s.viscosity <= 0.0
        && !(s.polymer.is_some() && sp.solution != crate::analytic::StartupFlow::Couette)
    {
        return fail(
            "solution",
            "the analytic start-up needs fluid.viscosity > 0".into(),
        );
    }
    if !(sp.tolerance.is_finite() && sp.tolerance > 0.0) {
        return fail("tolerance", format!("found {}; must be > 0", sp.tolerance));
    }
    if sp.times.is_empty() {
        return fail("times", "give at least one time".into());
    }
    let width = case.domain.lengths[w.axis.index()];
    if let Some(y) = sp
        .positions
        .iter()
        .find(|y| !(y.is_finite() && (0.0..=width).contains(*y)))
    {
        return fail(
            "positions",
            format!("found {y}; positions lie across the channel, in [0, {width}]"),
        );
    }
    let dt = case.integrator.dt();
    let every = case.run.sample_every;
    for &t in &sp.times {
        let step = (t / dt).round();
        let sampled = t.is_finite()
            && t > 0.0
            && (step * dt - t).abs() <= 1e-9 * t
            && (step as u64).is_multiple_of(every)
            && step as u64 > case.run.equilibration
            && step as u64 <= case.run.steps;
        if !sampled {
            return fail(
                "times",
                format!(
                    "t = {t} is not a sampled time: each must be a multiple of Δt · \
                     run.sample_every = {} after run.equilibration and within run.steps",
                    dt * every as f64
                ),
            );
        }
    }
    Ok(())
}

/// `[run]` and the block count of the error estimates (shared by every kind of scene).
pub(super) fn validate_run(r: &RunCfg, blocks: usize, ix: &SpanIndex) -> Result<(), CaseError> {
    let err = |keys: &[&str], msg: String| Err(ix.error(&path(keys), msg));
    if r.steps == 0 {
        return err(
            &["run", "steps"],
            "found 0; a run needs at least one step".into(),
        );
    }
    if r.sample_every == 0 {
        return err(&["run", "sample_every"], "found 0; must be ≥ 1".into());
    }
    if r.equilibration >= r.steps {
        return err(
            &["run", "equilibration"],
            format!(
                "found {}, which leaves no step to average over (steps = {}); use fewer",
                r.equilibration, r.steps
            ),
        );
    }
    if !(r.progress_seconds.is_finite() && r.progress_seconds >= 0.0) {
        return err(
            &["run", "progress_seconds"],
            format!(
                "found {}; must be ≥ 0 (0 turns progress lines off)",
                r.progress_seconds
            ),
        );
    }
    if blocks > MAX_BINS {
        return err(
            &["diagnostics", "blocks"],
            format!("found {}; must be between 2 and {MAX_BINS}", blocks),
        );
    }
    if blocks < 2 {
        return err(
            &["diagnostics", "blocks"],
            format!("found {}; block averaging needs at least 2 blocks", blocks),
        );
    }
    let samples = (r.steps - r.equilibration) / r.sample_every;
    if samples < blocks as u64 {
        return err(
            &["run", "sample_every"],
            format!(
                "only {samples} samples after equilibration, fewer than the {} blocks of the \
                 error estimate; sample more often or run longer",
                blocks
            ),
        );
    }
    Ok(())
}

/// Checks a `kind = "value"` reference (entry `i` of `[[reference]]`): its observable is one of
/// the `scalars` this `what` ("case", "scene") measures, its tolerance is > 0 and its value
/// finite (and ≠ 0 for a relative error).
pub(super) fn validate_value_reference(
    v: &ValueReference,
    i: usize,
    scalars: &[String],
    what: &str,
    ix: &SpanIndex,
) -> Result<(), CaseError> {
    let at = |key: &str| vec![k("reference"), Segment::Index(i), k(key)];
    if !scalars.iter().any(|s| s == &v.observable) {
        let valid = if scalars.is_empty() {
            "none — add the observable to diagnostics.observables".to_owned()
        } else {
            scalars.join(", ")
        };
        return Err(ix.error(
            &at("observable"),
            format!(
                "found \"{}\", which this {what} does not measure; measured here: {valid}",
                v.observable
            ),
        ));
    }
    if !(v.tolerance.is_finite() && v.tolerance > 0.0) {
        return Err(ix.error(
            &at("tolerance"),
            format!("found {}; must be > 0", v.tolerance),
        ));
    }
    if !v.value.is_finite() || (v.metric == Metric::RelativeError && v.value == 0.0) {
        return Err(ix.error(
            &at("value"),
            format!(
                "found {}; must be finite (and ≠ 0 for a relative error)",
                v.value
            ),
        ));
    }
    Ok(())
}
