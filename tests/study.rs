//! `mesorheo study` and `mesorheo stability` end to end, through the real binary (the sweep's
//! points are child processes).
//!
//! The 3-point sweep runs Hookean dumbbells (Heun) in shear at Wi = 1, whose exact
//! η_p = Gλ = 1 (upper-convected Maxwell) is the reference from outside the code. The test
//! recomputes what the tool must have written — each point's error from its own summary.json,
//! the Pareto front, the recommendation — and checks that a second invocation resumes instead
//! of running the points again.

use std::path::{Path, PathBuf};
use std::process::Command;

fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_mesorheo")
}

fn case(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name)
}

fn csv_rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            head.iter()
                .zip(l.split(','))
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

fn num(row: &std::collections::BTreeMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = {:?}", row[key]))
}

#[test]
fn a_three_point_sweep_runs_resumes_and_recommends_the_cheapest_point_within_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            r#"
title = "CI: Hookean dumbbells, N_d"
case = "{}"
threads = 1
set = ["flow.particles=40", "run.steps=1200", "run.equilibration=300"]
target = 0.05

[[knob]]
key = "polymer.per_particle"
values = [20, 100, 400]

[[observable]]
name = "polymer_viscosity"
value = 1.0
"#,
            case("dumbbells_hookean_shear_3d.toml").display()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let mut cmd = Command::new(exe());
    cmd.args([
        "study",
        sweep.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    if let Some(py) = std::env::var_os("MESORHEO_PYTHON") {
        cmd.env("MESORHEO_PYTHON", py);
    }
    let run = cmd.output().unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let rows = csv_rows(&out.join("study.csv"));
    assert_eq!(rows.len(), 3);
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row["status"], "done");
        // The error column against the point's own summary.json and the exact η_p = 1.
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(format!("points/{i:03}/summary.json"))).unwrap(),
        )
        .unwrap();
        let est = &summary["observables"]["polymer_viscosity"];
        let (mean, stderr) = (
            est["mean"].as_f64().unwrap(),
            est["stderr"].as_f64().unwrap(),
        );
        assert!((num(row, "polymer_viscosity:error") - (mean - 1.0).abs()).abs() < 1e-9);
        assert!((num(row, "polymer_viscosity:statistical") - stderr).abs() < 1e-9);
        // The physics: Heun at Δt = 0.01 λ has a bias far below these error bars, so every
        // point is within 4.5 standard errors of the exact value.
        assert!(
            (mean - 1.0).abs() < 4.5 * stderr,
            "N_d = {}: η_p = {mean} ± {stderr}",
            row["polymer.per_particle"]
        );
        assert!(num(row, "core_seconds") > 0.0);
        // The memory column: the stored connectors of plain dumbbells, N_d × D × 8 B (3D,
        // double precision), as the run reports them.
        let n_d: f64 = row["polymer.per_particle"].parse().unwrap();
        assert_eq!(num(row, "bytes_per_particle"), n_d * 3.0 * 8.0, "{row:?}");
    }
    // Memory/error front: the smallest N_d stores least, so it is on it whatever its error;
    // another point is on it exactly when no point stores at most as much with at most its error.
    for (i, row) in rows.iter().enumerate() {
        let dominated = (0..3).any(|j| {
            j != i
                && num(&rows[j], "bytes_per_particle") <= num(row, "bytes_per_particle")
                && num(&rows[j], "error") <= num(row, "error")
        });
        assert_eq!(row["pareto_memory"] == "1", !dominated, "{rows:?}");
    }
    assert_eq!(rows[0]["pareto_memory"], "1");
    // More dumbbells, smaller error bars: 20× the dumbbells should give about √20 ≈ 4.5× less
    // noise; at least 2× (the stderr estimates themselves scatter by ~25 % with 10 blocks).
    assert!(
        num(&rows[0], "polymer_viscosity:statistical")
            > 2.0 * num(&rows[2], "polymer_viscosity:statistical")
    );
    // The recommendation, recomputed: the cheapest point with error + 2 × statistical ≤ 0.05.
    let ok: Vec<usize> = (0..3)
        .filter(|&i| {
            num(&rows[i], "polymer_viscosity:error")
                + 2.0 * num(&rows[i], "polymer_viscosity:statistical")
                <= 0.05
        })
        .collect();
    let cheapest = ok
        .iter()
        .copied()
        .min_by(|&a, &b| num(&rows[a], "core_seconds").total_cmp(&num(&rows[b], "core_seconds")));
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row["recommended"] == "1", Some(i) == cheapest, "{rows:?}");
        // Pareto: no other point both cheaper-or-equal and more-accurate-or-equal.
        let dominated = (0..3).any(|j| {
            j != i
                && num(&rows[j], "core_seconds") <= num(row, "core_seconds")
                && num(&rows[j], "error") <= num(row, "error")
        });
        assert_eq!(row["pareto"] == "1", !dominated, "{rows:?}");
    }
    if let Some(i) = cheapest {
        assert!(
            stdout.contains(&format!(
                "polymer.per_particle={}",
                rows[i]["polymer.per_particle"]
            )),
            "{stdout}"
        );
    } else {
        assert!(stdout.contains("no point meets"), "{stdout}");
    }
    if std::env::var_os("MESORHEO_PYTHON").is_some() {
        let png = std::fs::metadata(out.join("study.png")).expect("study.png");
        assert!(png.len() > 10_000, "a plot, not an empty file");
    }
    // Resumed: the points are not run again (their point.json records are untouched).
    let stamp = |i: usize| {
        std::fs::metadata(out.join(format!("points/{i:03}/point.json")))
            .unwrap()
            .modified()
            .unwrap()
    };
    let before: Vec<_> = (0..3).map(stamp).collect();
    let again = Command::new(exe())
        .args([
            "study",
            sweep.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["-q"])
        .output()
        .unwrap();
    assert!(again.status.success());
    let after: Vec<_> = (0..3).map(stamp).collect();
    assert_eq!(before, after, "a finished point was run again");
    assert_eq!(csv_rows(&out.join("study.csv")), rows);
}

#[test]
fn a_bad_sweep_file_is_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            "case = \"{}\"\n[[knob]]\nkey = \"integrator.dtt\"\nvalues = [0.01]\n\
             [[observable]]\nname = \"polymer_viscosity\"\nvalue = 1.0\n",
            case("dumbbells_hookean_shear_3d.toml").display()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let run = Command::new(exe())
        .args([
            "study",
            sweep.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("every point of the sweep is refused"), "{err}");
    assert!(err.contains("dtt"), "{err}");
    assert!(!out.join("points").exists(), "nothing ran");
}

/// The stability bisection on the explicit Euler–Maruyama scheme for Hookean dumbbells at rest,
/// whose exact linear stability limit is Δt = 4λ (the mean connector's amplification
/// 1 − Δt/(2λ) must stay within (−1, 1)); `check` refuses from 0.95 × 4λ on.
#[test]
fn the_stability_bisection_finds_the_euler_limit_of_4_lambda() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("map");
    let at_rest = dir.path().join("hookean_euler_at_rest.toml");
    std::fs::write(
        &at_rest,
        r#"
title = "Hookean dumbbells at rest, Euler–Maruyama"
dimension = 3
seed = 3
[flow]
kind = "rest"
particles = 4
[polymer]
kind = "dumbbells"
spring = "hookean"
relaxation_time = 1.0
per_particle = 50
scheme = "euler_maruyama"
[integrator]
kind = "brownian_dynamics"
dt = 0.5
[run]
steps = 100
sample_every = 10
"#,
    )
    .unwrap();
    let run = Command::new(exe())
        .args([
            "stability",
            at_rest.to_str().unwrap(),
            "--over",
            "polymer.relaxation_time=1,2",
            "--steps",
            "3000",
            "--tolerance",
            "0.02",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let rows = csv_rows(&out.join("stability.csv"));
    assert_eq!(rows.len(), 2);
    for row in &rows {
        let lambda = num(row, "polymer.relaxation_time");
        let (stable, unstable) = (num(row, "largest_stable"), num(row, "smallest_unstable"));
        // The bracket holds the exact 4λ: at 4λ the connectors random-walk (variance 4n
        // per component after n steps), past the runaway bound 10⁴ × 3 within 3000 steps; a
        // step 0.1 % below it saturates at a variance 2λ/(δ … ) ≈ 500× smaller than the bound.
        assert!(unstable / stable <= 1.02 + 1e-9);
        assert!(
            stable <= 4.0 * lambda * 1.001 && unstable >= 4.0 * lambda * 0.999,
            "λ = {lambda}: bracket [{stable}, {unstable}] misses 4λ"
        );
        // check keeps 5 % off the bound (EXPLICIT_STABILITY_MARGIN).
        assert!((num(row, "check_limit") / (0.95 * 4.0 * lambda) - 1.0).abs() < 1e-5);
        assert_eq!(row["check_refuses_unstable"], "1");
    }
    assert!(
        stdout.contains("check refuses every unstable point: yes"),
        "{stdout}"
    );
}
