//! Validation of `[fluid] kind = "sph"` and of the tables only SPH reads, `[walls]` and
//! `[inclusions]`: what [`crate::models::FluidModel::validate`] runs for an SPH case.

use crate::geometry::{Boundary, Lattice};
use crate::integrators::IntegratorCfg;
use crate::models::fluid_model::CaseView;
use crate::spans::{CaseError, Segment, SpanIndex};

fn k(s: &str) -> Segment {
    Segment::Key(s.to_owned())
}

/// `[inclusions]`: each inside the box (none straddles a boundary, so a sheared image never
/// splits one), none overlapping another or a wall layer, each holding boundary particles.
fn validate_inclusions(case: &dyn CaseView, ix: &SpanIndex) -> Result<(), CaseError> {
    let Some(inc) = case.inclusions() else {
        return Ok(());
    };
    let dim = case.dimension();
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
            let l = case.lengths()[d];
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
pub(super) fn validate_sph(
    case: &dyn CaseView,
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
    if s.xsph != 0.0 && !matches!(case.integrator(), IntegratorCfg::KickDriftKick(_)) {
        return Err(ix.error(
            &[k("integrator"), k("kind")],
            format!(
                "XSPH (fluid.xsph = {}) moves the particles in the kick–drift–kick drift only; \
                 use kind = \"kick_drift_kick\" or set fluid.xsph = 0",
                s.xsph
            ),
        ));
    }
    if !(s.transport_pressure.is_finite() && s.transport_pressure >= 0.0) {
        return Err(ix.error(
            &fl("transport_pressure"),
            format!(
                "found {}; the transport-velocity background pressure must be ≥ 0 (0: off; \
                 a few times the largest polymer tension, like background_pressure)",
                s.transport_pressure
            ),
        ));
    }
    if s.transport_pressure != 0.0 {
        if !matches!(case.integrator(), IntegratorCfg::KickDriftKick(_)) {
            return Err(ix.error(
                &[k("integrator"), k("kind")],
                format!(
                    "the transport velocity (fluid.transport_pressure = {}) moves the particles \
                     in the kick–drift–kick drift only; use kind = \"kick_drift_kick\" or set \
                     fluid.transport_pressure = 0",
                    s.transport_pressure
                ),
            ));
        }
        if s.density != crate::models::sph::DensityMethod::Summation {
            return Err(ix.error(
                &fl("density"),
                "the transport velocity moves the particles with v̂ ≠ v, which a continuity \
                 density (dρ/dt from v) does not follow; use density = \"summation\" or set \
                 fluid.transport_pressure = 0"
                    .to_string(),
            ));
        }
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
                "MSPH derivatives use the summation density (docs/theory/msph_dumbbells.md §1.1); \
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
        if case.inclusions().is_some() {
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
        // The optional keys, each read by some laws only.
        let optional = [
            ("rotation", !poly.rotation),
            ("per_particle", poly.per_particle.is_some()),
            ("spring", poly.spring.is_some()),
            ("b", poly.b.is_some()),
            ("scheme", poly.scheme.is_some()),
            ("precision", poly.precision.is_some()),
            ("noise", poly.noise.is_some()),
            ("cells", poly.cells.is_some()),
            ("q_max", poly.q_max.is_some()),
        ];
        if let Some((key, _)) = optional
            .iter()
            .find(|(key, given)| *given && !poly.model.reads(key))
        {
            let owners: Vec<String> = super::polymer::PolymerModel::ALL
                .iter()
                .filter(|(m, _)| m.reads(key))
                .map(|(_, name)| format!("\"{name}\""))
                .collect();
            let what = match *key {
                "rotation" => "switching the rotation terms off is the linear variant of the \
                               corotational model"
                    .to_string(),
                _ if owners == ["\"bddfs\""] => {
                    format!("`{key}` describes a BDDFS histogram grid")
                }
                _ if owners.contains(&"\"dumbbells\"".to_string())
                    && owners
                        .iter()
                        .all(|o| o == "\"dumbbells\"" || o == "\"bddfs\"") =>
                {
                    format!("`{key}` describes dumbbell ensembles")
                }
                _ => format!("`{key}` is not a key of model = \"{}\"", poly.model.name()),
            };
            return Err(ix.error(
                &pl(key),
                format!(
                    "{what}; only model = {} reads it (remove it for model = \"{}\")",
                    owners.join(" | "),
                    poly.model.name()
                ),
            ));
        }
        if let Err((key, message)) = poly.model.validate(poly) {
            return Err(ix.error(&pl(key), message));
        }
        if let (true, Some(n_d)) = (poly.is_ensemble(), poly.per_particle) {
            crate::models::dumbbell_settings::validate_ensemble(
                &[k("fluid"), k("polymer")],
                n_d,
                poly.spring
                    .unwrap_or(crate::models::dumbbell_settings::SpringKind::Hookean),
                poly.b,
                poly.scheme,
                ix,
            )?;
        }
        if let Some(grid) = poly.histogram_grid() {
            crate::models::dumbbell_settings::validate_histogram_grid(
                &[k("fluid"), k("polymer")],
                &grid,
                (poly.cells.is_some(), poly.q_max.is_some()),
                poly.spring
                    .unwrap_or(crate::models::dumbbell_settings::SpringKind::Hookean),
                poly.spring_law(),
                case.dimension(),
                ix,
            )?;
        }
    }
    let dim = case.dimension();
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
    let want = s.rest_density / case.number_density();
    let m = case.mass();
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
    let Some(w) = case.walls() else {
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
    if case.lattice() != Lattice::Cubic {
        return Err(ix.error(
            &[k("particles"), k("lattice")],
            "walls continue a \"cubic\" lattice beyond the faces; use lattice = \"cubic\""
                .to_string(),
        ));
    }
    if case.shear_rate() != 0.0 {
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
    let thickest = case.lengths()[w.axis.index()].max(2.0 * s.support());
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
                "treatment = \"mirror\" is the MSPH wall (docs/theory/msph_dumbbells.md §5.1); it \
                 needs fluid.derivatives = \"msph\" (with SPH use \"layers\" or \"morris\")"
                    .to_string(),
            ));
        }
        crate::models::sph::WallTreatment::Morris if msph => {
            return Err(ix.error(
                &wk("treatment"),
                "with fluid.derivatives = \"msph\" use treatment = \"mirror\" (the working \
                 scheme of docs/theory/msph_dumbbells.md §5.1) or \"layers\" (the paper's literal \
                 walls, ill-posed); Morris's pairwise images give no single wall value"
                    .to_string(),
            ));
        }
        crate::models::sph::WallTreatment::Mirror if case.decomposition_axis() == w.axis => {
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
