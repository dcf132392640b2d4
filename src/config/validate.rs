//! Checks of values and of their combinations, after the structure has been parsed.

use super::spans::{Segment, SpanIndex};
use super::*;

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
    case.fluid.model().validate(case, ix)?;
    if !case.fluid.carries_boundary_particles() {
        let kind = case.fluid.model().kind();
        if case.inclusions.is_some() {
            return err(
                &["inclusions"],
                format!(
                    "inclusions of boundary particles need a fluid model that carries boundary \
                     particles, which kind = \"{kind}\" does not ({} does)",
                    super::registry::kinds_carrying_boundary_particles()
                ),
            );
        }
        if case.walls.is_some() {
            return err(
                &["walls"],
                format!(
                    "boundary-particle walls need a fluid model that carries boundary \
                     particles, which kind = \"{kind}\" does not ({} does); for reflecting \
                     walls set box.boundaries",
                    super::registry::kinds_carrying_boundary_particles()
                ),
            );
        }
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
        if case
            .fluid
            .model()
            .friction_rate(case.dimension, case.particles.density, case.particles.mass)
            .is_none()
        {
            return err(
                &["integrator", "thermostat"],
                "thermostat = \"exponential\" integrates a thermostat's friction; this fluid has none \
                 (use \"explicit\")"
                    .to_string(),
            );
        }
    }
    if let Err(message) = case.fluid.model().accepts_integrator(&case.integrator) {
        return err(&["integrator", "kind"], message);
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
    let cutoff_key = case.fluid.model().cutoff_key();
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
    if !case.run.beyond_stability_limits
        && let Some(message) = case.fluid.model().time_step_error(case, dt)
    {
        return err(&["integrator", "dt"], message);
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
        if let Err(message) = case.fluid.model().supports(case, *o) {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                message,
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
        if *o == Observable::WallShearStress && case.walls.is_none() {
            return Err(ix.error(
                &[k("diagnostics"), k("observables"), Segment::Index(i)],
                "\"wall_shear_stress\" needs [walls] (boundary-particle walls of an SPH fluid)"
                    .to_string(),
            ));
        }
        if *o == Observable::GreenKuboViscosity {
            let at = [k("diagnostics"), k("observables"), Segment::Index(i)];
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
            if shear != 0.0 || boundaries.contains(&Boundary::Wall) || case.body_forced() {
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
                match dp.viscosity.or(case.fluid.model().target_viscosity()) {
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
    let force = case.fluid.model().body_force();
    force.reverse && force.x() != 0.0 && force.acceleration[1..].iter().all(|&g| g == 0.0)
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
    let (Some(fluid), Some(w)) = (case.fluid.model().continuum(), &case.walls) else {
        return fail(
            "kind",
            "a startup_profile reference needs [walls] and a fluid with a continuum \
             constitutive law"
                .into(),
        );
    };
    let force = case.fluid.model().body_force();
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
            x(&w.upper_velocity) != 0.0 && x(&w.lower_velocity) == 0.0 && force.x() == 0.0
        }
        crate::analytic::StartupFlow::Poiseuille => {
            force.x() != 0.0 && x(&w.upper_velocity) == 0.0 && x(&w.lower_velocity) == 0.0
        }
        crate::analytic::StartupFlow::ViscoelasticRelaxation => {
            case.particles.velocity_profile == crate::config::VelocityProfile::HalfSine
                && force.x() == 0.0
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
        && let Some(poly) = &fluid.polymer
    {
        let oldroyd_b = poly.oldroyd_b;
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
    if fluid.solvent_viscosity <= 0.0
        && !(fluid.polymer.is_some() && sp.solution != crate::analytic::StartupFlow::Couette)
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
