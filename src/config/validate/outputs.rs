//! `[run]`, `[output]` and `[diagnostics]` of a particle case.

#[allow(unused_imports)]
use super::*;

/// `[run]`, `[output]` and `[diagnostics]`, after the tables that set the scene.
pub(super) fn validate_outputs(case: &Case, ix: &SpanIndex) -> Result<(), CaseError> {
    let dim = case.dimension;
    let err = |keys: &[&str], msg: String| Err(ix.error(&path(keys), msg));
    let shear = case.domain.shear_rate;
    let boundaries = case.boundaries();
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
    // The engine's fields, then those the fluid model offers in this case.
    let offered = case.fluid.model().snapshot_quantities(case);
    let available: Vec<&str> = crate::config::SnapshotField::ALL
        .iter()
        .filter(|f| f.is_engine_field())
        .map(|f| f.name())
        .chain(offered.iter().map(|q| q.name))
        .collect();
    let listed = || {
        available
            .iter()
            .map(|n| format!("\"{n}\""))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if o.snapshot_every > 0 && o.snapshot_fields.is_empty() {
        return err(
            &["output", "snapshot_fields"],
            format!(
                "found an empty list with snapshot_every > 0; name at least \"position\" \
                 (this case offers {})",
                listed()
            ),
        );
    }
    for (i, f) in o.snapshot_fields.iter().enumerate() {
        if !available.contains(&f.name()) {
            return Err(ix.error(
                &[k("output"), k("snapshot_fields"), Segment::Index(i)],
                format!(
                    "\"{}\" is not provided by fluid.kind = \"{}\" in this case; this case \
                     offers {}",
                    f.name(),
                    case.fluid.model().kind(),
                    listed()
                ),
            ));
        }
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
    if !(d.rdf_bin_width.is_finite() && d.rdf_bin_width > 0.0) {
        return err(
            &["diagnostics", "rdf_bin_width"],
            format!("found {}; the RDF's bin width must be > 0", d.rdf_bin_width),
        );
    }
    let lengths = &case.domain.lengths[..dim.min(case.domain.lengths.len())];
    let half = 0.5 * lengths.iter().copied().fold(f64::INFINITY, f64::min);
    let range = d.rdf_range(lengths);
    if let Some(r) = d.rdf_range
        && !(r.is_finite() && r > 0.0 && r <= half)
    {
        return err(
            &["diagnostics", "rdf_range"],
            format!(
                "found {r}; the RDF's range must be > 0 and at most half the smallest box edge \
                 ({half}), where the minimum image of a distance is still unique"
            ),
        );
    }
    let rdf_bins = crate::rigid_bodies::rdf::bin_count(range, d.rdf_bin_width);
    if d.observables.contains(&Observable::ColloidSolventRdf) && !(2..=MAX_BINS).contains(&rdf_bins)
    {
        return err(
            &["diagnostics", "rdf_bin_width"],
            format!(
                "found {} with the range {range}: {rdf_bins} bins; the RDF needs 2 to {MAX_BINS} \
                 bins of this width within its range",
                d.rdf_bin_width
            ),
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
    Ok(())
}

/// `[run]` and the block count of the error estimates (shared by every kind of scene).
pub(crate) fn validate_run(r: &RunCfg, blocks: usize, ix: &SpanIndex) -> Result<(), CaseError> {
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
