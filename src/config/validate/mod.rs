//! Checks of values and of their combinations, after the structure has been parsed.

use super::spans::{Segment, SpanIndex};
use super::*;

mod outputs;
mod references;
pub(crate) use outputs::validate_run;
pub(crate) use references::validate_value_reference;

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
    outputs::validate_outputs(case, ix)?;
    references::validate_references(case, ix)
}
