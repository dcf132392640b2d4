//! CONNFFESSIT: SPH particles carrying dumbbell ensembles (`[fluid.polymer] model =
//! "dumbbells"`), the ensembles stepping with each particle's own velocity gradient and their
//! Kramers stress driving the fluid.
//!
//! - The stock steady-shear scene meets its analytic references (Hookean dumbbells are the
//!   Oldroyd-B fluid: η = η_s + Gλ, N₁ = 2Gλ²γ̇²) within 2 %.
//! - The coupled run is the same bits on 1–4 ranks × 1–2 threads (ensembles migrate with their
//!   particles; the noise is keyed by particle id and step).
//! - Wall particles carry no dumbbells; fluid particles carry N_d each.

use crate::common;
use common::{
    assert_all_equal, assert_references_pass, case_from_str, digests_on_1_to_4_ranks, stock_text,
    stock_text_with, with_overrides,
};
use mesorheo::comm::SerialComm;
use mesorheo::models::dumbbell_ensemble::CONNECTORS;
use mesorheo::models::sph::FLUID;
use mesorheo::sim::Simulation;

#[test]
fn stock_shear_scene_meets_the_oldroyd_b_references() {
    let loaded = common::stock_case("connffessit_shear_2d.toml");
    assert_references_pass("connffessit_shear_2d.toml", &loaded);
}

/// The default scene of `./run` (the same fluid with 10× the dumbbells, ~30 s on 2 threads):
/// every stock case under a minute runs its references here.
#[test]
fn default_scene_meets_the_oldroyd_b_references() {
    assert_references_pass("default.toml", &common::stock_case("default.toml"));
}

#[test]
fn coupled_run_is_bitwise_on_1_to_4_ranks_and_1_2_threads() {
    let text = stock_text_with(
        "connffessit_shear_2d.toml",
        &[
            "run.steps=80",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
        ],
    )
    // Every part of the momentum flux too (the SPH pair virial, summed exactly).
    .replace(
        "\"constitutive_stress\",",
        "\"constitutive_stress\", \"stress\",",
    );
    assert!(text.contains("\"stress\""), "the observables line changed");
    let d = digests_on_1_to_4_ranks(&text, "connffessit shear", |s| {
        assert_eq!(s.steps, 80);
        assert!(s.observables.contains_key("stress_polymer_yx"));
    });
    assert_all_equal("connffessit shear", &d);
}

/// Ensembles and their stress migrate with their particle: the coupled run to step 1000, in
/// which particles cross the slab faces of 2 ranks (the first at step 896, where a particle
/// arrives on rank 0), is the same bits on 1 and 2 ranks. The polymer stress τ_p is formed from
/// the connectors before the step's migration; when it was a field that stayed behind, the
/// arriving particle came without it and the 2-rank run differed from step 896 on (the 80-step
/// test above has no migration).
#[test]
fn coupled_run_is_bitwise_on_1_and_2_ranks_across_migrations() {
    let text = stock_text_with(
        "connffessit_shear_2d.toml",
        &[
            "run.steps=1000",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
            "reference=[]",
        ],
    );
    let loaded = case_from_str(&text, "connffessit migrations");
    let digest = |ranks: usize| {
        mesorheo::driver::run_in_process(&loaded, ranks, 1, None)
            .unwrap_or_else(|e| panic!("{ranks} ranks: {e}"))
            .state_digest
    };
    assert_eq!(digest(2), digest(1));
}

#[test]
fn wall_particles_carry_no_dumbbells() {
    let text = stock_text("sph_couette_2d.toml")
        + "\n[fluid.polymer]\nmodel = \"dumbbells\"\nviscosity = 1.0\nrelaxation_time = 1.0\nper_particle = 7\n";
    // [fluid.polymer] appended after [[reference]] tables would belong to them: move it up.
    let (head, refs) = text.split_at(text.find("[[reference]]").expect("references"));
    let polymer = refs[refs.find("\n[fluid.polymer]").expect("appended")..].to_owned();
    let refs = &refs[..refs.find("\n[fluid.polymer]").expect("appended")];
    let text = format!("{head}{polymer}\n{refs}");
    let loaded = case_from_str(&text, "couette with dumbbells");
    let comm = SerialComm::new();
    let sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    let p = &sim.particles;
    let k = p
        .var
        .iter()
        .position(|f| f.name == CONNECTORS)
        .expect("connectors");
    let (mut fluid, mut walls) = (0, 0);
    for i in 0..p.n_owned {
        let len = p.var[k].data.row_len(i);
        if p.species_of(i) == FLUID {
            assert_eq!(len, 7 * 2, "fluid particle {}", p.gid[i]);
            fluid += 1;
        } else {
            assert_eq!(len, 0, "wall particle {}", p.gid[i]);
            walls += 1;
        }
    }
    assert!(
        fluid > 0 && walls > 0,
        "{fluid} fluid, {walls} wall particles"
    );
}

/// An SPH case that leaves out `[diagnostics] observables` gets ones SPH can record (not the
/// DPD default, whose pressure needs a pair virial): the viscometric functions when sheared.
#[test]
fn an_sph_case_without_observables_gets_the_viscometric_ones() {
    let text = stock_text("connffessit_shear_2d.toml");
    let text = &text[..text.find("[diagnostics]").expect("diagnostics")];
    let loaded = case_from_str(text, "no diagnostics");
    use mesorheo::config::Observable;
    assert_eq!(
        loaded.case.diagnostics.observables,
        vec![
            Observable::Momentum,
            Observable::Viscosity,
            Observable::FirstNormalStressDifference
        ]
    );
}

/// A support barely beyond the lattice spacing leaves every moment matrix nearly singular:
/// each estimate keeps the plain form and the summary counts them, summed over the ranks
/// (400 particles × 22 evaluations: the initial ones and one per step).
#[test]
fn uncorrected_gradient_estimates_are_counted_in_the_summary() {
    let text = stock_text_with(
        "connffessit_shear_2d.toml",
        &[
            "reference=[]",
            "fluid.smoothing_length=0.0505",
            "run.steps=20",
            "run.equilibration=0",
            "run.sample_every=2",
            "fluid.polymer.per_particle=4",
            "run.beyond_stability_limits=true",
        ],
    );
    let loaded = case_from_str(&text, "sparse");
    for ranks in [1, 2] {
        let s = mesorheo::driver::run_in_process(&loaded, ranks, 1, None).expect("run");
        assert!(
            s.warnings
                .iter()
                .any(|w| w.starts_with("8800 velocity-gradient estimates")),
            "{ranks} ranks: {:?}",
            s.warnings
        );
    }
}

/// Blow-up detection (issue #18) inside a particle scene: a connector of one particle's
/// ensemble made not finite (NaN for Hookean, ∞ for FENE; the semi-implicit FENE scheme, the
/// only one particle scenes allow, pulls a finite |Q|² ≥ b back inside, so only rounding to
/// single precision can leave a finite one outside) stops the next step with a diagnosis
/// naming the particle, the dumbbell and |Q|², "the run is unstable" (exit code 4 from
/// `mesorheo run`). Fails if the ensemble's update stops reporting (the step then succeeds) or
/// if the reduction drops the report.
#[test]
fn a_connector_outside_its_domain_stops_a_particle_scene() {
    let base = stock_text_with(
        "connffessit_shear_2d.toml",
        &["reference=[]", "fluid.polymer.per_particle=8"],
    );
    let fene: &[&str] = &["fluid.polymer.spring=\"fene\"", "fluid.polymer.b=10.0"];
    for (spring, poison, expect) in [
        (&[][..], f64::NAN, "(not finite)"),
        (fene, f64::INFINITY, "(not finite)"),
    ] {
        let text = with_overrides(&base, spring);
        let loaded = case_from_str(&text, "connffessit blow-up");
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
        sim.advance().expect("a good step");
        let p = &mut sim.particles;
        let k = p
            .var
            .iter()
            .position(|f| f.name == CONNECTORS)
            .expect("connectors");
        let i = (0..p.n_owned)
            .find(|&i| p.gid[i] == 40)
            .expect("particle 40");
        // Dumbbell 3: Q = (poison, poison).
        match &mut p.var[k].data {
            mesorheo::particles::VarData::Double(rows) => {
                rows[i][6] = poison;
                rows[i][7] = poison;
            }
            mesorheo::particles::VarData::Single(_) => panic!("double storage"),
        }
        let err = sim
            .advance()
            .expect_err(&format!("the blow-up is caught ({spring:?})"));
        assert!(
            err.to_string()
                .contains("dumbbell 3 of particle 40 has |Q|²")
                && err.to_string().contains(expect)
                && err.unstable().is_some(),
            "{err}"
        );
    }
}
