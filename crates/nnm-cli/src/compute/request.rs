//! Which branch starts where: each job entry resolved to its linear mode, or to the event of
//! its parent branch it switches at.

use anyhow::{Context, Result, anyhow, bail};
use nnm::Start;
use nnm::bifurcation::switch_branch;
use nnm::model::Structure;
use nnm::modes::LinearMode;
use nnm_io::job::{BranchJob, EventStart, SWITCH_AMPLITUDE, phase_name, resolve_mode};
use nnm_io::output::{BranchInfo, SwitchedFrom};

use super::outcome::Outcome;

/// A branch ready to compute: what the job asked, the mode it starts from, and its start when
/// that is a linear mode.
#[derive(Clone)]
pub struct BranchRequest {
    pub job: BranchJob,
    pub index: usize,
    pub info: BranchInfo,
    /// The start from the linear mode (`None` for a branch started from an event).
    pub start: Option<Start>,
}

/// The starting mode of each branch and, for a branch started from a linear mode, its start,
/// made before anything is computed or written: a wrong label, a pattern the mode does not
/// have (a travelling wave of a single mode) or any other start the model refuses fails the
/// command at once, not once other branches' files are written. A branch started from an
/// event inherits its parent's mode (its start needs the parent's results).
pub fn resolve(
    structure: &Structure,
    branches: &[BranchJob],
    modes: &[LinearMode],
) -> Result<Vec<BranchRequest>> {
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
                start: None,
            });
            continue;
        }
        let index = resolve_mode(modes, &b.mode, b.pattern)
            .map_err(|m| anyhow!("branch `{}`: {m}", b.name))?;
        let start = Start::for_branch(structure, modes, index, b.travel, &b.settings)
            .map_err(|e| anyhow!("branch `{}`: {e}", b.name))?;
        let mode = &modes[index];
        requests.push(BranchRequest {
            start: Some(start),
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

/// The start of a branch: its linear mode, or the switch at its parent's event (which also
/// records, in `info`, where the branch came from).
pub fn make_start(
    structure: &Structure,
    request: &BranchRequest,
    parent: Option<(&EventStart, &Outcome)>,
    info: &mut BranchInfo,
) -> Result<Start> {
    let job = &request.job;
    let start = match parent {
        None => match &request.start {
            Some(start) => start.clone(),
            None => bail!("branch `{}`: no start was made for its mode", job.name),
        },
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
