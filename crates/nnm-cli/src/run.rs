//! The `modes` and `run` commands: files in, library calls, files and progress out.

use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use nnm::continuation::{Branch, BranchPoint, Start, continue_branch};
use nnm::model::Structure;
use nnm::modes::{LinearMode, StandingWave, find_mode, linear_modes};
use nnm_io::job::{BranchJob, load_job};
use nnm_io::output::{BranchInfo, BranchWriter, write_modes_csv};
use nnm_plot::{FrequencyEnergyPlot, Series, SeriesPoint};
use rayon::prelude::*;

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
/// fails at once.
pub fn resolve(branches: &[BranchJob], modes: &[LinearMode]) -> Result<Vec<BranchRequest>> {
    branches
        .iter()
        .map(|b| {
            let (index, mode) = find_mode(modes, &b.mode, b.pattern).ok_or_else(|| {
                let labels = modes.iter().any(|m| m.cyclic.is_some());
                let hint = if labels {
                    "a label \"n,d\" listed by `nnm modes`, or an index"
                } else {
                    "an index from 0 to the number of modes - 1 (this model has no (n,d) labels)"
                };
                anyhow!("branch `{}`: unknown mode `{}` (expected {hint})", b.name, b.mode)
            })?;
            if mode.rigid {
                bail!(
                    "branch `{}`: mode `{}` is a rigid-body mode and has no nonlinear normal mode",
                    b.name,
                    b.mode
                );
            }
            let found = mode.cyclic.and_then(|c| c.pattern);
            if b.pattern.is_some() && found.is_some() && b.pattern != found {
                bail!(
                    "branch `{}`: mode {} is the {} wave of its pair, but `pattern` asks for the other",
                    b.name,
                    b.mode,
                    if found == Some(StandingWave::Cos) { "cos" } else { "sin" }
                );
            }
            if b.pattern.is_some() && mode.cyclic.is_none_or(|c| c.pattern.is_none()) {
                bail!(
                    "branch `{}`: `pattern` applies only to a degenerate pair, and mode `{}` is single",
                    b.name,
                    b.mode
                );
            }
            Ok(BranchRequest {
                job: b.clone(),
                index,
                info: BranchInfo {
                    name: b.name.clone(),
                    mode_index: index,
                    mode_label: mode.label(),
                    pattern: mode.cyclic.and_then(|c| c.pattern),
                    linear_frequency_rad_s: mode.frequency,
                    symmetry: None,
                },
            })
        })
        .collect()
}

pub struct Outcome {
    pub info: BranchInfo,
    pub result: Result<Branch>,
    pub seconds: f64,
}

pub fn run_job(job_path: &Path, out: &Path, threads: Option<usize>, quiet: bool) -> Result<()> {
    let job = load_job(job_path)?;
    if job.branches.is_empty() {
        bail!(
            "{}: the job has no [[branch]] to compute",
            job_path.display()
        );
    }
    let modes = linear_modes(&job.structure).context("modal analysis failed")?;
    let requests = resolve(&job.branches, &modes)?;
    create_dir(out)?;
    write_modes_csv(&out.join("modes.csv"), &modes)?;
    let clock = Instant::now();
    let outcomes = compute_all(&job.structure, &modes, requests, out, threads, quiet)?;
    plot(&outcomes, &out.join("fep"), "Frequency-energy plot")?;
    if !quiet {
        eprintln!();
    }
    print_summary(&outcomes);
    println!(
        "wall time {:.2} s; results in {}",
        clock.elapsed().as_secs_f64(),
        out.display()
    );
    let failures: Vec<String> = outcomes
        .iter()
        .filter_map(|o| {
            o.result
                .as_ref()
                .err()
                .map(|e| format!("{}: {e:#}", o.info.name))
        })
        .collect();
    if !failures.is_empty() {
        bail!(
            "{} of {} branches failed ({})",
            failures.len(),
            outcomes.len(),
            failures.join("; ")
        );
    }
    Ok(())
}

/// Computes branches in parallel (one per worker thread), each written to `out` as it goes.
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
    Ok(pool.install(|| {
        requests
            .into_par_iter()
            .map(|request| {
                let started = Instant::now();
                let result = compute_branch(structure, modes, &request, out, quiet, &log, |_| {
                    ControlFlow::Continue(())
                });
                let done = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                if total > 1 {
                    let _guard = log.lock();
                    eprintln!(
                        "progress: {done}/{total} branches done ({:.1} s)",
                        clock.elapsed().as_secs_f64()
                    );
                }
                Outcome {
                    info: request.info,
                    result,
                    seconds: started.elapsed().as_secs_f64(),
                }
            })
            .collect()
    }))
}

/// One line per branch: points, energy and frequency reached, time, why it stopped.
pub fn print_summary(outcomes: &[Outcome]) {
    println!(
        "{:<16} {:>6} {:>7} {:>11} {:>11} {:>10} {:>8}  stop",
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
                    "{:<16} {:>6} {:>7} {:>11.4e} {:>11.6} {:>9.2}% {:>8.2}  {}",
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
            Err(e) => println!("{:<16} failed: {e:#}", o.info.name),
        }
    }
}

trait Label {
    fn mode_label_or_index(&self) -> String;
}

impl Label for BranchInfo {
    fn mode_label_or_index(&self) -> String {
        if self.mode_label.is_empty() {
            self.mode_index.to_string()
        } else {
            self.mode_label.clone()
        }
    }
}

/// Computes one branch, writing every point as it converges; `extra` sees each point after it
/// is written and may stop the branch.
pub fn compute_branch(
    structure: &Structure,
    modes: &[LinearMode],
    request: &BranchRequest,
    out: &Path,
    quiet: bool,
    log: &Mutex<()>,
    mut extra: impl FnMut(&BranchPoint) -> ControlFlow<()>,
) -> Result<Branch> {
    let (branch, index, info) = (&request.job, request.index, &request.info);
    let started = Instant::now();
    let mut start = Start::from_linear_mode(structure, modes, index, branch.energy_start)?;
    if !branch.symmetry {
        start = start.unrestricted();
    }
    let info = &BranchInfo {
        symmetry: start.symmetry,
        ..info.clone()
    };
    let mut writer = BranchWriter::create(out, info.clone())?;
    let mut write_error = None;
    let result = continue_branch(structure, &start, &branch.settings, |p| {
        if let Err(e) = writer.write_point(p) {
            write_error = Some(e);
            return ControlFlow::Break(());
        }
        if !quiet {
            let _guard = log.lock();
            eprintln!(
                "[{}] point {:>3}  E = {:<11.4e} f = {:.6} rad/s ({:+.3}%)  {}  |mu|max = {:.6}",
                info.name,
                p.index,
                p.energy,
                p.frequency,
                100.0 * (p.frequency / info.linear_frequency_rad_s - 1.0),
                if p.floquet.stable {
                    "stable  "
                } else {
                    "unstable"
                },
                p.floquet.max_modulus
            );
        }
        extra(p)
    });
    if let Some(e) = write_error {
        return Err(e.into());
    }
    match result {
        Ok(branch) => {
            writer.finish(&branch, started.elapsed().as_secs_f64())?;
            let _guard = log.lock();
            eprintln!(
                "[{}] done: {} points, {}",
                info.name,
                branch.points.len(),
                branch.stop
            );
            Ok(branch)
        }
        Err(e) => {
            writer.fail(&e.to_string())?;
            Err(e.into())
        }
    }
}

/// One frequency–energy plot of every branch that has points: `<stem>.png` and `<stem>.svg`.
pub fn plot(outcomes: &[Outcome], stem: &Path, title: &str) -> Result<()> {
    let series: Vec<Series> = outcomes
        .iter()
        .filter_map(|o| {
            let branch = o.result.as_ref().ok()?;
            Some(Series {
                label: o.info.name.clone(),
                points: branch
                    .points
                    .iter()
                    .map(|p| SeriesPoint {
                        energy: p.energy,
                        frequency: p.frequency,
                        stable: p.floquet.stable,
                    })
                    .collect(),
                ..Default::default()
            })
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    if series.is_empty() {
        return Ok(());
    }
    FrequencyEnergyPlot {
        title: title.into(),
        series,
        frequency_label: "frequency (rad/s)".into(),
        ..Default::default()
    }
    .write(stem)?;
    Ok(())
}
