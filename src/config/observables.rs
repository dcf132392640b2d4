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

/// Contributions of the stress tensor.
pub const STRESS_PARTS: [&str; 5] = ["total", "kinetic", "conservative", "dissipative", "random"];

/// Every scalar observable name the case produces (for references and the summary).
pub fn scalar_names(case: &Case) -> Vec<String> {
    let mut out = Vec::new();
    let dim = case.dimension;
    for o in &case.diagnostics.observables {
        match o {
            Observable::Stress => {
                for part in STRESS_PARTS {
                    for (_, _, c) in tensor_components(dim) {
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
            Observable::WallShearStress => {
                out.push("wall_shear_stress_lower".to_owned());
                out.push("wall_shear_stress_upper".to_owned());
            }
            Observable::CompositeViscosity => {
                out.push("composite_viscosity".to_owned());
                out.push("inclusion_torque".to_owned());
            }
            Observable::TransverseCurrentViscosity => {
                out.push(o.name().to_owned());
                for j in 1..=case.diagnostics.transverse_current_modes {
                    out.push(crate::transverse_current::mode_observable(j));
                }
            }
            other => out.push(other.name().to_owned()),
        }
    }
    out
}
