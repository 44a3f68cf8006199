//! The backbones of the study: which modes are continued, their continuation in parallel, and
//! what the later sections read off a computed branch (its frequency at a given energy, where
//! it turns back in energy). Numbers only; nothing here writes a report or a figure.

use crate::progress::say;
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Result, bail};
use nnm::model::Structure;
use nnm::modes::{LinearMode, StandingWave};
use nnm::{Branch, BranchPoint, Settings};
use nnm_io::job::BranchJob;

use super::StudyOptions;
use crate::compute::{Outcome, compute_all, compute_branch, failures, make_start, resolve};
use crate::out_dir::create_dir;

/// Backbones of the quick study: enough for every section (the tongue's ends (0,6) and (1,12),
/// the localizing (1,14), the switch on (1,5)) and a few to compare with.
const QUICK_MODES: [&str; 7] = ["0,2", "0,6", "0,14", "1,0", "1,5", "1,12", "1,14"];

/// The computed backbones, all successful (a failure stops the study).
pub(super) struct Backbones {
    pub outcomes: Vec<Outcome>,
    /// Wall time of the parallel continuation.
    pub seconds: f64,
    /// Threads the backbones were computed on.
    pub threads: usize,
}

impl Backbones {
    /// The backbone of the mode labelled `label` ("n,d"); the study only asks for modes it
    /// computed.
    pub fn branch(&self, label: &str) -> &Branch {
        self.outcomes
            .iter()
            .find(|o| o.info.mode_label == label)
            .and_then(|o| o.result.as_ref().ok())
            .expect("computed above")
    }

    /// Every backbone with its outcome (name, label, timing), in the order computed.
    pub fn computed(&self) -> impl Iterator<Item = (&Outcome, &Branch)> {
        self.outcomes
            .iter()
            .filter_map(|o| Some((o, o.result.as_ref().ok()?)))
    }

    pub fn total_points(&self) -> usize {
        self.computed().map(|(_, b)| b.points.len()).sum()
    }
}

/// "1 thread", "4 threads".
pub(super) fn threads_text(threads: usize) -> String {
    match threads {
        1 => "1 thread".into(),
        n => format!("{n} threads"),
    }
}

fn name_of(label: &str) -> String {
    format!("mode-{}", label.replace(',', "-"))
}

/// Continues the backbone of every distinct mode (one member of each degenerate pair, the cos
/// wave) — or of `QUICK_MODES` in quick mode — in parallel, into `out/backbones`.
pub(super) fn compute(
    structure: &Structure,
    modes: &[LinearMode],
    settings: &Settings,
    options: &StudyOptions,
    out: &Path,
) -> Result<Backbones> {
    let labels: Vec<String> = if options.quick {
        QUICK_MODES.iter().map(|s| s.to_string()).collect()
    } else {
        modes
            .iter()
            .filter(|m| {
                !m.rigid
                    && m.cyclic
                        .is_some_and(|c| c.pattern != Some(StandingWave::Sin))
            })
            .map(LinearMode::label)
            .collect()
    };
    let jobs: Vec<BranchJob> = labels
        .iter()
        .map(|label| BranchJob {
            name: name_of(label),
            mode: label.clone(),
            from_event: None,
            pattern: None,
            travel: None,
            settings: settings.clone(),
        })
        .collect();
    let backbone_dir = out.join("backbones");
    create_dir(&backbone_dir)?;
    // The pool `compute_all` builds has this many threads (rayon's default: one per core).
    let threads = options.threads.unwrap_or_else(rayon::current_num_threads);
    say!(
        "study: {} backbones on {}",
        jobs.len(),
        threads_text(threads)
    );
    let started = Instant::now();
    let outcomes = compute_all(
        structure,
        resolve(structure, &jobs, modes)?,
        &backbone_dir,
        options.threads,
        true,
    )?;
    let seconds = started.elapsed().as_secs_f64();
    let failed = failures(&outcomes);
    if !failed.is_empty() {
        bail!("backbones failed: {}", failed.join("; "));
    }
    Ok(Backbones {
        outcomes,
        seconds,
        threads,
    })
}

/// A backbone that turns back in energy: it met a fold or an internal resonance (a tongue)
/// before the energy limit.
pub(super) struct TurnBack {
    pub label: String,
    /// Energy where it first turns back.
    pub first_energy: f64,
    /// How many times the energy changes direction along it.
    pub reversals: usize,
}

pub(super) fn turning_back(backbones: &Backbones) -> Vec<TurnBack> {
    backbones
        .computed()
        .filter_map(|(o, b)| {
            let reversals = b
                .points
                .windows(3)
                .filter(|w| (w[1].energy - w[0].energy) * (w[2].energy - w[1].energy) < 0.0)
                .count();
            let first_energy = b
                .points
                .windows(2)
                .find(|w| w[1].energy < w[0].energy)
                .map(|w| w[0].energy)?;
            Some(TurnBack {
                label: o.info.mode_label.clone(),
                first_energy,
                reversals,
            })
        })
        .collect()
}

/// Frequency of a branch at energy `e`, by cubic Lagrange interpolation in `log E` through the
/// points around its crossing of `e` (fewer when the branch is short or folds there). `None`
/// when the branch never reaches `e` or crosses it more than once (it folds: the frequency at
/// that energy is not unique).
pub(super) fn frequency_at(branch: &Branch, e: f64) -> Option<f64> {
    let p = &branch.points;
    let crossings: Vec<usize> = (0..p.len().saturating_sub(1))
        .filter(|&k| {
            (p[k].energy - e) * (p[k + 1].energy - e) <= 0.0 && p[k].energy != p[k + 1].energy
        })
        .collect();
    let [k] = crossings[..] else { return None };
    // Nodes k-1..=k+2 on the monotone stretch around the crossing.
    let rising = p[k + 1].energy > p[k].energy;
    let monotone = |a: usize, b: usize| (p[b].energy > p[a].energy) == rising;
    let lo = if k > 0 && monotone(k - 1, k) {
        k - 1
    } else {
        k
    };
    let hi = if k + 2 < p.len() && monotone(k + 1, k + 2) {
        k + 2
    } else {
        k + 1
    };
    let x = e.ln();
    let nodes: Vec<(f64, f64)> = p[lo..=hi]
        .iter()
        .map(|q| (q.energy.ln(), q.frequency))
        .collect();
    Some(lagrange(&nodes, x))
}

/// Lagrange interpolation through `nodes` at `x`.
pub(super) fn lagrange(nodes: &[(f64, f64)], x: f64) -> f64 {
    nodes
        .iter()
        .enumerate()
        .map(|(i, &(xi, yi))| {
            nodes
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .fold(yi, |acc, (_, &(xj, _))| acc * (x - xj) / (xi - xj))
        })
        .sum()
}

/// Computes one branch of the study quietly (files in `out`), `extra` seeing every point: the
/// tongue and the finely sampled (1,12) reference, which are not backbones of the parallel run.
pub(super) fn single_branch(
    structure: &Structure,
    modes: &[LinearMode],
    job: &BranchJob,
    out: &Path,
    extra: impl FnMut(&BranchPoint) -> ControlFlow<&'static str>,
) -> Result<Branch> {
    let request = resolve(structure, std::slice::from_ref(job), modes)?
        .pop()
        .expect("one request per job");
    let mut info = request.info.clone();
    let start = make_start(structure, &request, None, &mut info)?;
    compute_branch(
        structure,
        &start,
        &request.job,
        &info,
        out,
        true,
        &Mutex::new(()),
        extra,
    )
}
