//! `nnm run`: every branch of a job computed and written, its plots, the summary, and the exit
//! verdict.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use nnm::StopReason;
use nnm::modes::{add_labelled_mode, linear_modes};
use nnm_io::job::{BranchJob, load_job};
use nnm_io::output::write_modes_csv;

use crate::compute::{NotStarted, Outcome, compute_all, failures, print_summary, resolve};
use crate::exit::Unfinished;
use crate::fep;
use crate::out_dir::{OutDir, foreign_branches};
use crate::progress::say;
use crate::resonance::ComputedBranch;
use crate::response;
use crate::vtk::VtkPoints;

/// Computes every branch and response curve of the job file `job_path` into `out`
/// (docs/output.md), on `threads` worker threads (default one per core): branches side by
/// side, the curves one after another, a large model's split stage solves on the same
/// threads.
pub fn run_job(
    job_path: &Path,
    out: &Path,
    threads: Option<usize>,
    quiet: bool,
    vtk: Option<&VtkPoints>,
) -> Result<()> {
    let job = load_job(job_path)?;
    let layout = match vtk {
        Some(_) => Some(crate::vtk::check_layout(job.layout.as_ref())?),
        None => None,
    };
    if job.branches.is_empty() && job.responses.is_empty() {
        bail!(
            "{}: the job has no [[branch]] or [[response]] to compute",
            job_path.display()
        );
    }
    let mut modes = linear_modes(&job.structure).context("modal analysis failed")?;
    // A label beyond the lowest modes of a large cyclic model (its sector problem).
    for b in job.branches.iter().filter(|b| b.from_event.is_none()) {
        add_labelled_mode(&job.structure, &mut modes, &b.mode, b.pattern)
            .with_context(|| format!("branch `{}`: modal analysis failed", b.name))?;
    }
    let requests = resolve(&job.structure, &job.branches, &modes)?;
    check_responses_resolvable(&job.responses, &modes)?;
    let _lock = OutDir::lock(out)?;
    warn_of_foreign_branches(out, &job.branches);
    write_modes_csv(&out.join("modes.csv"), &modes)?;
    let clock = Instant::now();
    let outcomes = compute_all(&job.structure, requests, out, threads, quiet)?;
    if !outcomes.is_empty() {
        fep::plot(&outcomes, &modes, &out.join("fep"), "Frequency-energy plot")?;
        fep::amplitude_plot(&outcomes, &modes, &out.join("amplitude"))?;
    }
    // The computed branches, where a response looks for its backbone.
    let computed: Vec<ComputedBranch<'_>> = outcomes
        .iter()
        .filter_map(|o| {
            let branch = o.result.as_ref().ok()?;
            let job = job.branches.iter().find(|b| b.name == o.info.name)?;
            Some(ComputedBranch {
                name: &o.info.name,
                output_dofs: &o.info.output_dofs,
                points: &branch.points,
                balance: job.settings.output.energy_balance.as_deref(),
            })
        })
        .collect();
    for branch in &computed {
        crate::resonance::plot_resonance_peaks(branch, out)?;
    }
    let curves = match &job.damping {
        Some(damping) if !job.responses.is_empty() => {
            // One curve at a time; `threads` bounds what a large model's stage solves share.
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads.unwrap_or(0))
                .build()
                .context("cannot start worker threads")?
                .install(|| {
                    response::run_responses(&job.structure, damping, &job.responses, &computed, out)
                })?
        }
        _ => Vec::new(),
    };
    if let (Some(points), Some(layout)) = (vtk, layout) {
        let (written, failed) =
            crate::vtk::write(&job.structure, layout, &modes, &outcomes, points, out);
        say!(
            "ParaView: {} collections (.pvd) in {}",
            written.len(),
            out.join("vtk").display()
        );
        // Printed even with --quiet: files the user asked for are missing.
        for why in failed {
            eprintln!("warning: ParaView file not written: {why}");
        }
    }
    let early = stopped_early(&outcomes);
    let verdict = unfinished(&outcomes, &early).and(curves_verdict(&curves));
    // Quiet means errors only: nothing on a successful run. When a branch failed, stopped
    // early or was interrupted, the summary says which, beside the `error: ...` line.
    if !quiet {
        crate::progress::separate();
    }
    if !quiet || verdict.is_err() {
        if !outcomes.is_empty() {
            print_summary(&outcomes, &modes);
        }
        response::print_summary(&curves);
        println!(
            "wall time {:.2} s; results in {}{}",
            clock.elapsed().as_secs_f64(),
            out.display(),
            match early.len() {
                0 => String::new(),
                1 => "; 1 branch stopped before its limit".into(),
                n => format!("; {n} branches stopped before their limits"),
            }
        );
    }
    verdict
}

/// Refuses a response whose forcing frequencies the model's lowest natural frequency puts out
/// of reach ([`nnm::forced::check_sweep_resolvable`]), before anything is written.
fn check_responses_resolvable(
    responses: &[nnm_io::job::ResponseJob],
    modes: &[nnm::modes::LinearMode],
) -> Result<()> {
    let lowest = modes
        .iter()
        .map(|m| m.frequency)
        .filter(|&w| w > 0.0)
        .fold(f64::INFINITY, f64::min);
    if !lowest.is_finite() {
        return Ok(());
    }
    for r in responses {
        for sweep in &r.body.curves {
            nnm::forced::check_sweep_resolvable(sweep, lowest)
                .map_err(|e| anyhow::anyhow!("response `{}`: {e}", r.name))?;
        }
    }
    Ok(())
}

/// The run's verdict, most serious first: interrupted (Ctrl-C stopped or skipped a branch; one
/// that came after the last branch ended changed nothing), a branch failed, a branch stopped
/// before its limit; `Ok` when every branch reached its limit.
fn unfinished(outcomes: &[Outcome], early: &[String]) -> Result<()> {
    let cut_short = |o: &&Outcome| match &o.result {
        Ok(b) => b.stop == StopReason::Interrupted,
        Err(e) => e.is::<NotStarted>(),
    };
    let finished = outcomes.len() - outcomes.iter().filter(cut_short).count();
    if finished < outcomes.len() {
        return Err(Unfinished::Interrupted(format!(
            "interrupted: {finished} of {} branches finished; the summary and files hold what was computed",
            outcomes.len()
        ))
        .into());
    }
    let failures = failures(outcomes);
    if !failures.is_empty() {
        bail!(
            "{} of {} branches failed ({})",
            failures.len(),
            outcomes.len(),
            failures.join("; ")
        );
    }
    if !early.is_empty() {
        return Err(Unfinished::StoppedEarly(format!(
            "{} of {} branches stopped before their limits ({}); their points are written",
            early.len(),
            outcomes.len(),
            early.join("; ")
        ))
        .into());
    }
    Ok(())
}

/// The responses' verdict, as [`unfinished`]'s for branches: interrupted, a curve that could
/// not start, a curve whose continuation failed part-way (its points are written).
fn curves_verdict(curves: &[response::CurveOutcome]) -> Result<()> {
    let (interrupted, failed, early) = response::unfinished(curves);
    if interrupted > 0 {
        return Err(Unfinished::Interrupted(format!(
            "interrupted: {} of {} response curves finished; the summary and files hold what was computed",
            curves.len() - interrupted,
            curves.len()
        ))
        .into());
    }
    if !failed.is_empty() {
        bail!(
            "{} of {} response curves failed ({})",
            failed.len(),
            curves.len(),
            failed.join("; ")
        );
    }
    if !early.is_empty() {
        return Err(Unfinished::StoppedEarly(format!(
            "{} of {} response curves stopped before the end of their sweep ({}); their points are written",
            early.len(),
            curves.len(),
            early.join("; ")
        ))
        .into());
    }
    Ok(())
}

/// `"<branch>: <why>"` for every branch that stopped before its limits because a step failed
/// even at the minimum size: a partial branch a script must not take for the one asked for.
fn stopped_early(outcomes: &[Outcome]) -> Vec<String> {
    outcomes
        .iter()
        .filter_map(|o| match &o.result {
            Ok(b) if matches!(b.stop, StopReason::StepTooSmall(_)) => {
                Some(format!("{}: {}", o.info.name, b.stop))
            }
            _ => None,
        })
        .collect()
}

/// One warning line when `out` holds branch files of another job: they stay (they may be
/// someone's results; deleting them is not this run's call), but the user must not take them
/// for this job's, nor wonder why the plot leaves them out.
fn warn_of_foreign_branches(out: &Path, branches: &[BranchJob]) {
    let names: Vec<String> = branches.iter().map(|b| b.name.clone()).collect();
    let foreign = foreign_branches(out, &names);
    if !foreign.is_empty() {
        crate::progress::line(format_args!(
            "warning: {} holds results of branches not in this job ({}); they are left as they are and not plotted",
            out.display(),
            foreign.join(", ")
        ));
    }
}
