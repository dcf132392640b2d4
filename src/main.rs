//! `mesorheo`: command-line entry point. Thin: parse arguments, start the communicator and
//! logging, hand over to the library.

use clap::{Parser, Subcommand};
use mesorheo::comm::Comm;
use mesorheo::config;
use mesorheo::driver::{RunOptions, run_case, write_summary};
use std::path::PathBuf;
use std::process::ExitCode;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::{EnvFilter, Layer, fmt};

#[derive(Parser)]
#[command(
    name = "mesorheo",
    version,
    about = "Particle solver for polymeric and viscoelastic flows"
)]
struct Cli {
    /// Only warnings and errors on the console.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Debug output on the console.
    #[arg(long, short, global = true, conflicts_with = "quiet")]
    verbose: bool,
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
}

fn main() -> ExitCode {
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
        } => match config::load_with_overrides(&case, &overrides) {
            Ok(loaded) => {
                let ranks = ranks.max(1);
                if root {
                    print!("{}", mesorheo::check::report(&loaded.case, ranks));
                }
                let max = mesorheo::check::max_ranks(&loaded.case);
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
        Command::Run {
            case,
            out,
            threads,
            steps,
            mut overrides,
        } => {
            if let Some(n) = steps {
                overrides.push(format!("run.steps={n}"));
            }
            run(
                &*comm,
                &case,
                &out,
                threads,
                &overrides,
                cli.quiet,
                cli.verbose,
            )
        }
    }
}

fn run(
    comm: &dyn Comm,
    case: &std::path::Path,
    out: &std::path::Path,
    threads: usize,
    overrides: &[String],
    quiet: bool,
    verbose: bool,
) -> ExitCode {
    let root = comm.rank() == 0;
    let loaded = match config::load_with_overrides(case, overrides) {
        Ok(l) => l,
        Err(e) => {
            if root {
                eprintln!("error: {e}");
            }
            return ExitCode::from(2);
        }
    };
    let _guard = match init_logging(comm.rank(), out, quiet, verbose) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: cannot write logs under {}: {e}", out.display());
            return ExitCode::FAILURE;
        }
    };
    let options = RunOptions {
        threads,
        steps: None,
    };
    match run_case(&loaded, comm, &options) {
        Ok(summary) => {
            if root {
                if let Err(e) = write_summary(&summary, out) {
                    eprintln!("error: cannot write {}/summary.json: {e}", out.display());
                    return ExitCode::FAILURE;
                }
                if !quiet {
                    eprint!("{}", mesorheo::summary::render(&summary));
                }
                tracing::info!("wrote {}/summary.json", out.display());
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
            ExitCode::FAILURE
        }
    }
}

/// Rank 0 logs to stderr; every rank logs to `OUT/logs/rankNNNN.log`.
fn init_logging(
    rank: usize,
    out: &std::path::Path,
    quiet: bool,
    verbose: bool,
) -> std::io::Result<tracing_appender::non_blocking::WorkerGuard> {
    let dir = out.join("logs");
    std::fs::create_dir_all(&dir)?;
    let file = tracing_appender::rolling::never(&dir, format!("rank{rank:04}.log"));
    let (writer, guard) = tracing_appender::non_blocking(file);
    let file_layer = fmt::layer()
        .with_ansi(false)
        .with_writer(writer)
        .with_filter(EnvFilter::new("debug"));
    let console_level = if quiet {
        "warn"
    } else if verbose {
        "debug"
    } else {
        "info"
    };
    let console = (rank == 0).then(|| {
        fmt::layer()
            .with_writer(std::io::stderr)
            .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
            .with_target(false)
            .with_filter(
                EnvFilter::try_from_env("MESORHEO_LOG")
                    .unwrap_or_else(|_| EnvFilter::new(console_level)),
            )
    });
    tracing_subscriber::registry()
        .with(file_layer)
        .with(console)
        .try_init()
        .map_err(std::io::Error::other)?;
    Ok(guard)
}
