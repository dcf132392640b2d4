//! `[fluid.physical]` of a DPD fluid: the fluid given by its physical properties (viscosity,
//! compressibility, time-scale ratio, optionally a Schmidt number or a particle diffusion
//! time) instead of raw force parameters. Before the case is deserialised, the table is mapped
//! by [`crate::dpd_parameters::map`] (Nguyen 2021, docs/theory/dpd_physical_parameters.md §2.7) and
//! the resulting `a`, `gamma`, `weight_exponent` (s) and `conservative_exponent` (s̄) are written
//! into `[fluid]`; a raw parameter given beside the table must equal the mapped value (so the
//! case echo of a checkpoint, which holds both, parses again), any other value is refused.
//! The particle density and mass come from `[particles]`, k_BT and r_c from `[fluid]`.

use super::PhysicalDpdCfg;
use crate::dpd_parameters::{
    self, DissipationConstraint, DpdFluid, DpdParameters, PhysicalInputs, RepulsionRule,
};
use crate::spans::{CaseError, Segment, SpanIndex};

/// The raw DPD keys the mapping fills, with the mapped value of each.
fn mapped_keys(p: &DpdParameters) -> [(&'static str, f64); 4] {
    [
        ("a", p.a),
        ("gamma", p.gamma),
        ("weight_exponent", p.dissipative_exponent),
        ("conservative_exponent", p.conservative_exponent),
    ]
}

/// The mapping's inputs for a case table with `[fluid.physical]`: the table, the case's
/// dimension, k_BT, r_c, density and mass (defaults as the case keys have them).
pub fn inputs_of(
    physical: &PhysicalDpdCfg,
    dimension: usize,
    kt: f64,
    cutoff: f64,
    density: f64,
    mass: f64,
) -> Result<PhysicalInputs, String> {
    let dimension = dpd_parameters::Dimension::try_from(dimension)?;
    let repulsion = match physical.time_scale_ratio {
        Some(alpha) => RepulsionRule::TimeScaleRatio(alpha),
        None => RepulsionRule::ClassicalWater,
    };
    let constraint = match (physical.schmidt_number, physical.particle_diffusion_time) {
        (Some(_), Some(_)) => {
            return Err(
                "give schmidt_number or particle_diffusion_time, not both: each fixes \
                        the dissipative exponent s"
                    .into(),
            );
        }
        (Some(sc), None) => DissipationConstraint::SchmidtNumber(sc),
        (None, Some(tau)) => DissipationConstraint::ParticleDiffusionTime(tau),
        (None, None) => DissipationConstraint::ViscosityOnly,
    };
    Ok(PhysicalInputs::new(
        dimension,
        density,
        mass,
        cutoff,
        physical.viscosity,
        repulsion,
    )
    .with_kt(kt)
    .with_inverse_compressibility(physical.inverse_compressibility)
    .with_constraint(constraint))
}

/// What `check` prints for a mapped fluid: the inputs, the DPD parameters and the
/// kinetic-theory predictions of the result.
pub fn report(inputs: &PhysicalInputs, p: &DpdParameters) -> Vec<String> {
    let mut out = vec![format!(
        "physical input ([fluid.physical]): η = {}, κ⁻¹ = {}, {}, {}; n = {}, m = {}, k_BT = {}, \
         r_c = {}",
        inputs.viscosity,
        inputs.inverse_compressibility,
        match inputs.repulsion {
            RepulsionRule::TimeScaleRatio(a) => format!("α = {a}"),
            RepulsionRule::ClassicalWater => "classical-water repulsion (s̄ = 1)".into(),
        },
        match inputs.constraint {
            DissipationConstraint::ViscosityOnly => "s = 1/2".into(),
            DissipationConstraint::SchmidtNumber(sc) => format!("Sc = {sc}"),
            DissipationConstraint::ParticleDiffusionTime(t) => format!("τ_P = {t}"),
        },
        inputs.number_density,
        inputs.mass,
        inputs.kt,
        inputs.cutoff
    )];
    out.push(format!(
        "mapped DPD parameters (Nguyen 2021 §2.7): a = {:.6}, s̄ = {:.6}, γ = {:.6}, s = {:.6}, \
         σ = {:.6}",
        p.a, p.conservative_exponent, p.gamma, p.dissipative_exponent, p.sigma
    ));
    match DpdFluid::from_mapping(inputs, p).predict() {
        Ok(k) => out.push(format!(
            "kinetic theory of the result: η̄_D = {:.4}, η̄_K = {:.4}, η = {:.4}, Sc = {:.2} \
             (η̄_D/ρD), α = {:.4}, κ⁻¹ = {:.4}, c_s = {:.4}{} (the measured η of a dense DPD \
             fluid differs from this estimate: measure it)",
            k.dissipative_viscosity,
            k.kinetic_viscosity,
            k.total_viscosity,
            k.schmidt_number_dissipative,
            k.time_scale_ratio,
            k.inverse_compressibility,
            k.speed_of_sound,
            k.particle_diffusion_time
                .map_or(String::new(), |t| format!(", τ_P = {t:.4}"))
        )),
        Err(e) => out.push(format!("kinetic theory of the result: {e}")),
    }
    out
}

/// Maps `[fluid.physical]` (when the case has one) and writes the raw parameters into
/// `[fluid]` of `table`. Errors are located at the physical table or at the conflicting key.
pub fn resolve(table: &mut toml::Table, index: &SpanIndex) -> Result<(), CaseError> {
    let k = |s: &str| Segment::Key(s.to_owned());
    let Some(fluid) = table.get("fluid").and_then(toml::Value::as_table) else {
        return Ok(());
    };
    let Some(physical_value) = fluid.get("physical") else {
        return Ok(());
    };
    if fluid.get("kind").and_then(toml::Value::as_str) != Some("dpd") {
        // Left to the deserialiser: `physical` is then an unknown key of that fluid.
        return Ok(());
    }
    let physical: PhysicalDpdCfg = serde_path_to_error::deserialize(physical_value.clone())
        .map_err(|e| {
            let mut path = vec![k("fluid"), k("physical")];
            path.extend(crate::spans::segments(e.path()));
            index.structural_error(&path, e.inner().message(), None)
        })?;
    let number = |t: Option<&toml::Value>, default: f64| -> Option<f64> {
        match t {
            None => Some(default),
            Some(v) => v.as_float().or_else(|| v.as_integer().map(|i| i as f64)),
        }
    };
    let particles = table.get("particles").and_then(toml::Value::as_table);
    let inputs = (|| {
        let dimension = table.get("dimension")?.as_integer()?;
        let kt = number(Some(fluid.get("kt")?), 0.0)?;
        let cutoff = number(fluid.get("cutoff"), 1.0)?;
        let density = number(Some(particles?.get("density")?), 0.0)?;
        let mass = number(particles?.get("mass"), 1.0)?;
        Some((dimension as usize, kt, cutoff, density, mass))
    })();
    // Missing or mistyped inputs are reported by the deserialiser, with its usual messages.
    let Some((dimension, kt, cutoff, density, mass)) = inputs else {
        return Ok(());
    };
    let at_physical = [k("fluid"), k("physical")];
    let mapped = inputs_of(&physical, dimension, kt, cutoff, density, mass)
        .and_then(|i| dpd_parameters::map(&i))
        .map_err(|e| {
            index.error(
                &at_physical,
                format!("these physical properties have no DPD fluid: {e}"),
            )
        })?;
    let fluid = table
        .get_mut("fluid")
        .and_then(toml::Value::as_table_mut)
        .expect("checked above");
    for (key, value) in mapped_keys(&mapped) {
        match fluid.get(key) {
            None => {
                fluid.insert(key.to_owned(), toml::Value::Float(value));
            }
            Some(given) => {
                let g = given
                    .as_float()
                    .or_else(|| given.as_integer().map(|i| i as f64));
                let same = g.is_some_and(|g| (g - value).abs() <= 1e-12 * value.abs());
                if !same {
                    return Err(index.error(
                        &[k("fluid"), k(key)],
                        format!(
                            "found {given}, but [fluid.physical] maps to {key} = {value}: give \
                             either the raw DPD parameters or [fluid.physical] (then leave \
                             a, gamma, weight_exponent and conservative_exponent out)"
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}
