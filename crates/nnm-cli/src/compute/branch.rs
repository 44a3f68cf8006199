//! One branch followed from its start, written as it goes, with the warnings its end calls for.

use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use anyhow::Result;
use nnm::integrate::IntegrationMethod;
use nnm::model::Structure;
use nnm::{Branch, BranchPoint, Start, StopReason, continue_branch_observed};
use nnm_io::job::BranchJob;
use nnm_io::output::{BranchInfo, BranchWriter};

use super::writing::Writing;
use crate::interrupt;

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
    let mut writer = interrupt::writing(|| BranchWriter::create(out, info.clone()))?;
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
            let wall_time = started.elapsed().as_secs_f64();
            interrupt::writing(|| writer.finish(&branch, &stop, wall_time))?;
            if quiet {
                return Ok(branch);
            }
            let _guard = log.lock();
            crate::progress::line(format_args!(
                "[{}] done: {} points, {} events, {stop}",
                info.name,
                branch.points.len(),
                branch.events.len(),
            ));
            // A requested value without a point is said (and kept in the JSON), not dropped.
            for missed in &branch.missed_requests {
                crate::progress::line(format_args!("[{}] warning: {missed}", info.name));
            }
            // A conservative orbit's multipliers come in pairs (μ, 1/μ); members without a
            // partner mean what the integrator the branch ran makes them mean. Said, since the
            // stability verdicts rest on them.
            let defect = branch
                .points
                .iter()
                .map(|p| p.floquet.reciprocity_defect)
                .filter(|d| d.is_finite())
                .fold(0.0, f64::max);
            if defect > RECIPROCITY_WARNING {
                crate::progress::line(format_args!(
                    "[{}] warning: Floquet multipliers lack reciprocal partners by up to {defect:.1e}: {}",
                    info.name,
                    reciprocity_cause(branch.integrator)
                ));
            }
            Ok(branch)
        }
        Err(e) => {
            interrupt::writing(|| writer.fail(&e.to_string()))?;
            Err(e.into())
        }
    }
}

/// What a reciprocity defect above [`RECIPROCITY_WARNING`] means for a branch integrated by
/// `method`: modes damped by design (Radau IIA on a fine mesh: docs/method.md §6), or, for a
/// method that damps nothing (the explicit pairs, symplectic Gauss–Legendre), an integration
/// not accurate enough for the multipliers, with the setting that makes it more accurate.
fn reciprocity_cause(method: Option<IntegrationMethod>) -> String {
    match method {
        Some(m) if m.damps_unresolved_modes() => format!(
            "{} damps the modes its step does not resolve (by design), so the stability verdicts see only the resolved modes",
            m.name()
        ),
        Some(m) => format!(
            "{} damps no mode by design, so this is the integration's error and the stability verdicts may be wrong; a smaller {} makes it more accurate",
            m.name(),
            if m.is_collocation() {
                "`tolerance`"
            } else {
                "`integration_factor` (or `tolerance`)"
            }
        ),
        None => "the integrator damps modes it does not resolve or is not accurate enough, so the stability verdicts may be wrong".into(),
    }
}

/// Largest reciprocity defect `|μν − 1|` of a branch's multiplier pairs before a warning:
/// resolved multipliers pair to ~1e-5 at worst (near-double pairs; 2.4e-6 on the bladed
/// disk's (0,1) backbone), a damped fast mode by far more (0.017 for radau5's 0.9915 on two
/// DOF with ω = 1 and √401).
const RECIPROCITY_WARNING: f64 = 1e-3;
