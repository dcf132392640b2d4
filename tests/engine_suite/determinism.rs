//! Determinism across decompositions: the same case gives a bitwise identical final state
//! (`state_digest`: ids, positions, velocities, forces, image counts) for 1–4 in-process ranks
//! and 1–2 rayon threads per rank, with and without Lees–Edwards shear
//! (docs/architecture.md rule 5); and so are the time-averaged observables
//! (every diagnostic sum is exact).

use crate::common;
use common::{assert_all_equal, case_from_str, digests_on_1_to_4_ranks, small_dpd};
use mesorheo::driver::run_in_process;
use mesorheo::facade::Engine;

fn digests(text: &str, name: &str) -> Vec<(usize, usize, String)> {
    digests_on_1_to_4_ranks(text, name, |s| {
        assert_eq!(s.steps, 200);
        // The averaged observables too (exact reductions), compared to the last bit.
        assert!(
            s.observables.contains_key("temperature"),
            "{:?}",
            s.observables
        );
    })
}

#[test]
fn periodic_dpd_3d_is_bitwise_identical_on_1_to_4_ranks_and_1_to_2_threads() {
    let d = digests(&small_dpd(3, 6.0, 0.0, 200, ""), "periodic_3d");
    assert_all_equal("periodic 3D", &d);
}

#[test]
fn sheared_dpd_2d_is_bitwise_identical_on_1_to_4_ranks_and_1_to_2_threads() {
    let d = digests(&small_dpd(2, 8.0, 0.5, 200, ""), "lees_edwards_2d");
    assert_all_equal("Lees–Edwards 2D", &d);
}

#[test]
fn sheared_dpd_3d_is_bitwise_identical_on_1_to_4_ranks_and_1_to_2_threads() {
    let d = digests(&small_dpd(3, 6.0, 0.3, 200, ""), "lees_edwards_3d");
    assert_all_equal("Lees–Edwards 3D", &d);
}

#[test]
fn slabs_along_z_under_shear_give_the_same_bits_as_slabs_along_y() {
    let y = case_from_str(&small_dpd(3, 6.0, 0.3, 200, ""), "y");
    let z = case_from_str(
        &small_dpd(3, 6.0, 0.3, 200, "[decomposition]\naxis = \"z\"\n"),
        "z",
    );
    let a = run_in_process(&y, 2, 1, None).expect("y slabs");
    let b = run_in_process(&z, 3, 2, None).expect("z slabs");
    // Every coordinate of every image goes through the same sequence of shifts (y, then z, then
    // x) whichever axis is cut into slabs, so even the slab axis does not change a bit.
    assert_eq!(a.particles, b.particles);
    assert_eq!(a.state_digest, b.state_digest);
}

#[test]
fn a_different_seed_gives_a_different_trajectory() {
    let a = case_from_str(&small_dpd(3, 6.0, 0.0, 20, ""), "a");
    let text = common::with_overrides(&small_dpd(3, 6.0, 0.0, 20, ""), &["seed=12"]);
    let b = case_from_str(&text, "b");
    let da = run_in_process(&a, 1, 1, None).expect("a").state_digest;
    let db = run_in_process(&b, 1, 1, None).expect("b").state_digest;
    assert_ne!(da, db);
}

#[test]
fn too_many_ranks_for_the_slab_width_is_refused_with_the_usable_maximum() {
    let loaded = case_from_str(&small_dpd(3, 6.0, 0.0, 10, ""), "thin");
    let err = run_in_process(&loaded, 5, 1, None).expect_err("slabs 1.2 < 1.3");
    assert!(err.to_string().contains("at most 4 ranks"), "{err}");
}

#[test]
fn walls_keep_particles_inside_and_are_decomposition_invariant() {
    let text = small_dpd(
        3,
        6.0,
        0.0,
        200,
        "[diagnostics]\nobservables = [\"temperature\", \"momentum\"]\n",
    )
    .replace(
        "lengths = [6, 6, 6]",
        "lengths = [6, 6, 6]\nboundaries = [\"periodic\", \"wall\", \"periodic\"]",
    );
    assert!(text.contains("wall"), "case text changed shape: {text}");
    let loaded = case_from_str(&text, "walls");
    let mut seen = Vec::new();
    for ranks in [1, 2, 3] {
        let comms = mesorheo::comm::local_universe(ranks);
        let handles: Vec<_> = comms
            .into_iter()
            .map(|comm| {
                let case = loaded.case.clone();
                std::thread::spawn(move || {
                    let mut sim =
                        mesorheo::sim::Simulation::<3>::new(&case, &comm, 1).expect("setup");
                    sim.run_steps(200).expect("run");
                    let p = &sim.particles;
                    let inside = p.pos[..p.n_owned].iter().all(|x| x[1] >= 0.0 && x[1] < 6.0);
                    (inside, sim.state_digest())
                })
            })
            .collect();
        for h in handles {
            let (inside, digest) = h.join().expect("rank");
            assert!(inside, "a particle left through a wall ({ranks} ranks)");
            seen.push((ranks, digest));
        }
    }
    for (r, d) in &seen {
        assert_eq!(d, &seen[0].1, "walls: {r} ranks differ from 1");
    }
}

#[test]
fn pressure_is_the_same_bits_whether_or_not_the_full_stress_tensor_is_sampled() {
    // A pressure-only case accumulates the diagonal of the virial only; the diagonal sums are
    // exact, so the pressure must equal, to the last bit, the one of a case that samples every
    // component (and the state is untouched either way).
    let run = |observables: &str| {
        let extra = format!("[diagnostics]\nobservables = [{observables}]\nblocks = 4\n");
        let loaded = case_from_str(&small_dpd(3, 6.0, 0.3, 60, &extra), "scope");
        let s = run_in_process(&loaded, 2, 1, None).expect("run");
        let all = serde_json::to_value(&s.observables).expect("json");
        (s.state_digest, all["pressure"].to_string(), all)
    };
    let (digest_p, pressure_p, _) = run("\"pressure\"");
    let (digest_s, pressure_s, all) = run("\"pressure\", \"stress\", \"viscosity\"");
    assert_eq!(digest_p, digest_s);
    assert_eq!(pressure_p, pressure_s);
    assert!(pressure_p.contains("mean"), "{pressure_p}");
    // The full run does have off-diagonal components.
    assert!(
        all["viscosity"]["mean"].as_f64().is_some_and(|v| v != 0.0),
        "{all}"
    );
}
