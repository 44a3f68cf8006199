//! `nnm`: nonlinear normal modes from the command line.

mod beam_study;
mod bench;
mod compute;
mod exit;
mod export;
mod fep;
mod interrupt;
mod modes;
mod out_dir;
mod progress;
mod resonance;
mod response;
mod run;
mod study;
mod vtk;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "nnm",
    version,
    about = "Nonlinear normal modes of structures: shooting with sensitivity analysis, \
             pseudo-arclength continuation, Floquet stability, frequency-energy plots"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Linear modes of a model (or job) file, in ascending frequency.
    Modes {
        /// TOML file with a `[model]` section.
        file: PathBuf,
        /// Also write DIR/modes.csv (index,frequency_rad_s,label,pattern,rigid).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
    },
    /// Compute every branch of a job: DIR/<name>.csv and .json per branch, DIR/fep.png/.svg.
    Run {
        /// Job file (TOML): `[model]` and `[[branch]]` sections.
        job: PathBuf,
        /// Output folder (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Branches computed at once, at least 1 (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
        /// Print errors only: no progress, and the summary only when a branch did not finish.
        #[arg(long, short)]
        quiet: bool,
        /// Also write ParaView files (beams and solids): DIR/vtk/modes.pvd (the linear mode
        /// shapes) and DIR/vtk/<branch>-<point>.pvd (a period's motion in 32 frames) for the
        /// POINTS of each branch: first, last, all, or indices such as 0,10,-1.
        #[arg(
            long,
            value_name = "POINTS",
            num_args = 0..=1,
            default_missing_value = "first,last",
            allow_negative_numbers = true
        )]
        vtk: Option<vtk::VtkPoints>,
    },
    /// Write a job's model as a finite-element code exports it: DIR/M.mtx and K.mtx (Matrix
    /// Market), f2.txt and f3.txt (quadratic and cubic force terms) and DIR/<job>.toml, which
    /// reads them and copies the job's branches and responses (same dofs).
    Export {
        /// Job file (TOML) whose `[model]` is written.
        job: PathBuf,
        /// Output folder (created if missing); existing files are not overwritten.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
    /// The bladed-disk study of the paper on a job's model: every backbone, similar vs
    /// nonsimilar modes, localization, the 3:1 tongue, the sensitivity/finite-difference cost
    /// comparison; figures and DIR/report.md.
    Study {
        /// Job file whose [model] is a cyclic bladed disk ([settings] gives the backbone limits).
        job: PathBuf,
        /// Output folder (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// A subset of backbones and no finite-difference comparison, for a first look.
        #[arg(long)]
        quick: bool,
        /// Branches computed at once, at least 1 (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
        /// Print errors only: no progress, no closing line (the report holds everything).
        #[arg(long, short)]
        quiet: bool,
    },
    /// Benchmark table: sensitivity vs finite-difference Jacobian on the same cases, same run.
    Bench {
        /// Repetitions of the single-evaluation case.
        #[arg(long, default_value_t = 5)]
        repeat: usize,
        /// Also the stiff finite-element cases (cantilever beams of 19, 50, 100 and 200 elements,
        /// the von Kármán beam; about a minute).
        #[arg(long)]
        stiff: bool,
        /// Also the large matrix-free cases (the 1,000-element beam, its backbone and its forced
        /// resonance, the (1,0) mode of a 5,000-sector disk, the first mode of a 3,333-element
        /// von Kármán beam and the forced resonance of a 3,336-element one, built-in and
        /// imported, all of 10^4 dofs; about half an hour).
        #[arg(long)]
        large: bool,
    },
    /// Run a built-in study end to end; its job file is written into DIR to edit and rerun.
    Example {
        #[command(subcommand)]
        which: Example,
    },
}

#[derive(Subcommand, Clone)]
enum Example {
    /// The paper's 30-sector nonlinear bladed disk: the whole study of docs/method.md §11 (`nnm study`).
    BladedDisk(ExampleArgs),
    /// Duffing oscillator against its exact period.
    Duffing(ExampleArgs),
    /// The two-DOF system of Kerschen et al. (2009).
    TwoDof(ExampleArgs),
    /// The ECL cantilever beam (NLvib's example 09; 19 elements, cubic tip spring): linear
    /// frequencies against Euler-Bernoulli theory, NNMs of modes 1-3 in Hz and J, the first
    /// one's deflected shape along its branch; DIR/report.md.
    CantileverBeam(ExampleArgs),
}

#[derive(clap::Args, Clone)]
struct ExampleArgs {
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR")]
    out: std::path::PathBuf,
    /// Print errors only: no progress, no summary (the files hold everything).
    #[arg(long, short)]
    quiet: bool,
    /// A first look: the bladed disk's subset of backbones without the finite-difference
    /// comparison; the cantilever beam's first NNM only.
    #[arg(long)]
    quick: bool,
}

/// Output piped into a program that stops reading (`nnm modes m.toml | head`) should end the
/// process quietly, as for other command-line tools, not as a failed write. Rust ignores
/// SIGPIPE by default; restore the default action.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any other thread exists; setting a signal's
    // disposition to SIG_DFL has no other precondition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    interrupt::install();
    // A bug must still end in one line on stderr, not a backtrace.
    std::panic::set_hook(Box::new(|info| {
        let message = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        let location = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        eprintln!("error: internal error (please report): {message}{location}");
    }));
    match std::panic::catch_unwind(|| execute(Cli::parse())) {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(e)) => {
            let text = format!("{e:#}").replace('\n', " ");
            eprintln!("error: {text}");
            ExitCode::from(exit::exit_code(&e))
        }
        Err(_) => ExitCode::from(101),
    }
}

/// `--threads 0` would mean rayon's default (one per core), which leaving the option out
/// already says; as a count it is a slip, refused rather than silently read as "all".
fn check_threads(threads: Option<usize>) -> Result<()> {
    if threads == Some(0) {
        anyhow::bail!("--threads must be at least 1 (leave it out for one thread per core)");
    }
    Ok(())
}

fn execute(cli: Cli) -> Result<()> {
    if let Command::Run { threads, .. } | Command::Study { threads, .. } = &cli.command {
        check_threads(*threads)?;
    }
    match cli.command {
        Command::Modes { file, out } => modes::modes(&file, out.as_deref()),
        Command::Run {
            job,
            out,
            threads,
            quiet,
            vtk,
        } => {
            // The forced responses' progress asks the switch (`say!`); branches carry it.
            progress::set_quiet(quiet);
            run::run_job(&job, &out, threads, quiet, vtk.as_ref())
        }
        Command::Export { job, out } => export::export(&job, &out),
        Command::Study {
            job,
            out,
            quick,
            threads,
            quiet,
        } => {
            progress::set_quiet(quiet);
            study::bladed_disk_study(&job, &out, &study::StudyOptions { quick, threads })
        }
        Command::Bench {
            repeat,
            stiff,
            large,
        } => bench::bench(repeat, stiff, large),
        Command::Example { which } => {
            let (Example::BladedDisk(a)
            | Example::Duffing(a)
            | Example::TwoDof(a)
            | Example::CantileverBeam(a)) = &which;
            progress::set_quiet(a.quiet);
            let bladed_disk = matches!(which, Example::BladedDisk(_));
            let (name, text, args) = match which {
                Example::CantileverBeam(a) => {
                    let options = beam_study::BeamOptions {
                        quick: a.quick,
                        quiet: a.quiet,
                    };
                    return beam_study::cantilever_beam_example(&a.out, &options);
                }
                Example::BladedDisk(a) => (
                    "bladed-disk",
                    include_str!("../../../examples/bladed-disk.toml"),
                    a,
                ),
                Example::Duffing(a) => {
                    ("duffing", include_str!("../../../examples/duffing.toml"), a)
                }
                Example::TwoDof(a) => {
                    ("two-dof", include_str!("../../../examples/two-dof.toml"), a)
                }
            };
            let job = write_example_job(&args.out, name, text)?;
            if bladed_disk {
                let options = study::StudyOptions {
                    quick: args.quick,
                    threads: None,
                };
                study::bladed_disk_study(&job, &args.out, &options)
            } else {
                run::run_job(&job, &args.out, None, args.quiet, None)
            }
        }
    }
}

/// Writes an example's job file as `DIR/<name>.toml` (creating DIR), to edit and rerun; returns
/// its path.
fn write_example_job(out: &Path, name: &str, text: &str) -> Result<PathBuf> {
    out_dir::create_dir(out)?;
    let job = out.join(format!("{name}.toml"));
    std::fs::write(&job, text).with_context(|| format!("cannot write {}", job.display()))?;
    progress::say!("example {name}: job file written to {}", job.display());
    Ok(job)
}
