//! The one checkpoint format: files written now carry `format_version = 2` and their scene;
//! files written by the version-1 code (particle and homogeneous-flow scenes, kept in
//! `tests/data/format_v1`, made by commit 2a734f2 from the case files beside them) restart
//! and end in the same state as one uninterrupted run of the current code; a file of an
//! unknown version is refused with a message that names the version, and is not set aside as
//! damaged.

mod common;
use common::case_from_str;
use mesorheo::config::{self, CaseScene};
use mesorheo::driver::{RunOptions, in_process, restart_case, run_case};
use mesorheo::output::checkpoint::{self, FORMAT_VERSION, SceneKind};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/format_v1")
        .join(name)
}

/// Copies a fixture checkpoint into `out/checkpoints/` (where a run keeps them) and returns
/// the copy.
fn place(name: &str, out: &Path) -> PathBuf {
    let dir = out.join("checkpoints");
    std::fs::create_dir_all(&dir).expect("mkdir");
    let step = name.rsplit('_').next().expect("checkpoint_<step>.h5");
    let to = dir.join(format!("checkpoint_{step}"));
    std::fs::copy(fixture(name), &to).expect("copy fixture");
    to
}

fn restart(path: &Path, out: &Path, ranks: usize) -> Result<String, mesorheo::error::Error> {
    let (path, out) = (path.to_path_buf(), out.to_path_buf());
    in_process(ranks, move |comm| {
        let options = RunOptions {
            threads: 1,
            out: Some(out.clone()),
            ..RunOptions::default()
        };
        restart_case(&path, comm, &options).map(|s| s.state_digest)
    })
}

#[test]
fn a_version_1_particle_checkpoint_restarts_bitwise_on_one_and_two_ranks() {
    let text = std::fs::read_to_string(fixture("particles_v1.toml")).expect("case");
    let loaded = case_from_str(&text, "particles_v1.toml");
    let whole = in_process(1, move |comm| {
        run_case(&loaded, comm, &RunOptions::default()).map(|s| s.state_digest)
    })
    .expect("uninterrupted run");
    for ranks in [1, 2] {
        let dir = tempfile::tempdir().expect("tempdir");
        let ck = place("particles_checkpoint_000000000030.h5", dir.path());
        assert_eq!(
            checkpoint::scene_of(&ck).expect("identified"),
            SceneKind::Particles
        );
        let digest = restart(&ck, dir.path(), ranks).expect("restart from version 1");
        assert_eq!(digest, whole, "{ranks} ranks");
        // What the restarted run wrote is version 2, with its scene.
        let newest = checkpoint::list(&dir.path().join("checkpoints"))[0]
            .1
            .clone();
        let f = mesorheo::output::h5_options().open(&newest).expect("open");
        let version: u64 = f.attr("format_version").unwrap().read_scalar().unwrap();
        assert_eq!(version, FORMAT_VERSION);
        assert_eq!(checkpoint::scene_of(&newest), Ok(SceneKind::Particles));
    }
}

#[test]
fn a_version_1_flow_checkpoint_restarts_bitwise() {
    let path = fixture("flow_v1.toml");
    let CaseScene::HomogeneousFlow(case) = config::load_scene(&path, &[]).expect("case").scene
    else {
        panic!("a homogeneous-flow scene");
    };
    let whole = in_process(1, move |comm| {
        mesorheo::driver::run_flow_case(&case, Path::new("flow"), comm, &RunOptions::default())
            .map(|s| s.state_digest)
    })
    .expect("uninterrupted run");
    for ranks in [1, 3] {
        let dir = tempfile::tempdir().expect("tempdir");
        let ck = place("flow_checkpoint_000000000050.h5", dir.path());
        assert_eq!(checkpoint::scene_of(&ck), Ok(SceneKind::HomogeneousFlow));
        let digest = restart(&ck, dir.path(), ranks).expect("restart from version 1");
        assert_eq!(digest, whole, "{ranks} ranks");
    }
}

#[test]
fn a_checkpoint_of_an_unknown_version_is_refused_by_name_and_kept() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ck = place("particles_checkpoint_000000000030.h5", dir.path());
    {
        let f = mesorheo::output::h5_options().open_rw(&ck).expect("open");
        f.attr("format_version")
            .expect("attribute")
            .write_scalar(&7u64)
            .expect("write");
    }
    let err = checkpoint::scene_of(&ck).expect_err("version 7 is unknown");
    assert!(!err.is_damaged(), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("format version 7") && text.contains("reads versions 1 and 2"),
        "{text}"
    );
    let err = restart(&ck, dir.path(), 1).expect_err("nothing to restart from");
    assert!(err.to_string().contains("format version 7"), "{err}");
    assert!(
        ck.exists(),
        "a good file of another version is not set aside"
    );
    assert!(!ck.with_extension("h5.corrupt").exists());
}
