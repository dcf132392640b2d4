//! The `[[reference]]` entries of a particle case: each checked against the scene it needs.

#[allow(unused_imports)]
use super::*;

/// Every `[[reference]]` of the case.
pub(super) fn validate_references(case: &Case, ix: &SpanIndex) -> Result<(), CaseError> {
    let shear = case.domain.shear_rate;
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

/// Checks a `kind = "value"` reference (entry `i` of `[[reference]]`): its observable is one of
/// the `scalars` this `what` ("case", "scene") measures, its tolerance is > 0 and its value
/// finite (and ≠ 0 for a relative error).
pub(crate) fn validate_value_reference(
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
