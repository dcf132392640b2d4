//! The scalar observables a case produces: their names follow from the case alone (what it
//! asks for, in how many dimensions), so validation can check the references against them.

use super::{Case, Observable};

/// Names of the D×D components in the upper triangle.
pub fn tensor_components(dimension: usize) -> Vec<(usize, usize, String)> {
    let names = ["x", "y", "z"];
    let mut out = Vec::new();
    for a in 0..dimension {
        for b in a..dimension {
            out.push((a, b, format!("{}{}", names[a], names[b])));
        }
    }
    out
}

/// The components of the `stress` observable: the upper triangle for a symmetric momentum
/// flux (central pair forces), every component otherwise (SPH, whose Morris viscous force lies
/// along v_ij and whose inclusions take couples: `stress_*_xy` is the x-momentum crossing
/// planes y = const, `stress_*_yx` the y-momentum crossing planes x = const).
pub fn stress_components(case: &Case) -> Vec<(usize, usize, String)> {
    if case.fluid.model().symmetric_stress() {
        return tensor_components(case.dimension);
    }
    let names = ["x", "y", "z"];
    let d = case.dimension;
    (0..d)
        .flat_map(|a| (0..d).map(move |b| (a, b, format!("{}{}", names[a], names[b]))))
        .collect()
}

pub use crate::models::fluid_model::CENTRAL_STRESS_PARTS as STRESS_PARTS;

/// The contributions the `stress` observable of this case reports (the fluid model's).
pub fn stress_parts(case: &Case) -> Vec<&'static str> {
    case.fluid.model().stress_parts()
}

/// The names of the constitutive viscometric functions ([`Observable::ConstitutiveStress`]) in
/// `dimension` dimensions.
pub use crate::observable::constitutive_names;

/// Every scalar observable name the case produces (for references and the summary).
pub fn scalar_names(case: &Case) -> Vec<String> {
    let mut out = Vec::new();
    let dim = case.dimension;
    for o in &case.diagnostics.observables {
        match o {
            Observable::Stress => {
                for part in stress_parts(case) {
                    for (_, _, c) in stress_components(case) {
                        out.push(format!("stress_{part}_{c}"));
                    }
                }
            }
            Observable::Momentum => {
                for c in ["x", "y", "z"].iter().take(dim) {
                    out.push(format!("momentum_{c}"));
                }
            }
            Observable::VelocityProfile => {}
            Observable::ConstitutiveStress => {
                out.extend(constitutive_names(dim).iter().map(|s| s.to_string()));
            }
            Observable::Conformation => {
                out.extend(
                    crate::observable::conformation_names(dim)
                        .iter()
                        .map(|s| s.to_string()),
                );
            }
            Observable::WallShearStress => {
                out.push("wall_shear_stress_lower".to_owned());
                out.push("wall_shear_stress_upper".to_owned());
            }
            Observable::ColloidVelocityVariance => {
                out.extend(
                    crate::observable::COLLOID_VELOCITY_VARIANCE_NAMES
                        .iter()
                        .map(|s| s.to_string()),
                );
            }
            Observable::ColloidSolventRdf => {
                out.push(crate::observable::COLLOID_EXCLUSION_RADIUS.to_owned());
            }
            Observable::CompositeViscosity => {
                out.push("composite_viscosity".to_owned());
                out.push("inclusion_torque".to_owned());
            }
            Observable::TransverseCurrentViscosity => {
                out.push(o.name().to_owned());
                for j in 1..=case.diagnostics.transverse_current_modes {
                    out.push(transverse_current_mode(j));
                }
            }
            other => out.push(other.name().to_owned()),
        }
    }
    out
}

/// The summary name of the transverse-current viscosity η_k of mode j (1-based).
pub fn transverse_current_mode(j: usize) -> String {
    format!("transverse_current_viscosity_k{j}")
}
