//! `mesorheo`: command-line entry point. Thin: parse arguments, start the communicator and
//! logging, hand over to the library.

use clap::{Parser, Subcommand};
use mesorheo::comm::Comm;
use mesorheo::config;
use mesorheo::driver::{RunOptions, restart_case, run_case, write_summary};
use std::path::PathBuf;
use std::process::ExitCode;
use tracing_subscriber::filter::Targets;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::{Layer, fmt};

#[derive(Parser)]
#[command(
    name = "mesorheo",
    version,
    about = "Particle solver for polymeric and viscoelastic flows"
)]
struct Cli {
    /// No progress or info lines on the console: the results table, warnings and errors only.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Debug output on the console.
    #[arg(long, short, global = true, conflicts_with = "quiet")]
    verbose: bool,
    /// Level of the per-rank log files OUT/logs/rankNNNN.log: error, warn, info, debug or
    /// trace, or a tracing directive such as `mesorheo=debug` [default: MESORHEO_LOG, else
    /// info]. At debug, each rank logs its neighbour-list rebuilds once per progress interval;
    /// at trace, every rebuild.
    #[arg(long, global = true, value_name = "LEVEL", value_parser = log_level)]
    log_level: Option<String>,
    /// `run` and `restart`: draw no PNGs at the end (OUT/observables.png, and
    /// OUT/velocity_profile.png where the case records a velocity profile; drawn with the
    /// matplotlib of MESORHEO_PYTHON, else python3).
    #[arg(long, global = true)]
    no_plots: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case (under mpirun: on all ranks).
    Run {
        /// Case file (TOML).
        case: PathBuf,
        /// Output directory (summary.json, logs/).
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// rayon threads per rank (0: all cores available to the rank).
        #[arg(long, short = 't', default_value_t = 0)]
        threads: usize,
        /// Override the case's run.steps (validated like the file).
        #[arg(long)]
        steps: Option<u64>,
        /// Override any key: `--set integrator.dt=0.02` (repeatable; TOML values).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        overrides: Vec<String>,
        /// Stop cleanly at this step with a checkpoint (what a batch job does before its
        /// wall-clock limit); continue with `mesorheo restart`.
        #[arg(long, value_name = "K")]
        until_step: Option<u64>,
        /// Wall-clock budget: after timing the first 20 steps, stop (with a checkpoint and an
        /// error) if the remaining steps would take longer than this many hours.
        #[arg(long, value_name = "H", value_parser = positive_hours)]
        max_hours: Option<f64>,
    },
    /// Continue a run from a checkpoint, on any number of ranks. Given a directory, the newest
    /// checkpoint in it; a corrupt checkpoint is reported and the previous one is used.
    Restart {
        /// Checkpoint file (OUT/checkpoints/checkpoint_<step>.h5) or a directory of them.
        checkpoint: PathBuf,
        /// Output directory (default: the run directory the checkpoint belongs to).
        #[arg(long)]
        out: Option<PathBuf>,
        /// rayon threads per rank (0: all cores available to the rank).
        #[arg(long, short = 't', default_value_t = 0)]
        threads: usize,
        /// New total step count (to extend a finished run).
        #[arg(long)]
        steps: Option<u64>,
        /// Stop cleanly at this step with a checkpoint.
        #[arg(long, value_name = "K")]
        until_step: Option<u64>,
        /// Wall-clock budget in hours (as for `run`).
        #[arg(long, value_name = "H", value_parser = positive_hours)]
        max_hours: Option<f64>,
    },
    /// Print what an HDF5 file written by mesorheo holds (series, steps, fields, case).
    Info {
        /// Snapshot series or checkpoint.
        file: PathBuf,
    },
    /// Validate a case and print particle count, neighbours, dimensionless groups, time-step
    /// limits, memory and cost.
    Check {
        /// Case file (TOML).
        case: PathBuf,
        /// Rank count to check the decomposition for.
        #[arg(long, short = 'n', default_value_t = 1)]
        ranks: usize,
        /// Override any key: `--set integrator.dt=0.02` (repeatable; TOML values).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        overrides: Vec<String>,
    },
    /// Print the case-file key reference (Markdown).
    Keys,
    /// Speed/accuracy study: run every point of a sweep file (knobs × values) as an ordinary
    /// run, and write the error against cost (study.csv, study.png), the Pareto front and the
    /// cheapest point meeting a tolerance. Resumes: finished points are not run again.
    Study {
        /// Sweep file (TOML; see the README's "Studies").
        sweep: PathBuf,
        /// Output folder (default: out/study/<sweep name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Tolerance of the recommendation (overrides the sweep's `target`).
        #[arg(long, value_name = "TOL", value_parser = positive_hours)]
        target: Option<f64>,
        /// Run every point again, even those already done.
        #[arg(long)]
        rerun: bool,
    },
    /// Stability map: the largest stable value of a knob (by bisection over trial runs that a
    /// blow-up detector stops or not) at each value of a second parameter, beside what `check`
    /// accepts (stability.csv, stability.png).
    Stability {
        /// Case file (TOML).
        case: PathBuf,
        /// The knob to maximise.
        #[arg(long, default_value = "integrator.dt")]
        vary: String,
        /// The second parameter: KEY=a..b (with --points, --log) or KEY=v1,v2,….
        #[arg(long)]
        over: String,
        /// Values of a range.
        #[arg(long, default_value_t = 5)]
        points: usize,
        /// Geometric spacing of a range.
        #[arg(long)]
        log: bool,
        /// Steps of every trial run.
        #[arg(long, default_value_t = 1000)]
        steps: u64,
        /// Stop bisecting when unstable/stable ≤ 1 + this.
        #[arg(long, default_value_t = 0.05)]
        tolerance: f64,
        /// Fixed overrides of every trial (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        overrides: Vec<String>,
        /// rayon threads of every trial.
        #[arg(long, short = 't', default_value_t = 1)]
        threads: usize,
        /// Output folder (default: out/stability/<case name>).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    // The environment before MPI_Init, for the child runs of `study` and `stability`.
    let pristine_env: Vec<(std::ffi::OsString, std::ffi::OsString)> = std::env::vars_os().collect();
    // The MPI universe is declared first so that it is dropped (MPI_Finalize) last.
    #[cfg(feature = "mpi")]
    let Some((universe, _threading)) = mpi::initialize_with_threading(mpi::Threading::Funneled)
    else {
        eprintln!("error: MPI could not be initialised (was it initialised twice?)");
        return ExitCode::FAILURE;
    };
    #[cfg(feature = "mpi")]
    let comm: Box<dyn Comm> = Box::new(mesorheo::comm::MpiComm::new(universe.world()));
    #[cfg(not(feature = "mpi"))]
    let comm: Box<dyn Comm> = Box::new(mesorheo::comm::SerialComm::new());

    let cli = Cli::parse();
    let root = comm.rank() == 0;
    match cli.command {
        Command::Study {
            sweep,
            out,
            target,
            rerun,
        } => {
            if comm.size() > 1 {
                if root {
                    eprintln!(
                        "error: run `mesorheo study` without mpirun: it launches each point \
                         itself, on the sweep file's `ranks`"
                    );
                }
                return ExitCode::from(2);
            }
            study(&sweep, out, target, rerun, cli.quiet, pristine_env)
        }
        Command::Stability {
            case,
            vary,
            over,
            points,
            log,
            steps,
            tolerance,
            overrides,
            threads,
            out,
        } => {
            if comm.size() > 1 {
                if root {
                    eprintln!("error: run `mesorheo stability` without mpirun");
                }
                return ExitCode::from(2);
            }
            let (over, over_values) = match mesorheo::stability_map::parse_over(&over, points, log)
            {
                Ok(v) => v,
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(2);
                }
            };
            let Ok(exe) = std::env::current_exe() else {
                eprintln!("error: cannot locate the mesorheo executable to run the trials");
                return ExitCode::FAILURE;
            };
            let out = out.unwrap_or_else(|| mesorheo::stability_map::default_out(&case));
            let request = mesorheo::stability_map::StabilityRequest {
                case,
                vary,
                over,
                over_values,
                steps,
                tolerance,
                set: overrides,
                threads,
                out: out.clone(),
                exe,
                python: Some(python()),
                progress: !cli.quiet,
                child_env: Some(pristine_env),
            };
            match mesorheo::stability_map::run_stability(&request) {
                Ok(rows) => {
                    print!("{}", mesorheo::stability_map::report(&request, &rows));
                    println!("wrote {0}/stability.csv, {0}/stability.png", out.display());
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Command::Keys => {
            if root {
                print!("{}", config::reference::render_markdown());
            }
            ExitCode::SUCCESS
        }
        Command::Check {
            case,
            ranks,
            overrides,
        } => match config::load_scene(&case, &overrides) {
            Ok(loaded) => {
                let ranks = ranks.max(1);
                let loaded = match loaded.scene {
                    config::CaseScene::Particles(c) => *c,
                    config::CaseScene::HomogeneousFlow(flow) => {
                        let (report, verdict) = mesorheo::check::flow_report(&flow, ranks);
                        if root {
                            print!("{report}");
                        }
                        return match verdict {
                            Ok(()) => ExitCode::SUCCESS,
                            Err(e) => {
                                if root {
                                    eprintln!("error: {}: {e}", case.display());
                                }
                                ExitCode::from(2)
                            }
                        };
                    }
                };
                let ranks = ranks.max(1);
                if root {
                    print!("{}", mesorheo::check::report(&loaded, ranks));
                }
                if let Err(e) = mesorheo::capacity::check_rank_memory(
                    &loaded,
                    ranks,
                    mesorheo::capacity::available_memory(),
                ) {
                    if root {
                        eprintln!("error: {}: {e}", case.display());
                    }
                    return ExitCode::from(2);
                }
                let max = mesorheo::capacity::max_ranks(&loaded);
                if ranks > max {
                    if root {
                        eprintln!(
                            "error: {} cannot run on {ranks} ranks: slabs would be thinner than \
                             cutoff + skin; use at most {max}",
                            case.display()
                        );
                    }
                    return ExitCode::from(2);
                }
                ExitCode::SUCCESS
            }
            Err(e) => {
                if root {
                    eprintln!("error: {e}");
                }
                ExitCode::from(2)
            }
        },
        Command::Info { file } => info(root, &file),
        Command::Run {
            case,
            out,
            threads,
            steps,
            mut overrides,
            until_step,
            max_hours,
        } => {
            if let Some(n) = steps {
                overrides.push(format!("run.steps={n}"));
            }
            let loaded = match config::load_scene(&case, &overrides) {
                Ok(l) => l,
                Err(e) => {
                    if root {
                        eprintln!("error: {e}");
                    }
                    return ExitCode::from(2);
                }
            };
            let options = RunOptions {
                threads,
                steps: None,
                until_step,
                out: Some(out.clone()),
                max_hours,
            };
            let logs = Logs {
                quiet: cli.quiet,
                verbose: cli.verbose,
                file_level: cli.log_level.clone(),
                plots: !cli.no_plots,
            };
            session(&*comm, &out, &logs, |comm| match &loaded.scene {
                config::CaseScene::HomogeneousFlow(flow) => {
                    mesorheo::driver::run_flow_case(flow, &loaded.path, comm, &options)
                }
                config::CaseScene::Particles(c) => {
                    let particles = config::LoadedCase {
                        case: (**c).clone(),
                        path: loaded.path.clone(),
                        source: loaded.source.clone(),
                    };
                    run_case(&particles, comm, &options)
                }
            })
        }
        Command::Restart {
            checkpoint,
            out,
            threads,
            steps,
            until_step,
            max_hours,
        } => {
            // Refused before anything is written: no logs, no summary, the file untouched.
            if let Err(e) = mesorheo::driver::check_restart_source(&checkpoint) {
                if root {
                    eprintln!("error: {e}");
                }
                return ExitCode::from(e.exit_code());
            }
            // OUT/checkpoints/checkpoint_N.h5 → OUT; OUT/checkpoints → OUT.
            let out = out.unwrap_or_else(|| {
                let dir = if checkpoint.is_dir() {
                    checkpoint.clone()
                } else {
                    checkpoint
                        .parent()
                        .map(std::path::Path::to_path_buf)
                        .unwrap_or_default()
                };
                let dir = if dir.as_os_str().is_empty() {
                    PathBuf::from(".")
                } else {
                    dir
                };
                let dir = std::fs::canonicalize(&dir).unwrap_or(dir);
                match dir.file_name().and_then(|n| n.to_str()) {
                    Some("checkpoints") => dir.parent().map(|p| p.to_path_buf()).unwrap_or(dir),
                    _ => dir,
                }
            });
            let out = if out.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                out
            };
            let options = RunOptions {
                threads,
                steps,
                until_step,
                out: Some(out.clone()),
                max_hours,
            };
            let logs = Logs {
                quiet: cli.quiet,
                verbose: cli.verbose,
                file_level: cli.log_level.clone(),
                plots: !cli.no_plots,
            };
            session(&*comm, &out, &logs, |comm| {
                restart_case(&checkpoint, comm, &options)
            })
        }
    }
}

/// The Python (with matplotlib) that draws the plots of study and stability: MESORHEO_PYTHON,
/// else python3.
fn python() -> PathBuf {
    std::env::var_os("MESORHEO_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("python3"))
}

/// `mesorheo study`: runs the sweep, prints the recommendation.
fn study(
    sweep: &std::path::Path,
    out: Option<PathBuf>,
    target: Option<f64>,
    rerun: bool,
    quiet: bool,
    child_env: Vec<(std::ffi::OsString, std::ffi::OsString)>,
) -> ExitCode {
    let loaded = match mesorheo::study::load_sweep(sweep) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let out = out.unwrap_or_else(|| {
        let stem = sweep
            .file_stem()
            .map_or("study".into(), |s| s.to_string_lossy().to_string());
        PathBuf::from("out/study").join(stem)
    });
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: cannot locate the mesorheo executable to run the points: {e}");
            return ExitCode::FAILURE;
        }
    };
    let options = mesorheo::study::StudyOptions {
        out: out.clone(),
        exe,
        target,
        rerun,
        python: Some(python()),
        progress: !quiet,
        child_env: Some(child_env),
    };
    match mesorheo::study::run_study(&loaded, &options) {
        Ok(analysis) => {
            print!("{}", analysis.recommendation);
            println!(
                "wrote {0}/study.csv, {0}/study.png, {0}/recommendation.txt",
                out.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(feature = "hdf5")]
fn info(root: bool, file: &std::path::Path) -> ExitCode {
    match mesorheo::output::info::describe(file) {
        Ok(text) => {
            if root {
                print!("{text}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            if root {
                eprintln!("error: {e}");
            }
            ExitCode::from(2)
        }
    }
}

#[cfg(not(feature = "hdf5"))]
fn info(root: bool, file: &std::path::Path) -> ExitCode {
    if root {
        eprintln!(
            "error: cannot read {}: this mesorheo was built without HDF5 (feature `hdf5`)",
            file.display()
        );
    }
    ExitCode::from(2)
}

/// SIGTERM and SIGUSR1 (what batch schedulers send before the wall-clock limit) ask the run to
/// finish its step, write a checkpoint and stop.
fn install_signal_handlers() {
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;
    let flag = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGUSR1] {
        if let Err(e) = signal_hook::flag::register(signal, flag.clone()) {
            eprintln!("warning: cannot install the handler of signal {signal}: {e}");
        }
    }
    std::thread::spawn(move || {
        loop {
            if flag.load(std::sync::atomic::Ordering::SeqCst) {
                mesorheo::driver::request_stop();
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
    });
}

/// What the console and the log files show.
struct Logs {
    /// `-q`: only warnings and errors on the console.
    quiet: bool,
    /// `-v`: debug output on the console.
    verbose: bool,
    /// `--log-level`: the level of the per-rank files.
    file_level: Option<String>,
    /// Whether the run draws its PNGs at the end (not `--no-plots`).
    plots: bool,
}

/// The script that draws a run's PNGs from OUT/observables.csv and OUT/summary.json.
const RUN_PLOTS: &str = include_str!("run_plots.py");

/// Draws OUT/observables.png and, where the case records a velocity profile,
/// OUT/velocity_profile.png with the matplotlib of [`python`] (the mechanism of `study` and
/// `stability`); returns the PNGs written, or why there are none (one line).
fn draw_run_plots(out: &std::path::Path) -> Result<Vec<PathBuf>, String> {
    if !out.join(mesorheo::observables_csv::FILE_NAME).exists() {
        return Ok(Vec::new());
    }
    let python = python();
    let o = std::process::Command::new(&python)
        .arg("-c")
        .arg(RUN_PLOTS)
        .arg(out)
        .output()
        .map_err(|e| {
            format!(
                "cannot start {} ({e}); set MESORHEO_PYTHON to a Python with matplotlib",
                python.display()
            )
        })?;
    if !o.status.success() {
        let stderr = String::from_utf8_lossy(&o.stderr);
        return Err(format!(
            "{}: {}",
            python.display(),
            stderr.lines().last().unwrap_or("failed")
        ));
    }
    Ok(String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(PathBuf::from)
        .collect())
}

/// The target of the log records that only the files take (the console shows the same text in
/// the results table).
const FILES_ONLY: &str = "mesorheo::results";

/// Logging, signal handlers, the run itself, summary.json and the exit code.
fn session(
    comm: &dyn Comm,
    out: &std::path::Path,
    logs: &Logs,
    job: impl FnOnce(&dyn Comm) -> Result<mesorheo::summary::Summary, mesorheo::error::Error>,
) -> ExitCode {
    let root = comm.rank() == 0;
    let _guard = match init_logging(comm.rank(), out, logs) {
        Ok(g) => g,
        Err(e) => {
            if root {
                eprintln!("error: {e}");
            }
            return ExitCode::from(2);
        }
    };
    install_signal_handlers();
    match job(comm) {
        Ok(summary) => {
            if root {
                if let Err(e) = write_summary(&summary, out) {
                    eprintln!("error: cannot write {}/summary.json: {e}", out.display());
                    return ExitCode::FAILURE;
                }
                // The results table (each warning once, in it) under -q too: quiet means no
                // progress or info lines, not no results (a failed reference exits 3, and the
                // table says which).
                eprint!("{}", mesorheo::summary::render(&summary));
                for w in &summary.warnings {
                    tracing::warn!(target: FILES_ONLY, "{w}");
                }
                tracing::info!("wrote {}/summary.json", out.display());
                if logs.plots {
                    match draw_run_plots(out) {
                        Ok(pngs) => {
                            for png in pngs {
                                tracing::info!("wrote {}", png.display());
                            }
                        }
                        // A missing Python or matplotlib is a note, never a failure.
                        Err(e) => eprintln!("note: no plots ({e})"),
                    }
                }
            }
            if summary.validation.iter().all(|v| v.pass) {
                ExitCode::SUCCESS
            } else {
                if root {
                    eprintln!("error: a reference check failed (see above and summary.json)");
                }
                ExitCode::from(3)
            }
        }
        Err(e) => {
            if root {
                eprintln!("error: {e}");
            }
            tracing::error!("{e}");
            // The code follows the variant: a blow-up (4) is told from an invalid case (2) and
            // from a failure of the machine or the files (1), by a script or a stability
            // bisection.
            ExitCode::from(e.exit_code())
        }
    }
}

/// The level of the log files when neither `--log-level` nor MESORHEO_LOG sets one.
const DEFAULT_FILE_LEVEL: &str = "info";

/// Rank 0 logs to stderr; every rank logs to `OUT/logs/rankNNNN.log`, at `--log-level`, else
/// MESORHEO_LOG, else info. The console follows MESORHEO_LOG, else -q / -v, else info.
fn init_logging(
    rank: usize,
    out: &std::path::Path,
    logs: &Logs,
) -> Result<tracing_appender::non_blocking::WorkerGuard, String> {
    use tracing_subscriber::filter::{FilterExt, filter_fn};
    let from_env = match std::env::var("MESORHEO_LOG") {
        Ok(v) if !v.trim().is_empty() => {
            Some(log_level(&v).map_err(|e| format!("MESORHEO_LOG={v:?}: {e}"))?)
        }
        _ => None,
    };
    let file_level = (logs.file_level.clone())
        .or_else(|| from_env.clone())
        .unwrap_or_else(|| DEFAULT_FILE_LEVEL.to_owned());
    let dir = out.join("logs");
    std::fs::create_dir_all(&dir)
        .map_err(|e| format!("cannot write logs under {}: {e}", out.display()))?;
    let file = tracing_appender::rolling::never(&dir, format!("rank{rank:04}.log"));
    let (writer, guard) = tracing_appender::non_blocking(file);
    let file_layer = fmt::layer()
        .with_ansi(false)
        .with_writer(writer)
        .with_filter(targets(&file_level));
    let console_level = if logs.quiet {
        "warn"
    } else if logs.verbose {
        "debug"
    } else {
        "info"
    };
    let console_level = from_env.unwrap_or_else(|| console_level.to_owned());
    let console = (rank == 0).then(|| {
        fmt::layer()
            .with_writer(std::io::stderr)
            .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
            .with_target(false)
            .with_filter(targets(&console_level).and(filter_fn(|meta| meta.target() != FILES_ONLY)))
    });
    tracing_subscriber::registry()
        .with(file_layer)
        .with(console)
        .try_init()
        .map_err(|e| format!("cannot start logging: {e}"))?;
    Ok(guard)
}

/// The filter of a level or directive list that [`log_level`] accepted (`Targets`: `level`,
/// `target=level`, comma-separated; tracing's `EnvFilter` with its span-field regexes pulled the
/// regex crates into every build for a syntax no one used).
fn targets(text: &str) -> Targets {
    text.parse()
        .unwrap_or_else(|_| Targets::new().with_default(tracing::Level::INFO))
}

/// `--log-level` and MESORHEO_LOG: a level or a tracing directive.
fn log_level(text: &str) -> Result<String, String> {
    let text = text.trim();
    if text.is_empty() {
        return Err("empty; give error, warn, info, debug or trace".to_owned());
    }
    // A bare word would parse as a target name ("debg": everything of a target `debg`, so
    // nothing at all): a single word must be a level.
    const LEVELS: [&str; 6] = ["off", "error", "warn", "info", "debug", "trace"];
    if !text.contains(['=', ',']) && !LEVELS.contains(&text.to_ascii_lowercase().as_str()) {
        return Err(format!(
            "{text:?} is not a log level: give error, warn, info, debug or trace, or a \
             directive such as mesorheo=debug"
        ));
    }
    text.parse::<Targets>()
        .map(|_| text.to_owned())
        .map_err(|e| {
            format!(
                "{text:?} is not a log level ({e}): give error, warn, info, debug or trace, or \
                 a directive such as mesorheo=debug"
            )
        })
}

/// `--max-hours` (and `--target`): a positive, finite number.
fn positive_hours(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(h) if h.is_finite() && h > 0.0 => Ok(h),
        Ok(h) => Err(format!(
            "found {h}; the budget must be a positive number of hours"
        )),
        Err(e) => Err(format!("{e}: give a number of hours, e.g. 1.5")),
    }
}
