//! Similar vs nonsimilar modes: how far each backbone's shape moves away from its linear mode
//! as the energy grows (the shape angle), and how far its frequency has moved at reference
//! energies. Numbers only.

use nnm::analysis::shape_angle;
use nnm::model::{MechanicalSystem, Structure};
use nnm::modes::LinearMode;

use super::backbones::{Backbones, frequency_at};

/// Reference energies at which frequency shifts are tabulated.
pub(super) const REFERENCE_ENERGIES: [f64; 2] = [10.0, 100.0];

/// One backbone's change of shape and frequency with energy.
pub(super) struct ShapeChange {
    /// The branch's file name and its mode's label.
    pub name: String,
    pub label: String,
    pub linear_frequency: f64,
    /// Every point of the branch with its shape angle.
    pub points: Vec<AnglePoint>,
    /// Largest shape angle along the branch (degrees).
    pub max_angle: f64,
    /// Frequency shift at each of `REFERENCE_ENERGIES`, in percent of the linear frequency;
    /// `None` where the branch does not reach that energy or passes it more than once.
    pub shifts: [Option<f64>; 2],
    /// Wall time of this backbone's continuation.
    pub seconds: f64,
}

pub(super) struct AnglePoint {
    pub energy: f64,
    pub frequency: f64,
    /// Angle in the mass metric between the displacement at the motion's turning point and
    /// the linear mode shape (degrees): 0 for a similar NNM.
    pub angle: f64,
}

impl ShapeChange {
    /// The shape angle at the first point at or above `energy`.
    pub fn angle_from(&self, energy: f64) -> Option<f64> {
        self.points
            .iter()
            .find(|p| p.energy >= energy)
            .map(|p| p.angle)
    }
}

/// The shape change of every backbone, in the order they were computed.
pub(super) fn shape_changes(
    structure: &Structure,
    modes: &[LinearMode],
    backbones: &Backbones,
) -> Vec<ShapeChange> {
    let n = structure.dofs();
    backbones
        .computed()
        .map(|(o, branch)| {
            let linear = &modes[o.info.mode_index];
            let mut max_angle: f64 = 0.0;
            let points = branch
                .points
                .iter()
                .map(|p| {
                    let angle =
                        shape_angle(structure.mass(), &linear.shape, &p.z0[..n]).to_degrees();
                    max_angle = max_angle.max(angle);
                    AnglePoint {
                        energy: p.energy,
                        frequency: p.frequency,
                        angle,
                    }
                })
                .collect();
            let shifts = REFERENCE_ENERGIES
                .map(|e| frequency_at(branch, e).map(|f| 100.0 * (f / linear.frequency - 1.0)));
            ShapeChange {
                name: o.info.name.clone(),
                label: o.info.mode_label.clone(),
                linear_frequency: linear.frequency,
                points,
                max_angle,
                shifts,
                seconds: o.seconds,
            }
        })
        .collect()
}

/// The shape angle of backbone `label` at the first point at or above `energy`.
pub(super) fn angle_from(changes: &[ShapeChange], label: &str, energy: f64) -> Option<f64> {
    changes
        .iter()
        .find(|c| c.label == label)
        .and_then(|c| c.angle_from(energy))
}
