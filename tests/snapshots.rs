//! Snapshot series (H5MD + XDMF): the same content for any rank count, frames after a
//! checkpoint dropped and rewritten identically on restart, `info` describes the file, and the
//! h5py snippet of the docs reads it and checks the XDMF sidecar.
#![cfg(feature = "hdf5")]

mod common;
use common::{case_from_str, h5_content as content, small_dpd};
use mesorheo::driver::{RunOptions, in_process, restart_case, run_case};
use std::path::Path;

fn case(steps: u64, extra: &str) -> String {
    small_dpd(
        3,
        6.0,
        0.4,
        steps,
        &format!(
            "[output]\nsnapshot_every = 20\nsnapshot_fields = [\"position\", \"velocity\", \"force\", \"image\"]\n{extra}\n\
             [diagnostics]\nobservables = [\"temperature\", \"viscosity\", \"velocity_profile\"]\n"
        ),
    )
}

fn run(text: &str, ranks: usize, out: &Path, until: Option<u64>) -> mesorheo::summary::Summary {
    run_threads(text, ranks, 1, out, until)
}

fn run_threads(
    text: &str,
    ranks: usize,
    threads: usize,
    out: &Path,
    until: Option<u64>,
) -> mesorheo::summary::Summary {
    let loaded = case_from_str(text, "snap");
    let out = out.to_path_buf();
    in_process(ranks, move |c| {
        run_case(
            &loaded,
            c,
            &RunOptions {
                threads,
                steps: None,
                until_step: until,
                out: Some(out.clone()),
                max_hours: None,
            },
        )
    })
    .expect("run")
}

/// Continues the run in `out` from its checkpoint at `step` on `ranks` × `threads`, writing
/// into the same folder.
fn restart_from(out: &Path, step: u64, ranks: usize, threads: usize) {
    let ck = out
        .join("checkpoints")
        .join(mesorheo::output::checkpoint::file_name(step));
    let out = out.to_path_buf();
    in_process(ranks, move |c| {
        restart_case(
            &ck,
            c,
            &RunOptions {
                threads,
                out: Some(out.clone()),
                ..RunOptions::default()
            },
        )
    })
    .expect("restart");
}

#[test]
fn snapshots_have_the_same_content_on_1_2_and_3_ranks() {
    let text = case(100, "");
    let dir = tempfile::tempdir().expect("tempdir");
    let mut first: Option<(Vec<_>, String)> = None;
    for ranks in 1..=3 {
        let out = dir.path().join(format!("r{ranks}"));
        run(&text, ranks, &out, None);
        let c = content(&out.join("snapshots.h5"));
        let x = std::fs::read_to_string(out.join("snapshots.xdmf")).expect("xdmf");
        let (c0, x0) = first.get_or_insert((c.clone(), x.clone()));
        let names: Vec<&String> = c.iter().map(|(n, _, _)| n).collect();
        assert!(
            names
                .iter()
                .any(|n| *n == "/particles/fluid/position/value")
        );
        assert!(names.iter().any(|n| *n == "/observables/viscosity/value"));
        for ((n, s, v), (n0, s0, v0)) in c.iter().zip(c0.iter()) {
            assert_eq!((n, s), (n0, s0), "{ranks} ranks");
            assert!(v == v0, "{n} differs between 1 and {ranks} ranks");
        }
        assert_eq!(c.len(), c0.len());
        assert_eq!(&x, x0, "XDMF differs on {ranks} ranks");
        // 5 frames of 648 particles × 3.
        let pos = c
            .iter()
            .find(|(n, _, _)| n == "/particles/fluid/position/value")
            .unwrap();
        assert_eq!(pos.1, vec![5, 648, 3]);
    }
}

#[test]
fn a_restart_drops_frames_written_after_its_checkpoint_and_rewrites_them() {
    let text = case(160, "checkpoint_every = 100\ncheckpoint_keep = 5");
    let dir = tempfile::tempdir().expect("tempdir");
    let whole = dir.path().join("whole");
    run(&text, 1, &whole, None);
    let parts = dir.path().join("parts");
    // Stops at 150 (frames 20…140, checkpoints 100 and 150); restart from 100 as if the
    // checkpoint at 150 had been lost: frames 120 and 140 must be dropped and rewritten.
    run(&text, 2, &parts, Some(150));
    restart_from(&parts, 100, 3, 1);
    // The time series likewise: the rows 101…150 of the stopped segment are dropped, not
    // repeated (mutation: keep every row of the file in `ObservablesCsv::open`).
    let csv = |dir: &Path| std::fs::read_to_string(dir.join("observables.csv")).expect("csv");
    let (restarted, uninterrupted) = (csv(&parts), csv(&whole));
    assert!(
        restarted == uninterrupted,
        "observables.csv of the restarted run ({} lines) differs from the uninterrupted one's \
         ({} lines)",
        restarted.lines().count(),
        uninterrupted.lines().count()
    );
    let a = content(&whole.join("snapshots.h5"));
    let b = content(&parts.join("snapshots.h5"));
    assert_eq!(a.len(), b.len());
    for ((n, s, v), (n0, s0, v0)) in b.iter().zip(a.iter()) {
        assert_eq!((n, s), (n0, s0));
        assert!(v == v0, "{n} differs from the uninterrupted run");
    }
    let info = mesorheo::output::info::describe(&parts.join("snapshots.h5")).expect("info");
    assert!(info.contains("frames: 8 (steps 20 … 160)"), "{info}");
    assert!(
        info.contains("/particles/fluid/force/value  [8, 648, 3]  float64"),
        "{info}"
    );
    let ck = mesorheo::output::info::describe(
        &parts
            .join("checkpoints")
            .join(mesorheo::output::checkpoint::file_name(160)),
    )
    .expect("info checkpoint");
    assert!(
        ck.contains("kind: checkpoint") && ck.contains("step: 160"),
        "{ck}"
    );
    assert!(
        ck.contains("dt: 0.04\n") && ck.contains("time: 6.4"),
        "{ck}"
    );
}

/// `observables.csv` records the observables from the first sample step on, the
/// equilibration included, and its rows after equilibration are exactly the samples the
/// summary averages (the shortest round-trip decimal form: their mean is the summary's to
/// round-off). Mutations: recording only after equilibration (`is_record_step` as
/// `is_sample_step`) moves the first row to step 45; writing `{v:.6e}` breaks the mean.
#[test]
fn observables_csv_records_the_start_up_and_averages_to_the_summary() {
    let text = case(120, "").replace("sample_every = 1", "sample_every = 5\nequilibration = 40");
    let dir = tempfile::tempdir().expect("tempdir");
    let summary = run(&text, 2, dir.path(), None);
    let csv = std::fs::read_to_string(dir.path().join("observables.csv")).expect("csv");
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("step,time,temperature,viscosity"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().expect("a number")).collect())
        .collect();
    let steps: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let expected: Vec<f64> = (1..=24).map(|k| 5.0 * k as f64).collect();
    assert_eq!(steps, expected, "one row every 5 steps from step 5");
    assert!(
        (rows[0][1] - 5.0 * 0.04).abs() < 1e-12,
        "time {}",
        rows[0][1]
    );
    for (column, name) in [(2, "temperature"), (3, "viscosity")] {
        let after: Vec<f64> = rows
            .iter()
            .filter(|r| r[0] > 40.0)
            .map(|r| r[column])
            .collect();
        assert_eq!(after.len(), 16);
        let mean = after.iter().sum::<f64>() / after.len() as f64;
        let reported = summary.observables[name].mean;
        assert!(
            (mean - reported).abs() <= 1e-12 * reported.abs(),
            "{name}: the rows after equilibration average {mean}, the summary {reported}"
        );
    }
}

/// A homogeneous-flow scene writes `observables.csv` too: the material function first, one row
/// per sample from step 0 on (the start-up), the rows after equilibration averaging to the
/// summary's per-particle means to round-off. Mutation: `FlowScene::observables_row` returning
/// `None` (no file).
#[test]
fn a_homogeneous_flow_scene_writes_observables_csv_from_the_start() {
    let text = common::stock_text_with(
        "dumbbells_hookean_shear_3d.toml",
        &[
            "flow.particles=40",
            "polymer.per_particle=50",
            "run.steps=200",
            "run.equilibration=100",
        ],
    );
    let mesorheo::config::CaseScene::HomogeneousFlow(case) =
        mesorheo::config::parse_scene(&text, Path::new("flow.toml")).expect("a flow case")
    else {
        panic!("a [flow] table makes a flow scene");
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_path_buf();
    let summary = in_process(2, move |c| {
        mesorheo::driver::run_flow_case(
            &case,
            Path::new("flow.toml"),
            c,
            &RunOptions {
                threads: 1,
                out: Some(out.clone()),
                ..RunOptions::default()
            },
        )
    })
    .expect("run");
    let csv = std::fs::read_to_string(dir.path().join("observables.csv")).expect("csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(
        header[..4],
        [
            "step",
            "time",
            "polymer_viscosity",
            "first_normal_stress_difference"
        ]
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().expect("a number")).collect())
        .collect();
    assert_eq!(rows.len(), 20);
    assert_eq!(rows[0][0], 10.0);
    let after: Vec<f64> = rows.iter().filter(|r| r[0] > 100.0).map(|r| r[2]).collect();
    let mean = after.iter().sum::<f64>() / after.len() as f64;
    let reported = summary.observables["polymer_viscosity"].mean;
    assert!(
        (mean - reported).abs() <= 1e-12 * reported.abs(),
        "the rows after equilibration average {mean}, the summary {reported}"
    );
}

/// The h5py snippet of the docs reads the series and checks the XDMF sidecar against the
/// datasets. `./run test` provides a Python with h5py (MESORHEO_PYTHON); without it the test
/// says so and passes only if MESORHEO_REQUIRE_PYTHON is unset.
#[test]
fn the_h5py_snippet_reads_the_series_and_the_xdmf_matches() {
    let Some(python) = common::python_or_skip(
        "the h5py snippet",
        "set MESORHEO_PYTHON to a Python with h5py (./run test does)",
    ) else {
        return;
    };
    let text = case(60, "");
    let dir = tempfile::tempdir().expect("tempdir");
    run(&text, 2, dir.path(), None);
    let snippet = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/snippets/read_snapshots.py");
    let o = std::process::Command::new(python)
        .arg(snippet)
        .arg(dir.path().join("snapshots.h5"))
        .output()
        .expect("python");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("648 particles, 3 frames"), "{stdout}");
    assert!(stdout.contains("XDMF sidecar OK (3 frames"), "{stdout}");
}

/// The XDMF sidecar read as a viewer reads it (tools/check_xdmf.py: the XDMF evaluated item by
/// item against the H5MD datasets, and through VTK's vtkXdmfReader, ParaView's, when VTK is
/// installed): velocity, force and image are N × 3 `Vector` attributes in 2D (padded with a
/// zero z) as in 3D. Fails with 2D vectors declared N × 2 again (mutation: `vector` returning
/// `slab(field, frame)` for D = 2, or `AttributeType="Matrix"`). Needs MESORHEO_PYTHON like the
/// h5py test.
#[test]
fn the_xdmf_gives_viewers_n_by_3_vectors_in_2d_and_3d() {
    let Some(python) = common::python_or_skip(
        "the XDMF reader check",
        "set MESORHEO_PYTHON to a Python with h5py (./run test does)",
    ) else {
        return;
    };
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/check_xdmf.py");
    let dir = tempfile::tempdir().expect("tempdir");
    for dimension in [2, 3] {
        let text = small_dpd(
            dimension,
            6.0,
            0.4,
            60,
            "[output]\nsnapshot_every = 20\nsnapshot_fields = [\"position\", \"velocity\", \"force\", \"image\"]\n",
        );
        let out = dir.path().join(format!("d{dimension}"));
        run(&text, 1, &out, None);
        // Under ./run test (MESORHEO_REQUIRE_PYTHON), VTK must be there and read it too.
        let mut cmd = std::process::Command::new(&python);
        cmd.arg(&script).arg(out.join("snapshots.xdmf"));
        if std::env::var("MESORHEO_REQUIRE_PYTHON").is_ok() {
            cmd.arg("--require-vtk");
        }
        let o = cmd.output().expect("python");
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{dimension}D: {stdout}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(
            stdout.contains("XDMF OK: 3 frames of ")
                && stdout.contains(&format!(
                    "({dimension}D), vectors N × 3: force, image, velocity"
                )),
            "{stdout}"
        );
    }
}

/// The 2D cell of `cases/inclusion_maxwell_2d.toml` (corotational Maxwell SPH around a fixed
/// cylinder: 2500 particles, of which the inclusion's are boundary particles), a few steps
/// with a frame every 3, writing `fields`.
fn inclusion_2d(fields: &str) -> String {
    common::stock_text_with(
        "inclusion_maxwell_2d.toml",
        &[
            "reference=[]",
            "run.steps=6",
            "run.equilibration=0",
            "run.sample_every=1",
            "diagnostics.blocks=2",
            "diagnostics.observables=[\"viscosity\"]",
            "output.snapshot_every=3",
            &format!("output.snapshot_fields={fields}"),
        ],
    )
}

/// The 3D CONNFFESSIT case of `cases/connffessit_shear_3d.toml` shrunk to 8³ SPH particles of
/// 10 Hookean dumbbells each, a few steps with a frame every 2.
fn connffessit_3d(fields: &str) -> String {
    common::stock_text_with(
        "connffessit_shear_3d.toml",
        &[
            "reference=[]",
            "particles.density=512.0",
            "particles.mass=0.001953125",
            "fluid.smoothing_length=0.375",
            "fluid.polymer.per_particle=10",
            "run.steps=4",
            "run.equilibration=0",
            "run.sample_every=1",
            "diagnostics.blocks=2",
            "diagnostics.observables=[\"viscosity\"]",
            "output.snapshot_every=2",
            &format!("output.snapshot_fields={fields}"),
        ],
    )
}

/// Every field an SPH case offers, and the engine's, in 2D (with an inclusion: its particles
/// are their own group) and in 3D (CONNFFESSIT: τ and ⟨QQ⟩ of each particle's dumbbells),
/// read through the XDMF by tools/check_xdmf.py and VTK's vtkXdmfReader: vectors N × 3,
/// tensors `Tensor6` (N × 6, padded in 2D), scalars N, one grid per group with the group's
/// particles only. Mutations: writing every particle into `fluid` (`Species::group` returning
/// "fluid") leaves no `inclusion` group; dropping the parentheses of the 2D tensor `JOIN` makes
/// VTK read xy as 0; the 3D ⟨QQ⟩ summed instead of averaged fails the value check below.
#[test]
fn model_fields_and_particle_groups_read_through_the_xdmf_in_2d_and_3d() {
    let Some(python) = common::python_or_skip(
        "the XDMF reader check of model fields",
        "set MESORHEO_PYTHON to a Python with h5py (./run test does)",
    ) else {
        return;
    };
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/check_xdmf.py");
    let dir = tempfile::tempdir().expect("tempdir");
    let cases = [
        (
            2,
            inclusion_2d(
                "[\"position\", \"velocity\", \"density\", \"pressure\", \"polymer_stress\", \
                 \"species\", \"unwrapped_position\", \"image\"]",
            ),
            "vectors N × 3: image, unwrapped_position, velocity; tensors N × 6: polymer_stress; \
             scalars: density, pressure, species; groups: fluid (",
        ),
        (
            3,
            connffessit_3d(
                "[\"position\", \"velocity\", \"force\", \"density\", \"pressure\", \
                 \"polymer_stress\", \"conformation\", \"species\"]",
            ),
            "vectors N × 3: force, velocity; tensors N × 6: conformation, polymer_stress; \
             scalars: density, pressure, species; groups: fluid (512)",
        ),
    ];
    for (dimension, text, expected) in cases {
        let out = dir.path().join(format!("d{dimension}"));
        run(&text, 1, &out, None);
        let mut cmd = std::process::Command::new(&python);
        cmd.arg(&script).arg(out.join("snapshots.xdmf"));
        if std::env::var("MESORHEO_REQUIRE_PYTHON").is_ok() {
            cmd.arg("--require-vtk");
        }
        let o = cmd.output().expect("python");
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{dimension}D: {stdout}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(stdout.contains(expected), "{dimension}D: {stdout}");
        assert!(
            stdout.contains(&format!("({dimension}D)")),
            "{dimension}D: {stdout}"
        );
        let h5 = content(&out.join("snapshots.h5"));
        let get = |name: &str| {
            h5.iter()
                .find(|(n, _, _)| n == name)
                .unwrap_or_else(|| panic!("{name} missing"))
                .clone()
        };
        if dimension == 2 {
            // The inclusion's particles apart, the fluid without them; τ packed (xx, xy, yy).
            assert!(
                stdout.contains("inclusion ("),
                "no inclusion group: {stdout}"
            );
            let (_, fluid_shape, _) = get("/particles/fluid/polymer_stress/value");
            let (_, inclusion_shape, species) = get("/particles/inclusion/species");
            // Frames at steps 3 and 6.
            assert_eq!(fluid_shape[0], 2);
            assert_eq!(fluid_shape[2], 3);
            assert_eq!(fluid_shape[1] + inclusion_shape[0], 2500);
            // (`content` reads the i32 species as f64 bit patterns.)
            assert!(
                species.iter().all(|&s| f64::from_bits(s) == 3.0),
                "inclusion species {:?}",
                species
                    .iter()
                    .map(|&s| f64::from_bits(s))
                    .collect::<Vec<_>>()
            );
        } else {
            // ⟨QQ⟩ of Hookean dumbbells starts near equilibrium: its trace is about 3 (the
            // connectors' unit), not 10 × 3 (a sum over the 10 dumbbells).
            let (_, shape, bits) = get("/particles/fluid/conformation/value");
            assert_eq!(shape, vec![2, 512, 6]);
            let v: Vec<f64> = bits.iter().map(|&b| f64::from_bits(b)).collect();
            let trace: f64 =
                v.chunks_exact(6).map(|t| t[0] + t[3] + t[5]).sum::<f64>() / (v.len() / 6) as f64;
            assert!((trace - 3.0).abs() < 0.3, "mean tr⟨QQ⟩ = {trace}");
        }
    }
}

/// The model fields and the particle groups are written in global-id order: the datasets of
/// the 2D inclusion cell are bitwise the same on 1 and 2 in-process ranks (mutation: writing
/// a group's rows at the rank's block start instead of its offset in the group, `g.start` →
/// `0`, mixes the ranks' rows).
#[test]
fn model_fields_and_groups_are_the_same_on_1_and_2_ranks() {
    let text = inclusion_2d(
        "[\"position\", \"velocity\", \"density\", \"pressure\", \"polymer_stress\", \
         \"species\", \"unwrapped_position\"]",
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let mut first: Option<Vec<_>> = None;
    for ranks in [1, 2] {
        let out = dir.path().join(format!("r{ranks}"));
        run(&text, ranks, &out, None);
        let c = content(&out.join("snapshots.h5"));
        let names: Vec<&str> = c.iter().map(|(n, _, _)| n.as_str()).collect();
        for want in [
            "/particles/fluid/density/value",
            "/particles/fluid/polymer_stress/value",
            "/particles/inclusion/pressure/value",
            "/particles/inclusion/species",
            "/particles/fluid/unwrapped_position/value",
        ] {
            assert!(names.contains(&want), "{want} missing: {names:?}");
        }
        let c0 = first.get_or_insert(c.clone());
        assert_eq!(c.len(), c0.len());
        for ((n, s, v), (n0, s0, v0)) in c.iter().zip(c0.iter()) {
            assert_eq!((n, s), (n0, s0), "{ranks} ranks");
            assert!(v == v0, "{n} differs between 1 and {ranks} ranks");
        }
    }
}

/// The model fields of a CONNFFESSIT scene (τ from the SPH fluid, ⟨QQ⟩ from each particle's
/// dumbbells, density, pressure, species, unwrapped positions) are bitwise the same on 1 rank ×
/// 1 thread, 2 ranks × 2 threads, and across a restart from the step-2 checkpoint on another
/// rank count (the frame at step 4 rewritten from the restarted state). Mutation: ⟨QQ⟩ of the
/// next rank-local row (`rows.extend_f64((i + 1) % rows.len(), …)` in the dumbbells'
/// `snapshot_values`) gives each particle another's conformation, which depends on the local
/// order and so on the rank count.
#[test]
fn model_fields_are_the_same_for_any_thread_count_and_across_a_restart() {
    let text = common::with_overrides(
        &connffessit_3d(
            "[\"position\", \"density\", \"pressure\", \"polymer_stress\", \"conformation\", \
             \"species\", \"unwrapped_position\"]",
        ),
        &["output.checkpoint_every=2"],
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let whole = dir.path().join("whole");
    run_threads(&text, 1, 1, &whole, None);
    let reference = content(&whole.join("snapshots.h5"));
    let names: Vec<&str> = reference.iter().map(|(n, _, _)| n.as_str()).collect();
    for want in [
        "/particles/fluid/conformation/value",
        "/particles/fluid/polymer_stress/value",
        "/particles/fluid/density/value",
    ] {
        assert!(names.contains(&want), "{want} missing: {names:?}");
    }
    let same = |out: &Path, what: &str| {
        let c = content(&out.join("snapshots.h5"));
        assert_eq!(c.len(), reference.len(), "{what}");
        for ((n, s, v), (n0, s0, v0)) in c.iter().zip(reference.iter()) {
            assert_eq!((n, s), (n0, s0), "{what}");
            assert!(v == v0, "{n} differs on {what}");
        }
    };
    let threaded = dir.path().join("threaded");
    run_threads(&text, 2, 2, &threaded, None);
    same(&threaded, "2 ranks × 2 threads");

    let parts = dir.path().join("parts");
    run_threads(&text, 2, 1, &parts, Some(2));
    restart_from(&parts, 2, 1, 2);
    same(
        &parts,
        "a restart from step 2 (2 ranks, then 1 rank × 2 threads)",
    );
}

/// The run draws its pictures itself at the end, with the matplotlib of MESORHEO_PYTHON (the
/// mechanism of `study` and `stability`): `observables.png` (every column of
/// `observables.csv` against time) and, for a case that records a velocity profile,
/// `velocity_profile.png` against its `linear_shear_profile` reference; both valid PNGs. A
/// Python that cannot be started costs the pictures and one note line, never the run (exit 0);
/// `--no-plots` draws none. Mutation: dropping the `draw_run_plots` call from `session` leaves
/// no PNG.
#[test]
fn a_run_draws_its_observables_and_velocity_profile_as_png() {
    let Some(python) = common::python_or_skip(
        "the run's PNGs",
        "set MESORHEO_PYTHON to a Python with matplotlib (./run test does)",
    ) else {
        return;
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let case_file = dir.path().join("shear.toml");
    let text = format!(
        "{}\n[[reference]]\nkind = \"linear_shear_profile\"\nname = \"linear profile\"\n\
         tolerance = 100.0\n",
        case(60, "")
    );
    std::fs::write(&case_file, text).expect("case");
    let run_binary = |out: &str, python: &str, extra: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_mesorheo"))
            .arg("run")
            .arg(&case_file)
            .args(["--out", out, "-q", "-t", "1"])
            .args(extra)
            .current_dir(dir.path())
            .env("MESORHEO_PYTHON", python)
            .output()
            .expect("run the binary");
        let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(0), "{stderr}");
        stderr
    };
    let png = |out: &str, name: &str| std::fs::read(dir.path().join(out).join(name)).ok();
    let stderr = run_binary("drawn", &python, &[]);
    assert!(!stderr.contains("no plots"), "{stderr}");
    for name in ["observables.png", "velocity_profile.png"] {
        let bytes = png("drawn", name).unwrap_or_else(|| panic!("no {name}: {stderr}"));
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 5000,
            "{name}: {} bytes, not a PNG",
            bytes.len()
        );
    }
    let stderr = run_binary("no_python", "/nonexistent/python", &[]);
    assert_eq!(
        stderr
            .lines()
            .filter(|l| l.starts_with("note: no plots (cannot start /nonexistent/python"))
            .count(),
        1,
        "{stderr}"
    );
    assert!(png("no_python", "observables.png").is_none());
    let stderr = run_binary("not_asked", &python, &["--no-plots"]);
    assert!(
        png("not_asked", "observables.png").is_none() && !stderr.contains("no plots"),
        "{stderr}"
    );
}
