//! Rigid fixed inclusions in SPH (`[inclusions]`) against exact and Stokes results, and the
//! engine's invariants:
//!
//! - the stock Newtonian cell passes its references: the cell's effective viscosity (the
//!   momentum flux) and the torque against the Stokes solution of the same Lees–Edwards cell
//!   (`tools/stokes_inclusion_cell.py`), and the mean fluid stress 1/(1 − πR²) of ηγ̇ (exact for
//!   no-slip on a fixed inclusion);
//! - those Stokes numbers are the independent solver's (run here when Python is given);
//! - the shear rate near the top of the cylinder follows the Stokes single-inclusion solution
//!   (3γ̇ at the surface);
//! - a sheared cell with an inclusion gives the same bits on 1–4 ranks × 1–2 threads, with the
//!   fitted images and with Morris's.

use crate::common;
use common::{
    assert_all_equal, assert_references_pass, assert_window_references_pass,
    digests_on_1_to_4_ranks, stock_case,
};
use mesorheo::comm::SerialComm;
use mesorheo::facade::Engine;
use mesorheo::sim::Simulation;

/// The stock Newtonian inclusion cell, shortened (issue #40: a quarter of its steps; the stock
/// length, t ∈ [0.2, 1] against the period-averaged Stokes cell with bounds 0.12 %, 0.75 %,
/// 0.15 %, is `./run validate stock`'s), passes references of its own window t ∈ [0.09, 0.252]:
/// the Stokes cell of `tools/stokes_inclusion_cell.py` averaged over the window's image offsets
/// s = γ̇Lt (a cosine series through the solver's 16-point η_eff(s), T(s); docs/validation.md,
/// "Fitted images"), η_eff 1.094647 and T −0.064763, and the exact fluid mean 1/(1 − πR²).
/// Measured on this window (2026-11-28, fitted images, 1 rank × 2 threads, the serial run's
/// bits): η_eff −0.040 %, torque −0.64 %, fluid mean −0.06 %. Bounds: 0.15 %, 1.5 %, 0.15 %
/// (about 2.5–3.5× those). Morris's images on the same window (`images = "morris"`: −0.44 %,
/// −3.17 %, −0.27 %) fail all three.
#[test]
fn stock_newtonian_inclusion_passes_its_window_references() {
    assert_window_references_pass(
        "inclusion_newtonian_2d.toml",
        &["run.steps=2800", "run.equilibration=1000"],
        &[
            ("viscosity", 1.094647, 0.0015),
            ("inclusion_torque", -0.064763, 0.015),
            ("viscosity_constitutive", 1.03243, 0.0015),
        ],
    );
}

/// The stock Maxwell inclusion cell passes its references. Run by `./run validate stock`, not by
/// `./run test` (issue #40, CI time: 157 s of the test phase's 3 262 test-seconds): its
/// momentum-flux reference needs the whole window. Shortened, the flux misses its 0.5 % on
/// either side: to 5 000 steps −0.77 ± 0.94 % (2026-11-27), and on the Newtonian cell's early
/// window t ∈ [0.09, 0.252] (630 steps, equilibration 225) η_eff 1.0720 against 1.0945 (−2.1 %)
/// and the torque −0.0546 against −0.0648 (2026-11-28; the Maxwell cell keeps Morris's images,
/// and its stock window is t ∈ [1, 3]). The cell's bits are still checked here, on 1–4 ranks
/// (`inclusion_cell_is_bitwise_rank_invariant`).
#[test]
#[ignore = "in ./run validate stock: its flux reference needs the full 7 500 steps (≈ 80 s alone)"]
fn stock_maxwell_inclusion_passes_its_references() {
    let name = "inclusion_maxwell_2d.toml";
    assert_references_pass(name, &stock_case(name));
}

/// Velocity of Stokes flow past a fixed cylinder of radius `r0` at the origin in the simple
/// shear v = γ̇ y x̂ (γ̇ = 1; docs/theory/sph_maxwell.md §3 T5, Eq. 3.23 with Ω = 0):
/// v = (1 − R⁴/r⁴) Γ·r + (1 − R²/r²) ω×r + 2 (R⁴/r⁴ − R²/r²) r (r̂·Γ·r̂).
fn stokes_velocity(x: f64, y: f64, r0: f64) -> [f64; 2] {
    let r2 = x * x + y * y;
    let (a2, a4) = (r0 * r0 / r2, r0.powi(4) / (r2 * r2));
    let strain = [0.5 * y, 0.5 * x]; // Γ·r
    let rotation = [0.5 * y, -0.5 * x]; // ω×r, ω = −γ̇/2 ẑ
    let rgr = x * y / r2; // r̂·Γ·r̂ · r²/r² … times r below
    std::array::from_fn(|d| {
        let r = [x, y][d];
        (1.0 - a4) * strain[d] + (1.0 - a2) * rotation[d] + 2.0 * (a4 - a2) * r * rgr
    })
}

/// ∂_y v_x + ∂_x v_y of the Stokes solution (central differences of the exact field).
fn stokes_shear_rate(x: f64, y: f64, r0: f64) -> f64 {
    let h = 1e-6;
    (stokes_velocity(x, y + h, r0)[0] - stokes_velocity(x, y - h, r0)[0]) / (2.0 * h)
        + (stokes_velocity(x + h, y, r0)[1] - stokes_velocity(x - h, y, r0)[1]) / (2.0 * h)
}

/// Above and below the cylinder (|x − x₀| < Δ), in the band R + Δ/2 < r < R + 3Δ, the fluid
/// particles' own shear rate S_xy/η = ∂_y v_x + ∂_x v_y against the Stokes solution at their
/// positions, which rises to 3γ̇ at the surface (2.5γ̇ at r = R + Δ/4). Measured at t = 0.125
/// (1 389 steps; the disc's disturbance develops in R²/ν = 0.01) of the stock cell with its
/// fitted images (2026-11-28): the band's mean 1.4314 against Stokes 1.4196 (+0.83 %, 10
/// particles; the periodic images and Re = 1 change the field by a few per cent); at t = 0.25
/// +1.32 %, at t = 0.5 (the test's time before issue #40's CI budget) +1.36 %. In the first row
/// (r < R + Δ/2, not tested) the kernel (support 3.1Δ) smears the steep gradient: 1.85 against
/// 2.5 (Morris's images). The bound, 4 % on the band's mean, fails Morris's images switched off
/// (images = "morris" with morris_cap = 1: the disc's particles seen at rest): −10.6 % at
/// t = 0.125, −9.9 % at t = 0.25 (2026-11-28).
#[test]
fn shear_rate_near_the_inclusion_follows_stokes() {
    let loaded = stock_case("inclusion_newtonian_2d.toml");
    let comm = SerialComm::new();
    let mut sim =
        Simulation::<2>::new(&loaded.case, &comm, crate::common::PHYSICS_THREADS).expect("set up");
    sim.run_steps(1389).expect("run");
    let p = &sim.particles;
    let stress = p.extra_index("viscous_stress").expect("viscous stress");
    let (r0, spacing) = (0.1, 0.02);
    let (mut sph, mut stokes, mut n) = (0.0, 0.0, 0);
    for i in 0..p.n_owned {
        let (x, y) = (p.pos[i][0] - 0.5, p.pos[i][1] - 0.5);
        let r = (x * x + y * y).sqrt();
        if p.species_of(i) != 0 || x.abs() >= spacing || r <= r0 + 0.5 * spacing {
            continue;
        }
        if r < r0 + 3.0 * spacing {
            sph += p.extra[stress].data[i * 4 + 1]; // η = 1
            stokes += stokes_shear_rate(x, y, r0);
            n += 1;
        }
    }
    let (sph, stokes) = (sph / n as f64, stokes / n as f64);
    eprintln!(
        "shear rate near the top and bottom: SPH {sph:.4}, Stokes {stokes:.4} ({n} particles)"
    );
    assert!(n >= 8, "only {n} particles in the band");
    assert!(
        (sph / stokes - 1.0).abs() < 0.04,
        "SPH {sph} vs Stokes {stokes}"
    );
    // The Stokes field itself: 3γ̇ at the top of the cylinder.
    assert!((stokes_shear_rate(0.0, r0 * (1.0 + 1e-9), r0) - 3.0).abs() < 1e-6);
}

/// A sheared cell with an inclusion (the traction moments, XSPH), Newtonian and Maxwell (the
/// mirrored polymer stress), gives the same bits on 1–4 ranks × 1–2 threads, with either
/// image velocity: the Newtonian cell's fitted images (a gather pass whose sums reach the
/// ghosts) and Morris's pairwise images.
#[test]
fn inclusion_cell_is_bitwise_rank_invariant() {
    for (name, images) in [
        (
            "inclusion_newtonian_2d.toml",
            "inclusions.images=\"fitted\"",
        ),
        (
            "inclusion_newtonian_2d.toml",
            "inclusions.images=\"morris\"",
        ),
        ("inclusion_maxwell_2d.toml", "inclusions.images=\"fitted\""),
        ("inclusion_maxwell_2d.toml", "inclusions.images=\"morris\""),
    ] {
        let text = common::stock_text_with(
            name,
            &[
                images,
                "run.steps=60",
                "run.equilibration=0",
                "run.sample_every=5",
            ],
        );
        let d = digests_on_1_to_4_ranks(&text, name, |_| {});
        assert_all_equal(name, &d);
    }
}

/// A time step beyond the inclusion viscous limit is refused, naming the limit, unless the case
/// asks to run beyond the limits (stability studies).
#[test]
fn time_step_limit_can_be_lifted_for_stability_studies() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/bad_cases/inclusion_dt_beyond_viscous_limit.toml");
    let text = std::fs::read_to_string(path).expect("bad case");
    let refused = mesorheo::config::parse(&text, std::path::Path::new("dt.toml"))
        .expect_err("Δt beyond the limit must be refused");
    assert!(
        refused.to_string().contains("viscous (inclusions)"),
        "{refused}"
    );
    let lifted = common::with_overrides(&text, &["run.beyond_stability_limits=true"]);
    common::case_from_str(&lifted, "dt_lifted.toml");
}

/// The stock cell's Stokes references are the independent solver's numbers
/// (`tools/stokes_inclusion_cell.py`, written from the equations, not from `src/`): the cell's
/// effective viscosity and the torque at R = 0.1, averaged over the image offset, to 10⁻⁶.
/// Skipped (with a note) when no Python is given, unless MESORHEO_REQUIRE_PYTHON is set
/// (`./run test` sets both; its own self-test runs there too).
#[test]
fn stokes_references_of_the_stock_cell_come_from_the_independent_solver() {
    let Some(python) = common::python_or_skip(
        "the Stokes-cell comparison",
        "set MESORHEO_PYTHON (./run test does)",
    ) else {
        return;
    };
    let tool =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/stokes_inclusion_cell.py");
    let o = std::process::Command::new(python)
        .arg(tool)
        .args(["--json", "--radius", "0.1"])
        .output()
        .expect("run the Stokes-cell solver");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let row = &out["rows"][0];
    assert_eq!(row["R"].as_f64(), Some(0.1));
    let case = stock_case("inclusion_newtonian_2d.toml").case;
    let reference = |observable: &str| {
        case.reference
            .iter()
            .find_map(|r| match r {
                mesorheo::config::ReferenceCfg::Value(v) if v.observable == observable => {
                    Some(v.value)
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("no reference on {observable}"))
    };
    for (observable, key) in [
        ("viscosity", "eta_eff_avg"),
        ("inclusion_torque", "torque_avg"),
    ] {
        let solver = row[key].as_f64().expect("number");
        let quoted = reference(observable);
        eprintln!("{observable}: case {quoted}, solver {solver}");
        assert!(
            (quoted / solver - 1.0).abs() < 1e-6,
            "{observable}: the case quotes {quoted}, the solver gives {solver}"
        );
    }
}
