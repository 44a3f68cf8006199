//! The `modes` and `run` commands: files in, library calls, files and progress out.

use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use nnm::analysis::{RegimeKind, regime_changes};
use nnm::bifurcation::{Event, switch_branch};
use nnm::integrate::IntegrationMethod;
use nnm::model::Structure;
use nnm::modes::{LinearMode, add_labelled_mode, linear_modes};
use nnm::shooting::{EvaluationProgress, Travel};
use nnm::{Branch, BranchPoint, Observer, Start, StopReason, continue_branch_observed};
use nnm_io::job::{BranchJob, EventStart, load_job, resolve_mode};
use nnm_io::output::{BranchInfo, BranchWriter, SwitchedFrom, write_modes_csv};
use rayon::prelude::*;

use crate::out_dir::{OutDir, foreign_branches};
use crate::{Unfinished, interrupt};

pub fn modes(file: &Path, out: Option<&Path>) -> Result<()> {
    let job = load_job(file)?;
    let modes = linear_modes(&job.structure).context("modal analysis failed")?;
    println!(
        "{:>5}  {:>16}  {:>6}  {:>7}",
        "index", "frequency_rad_s", "label", "pattern"
    );
    for (k, m) in modes.iter().enumerate() {
        let pattern = match m.cyclic.and_then(|c| c.pattern) {
            Some(p) => format!("{p:?}").to_lowercase(),
            None if m.rigid => "rigid".into(),
            None => String::new(),
        };
        println!(
            "{k:>5}  {:>16.9}  {:>6}  {:>7}",
            m.frequency,
            m.label(),
            pattern
        );
    }
    if let Some(dir) = out {
        create_dir(dir)?;
        let path = dir.join("modes.csv");
        write_modes_csv(&path, &modes)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))
}

/// A branch ready to compute: what the job asked, and the mode it starts from.
#[derive(Clone)]
pub struct BranchRequest {
    pub job: BranchJob,
    pub index: usize,
    pub info: BranchInfo,
}

/// The starting mode of each branch, resolved before any computation so that a wrong label
/// fails at once. A branch started from an event inherits its parent's mode.
pub fn resolve(branches: &[BranchJob], modes: &[LinearMode]) -> Result<Vec<BranchRequest>> {
    let mut requests: Vec<BranchRequest> = Vec::with_capacity(branches.len());
    for b in branches {
        if let Some(from) = &b.from_event {
            let parent = requests
                .iter()
                .find(|r| r.job.name == from.branch)
                .ok_or_else(|| {
                    anyhow!(
                        "branch `{}`: `start` refers to branch `{}`, which must come before it",
                        b.name,
                        from.branch
                    )
                })?;
            requests.push(BranchRequest {
                job: b.clone(),
                index: parent.index,
                info: BranchInfo {
                    name: b.name.clone(),
                    ..parent.info.clone()
                },
            });
            continue;
        }
        let index = resolve_mode(modes, &b.mode, b.pattern)
            .map_err(|m| anyhow!("branch `{}`: {m}", b.name))?;
        let mode = &modes[index];
        requests.push(BranchRequest {
            job: b.clone(),
            index,
            info: BranchInfo {
                name: b.name.clone(),
                mode_index: index,
                mode_label: mode.label(),
                pattern: b
                    .travel
                    .is_none()
                    .then(|| mode.cyclic.and_then(|c| c.pattern))
                    .flatten(),
                travel: b.travel,
                linear_frequency_rad_s: mode.frequency,
                symmetry: None,
                switched_from: None,
                output_dofs: Vec::new(),
            },
        });
    }
    Ok(requests)
}

pub struct Outcome {
    pub info: BranchInfo,
    /// The branch, or why it failed ([`NotStarted`] after Ctrl-C).
    pub result: Result<Branch>,
    pub seconds: f64,
    /// The start the branch was computed from (what a switched branch builds on).
    pub start: Option<Start>,
}

pub fn run_job(job_path: &Path, out: &Path, threads: Option<usize>, quiet: bool) -> Result<()> {
    let job = load_job(job_path)?;
    if job.branches.is_empty() {
        bail!(
            "{}: the job has no [[branch]] to compute",
            job_path.display()
        );
    }
    let mut modes = linear_modes(&job.structure).context("modal analysis failed")?;
    // A label beyond the lowest modes of a large cyclic model (its sector problem).
    for b in job.branches.iter().filter(|b| b.from_event.is_none()) {
        add_labelled_mode(&job.structure, &mut modes, &b.mode, b.pattern)
            .with_context(|| format!("branch `{}`: modal analysis failed", b.name))?;
    }
    let requests = resolve(&job.branches, &modes)?;
    let _lock = OutDir::lock(out)?;
    warn_of_foreign_branches(out, &job.branches);
    write_modes_csv(&out.join("modes.csv"), &modes)?;
    let clock = Instant::now();
    let outcomes = compute_all(&job.structure, &modes, requests, out, threads, quiet)?;
    crate::fep::plot(&outcomes, &modes, &out.join("fep"), "Frequency-energy plot")?;
    crate::fep::amplitude_plot(&outcomes, &modes, &out.join("amplitude"))?;
    let early = stopped_early(&outcomes);
    let verdict = unfinished(&outcomes, &early);
    // Quiet means errors only: nothing on a successful run. When a branch failed, stopped
    // early or was interrupted, the summary says which, beside the `error: ...` line.
    if !quiet {
        eprintln!();
    }
    if !quiet || verdict.is_err() {
        print_summary(&outcomes, &modes);
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
        eprintln!(
            "warning: {} holds results of branches not in this job ({}); they are left as they are and not plotted",
            out.display(),
            foreign.join(", ")
        );
    }
}

/// A branch skipped because Ctrl-C came before it started.
#[derive(Debug)]
pub struct NotStarted;

impl std::fmt::Display for NotStarted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("not started (interrupted)")
    }
}

impl std::error::Error for NotStarted {}

/// `"<branch>: <error>"` for every branch that failed (not those skipped after Ctrl-C).
pub fn failures(outcomes: &[Outcome]) -> Vec<String> {
    outcomes
        .iter()
        .filter_map(|o| {
            let e = o.result.as_ref().err()?;
            (!e.is::<NotStarted>()).then(|| format!("{}: {e:#}", o.info.name))
        })
        .collect()
}

/// Computes branches in parallel (one per worker thread), each written to `out` as it goes.
/// Branches started from an event of another run in a later round, once their parent is done.
pub fn compute_all(
    structure: &Structure,
    modes: &[LinearMode],
    requests: Vec<BranchRequest>,
    out: &Path,
    threads: Option<usize>,
    quiet: bool,
) -> Result<Vec<Outcome>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let log = Mutex::new(());
    let total = requests.len();
    let finished = std::sync::atomic::AtomicUsize::new(0);
    let clock = Instant::now();
    let names: Vec<String> = requests.iter().map(|r| r.job.name.clone()).collect();
    let mut outcomes: Vec<Option<Outcome>> = (0..total).map(|_| None).collect();
    while outcomes.iter().any(Option::is_none) {
        let ready: Vec<usize> = (0..total)
            .filter(|&k| outcomes[k].is_none())
            .filter(|&k| match &requests[k].job.from_event {
                None => true,
                Some(from) => names
                    .iter()
                    .position(|n| *n == from.branch)
                    .is_some_and(|p| outcomes[p].is_some()),
            })
            .collect();
        if ready.is_empty() {
            bail!("branches refer to each other in a cycle");
        }
        let done: Vec<(usize, Outcome)> = pool.install(|| {
            ready
                .par_iter()
                .map(|&k| {
                    let request = &requests[k];
                    if interrupt::requested() {
                        let outcome = Outcome {
                            info: request.info.clone(),
                            result: Err(NotStarted.into()),
                            seconds: 0.0,
                            start: None,
                        };
                        return (k, outcome);
                    }
                    let started = Instant::now();
                    let parent = request.job.from_event.as_ref().map(|from| {
                        let p = names.iter().position(|n| *n == from.branch).expect("ready");
                        (from, outcomes[p].as_ref().expect("ready"))
                    });
                    let mut info = request.info.clone();
                    let result = make_start(structure, modes, request, parent, &mut info).and_then(
                        |start| {
                            let branch = compute_branch(
                                structure,
                                &start,
                                &request.job,
                                &info,
                                out,
                                quiet,
                                &log,
                                |_| ControlFlow::Continue(()),
                            )?;
                            Ok((branch, start))
                        },
                    );
                    let done = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    if total > 1 && !quiet {
                        let _guard = log.lock();
                        eprintln!(
                            "progress: {done}/{total} branches done ({:.1} s)",
                            clock.elapsed().as_secs_f64()
                        );
                    }
                    let (result, start) = match result {
                        Ok((branch, start)) => (Ok(branch), Some(start)),
                        Err(e) => (Err(e), None),
                    };
                    let outcome = Outcome {
                        info,
                        result,
                        seconds: started.elapsed().as_secs_f64(),
                        start,
                    };
                    (k, outcome)
                })
                .collect()
        });
        for (k, outcome) in done {
            outcomes[k] = Some(outcome);
        }
    }
    Ok(outcomes.into_iter().map(|o| o.expect("all done")).collect())
}

pub use nnm_io::job::{SWITCH_AMPLITUDE, phase_name};

/// The start of a branch: its linear mode, or the switch at its parent's event (which also
/// records, in `info`, where the branch came from).
pub fn make_start(
    structure: &Structure,
    modes: &[LinearMode],
    request: &BranchRequest,
    parent: Option<(&EventStart, &Outcome)>,
    info: &mut BranchInfo,
) -> Result<Start> {
    let job = &request.job;
    let start = match parent {
        None => Start::for_branch(structure, modes, request.index, job.travel, &job.settings)?,
        Some((from, parent)) => {
            let (Ok(branch), Some(parent_start)) = (&parent.result, &parent.start) else {
                bail!("its parent branch `{}` failed", from.branch);
            };
            let event = branch.events.get(from.event).ok_or_else(|| {
                anyhow!(
                    "branch `{}` has {} event{} (see {}.events.csv), so no event {}",
                    from.branch,
                    branch.events.len(),
                    if branch.events.len() == 1 { "" } else { "s" },
                    from.branch,
                    from.event
                )
            })?;
            let switch = switch_branch(
                structure,
                parent_start,
                event,
                &job.settings,
                SWITCH_AMPLITUDE,
                from.direction,
            )
            .with_context(|| {
                format!("cannot switch at event {} of `{}`", from.event, from.branch)
            })?;
            let phase = switch.start.phase.unwrap_or(job.settings.shooting.phase);
            info.switched_from = Some(SwitchedFrom {
                branch: from.branch.clone(),
                event: from.event,
                direction: from.direction,
                kind: event.kind.name().into(),
                phase: phase_name(phase).into(),
            });
            switch.start
        }
    };
    info.symmetry = start.symmetry;
    info.output_dofs = start.output_dofs(&job.settings);
    // A period-doubled family is measured against half the parent's frequency.
    info.linear_frequency_rad_s = start.omega;
    Ok(start)
}

/// One line per branch: points, energy and frequency reached, time, why it stopped; then,
/// for each branch that entered an internal-resonance tongue or left its family, where.
pub fn print_summary(outcomes: &[Outcome], modes: &[LinearMode]) {
    println!(
        "{:<16} {:>8} {:>7} {:>11} {:>11} {:>10} {:>8}  stop",
        "branch", "mode", "points", "E_max", "f_max", "shift", "time_s"
    );
    for o in outcomes {
        match &o.result {
            Ok(branch) => {
                let last = branch.points.last();
                let (e, f) = last.map_or((f64::NAN, f64::NAN), |p| (p.energy, p.frequency));
                let e_max = branch
                    .points
                    .iter()
                    .map(|p| p.energy)
                    .fold(f64::NAN, f64::max);
                println!(
                    "{:<16} {:>8} {:>7} {:>11.4e} {:>11.6} {:>9.2}% {:>8.2}  {}",
                    o.info.name,
                    o.info.mode_label_or_index(),
                    branch.points.len(),
                    e_max.max(e),
                    f,
                    100.0 * (f / o.info.linear_frequency_rad_s - 1.0),
                    o.seconds,
                    branch.stop
                );
            }
            Err(e) if e.is::<NotStarted>() => println!("{:<16} {e}", o.info.name),
            Err(e) => println!("{:<16} failed: {e:#}", o.info.name),
        }
    }
    for o in outcomes {
        let Ok(branch) = &o.result else { continue };
        let notes = regime_notes(&branch.points, o.info.linear_frequency_rad_s, modes);
        if notes.is_empty() {
            continue;
        }
        println!("{}:", o.info.name);
        let shown = notes.len().min(MAX_REGIME_NOTES);
        for note in &notes[..shown] {
            println!("  {note}");
        }
        if notes.len() > shown {
            println!(
                "  ... {} more changes (the regime column of {}.csv has every point)",
                notes.len() - shown,
                o.info.name
            );
        }
    }
}

/// Regime changes listed per branch in the summary, at most.
const MAX_REGIME_NOTES: usize = 6;

/// Where a branch changed regime (docs/method.md eq. (86)): one line at the first point of
/// each stretch in a tongue or on another family (the partner named by its `(n,d)` label or
/// index), and where it came back to its backbone.
pub fn regime_notes(points: &[BranchPoint], linear: f64, modes: &[LinearMode]) -> Vec<String> {
    let name = |mode: usize| match modes.get(mode).map(LinearMode::label) {
        Some(label) if !label.is_empty() => format!("({label})"),
        _ => format!("mode {mode}"),
    };
    let mut notes = Vec::new();
    for k in regime_changes(points.iter().map(|p| p.regime.as_ref())) {
        let p = &points[k];
        let Some(regime) = &p.regime else { continue };
        let partner = regime
            .partner
            .filter(|_| regime.kind != RegimeKind::Backbone);
        let ratio = regime
            .ratio
            .map_or(String::new(), |(m, n)| format!("{m}:{n}"));
        let what = match (regime.kind, partner) {
            (RegimeKind::Tongue, Some(c)) if regime.ratio == Some((1, 1)) => format!(
                "in 1:1 internal resonance with the near-degenerate {} ({:.0}% of the energy)",
                name(c.mode),
                100.0 * c.share
            ),
            (RegimeKind::Tongue, Some(c)) => format!(
                "in a {ratio} internal-resonance tongue with {} ({:.0}% of the energy at {}ω)",
                name(c.mode),
                100.0 * c.share,
                c.harmonic
            ),
            (RegimeKind::OtherFamily, Some(c)) => format!(
                "left its family for that of {} at {}ω ({ratio})",
                name(c.mode),
                c.harmonic
            ),
            _ => "back on its backbone".into(),
        };
        notes.push(format!(
            "point {:>3} (E = {:.4e}, {:+.2}%): {what}",
            p.index,
            p.energy,
            100.0 * (p.frequency / linear - 1.0)
        ));
    }
    notes
}

trait Label {
    fn mode_label_or_index(&self) -> String;
}

impl Label for BranchInfo {
    /// The mode, with `→` for a forward travelling wave and `←` for a backward one.
    fn mode_label_or_index(&self) -> String {
        let mode = if self.mode_label.is_empty() {
            self.mode_index.to_string()
        } else {
            self.mode_label.clone()
        };
        match self.travel {
            Some(Travel::Forward) => format!("{mode} →"),
            Some(Travel::Backward) => format!("{mode} ←"),
            None => mode,
        }
    }
}

/// Computes one branch from `start`, writing every point and event as it is found; `extra`
/// sees each point after it is written and may stop the branch, `Break` giving the stop reason
/// the files record (a deliberate stop is not "interrupted", which is kept for Ctrl-C; the
/// branch in memory says `Interrupted` all the same). Ctrl-C stops it at the next point or
/// event.
#[allow(clippy::too_many_arguments)]
pub fn compute_branch(
    structure: &Structure,
    start: &Start,
    job: &BranchJob,
    info: &BranchInfo,
    out: &Path,
    quiet: bool,
    log: &Mutex<()>,
    extra: impl FnMut(&BranchPoint) -> ControlFlow<&'static str>,
) -> Result<Branch> {
    let started = Instant::now();
    let mut writer = BranchWriter::create(out, info.clone())?;
    let mut observer = Writing {
        writer: &mut writer,
        error: None,
        since_point: Instant::now(),
        points: 0,
        info,
        quiet,
        log,
        extra,
        stopped_by_extra: None,
    };
    let result = continue_branch_observed(structure, start, &job.settings, &mut observer);
    if let Some(e) = observer.error.take() {
        return Err(e.into());
    }
    match result {
        Ok(branch) => {
            let stop = match observer.stopped_by_extra {
                Some(reason) if branch.stop == StopReason::Interrupted => reason.to_string(),
                _ => branch.stop.to_string(),
            };
            writer.finish(&branch, &stop, started.elapsed().as_secs_f64())?;
            if quiet {
                return Ok(branch);
            }
            let _guard = log.lock();
            eprintln!(
                "[{}] done: {} points, {} events, {stop}",
                info.name,
                branch.points.len(),
                branch.events.len(),
            );
            // A requested value without a point is said (and kept in the JSON), not dropped.
            for missed in &branch.missed_requests {
                eprintln!("[{}] warning: {missed}", info.name);
            }
            // A conservative orbit's multipliers come in pairs (μ, 1/μ); members without a
            // partner are modes the integrator damped because it does not resolve them
            // (Radau IIA on a fine mesh, by design: docs/method.md §6). Said, since the
            // stability verdicts then see only the resolved modes.
            let defect = branch
                .points
                .iter()
                .map(|p| p.floquet.reciprocity_defect)
                .filter(|d| d.is_finite())
                .fold(0.0, f64::max);
            if defect > RECIPROCITY_WARNING {
                let damping: Vec<&str> = IntegrationMethod::ALL
                    .into_iter()
                    .filter(|m| m.damps_unresolved_modes())
                    .map(IntegrationMethod::name)
                    .collect();
                eprintln!(
                    "[{}] warning: Floquet multipliers lack reciprocal partners by up to {defect:.1e}: the integrator damps modes it does not resolve ({} does by design), so the stability verdicts see only the resolved modes",
                    info.name,
                    damping.join(", ")
                );
            }
            Ok(branch)
        }
        Err(e) => {
            writer.fail(&e.to_string())?;
            Err(e.into())
        }
    }
}

/// Largest reciprocity defect `|μν − 1|` of a branch's multiplier pairs before a warning:
/// resolved multipliers pair to ~1e-5 at worst (near-double pairs; 2.4e-6 on the bladed
/// disk's (0,1) backbone), a damped fast mode by far more (0.017 for radau5's 0.9915 on two
/// DOF with ω = 1 and √401).
const RECIPROCITY_WARNING: f64 = 1e-3;

/// Writes points and events as the continuation finds them, with a progress line each.
struct Writing<'a, F> {
    writer: &'a mut BranchWriter,
    error: Option<nnm_io::output::OutputError>,
    /// When the last point (or the branch) was done, and how many points there are: a point
    /// that takes longer than [`SLOW_POINT`] shows its evaluations.
    since_point: Instant,
    points: usize,
    info: &'a BranchInfo,
    quiet: bool,
    log: &'a Mutex<()>,
    extra: F,
    /// The stop reason `extra` gave when it stopped the branch.
    stopped_by_extra: Option<&'static str>,
}

impl<F> Writing<'_, F> {
    /// Keeps a write error (the continuation then stops) or prints the progress line.
    fn after_write(
        &mut self,
        written: Result<(), nnm_io::output::OutputError>,
        line: impl FnOnce() -> String,
    ) -> ControlFlow<()> {
        if let Err(e) = written {
            self.error = Some(e);
            return ControlFlow::Break(());
        }
        if !self.quiet {
            let _guard = self.log.lock();
            eprintln!("[{}] {}", self.info.name, line());
        }
        if interrupt::requested() {
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    }
}

/// A point taking longer than this shows its progress (each evaluation of the shooting
/// equations: Newton iterations, and trial points while an event is located).
const SLOW_POINT: std::time::Duration = std::time::Duration::from_secs(1);

impl<F: FnMut(&BranchPoint) -> ControlFlow<&'static str>> Observer for &mut Writing<'_, F> {
    fn evaluation(&mut self, e: &EvaluationProgress) {
        let elapsed = self.since_point.elapsed();
        if !self.quiet && elapsed > SLOW_POINT {
            let _guard = self.log.lock();
            eprintln!(
                "[{}] point {:>3} in progress: evaluation {}, relative residual {:.2e}, T = {:.6e} s ({:.1} s)",
                self.info.name,
                self.points,
                e.evaluations,
                e.relative_residual,
                e.period,
                elapsed.as_secs_f64()
            );
        }
    }

    fn point(&mut self, p: &BranchPoint) -> ControlFlow<()> {
        self.since_point = Instant::now();
        self.points += 1;
        let written = self.writer.write_point(p);
        let linear = self.info.linear_frequency_rad_s;
        self.after_write(written, || {
            format!(
                "point {:>3}  E = {:<11.4e} f = {:.6} rad/s ({:+.3}%)  {}  |mu|max = {:.6}{}",
                p.index,
                p.energy,
                p.frequency,
                100.0 * (p.frequency / linear - 1.0),
                if p.floquet.stable {
                    "stable  "
                } else {
                    "unstable"
                },
                p.floquet.max_modulus,
                p.label
                    .map_or(String::new(), |l| format!("  ({})", l.name()))
            )
        })?;
        match (self.extra)(p) {
            ControlFlow::Break(reason) => {
                self.stopped_by_extra = Some(reason);
                ControlFlow::Break(())
            }
            ControlFlow::Continue(()) => ControlFlow::Continue(()),
        }
    }

    fn event(&mut self, e: &Event) -> ControlFlow<()> {
        let written = self.writer.write_event(e);
        self.after_write(written, || {
            format!(
                "event: {} at E = {:.10e}, f = {:.9} rad/s, multiplier ({:.6}, {:.6}){}",
                e.kind.name(),
                e.point.energy,
                e.point.frequency,
                e.multiplier.0,
                e.multiplier.1,
                if e.converged {
                    ""
                } else {
                    " (location not converged)"
                }
            )
        })
    }
}
