//! The models and the integrator a case names ([`crate::config::registry`]).

#[allow(unused_imports)]
use super::*;

/// The fluid model the case names ([`crate::config::registry`]).
pub fn build_fluid<const D: usize>(case: &Case) -> Box<dyn ParticleModel<D>> {
    case.fluid.builder::<D>().build_fluid(case)
}

/// The models a case needs beside its fluid (the dumbbell ensembles of a CONNFFESSIT fluid),
/// attached after the species are known.
pub fn build_companions<const D: usize>(
    case: &Case,
) -> Result<Vec<Box<dyn ParticleModel<D>>>, String> {
    case.fluid.builder::<D>().build_companions(case)
}

/// The integrator the case names, for the species `species` (a one-species scene: `&[]`).
pub fn build_integrator<const D: usize>(
    case: &Case,
    species: &[Species],
) -> Box<dyn Integrator<D>> {
    match &case.integrator {
        IntegratorCfg::GrootWarren(gw) => {
            let integrator = GrootWarren::new(gw, case.particles.mass);
            if species.is_empty() {
                Box::new(integrator)
            } else {
                Box::new(integrator.with_species(species))
            }
        }
        IntegratorCfg::KickDriftKick(k) => {
            Box::new(KickDriftKick::new(k, case.particles.mass, species))
        }
        IntegratorCfg::Heun(t) => Box::new(TwoStage::new(
            t,
            TwoStageVariant::Heun,
            case.particles.mass,
            species,
        )),
        IntegratorCfg::Midpoint(t) => Box::new(TwoStage::new(
            t,
            TwoStageVariant::Midpoint,
            case.particles.mass,
            species,
        )),
        IntegratorCfg::ThesisPredictorCorrector(t) => Box::new(TwoStage::new(
            t,
            TwoStageVariant::ThesisPrinted,
            case.particles.mass,
            species,
        )),
    }
}
