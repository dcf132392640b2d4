//! `mesorheo run`'s exit codes follow the error's variant (`mesorheo::error::Error::exit_code`):
//! 4 a blow-up, 2 an invalid case or one that does not fit, 0 done. A script, a study or a
//! stability bisection tells them apart by the code alone. Fails if the code is taken from the
//! message again and a diagnosis loses the words, or if a blow-up is reported as a plain
//! failure (1).

use std::process::Command;

fn run(out: &std::path::Path, sets: &[&str]) -> (Option<i32>, String) {
    let case =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/dpd_equilibrium_3d.toml");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_mesorheo"));
    cmd.arg("run")
        .arg(case)
        .arg("--out")
        .arg(out)
        .args(["-q", "-t", "1"]);
    for s in sets {
        cmd.arg("--set").arg(s);
    }
    let o = cmd.output().expect("run the binary");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn a_blow_up_exits_4_and_names_the_particle_and_the_step() {
    let dir = tempfile::tempdir().expect("temp dir");
    // Δt = 0.5 is twelve times the stock 0.04: the random start throws particles beyond the
    // neighbour list's reach at the first step (the check, which refuses it, is switched off).
    let (code, err) = run(
        dir.path(),
        &[
            "integrator.dt=0.5",
            "run.beyond_stability_limits=true",
            "run.steps=400",
            "run.equilibration=100",
        ],
    );
    assert_eq!(code, Some(4), "{err}");
    assert!(
        err.contains("particle ")
            && err.contains("at step ")
            && err.contains("the run is unstable"),
        "{err}"
    );
    assert!(
        dir.path().join("blowup").is_dir(),
        "the state at the blow-up is kept"
    );
}

#[test]
fn an_invalid_case_and_one_that_does_not_fit_exit_2() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (code, err) = run(dir.path(), &["integrator.dt=-1"]);
    assert_eq!(code, Some(2), "{err}");
    let (code, err) = run(dir.path(), &["box.lengths=[800.0,800.0,800.0]"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("GiB"), "{err}");
}
