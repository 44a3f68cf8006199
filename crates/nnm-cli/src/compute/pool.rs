//! Branches computed at once, one per worker thread, in rounds: a branch switched at an event of
//! another waits for the round after its parent's.

use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use nnm::model::Structure;
use rayon::prelude::*;

use super::branch::compute_branch;
use super::outcome::{NotStarted, Outcome};
use super::request::{BranchRequest, make_start};
use crate::interrupt;

/// Computes branches in parallel (one per worker thread), each written to `out` as it goes.
/// Branches started from an event of another run in a later round, once their parent is done.
pub fn compute_all(
    structure: &Structure,
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
            // One branch a task: branches differ in cost by 10× or more (the study's
            // backbones 0.1–8 s), and rayon's default halving of the list left one core idle
            // for 16 s of the study's 50.
            ready
                .par_iter()
                .with_max_len(1)
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
                    let result =
                        make_start(structure, request, parent, &mut info).and_then(|start| {
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
                        });
                    let done = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    if total > 1 && !quiet {
                        let _guard = log.lock();
                        crate::progress::line(format_args!(
                            "progress: {done}/{total} branches done ({:.1} s)",
                            clock.elapsed().as_secs_f64()
                        ));
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
