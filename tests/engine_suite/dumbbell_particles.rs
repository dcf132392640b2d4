//! Dumbbell ensembles carried by moving, migrating particles (the micro half of CONNFFESSIT, a
//! model of the model layer) reproduce the homogeneous-flow ensembles — an independent path
//! through the code, verified against the analytic rheology in `tests/engine_suite/dumbbells.rs` — bit for
//! bit, in double and single storage, on 1–3 ranks, whether κ is imposed or read from each
//! particle's own velocity-gradient field.

use crate::common;
use common::{case_from_str, small_dpd};
use mesorheo::comm::{Comm, SerialComm, U64Op};
use mesorheo::driver::in_process;
use mesorheo::facade::Engine;
use mesorheo::facade::Ensembles;
use mesorheo::models::dumbbell_ensemble::{CONNECTORS, DumbbellEnsemble, VelocityGradient};
use mesorheo::models::dumbbells::{DumbbellParams, Scheme, Spring};
use mesorheo::models::homogeneous_flow::{EnsembleSpec, Flow, HomogeneousEnsembles};
use mesorheo::models::{FieldKind, FieldSpec, ParticleModel};
use mesorheo::particles::{FieldFlags, Particles, Precision, Tensor};
use mesorheo::sim::Simulation;
use std::sync::Arc;

const STEPS: u64 = 40;
const N_D: usize = 20;
const SEED: u64 = 11;
const FLOW: Flow = Flow::SimpleShear { rate: 1.5 };

/// FENE (b = 20) with the semi-implicit scheme, Hookean with the others.
fn params(scheme: Scheme) -> DumbbellParams {
    DumbbellParams {
        spring: if scheme == Scheme::SemiImplicit {
            Spring::Fene { b: 20.0 }
        } else {
            Spring::Hookean
        },
        scheme,
        lambda: 1.0,
        dt: 0.04,
    }
}

/// Every particle's connectors after `STEPS` steps of the homogeneous-flow ensembles, by id.
fn reference(total: u64, scheme: Scheme, precision: Precision) -> Vec<Vec<f64>> {
    let comm = SerialComm::new();
    let mut e = HomogeneousEnsembles::<3>::new(
        &comm,
        EnsembleSpec {
            threads: 1,
            total,
            n_d: N_D,
            params: params(scheme),
            flow: FLOW,
            seed: SEED,
        },
    )
    .expect("ensembles");
    if precision == Precision::Single {
        e = e.with_single_precision();
    }
    for _ in 0..STEPS {
        e.advance().expect("a stable step");
    }
    (0..total as usize)
        .map(|i| e.ensemble(i).to_vec())
        .collect()
}

/// Writes a constant κ (that of `FLOW`) into every owned particle's velocity-gradient field
/// before the ensembles are advanced: what an SPH estimate of ∇v will do.
struct ConstantGradient;

impl ParticleModel<3> for ConstantGradient {
    fn name(&self) -> &'static str {
        "constant velocity gradient"
    }
    fn fields(&self) -> Vec<FieldSpec> {
        vec![FieldSpec {
            name: "velocity_gradient",
            kind: FieldKind::Tensor,
            flags: FieldFlags::DERIVED,
        }]
    }
    fn update_state(
        &self,
        p: &mut Particles<3>,
        step: u64,
    ) -> Option<mesorheo::models::StateBlowUp> {
        let k = p.extra_index("velocity_gradient").expect("registered");
        let kappa: Tensor<3> = FLOW.kappa::<3>((step - 1) as f64 * 0.04);
        for i in 0..p.n_owned {
            p.set_tensor(k, i, &kappa);
        }
        None
    }
}

/// Runs the DPD case with ensembles on `ranks` ranks; returns the number of particles whose
/// connectors differ from `want` (over all ranks) and the number compared.
fn mismatches(
    ranks: usize,
    scheme: Scheme,
    precision: Precision,
    source: VelocityGradient,
    want: Arc<Vec<Vec<f64>>>,
) -> (u64, u64) {
    let loaded = case_from_str(&small_dpd(3, 6.0, 0.3, STEPS, ""), "carriers");
    in_process(ranks, move |comm: &dyn Comm| {
        let mut sim = Simulation::<3>::new(&loaded.case, comm, 2).map_err(|e| e.to_string())?;
        if matches!(source, VelocityGradient::Field(_)) {
            sim.attach(Box::new(ConstantGradient))
                .map_err(|e| e.to_string())?;
        }
        let model =
            DumbbellEnsemble::<3>::new(params(scheme), N_D, 1.0, SEED, precision, source.clone())?;
        sim.attach(Box::new(model)).map_err(|e| e.to_string())?;
        sim.run_steps(STEPS).map_err(|e| e.to_string())?;
        let p = &sim.particles;
        let k = (p.var.iter().position(|f| f.name == CONNECTORS)).ok_or("no connectors")?;
        let mut counts = [0u64, p.n_owned as u64];
        let mut row = Vec::new();
        for i in 0..p.n_owned {
            row.clear();
            p.var[k].data.extend_f64(i, &mut row);
            let same = row.len() == want[p.gid[i] as usize].len()
                && row
                    .iter()
                    .zip(&want[p.gid[i] as usize])
                    .all(|(a, b)| a.to_bits() == b.to_bits());
            counts[0] += u64::from(!same);
        }
        comm.allreduce_u64(&mut counts, U64Op::Sum);
        Ok::<_, String>((counts[0], counts[1]))
    })
    .expect("run")
}

#[test]
fn particle_ensembles_under_an_imposed_flow_equal_the_homogeneous_flow_ones_bit_for_bit() {
    let total = 648; // small_dpd: ρ = 3 in a 6³ box
    for (scheme, precision) in [
        (Scheme::SemiImplicit, Precision::Double),
        (Scheme::Heun, Precision::Single),
    ] {
        let want = Arc::new(reference(total, scheme, precision));
        for ranks in [1, 3] {
            let source = VelocityGradient::Imposed(FLOW);
            let (bad, n) = mismatches(ranks, scheme, precision, source, want.clone());
            assert_eq!(n, total, "particles compared");
            assert_eq!(bad, 0, "{scheme:?} {precision:?} on {ranks} ranks");
        }
    }
}

#[test]
fn each_particle_can_take_its_velocity_gradient_from_a_field() {
    let want = Arc::new(reference(648, Scheme::SemiImplicit, Precision::Double));
    let source = VelocityGradient::Field("velocity_gradient");
    let (bad, n) = mismatches(2, Scheme::SemiImplicit, Precision::Double, source, want);
    assert_eq!((bad, n), (0, 648));
}
