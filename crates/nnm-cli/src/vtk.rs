//! `nnm run --vtk`: ParaView files of a run on a model with a layout (beams, solids): the
//! linear mode shapes, and the motion over one period of chosen points of each branch.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use nnm::MechanicalSystem;
use nnm::model::Layout;
use nnm::modes::LinearMode;
use nnm_io::vtk::write_motion;

use crate::compute::Outcome;

/// Frames of a motion: one period cut into this many equal times.
pub const FRAMES: usize = 32;

/// Mode shapes written, at most (the lowest).
const MODE_SHAPES: usize = 20;

/// Relative accuracy of the sampled motions: far below what a picture shows.
const MOTION_TOLERANCE: f64 = 1e-6;

/// Which points of each branch `--vtk` draws: `first`, `last`, `all`, or indices (negative
/// from the end), comma-separated; checked before anything is computed.
#[derive(Debug, Clone, PartialEq)]
pub struct VtkPoints(Vec<PointChoice>);

#[derive(Debug, Clone, Copy, PartialEq)]
enum PointChoice {
    All,
    Index(i64),
}

impl std::str::FromStr for VtkPoints {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        s.split(',')
            .map(|word| match word.trim() {
                "all" => Ok(PointChoice::All),
                "first" => Ok(PointChoice::Index(0)),
                "last" => Ok(PointChoice::Index(-1)),
                w => w.parse().map(PointChoice::Index).map_err(|_| {
                    format!(
                        "`{w}` is not a point: give first, last, all, or indices such as 0,10,-1"
                    )
                }),
            })
            .collect::<Result<_, _>>()
            .map(VtkPoints)
    }
}

impl VtkPoints {
    /// The chosen indices of a branch of `count` points, ascending, each once.
    fn indices(&self, count: usize) -> Vec<usize> {
        let mut chosen: Vec<usize> = self
            .0
            .iter()
            .flat_map(|c| match *c {
                PointChoice::All => (0..count).collect::<Vec<_>>(),
                PointChoice::Index(i) => {
                    let k = if i < 0 { count as i64 + i } else { i };
                    (0..count as i64)
                        .contains(&k)
                        .then_some(k as usize)
                        .into_iter()
                        .collect()
                }
            })
            .collect();
        chosen.sort_unstable();
        chosen.dedup();
        chosen
    }
}

/// Refuses `--vtk` on a model with nothing to draw on, before anything is computed.
pub fn check_layout(layout: Option<&Layout>) -> Result<&Layout> {
    match layout {
        Some(layout) => Ok(layout),
        None => bail!(
            "--vtk draws on a model's nodes: the beam and solid families have them, this model does not"
        ),
    }
}

/// Writes `DIR/vtk/modes.pvd` (the lowest linear mode shapes, mass-normalised, one "time"
/// step per mode) and, for each computed branch, `DIR/vtk/<branch>-<point>.pvd`: the motion
/// of the chosen points over one period in [`FRAMES`] frames. Returns the files written and,
/// one line each, those that could not be (a motion that failed to integrate, a file that
/// could not be written): the branches' results stand whatever happens here.
pub fn write(
    system: &(impl MechanicalSystem + ?Sized),
    layout: &Layout,
    modes: &[LinearMode],
    outcomes: &[Outcome],
    points: &VtkPoints,
    out: &Path,
) -> (Vec<PathBuf>, Vec<String>) {
    let folder = out.join("vtk");
    let (mut written, mut failed) = (Vec::new(), Vec::new());
    let shapes: Vec<(f64, Vec<f64>)> = modes
        .iter()
        .take(MODE_SHAPES)
        .enumerate()
        .map(|(k, m)| (k as f64, m.shape.clone()))
        .collect();
    let path = folder.join("modes.pvd");
    match write_motion(&path, layout, &shapes) {
        Ok(()) => written.push(path),
        Err(e) => failed.push(e.to_string()),
    }
    let n = system.dofs();
    for outcome in outcomes {
        let Ok(branch) = &outcome.result else {
            continue;
        };
        for i in points.indices(branch.points.len()) {
            let point = &branch.points[i];
            let path = folder.join(format!("{}-{i}.pvd", outcome.info.name));
            let states = match nnm::analysis::sample_motion(
                system,
                &point.z0,
                point.period,
                FRAMES,
                MOTION_TOLERANCE,
            ) {
                Ok(states) => states,
                Err(e) => {
                    failed.push(format!("{}: the motion of point {i}: {e}", path.display()));
                    continue;
                }
            };
            let frames: Vec<(f64, Vec<f64>)> = states
                .into_iter()
                .take(FRAMES)
                .enumerate()
                .map(|(k, z)| (k as f64 * point.period / FRAMES as f64, z[..n].to_vec()))
                .collect();
            match write_motion(&path, layout, &frames) {
                Ok(()) => written.push(path),
                Err(e) => failed.push(e.to_string()),
            }
        }
    }
    (written, failed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_parse_and_resolve() {
        let p: VtkPoints = "first,last".parse().unwrap();
        assert_eq!(p.indices(5), vec![0, 4]);
        assert_eq!(p.indices(1), vec![0]);
        let p: VtkPoints = "2,-2,9".parse().unwrap();
        assert_eq!(p.indices(5), vec![2, 3]);
        let p: VtkPoints = "all".parse().unwrap();
        assert_eq!(p.indices(3), vec![0, 1, 2]);
        assert!("middle".parse::<VtkPoints>().is_err());
    }
}
