//! The GENERIC polymer fluid particle (`kind = "generic_polymer"`, docs/theory/
//! generic_polymer_particle.md) at rest: the fluctuation–dissipation theorem for the
//! conformation and the velocities at two time steps (against the stationary variance of the
//! kick–drift–kick scheme, derived in the theory document §3), the failure of the printed
//! Eq. 4.48 drift, momentum conservation, and bitwise invariance over ranks, threads and a
//! restart.

use crate::common;
use common::{assert_all_equal, case_from_str, digests_on_1_to_4_ranks};
use mesorheo::driver::run_in_process;
use mesorheo::summary::Summary;

/// k_BT/H per component; λ_H = 0.1 (relaxation rate k = 1/(2λ_H) = 5).
const KT_OVER_H: f64 = 1.0;
const LAMBDA: f64 = 0.1;

/// A 2D box of 16 × 16 particles at rest, k_BT = 1, m = 100 (thermal speed 0.1, Mach 0.1),
/// with `extra` appended to `[fluid]` and the run's `dt`, `steps`, `shear`.
pub(crate) fn at_rest(dt: f64, steps: u64, shear: f64, extra: &str) -> String {
    format!(
        r#"title = "GENERIC polymer fluid test box"
dimension = 2
seed = 5
[box]
lengths = [8.0, 8.0]
shear_rate = {shear}
[particles]
lattice = "cubic"
density = 4.0
mass = 100.0
temperature = 1.0
[fluid]
kind = "generic_polymer"
smoothing_length = 1.5
sound_speed = 1.0
solvent_viscosity = 40.0
kt = 1.0
spring_constant = {h}
relaxation_time = {LAMBDA}
dumbbell_density = 16.0
{extra}
[integrator]
kind = "kick_drift_kick"
dt = {dt}
[neighbour]
skin = 0.2
[run]
steps = {steps}
equilibration = {equilibration}
sample_every = 5
[diagnostics]
observables = ["temperature", "momentum", "conformation"]
blocks = 10
"#,
        h = 1.0 / KT_OVER_H,
        equilibration = steps / 8,
    )
}

fn run(text: &str, name: &str) -> Summary {
    let loaded = case_from_str(text, name);
    run_in_process(&loaded, 1, 2, None).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// (mean, standard error) of an observable.
fn estimate(s: &Summary, name: &str) -> (f64, f64) {
    let e = s
        .observables
        .get(name)
        .unwrap_or_else(|| panic!("no {name} in {:?}", s.observables.keys()));
    (e.mean, e.stderr)
}

/// At rest, ⟨Q_aQ_b⟩ = (k_BT/H) δ_ab and the kinetic temperature is k_BT (no thermostat: the
/// SDPD pair noise alone holds it), at Δt = 0.01 and 0.02. The kick–drift–kick scheme's
/// stationary variance of dQ = −Q/(2λ)dt + (k_BT/(Hλ))^½ dU is (k_BT/H)/(1 + Δt/(4λ))
/// (theory §3; −2.4 % and −4.8 % here), so the comparison is with that, within 4.5 standard
/// errors of the block averages (10 blocks of ≥ 50 relaxation times each); the biased value
/// is resolved (the naive k_BT/H is more than 3σ away at Δt = 0.02). Momentum stays zero to
/// round-off. Mutation: the conformation noise amplitude × 1.05 gives ⟨Q_x²⟩ = 1.0846 ± 0.0068
/// at Δt = 0.01 (15.6σ high; docs/validation.md).
#[test]
fn at_rest_conformation_and_temperature_obey_the_fdt_at_two_time_steps() {
    for (dt, steps) in [(0.01, 4000u64), (0.02, 2000)] {
        let s = run(&at_rest(dt, steps, 0.0, ""), "at rest");
        let expected = KT_OVER_H / (1.0 + dt / (4.0 * LAMBDA));
        for c in ["conformation_xx", "conformation_yy"] {
            let (m, se) = estimate(&s, c);
            eprintln!("Δt = {dt}: {c} = {m:.5} ± {se:.5} (expected {expected:.5})");
            assert!(
                (m - expected).abs() < 4.5 * se,
                "Δt = {dt}: {c} = {m} ± {se}, expected {expected} (FDT with the scheme's bias)"
            );
        }
        let (xy, se) = estimate(&s, "conformation_xy");
        assert!(xy.abs() < 4.5 * se, "Δt = {dt}: ⟨Q_xQ_y⟩ = {xy} ± {se}");
        let (t, se) = estimate(&s, "temperature");
        eprintln!("Δt = {dt}: k_BT = {t:.5} ± {se:.5}");
        assert!((t - 1.0).abs() < 4.5 * se, "Δt = {dt}: k_BT = {t} ± {se}");
        assert!(
            se < 0.02,
            "temperature error bar {se} too wide to test anything"
        );
        for p in ["momentum_x", "momentum_y"] {
            let (m, _) = estimate(&s, p);
            assert!(m.abs() < 1e-9, "Δt = {dt}: {p} = {m}");
        }
    }
}

/// The printed Eq. 4.48 (∂S/∂Q = F/T) with the entropy of Eq. 4.47 (whose derivative is
/// N^d F/T) and the printed M_QQ = 2T/ζ makes the drift N^d times too fast: with N^d = n^d/d =
/// 4 dumbbells per particle, ⟨Q_a²⟩ = k_BT/(HN^d) = 0.25 (and the scheme's bias
/// 1/(1 + N^dΔt/(4λ)) = 1/1.1 at Δt = 0.01) instead of 1: the FDT test fails by many σ.
#[test]
fn the_printed_eq_4_48_drift_fails_the_fdt_test() {
    let text = at_rest(0.01, 2000, 0.0, "conformation_drift = \"printed_generic\"");
    let s = run(&text, "printed drift");
    let (m, se) = estimate(&s, "conformation_xx");
    let printed = KT_OVER_H / 4.0 / (1.0 + 4.0 * 0.01 / (4.0 * LAMBDA));
    let fdt = KT_OVER_H / (1.0 + 0.01 / (4.0 * LAMBDA));
    eprintln!(
        "printed drift: ⟨Q_x²⟩ = {m:.5} ± {se:.5}, FDT {fdt:.5}, printed theory {printed:.5}"
    );
    assert!(
        (m - fdt).abs() > 50.0 * se,
        "the printed drift passes the FDT test? {m} ± {se}"
    );
    assert!(
        (m - printed).abs() < 4.5 * se,
        "⟨Q_x²⟩ = {m} ± {se}, expected k_BT/(HN^d) = {printed}"
    );
}

/// Bitwise identical final state and averages on 1–4 in-process ranks × 1–2 threads, under
/// Lees–Edwards shear with the pair noise on (pair noise keyed by the pair's ids, conformation
/// noise by the particle's id; exact sums).
#[test]
fn sheared_generic_polymer_is_bitwise_identical_on_1_to_4_ranks_and_1_to_2_threads() {
    let text = at_rest(0.01, 60, 0.3, "");
    let d = digests_on_1_to_4_ranks(&text, "generic_polymer", |s| assert_eq!(s.steps, 60));
    assert_all_equal("GENERIC polymer, Lees–Edwards 2D", &d);
}
