//! Real multi-process runs (`mpirun -n 1` and `-n 2`) of the MPI build: the final state digest
//! must be identical, and a decomposition that is too fine must be refused with the usable
//! rank count. Needs the `mpi` feature (`./run test` builds it).

mod common;

use std::path::Path;
use std::process::Command;

fn mpirun(ranks: usize, threads: usize, case: &Path, out: &Path) -> std::process::Output {
    Command::new("mpirun")
        .args([
            "-n",
            &ranks.to_string(),
            "--oversubscribe",
            "--bind-to",
            "none",
        ])
        .arg(env!("CARGO_BIN_EXE_mesorheo"))
        .args(["run", case.to_str().expect("utf-8 path"), "--out"])
        .arg(out)
        .args(["-t", &threads.to_string(), "-q"])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("NO_COLOR", "1")
        .output()
        .expect("mpirun is installed (./run installs openmpi-bin)")
}

fn digest(out: &Path) -> String {
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    v["state_digest"].as_str().expect("digest").to_owned()
}

/// The shared small Lees–Edwards DPD case of the integration tests.
fn case_text() -> String {
    common::small_dpd(
        3,
        6.0,
        0.3,
        200,
        "[diagnostics]\nobservables = [\"temperature\", \"viscosity\"]\n",
    )
}

#[test]
fn mpirun_one_and_two_ranks_give_the_same_state() {
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("le.toml");
    std::fs::write(&case, case_text()).expect("write case");
    let mut seen = Vec::new();
    for (ranks, threads) in [(1, 1), (2, 1), (2, 2)] {
        let out = dir.path().join(format!("out{ranks}_{threads}"));
        let o = mpirun(ranks, threads, &case, &out);
        assert!(
            o.status.success(),
            "mpirun -n {ranks}: {}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("summary.json")).expect("summary"),
        )
        .expect("json");
        assert_eq!(v["ranks"], ranks);
        seen.push((ranks, threads, digest(&out)));
        assert!(out.join("logs").join("rank0000.log").exists());
        if ranks == 2 {
            assert!(out.join("logs").join("rank0001.log").exists());
        }
    }
    for (r, t, d) in &seen {
        assert_eq!(
            d, &seen[0].2,
            "mpirun -n {r} × {t} threads differs from -n 1"
        );
    }
}

#[test]
fn too_many_ranks_are_refused_with_the_usable_maximum() {
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("thin.toml");
    // L_y = 2.9 holds two slabs of cutoff + skin = 1.3, not three.
    let text = common::small_dpd(3, 6.0, 0.0, 20, "").replace("[6, 6, 6]", "[6, 2.9, 6]");
    assert!(text.contains("2.9"), "{text}");
    std::fs::write(&case, text).expect("write");
    let o = mpirun(3, 1, &case, &dir.path().join("o"));
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("at most 2 ranks"), "{err}");
}
