//! DPD given by its physical properties (`[fluid.physical]`, Nguyen 2021;
//! docs/theory/dpd_physical_parameters.md §2.7): the case file maps to the thesis's parameters (the
//! reference rows of docs/theory/dpd_physical_parameters.md §2.8, to 10⁻⁴), the echo of a mapped
//! case parses again to the same fluid, and a contradicting raw key or an infeasible fluid is
//! refused with the reason.

mod common;
use common::case_from_str;
use mesorheo::config::{self, FluidCfg};
use mesorheo::models::dpd::DpdCfg;
use std::path::Path;

/// A 3D/2D DPD case with `[fluid.physical]` = `physical` and extra `[fluid]` keys `raw`.
fn case_text(
    dimension: usize,
    density: f64,
    mass: f64,
    cutoff: f64,
    raw: &str,
    physical: &str,
) -> String {
    let lengths = vec!["12.0"; dimension].join(", ");
    format!(
        r#"dimension = {dimension}
seed = 3
[box]
lengths = [{lengths}]
[particles]
lattice = "random"
density = {density}
mass = {mass}
temperature = 1.0
[fluid]
kind = "dpd"
kt = 1.0
cutoff = {cutoff}
{raw}
[fluid.physical]
{physical}
[integrator]
kind = "groot_warren"
dt = 0.0005
lambda = 0.5
[neighbour]
skin = 0.3
[run]
steps = 100
sample_every = 10
"#
    )
}

fn dpd_of(text: &str) -> DpdCfg {
    let loaded = case_from_str(text, "physical.toml");
    match loaded.case.fluid {
        FluidCfg::Dpd(d) => d,
        other => panic!("not DPD: {other:?}"),
    }
}

fn close(got: f64, want: f64, rel: f64, what: &str) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{what}: {got} vs {want} (relative {:.2e})",
        (got - want).abs() / want.abs()
    );
}

#[test]
fn the_chapter_4_solvent_maps_to_the_thesis_parameters() {
    // η = 30, Sc = 500, n = 4, r_c = 1.5, m = 1, classical-water repulsion: γ = 6.9710,
    // s = 0.4244, a = 3.5328 (thesis L1233, ✓T in docs/theory/dpd_physical_parameters.md §2.8),
    // s̄ = 1.
    let d = dpd_of(&case_text(
        3,
        4.0,
        1.0,
        1.5,
        "",
        "viscosity = 30.0\nschmidt_number = 500.0",
    ));
    close(d.gamma, 6.9710, 1e-4, "γ");
    close(d.weight_exponent, 0.4244, 2e-4, "s (printed to 4 places)");
    close(d.a, 3.53289, 1e-5, "a");
    assert_eq!(d.conservative_exponent, 1.0);
}

#[test]
fn the_cylinder_fluid_maps_to_figure_3_6() {
    // 2D, η = 100, n = 8, r_c = 2, m = 0.5, α = 1: a = 23.970 (printed truncated, 23.96),
    // s̄ = 6.6711, γ = 2.4479, s = 1/2.
    let d = dpd_of(&case_text(
        2,
        8.0,
        0.5,
        2.0,
        "",
        "viscosity = 100.0\ntime_scale_ratio = 1.0",
    ));
    close(d.a, 23.970, 1e-4, "a");
    close(d.conservative_exponent, 6.6711, 1e-4, "s̄");
    close(d.gamma, 2.4479, 1e-4, "γ");
    assert_eq!(d.weight_exponent, 0.5);
}

#[test]
fn the_echo_of_a_mapped_case_parses_to_the_same_fluid() {
    let text = case_text(
        3,
        4.0,
        1.0,
        1.5,
        "",
        "viscosity = 30.0\nschmidt_number = 500.0",
    );
    let case = case_from_str(&text, "physical.toml").case;
    let echo = toml::to_string(&case).expect("serialise");
    assert!(
        echo.contains("[fluid.physical]") && echo.contains("gamma"),
        "{echo}"
    );
    let again = config::parse(&echo, Path::new("echo.toml")).expect("the echo parses");
    assert_eq!(again, case);
}

#[test]
fn a_raw_parameter_contradicting_the_physical_table_is_refused_at_its_key() {
    let text = case_text(
        3,
        4.0,
        1.0,
        1.5,
        "a = 25.0",
        "viscosity = 30.0\nschmidt_number = 500.0",
    );
    let err = config::parse(&text, Path::new("both.toml")).expect_err("contradiction");
    let msg = err.to_string();
    assert!(
        msg.contains("fluid.a") && msg.contains("maps to a = 3.53") && msg.contains("either"),
        "{msg}"
    );
}

#[test]
fn an_infeasible_fluid_is_refused_with_what_to_change() {
    // The thesis's own α = 100 point (Fig. 3.11, m = 1): C = 4.0 ≤ 6, no s̄ exists.
    let text = case_text(
        2,
        10.0,
        1.0,
        1.6,
        "",
        "viscosity = 100.0\ntime_scale_ratio = 100.0",
    );
    let err = config::parse(&text, Path::new("infeasible.toml")).expect_err("infeasible");
    let msg = err.to_string();
    assert!(
        msg.contains("fluid.physical") && msg.contains("no DPD fluid") && msg.contains("α"),
        "{msg}"
    );
    // Sc and τ_P together.
    let text = case_text(
        3,
        4.0,
        1.0,
        1.5,
        "",
        "viscosity = 30.0\nschmidt_number = 500.0\nparticle_diffusion_time = 1.0",
    );
    let msg = config::parse(&text, Path::new("both.toml"))
        .expect_err("two constraints")
        .to_string();
    assert!(msg.contains("not both"), "{msg}");
}

#[test]
fn the_reverse_poiseuille_solution_has_the_thesis_extremes_and_exact_bin_means() {
    use mesorheo::analytic::double_poiseuille_mean;
    // ρ = 8, g = 1, η = 30, L_y = 20: u_max = 3.333 at s = ±5
    // (docs/theory/dpd_physical_parameters.md §7), antisymmetric.
    let u = |y: f64| double_poiseuille_mean(y - 1e-4, y + 1e-4, 20.0, 8.0, 1.0, 30.0);
    close(u(15.0), 10.0 / 3.0, 1e-7, "u(s = 5)");
    close(-u(5.0), 10.0 / 3.0, 1e-7, "u(s = −5)");
    assert!(u(10.0).abs() < 1e-7 && u(1e-4).abs() < 1e-3);
    // Bin means against a fine midpoint rule of u(y) = ρ g s (L/2 − |s|)/(2η).
    let exact = |y: f64| {
        let s = y - 10.0;
        8.0 * s * (10.0 - s.abs()) / 60.0
    };
    for (y0, y1) in [
        (0.0, 1.0),
        (9.0, 10.0),
        (10.0, 11.0),
        (14.5, 15.5),
        (9.5, 10.5),
    ] {
        let n = 100_000;
        let mid: f64 = (0..n)
            .map(|k| exact(y0 + (k as f64 + 0.5) * (y1 - y0) / n as f64))
            .sum::<f64>()
            / n as f64;
        let got = double_poiseuille_mean(y0, y1, 20.0, 8.0, 1.0, 30.0);
        assert!((got - mid).abs() < 1e-8, "[{y0}, {y1}]: {got} vs {mid}");
    }
}

/// A mapped fluid (s̄ ≠ 1, s = 1/2) in a reverse body force: bitwise the same on 1–4 ranks and
/// 1–2 threads, state and averaged profile, like every model; the force drives the two halves
/// apart (the profile's upper half moves along +x, the lower along −x).
#[test]
fn the_reverse_body_force_flow_is_bitwise_on_any_rank_count() {
    let text = case_text(
        2,
        8.0,
        1.0,
        1.0,
        "body_force = [1.0, 0.0]\nbody_force_profile = \"reverse\"",
        "viscosity = 30.0\ntime_scale_ratio = 1.0",
    );
    let text = common::with_overrides(
        &text,
        &[
            "run.steps=2000",
            "diagnostics.observables=[\"temperature\", \"velocity_profile\"]",
            "diagnostics.profile_bins=4",
        ],
    );
    let d = common::digests_on_1_to_4_ranks(&text, "reverse body force", |s| {
        let p = &s.velocity_profile;
        assert_eq!(p.len(), 4);
        assert!(
            p[0].mean < 0.0 && p[1].mean < 0.0 && p[2].mean > 0.0 && p[3].mean > 0.0,
            "{p:?}"
        );
    });
    common::assert_all_equal("reverse body force", &d);
}
