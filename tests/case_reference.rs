//! The key reference cannot drift: `docs/case-reference.md` is what `mesorheo keys` prints, and
//! the documented keys are exactly the fields the case structs serialise (a case using every
//! key and every reference kind, parsed and written back, gives the set of key paths).

mod common;
use common::case_from_str;
use mesorheo::config::reference::{keys, render_markdown};
use std::collections::BTreeSet;

const EVERY_KEY: &str = r#"
title = "every key"
dimension = 3
seed = 3
[box]
lengths = [10.0, 10.0, 10.0]
boundaries = ["periodic", "periodic", "wall"]
shear_rate = 0.1
[decomposition]
axis = "y"
[particles]
lattice = "fcc"
density = 3.0
mass = 1.0
temperature = 1.0
velocity_profile = "shear"
velocity_amplitude = 1.0
[fluid]
kind = "dpd"
a = 25.0
gamma = 4.5
kt = 1.0
cutoff = 1.0
weight_exponent = 2.0
conservative_exponent = 1.0
noise = "uniform"
soft_start_sweeps = 30
[integrator]
kind = "groot_warren"
dt = 0.02
lambda = 0.65
[neighbour]
skin = 0.3
[run]
steps = 100
equilibration = 10
sample_every = 5
progress_seconds = 1.0
beyond_stability_limits = false
[output]
checkpoint_every = 1000
checkpoint_keep = 2
checkpoint_at_end = false
snapshot_every = 100
snapshot_fields = ["position", "force", "unwrapped_position", "species"]
[diagnostics]
observables = ["temperature", "velocity_profile"]
profile_bins = 4
blocks = 4
green_kubo_time = 1.5
transverse_current_modes = 6
transverse_current_every = 2
transverse_current_time = 3.0
[[reference]]
kind = "value"
name = "t"
observable = "temperature"
value = 1.0
metric = "relative_error"
tolerance = 0.1
source = "s"
[[reference]]
kind = "linear_shear_profile"
name = "p"
tolerance = 0.1
"#;

/// The BDDFS keys of a homogeneous-flow scene (`[polymer] kind = "bddfs"`).
const EVERY_BDDFS_KEY: &str = r#"
dimension = 2
[flow]
kind = "simple_shear"
rate = 1.0
particles = 10
[polymer]
kind = "bddfs"
spring = "hookean"
relaxation_time = 1.0
per_particle = 10
cells = 20
q_max = 6.0
[integrator]
kind = "brownian_dynamics"
dt = 0.01
[run]
steps = 100
equilibration = 10
sample_every = 5
[[reference]]
kind = "value"
name = "occupancy"
observable = "occupied_histogram_cells"
value = 10.0
metric = "relative_error"
tolerance = 0.5
source = "s"
"#;

const EVERY_FLOW_KEY: &str = r#"
title = "every flow key"
dimension = 3
seed = 3
[flow]
kind = "shear_reversal"
rate = 1.0
reverse_at = 2.0
particles = 10
[polymer]
kind = "dumbbells"
spring = "fene"
b = 50.0
relaxation_time = 1.0
modulus = 1.0
per_particle = 10
scheme = "semi_implicit"
variance_reduction = false
precision = "single"
[integrator]
kind = "brownian_dynamics"
dt = 0.01
[run]
steps = 100
equilibration = 10
sample_every = 5
progress_seconds = 1.0
[output]
checkpoint_every = 1000
checkpoint_keep = 2
checkpoint_at_end = false
[diagnostics]
blocks = 4
[[reference]]
kind = "value"
name = "v"
observable = "polymer_viscosity"
value = 1.0
metric = "relative_error"
tolerance = 0.1
source = "s"
"#;

const EVERY_SPH_KEY: &str = r#"
dimension = 2
[box]
lengths = [1.0, 1.0]
boundaries = ["periodic", "wall"]
[particles]
lattice = "cubic"
density = 400.0
mass = 0.0025
temperature = 0.0
[fluid]
kind = "sph"
kernel = "lucy"
smoothing_length = 0.125
rest_density = 1.0
sound_speed = 10.0
equation_of_state = "tait"
density = "continuity"
viscosity = 1.0
viscous_term = "morris"
velocity_gradient = "corrected"
body_force = [0.0, 0.0]
morris_regularisation = 0.0
xsph = 0.5
background_pressure = 1.0
transport_pressure = 0.0
[fluid.polymer]
model = "corotational_maxwell"
viscosity = 1.0
relaxation_time = 0.1
rotation = true
[walls]
axis = "y"
thickness = 0.25
lower_velocity = [0.0, 0.0]
upper_velocity = [1.0, 0.0]
treatment = "morris"
morris_cap = 2.0
repulsion_strength = 100.0
repulsion_range = 0.05
[inclusions]
centres = [[0.5, 0.5]]
radius = 0.1
images = "morris"
morris_cap = 1.5
mirror_pressure = true
[integrator]
kind = "kick_drift_kick"
dt = 1e-4
[neighbour]
skin = 0.01
[run]
steps = 100
sample_every = 10
[diagnostics]
observables = ["velocity_profile"]
[[reference]]
kind = "startup_profile"
name = "c"
solution = "couette"
times = [0.01]
tolerance = 0.01
source = "s"
"#;

/// The GENERIC polymer fluid's reduced keys (`kind = "generic_polymer"`).
const EVERY_GENERIC_POLYMER_KEY: &str = r#"
title = "every generic_polymer key"
dimension = 2
[box]
lengths = [8.0, 8.0]
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
spring_constant = 1.0
relaxation_time = 0.1
dumbbell_density = 16.0
velocity_noise = false
conformation_drift = "printed_generic"
conformation_gradient = "smoothed"
explicit_dumbbells = 2
transport_pressure = 500.0
background_pressure = 5.0
[integrator]
kind = "kick_drift_kick"
dt = 0.01
[run]
steps = 100
equilibration = 0
sample_every = 5
[[reference]]
kind = "value"
name = "k_BT"
observable = "temperature"
value = 1.0
metric = "relative_error"
tolerance = 0.1
source = "the case"
"#;

/// The GENERIC polymer fluid in physical units (`[fluid.si]`, exclusive with the reduced keys).
const EVERY_GENERIC_POLYMER_SI_KEY: &str = r#"
title = "every generic_polymer [fluid.si] key"
dimension = 2
[box]
lengths = [1.0, 1.0]
shear_rate = 1.0
[particles]
lattice = "cubic"
density = 2500.0
mass = 0.0004
temperature = 0.0
[fluid]
kind = "generic_polymer"
smoothing_length = 0.08
[fluid.si]
box_length = 1e-5
relaxation_time = 1e-6
temperature = 300.0
solvent_viscosity = 1e-3
density = 1e3
dumbbells = 1e8
bead_radius = 4e-10
specific_gas_constant = 462.0
[integrator]
kind = "kick_drift_kick"
dt = 5e-4
[run]
steps = 100
equilibration = 0
sample_every = 5
[[reference]]
kind = "value"
name = "k_BT"
observable = "temperature"
value = 1.0
metric = "relative_error"
tolerance = 0.1
source = "the case"
"#;

fn paths(prefix: &str, v: &toml::Value, out: &mut BTreeSet<String>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                paths(&p, x, out);
            }
        }
        toml::Value::Array(a) if a.iter().all(|x| x.is_table()) && !a.is_empty() => {
            for x in a {
                paths(&format!("{prefix}[]"), x, out);
            }
        }
        _ => {
            out.insert(prefix.to_owned());
        }
    }
}

/// The dumbbell keys of `[fluid.polymer]` (which a constitutive model refuses).
const EVERY_DUMBBELL_KEY: &str = r#"
dimension = 2
[box]
lengths = [1.0, 1.0]
shear_rate = 1.0
[particles]
lattice = "cubic"
density = 400.0
mass = 0.0025
temperature = 0.0
[fluid]
kind = "sph"
kernel = "lucy"
smoothing_length = 0.15
sound_speed = 10.0
viscosity = 0.5
[fluid.polymer]
model = "dumbbells"
viscosity = 0.5
relaxation_time = 1.0
per_particle = 10
spring = "fene"
b = 50.0
scheme = "semi_implicit"
precision = "single"
noise = "configuration_fields"
[integrator]
kind = "kick_drift_kick"
dt = 1e-3
[run]
steps = 100
sample_every = 10
[diagnostics]
observables = ["viscosity"]
[[reference]]
kind = "value"
name = "v"
observable = "viscosity"
value = 1.0
metric = "relative_error"
tolerance = 0.1
source = "s"
"#;

/// The BDDFS keys of `[fluid.polymer]` (histograms carried by every SPH particle).
const EVERY_FLUID_BDDFS_KEY: &str = r#"
dimension = 2
[box]
lengths = [1.0, 1.0]
shear_rate = 1.0
[particles]
lattice = "cubic"
density = 400.0
mass = 0.0025
temperature = 0.0
[fluid]
kind = "sph"
kernel = "lucy"
smoothing_length = 0.15
sound_speed = 10.0
viscosity = 0.5
[fluid.polymer]
model = "bddfs"
viscosity = 0.5
relaxation_time = 1.0
per_particle = 10
spring = "fene"
b = 50.0
scheme = "semi_implicit"
cells = 200
q_max = 7.0
noise = "configuration_fields"
[integrator]
kind = "kick_drift_kick"
dt = 1e-3
[run]
steps = 100
sample_every = 10
[diagnostics]
observables = ["viscosity"]
[[reference]]
kind = "value"
name = "v"
observable = "viscosity"
value = 1.0
metric = "relative_error"
tolerance = 0.1
source = "s"
"#;

/// The MSPH keys: a shortened msph_channel_2d with a centre-line reference.
const EVERY_MSPH_KEY: &str = r#"
dimension = 2
[box]
lengths = [20.0, 24.0]
boundaries = ["periodic", "wall"]
[decomposition]
axis = "x"
[particles]
lattice = "cubic"
density = 1.0
mass = 1.0
temperature = 0.0
[fluid]
kind = "sph"
kernel = "truncated_gaussian"
smoothing_length = 2.0
sound_speed = 1.0
derivatives = "msph"
viscosity = 1.0
viscous_term = "nested_summation"
morris_share = 0.1
body_force = [1e-3, 0.0]
[walls]
treatment = "mirror"
thickness = 3.0
[integrator]
kind = "kick_drift_kick"
dt = 0.01
[run]
steps = 100
sample_every = 10
[diagnostics]
observables = ["velocity_profile"]
[[reference]]
kind = "startup_profile"
name = "p"
solution = "poiseuille"
times = [1.0]
positions = [11.5, 12.5]
tolerance = 0.03
"#;

/// `[fluid.physical]` with a Schmidt number and a time-scale ratio, and with a particle
/// diffusion time and the compressibility (the two constraints exclude each other).
const EVERY_PHYSICAL_KEY_SC: &str = r#"
dimension = 3
[box]
lengths = [9.0, 9.0, 9.0]
[particles]
lattice = "random"
density = 4.0
temperature = 1.0
[fluid]
kind = "dpd"
kt = 1.0
cutoff = 1.5
body_force = [1.0, 0.0, 0.0]
body_force_profile = "reverse"
[fluid.physical]
viscosity = 30.0
schmidt_number = 500.0
time_scale_ratio = 20.0
[integrator]
kind = "groot_warren"
dt = 0.001
thermostat = "exponential"
[run]
steps = 100
sample_every = 1
[diagnostics]
observables = ["temperature", "velocity_profile", "shear_stress_profile"]
[[reference]]
kind = "double_poiseuille_profile"
name = "p"
viscosity = 30.0
tolerance = 0.1
source = "s"
[[reference]]
kind = "double_poiseuille_stress"
name = "t"
tolerance = 0.1
source = "s"
"#;
/// [`EVERY_PHYSICAL_KEY_SC`] with the other constraint: a particle diffusion time, and the
/// compressibility.
fn every_physical_key_tau() -> String {
    EVERY_PHYSICAL_KEY_SC.replace(
        "schmidt_number = 500.0\ntime_scale_ratio = 20.0",
        "particle_diffusion_time = 0.9266\ninverse_compressibility = 15.9835",
    )
}

/// `[fluid.colloids]` with a count and random placement (and every optional key); the volume
/// fraction and explicit centres (the three counts exclude each other) in the variants below.
const EVERY_COLLOID_KEY: &str = r#"
dimension = 3
[box]
lengths = [8.0, 8.0, 8.0]
[particles]
lattice = "fcc"
density = 4.0
temperature = 1.0
[fluid]
kind = "dpd"
a = 3.5
gamma = 4.5
kt = 1.0
cutoff = 1.5
[fluid.colloids]
shape = "cube"
count = 4
placement = "random"
min_separation = 2.0
site_radius = 0.1
spring_stiffness = 100.0
fixed = true
[integrator]
kind = "groot_warren"
dt = 0.01
[run]
steps = 100
[diagnostics]
observables = ["temperature", "colloid_solvent_rdf"]
rdf_bin_width = 0.05
rdf_range = 3.0
[[reference]]
kind = "value"
name = "t"
observable = "temperature"
value = 1.0
metric = "relative_error"
tolerance = 0.1
source = "s"
"#;

#[test]
fn documented_keys_are_exactly_the_parsed_keys() {
    let physical_tau = every_physical_key_tau();
    let colloids_phi = EVERY_COLLOID_KEY.replace("count = 4", "volume_fraction = 0.02");
    let colloids_centres =
        EVERY_COLLOID_KEY.replace("count = 4", "centres = [[1.0, 1.0, 1.0], [5.0, 5.0, 5.0]]");
    let loaded = case_from_str(EVERY_KEY, "every_key.toml");
    let text = toml::to_string(&loaded.case).expect("serialise");
    let value: toml::Value = toml::from_str(&text).expect("re-parse");
    let mut found = BTreeSet::new();
    paths("", &value, &mut found);
    // The homogeneous-flow scene's keys (shared ones such as run.* appear in both).
    let flow = mesorheo::config::parse_scene(EVERY_FLOW_KEY, std::path::Path::new("flow.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let mesorheo::config::CaseScene::HomogeneousFlow(flow) = flow else {
        panic!("a [flow] table makes a homogeneous-flow scene");
    };
    let text = toml::to_string(&flow).expect("serialise");
    paths("", &toml::from_str(&text).expect("re-parse"), &mut found);
    let bddfs = mesorheo::config::parse_scene(EVERY_BDDFS_KEY, std::path::Path::new("bddfs.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let mesorheo::config::CaseScene::HomogeneousFlow(bddfs) = bddfs else {
        panic!("a [flow] table makes a homogeneous-flow scene");
    };
    let text = toml::to_string(&bddfs).expect("serialise");
    paths("", &toml::from_str(&text).expect("re-parse"), &mut found);
    let every_gas_key = common::small_gas(2, 8.0, 0.0, "cubic", 100, "");
    let gas = case_from_str(&every_gas_key, "gas.toml");
    let text = toml::to_string(&gas.case.fluid).expect("serialise");
    paths(
        "fluid",
        &toml::from_str(&text).expect("re-parse"),
        &mut found,
    );
    for (text, name) in [
        (EVERY_SPH_KEY, "sph.toml"),
        (EVERY_DUMBBELL_KEY, "dumbbells.toml"),
        (EVERY_FLUID_BDDFS_KEY, "fluid_bddfs.toml"),
        (EVERY_MSPH_KEY, "msph.toml"),
        (EVERY_PHYSICAL_KEY_SC, "physical_sc.toml"),
        (physical_tau.as_str(), "physical_tau.toml"),
        (EVERY_GENERIC_POLYMER_KEY, "generic_polymer.toml"),
        (EVERY_GENERIC_POLYMER_SI_KEY, "generic_polymer_si.toml"),
        (EVERY_COLLOID_KEY, "colloids.toml"),
        (colloids_phi.as_str(), "colloids_phi.toml"),
        (colloids_centres.as_str(), "colloids_centres.toml"),
    ] {
        let sph = case_from_str(text, name);
        let text = toml::to_string(&sph.case).expect("serialise");
        paths("", &toml::from_str(&text).expect("re-parse"), &mut found);
    }
    let documented: BTreeSet<String> = keys().iter().map(|k| k.path.to_owned()).collect();
    let missing: Vec<_> = found.difference(&documented).collect();
    let stale: Vec<_> = documented.difference(&found).collect();
    assert!(
        missing.is_empty(),
        "keys without documentation: {missing:?}"
    );
    assert!(
        stale.is_empty(),
        "documented keys the parser does not know: {stale:?}"
    );
    // The case itself uses every documented key.
    let mut in_text = BTreeSet::new();
    for text in [
        EVERY_KEY,
        EVERY_FLOW_KEY,
        EVERY_BDDFS_KEY,
        &every_gas_key,
        EVERY_SPH_KEY,
        EVERY_DUMBBELL_KEY,
        EVERY_FLUID_BDDFS_KEY,
        EVERY_MSPH_KEY,
        EVERY_PHYSICAL_KEY_SC,
        physical_tau.as_str(),
        EVERY_GENERIC_POLYMER_KEY,
        EVERY_GENERIC_POLYMER_SI_KEY,
        EVERY_COLLOID_KEY,
        colloids_phi.as_str(),
        colloids_centres.as_str(),
    ] {
        paths(
            "",
            &toml::from_str::<toml::Value>(text).expect("toml"),
            &mut in_text,
        );
    }
    assert_eq!(in_text, documented);
}

#[test]
fn docs_case_reference_is_up_to_date() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/case-reference.md");
    let on_disk = std::fs::read_to_string(&path).expect("docs/case-reference.md");
    assert!(
        on_disk == render_markdown(),
        "docs/case-reference.md is stale: regenerate with `mesorheo keys > docs/case-reference.md`"
    );
}

#[test]
fn every_stock_case_is_valid() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut n = 0;
    for entry in std::fs::read_dir(dir).expect("cases/") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "toml") {
            mesorheo::config::load_scene(&path, &[]).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 6);
}

/// The README's minimal case (the first ```toml block under "## A minimal case") parses, runs
/// and reports the observables it asks for: the newcomer's first file cannot rot.
#[test]
fn the_readme_minimal_case_runs() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let readme = std::fs::read_to_string(&path).expect("README.md");
    let section = &readme[readme
        .find("## A minimal case")
        .expect("README has a \"## A minimal case\" section")..];
    let start = section.find("```toml\n").expect("a ```toml block") + "```toml\n".len();
    let text = &section[start..start + section[start..].find("```").expect("closed block")];
    let loaded = case_from_str(text, "README minimal case");
    let s = mesorheo::driver::run_in_process(&loaded, 1, 1, None)
        .unwrap_or_else(|e| panic!("the README's minimal case: {e}"));
    assert!(s.completed, "the README's minimal case did not complete");
    for name in ["temperature", "viscosity"] {
        let v = s
            .observables
            .get(name)
            .unwrap_or_else(|| panic!("the README's minimal case reports no {name}"));
        assert!(v.mean.is_finite() && v.mean > 0.0, "{name} = {}", v.mean);
    }
}
