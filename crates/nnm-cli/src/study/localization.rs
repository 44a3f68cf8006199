//! Localization along a backbone: how the energy of the motion spreads over the sectors, point
//! by point, and the motion where it is most concentrated. Numbers only.

use anyhow::{Result, anyhow};
use nnm::Branch;
use nnm::analysis::{participation, sample_motion, sector_energies, top_share};
use nnm::model::{MechanicalSystem, Structure};
use nnm::modes::{LinearMode, find_mode};

use super::SAMPLES;

/// The backbone whose localization the study follows, and the standing wave it starts from.
const LOCALIZING_MODE: &str = "1,14";

/// How the energy is spread over the sectors at one point of the backbone.
#[derive(Clone, Copy)]
pub(super) struct Spread {
    pub energy: f64,
    pub frequency: f64,
    /// Share of the energy held by the three most energetic sectors.
    pub top3_share: f64,
    /// Participation number: how many sectors effectively share the energy.
    pub participation: f64,
}

pub(super) struct Localization {
    pub points: Vec<Spread>,
    /// The top-3 share of the linear standing wave: the backbone's value at low energy.
    pub standing_wave_share: f64,
    /// First energy where the top-3 share exceeds 1.5× the standing wave's.
    pub onset: Option<f64>,
    /// The most localized point.
    pub peak: Spread,
    /// The motion over one period at the most localized point (`SAMPLES + 1` states).
    pub peak_motion: Vec<Vec<f64>>,
    pub sectors: usize,
}

/// Localization along `branch`, the backbone of `LOCALIZING_MODE`. Sector energies are taken
/// at the turning point of the motion.
pub(super) fn along(
    structure: &Structure,
    modes: &[LinearMode],
    branch: &Branch,
) -> Result<Localization> {
    let n = structure.dofs();
    let points: Vec<Spread> = branch
        .points
        .iter()
        .map(|p| {
            let e = sector_energies(structure, &p.z0[..n], &p.z0[n..]).expect("cyclic model");
            Spread {
                energy: p.energy,
                frequency: p.frequency,
                top3_share: top_share(&e, 3),
                participation: participation(&e),
            }
        })
        .collect();
    let (_, linear) = find_mode(modes, LOCALIZING_MODE, None).expect("checked");
    let e_linear = sector_energies(structure, &linear.shape, &vec![0.0; n]).expect("cyclic model");
    let standing_wave_share = top_share(&e_linear, 3);
    let onset = points
        .iter()
        .find(|s| s.top3_share > 1.5 * standing_wave_share)
        .map(|s| s.energy);
    let (peak_index, peak) = points
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.top3_share.total_cmp(&b.1.top3_share))
        .map(|(k, s)| (k, *s))
        .ok_or_else(|| anyhow!("({LOCALIZING_MODE}) has no points"))?;
    let p = &branch.points[peak_index];
    let peak_motion = sample_motion(structure, &p.z0, p.period, SAMPLES, 1e-10)?;
    Ok(Localization {
        points,
        standing_wave_share,
        onset,
        peak,
        peak_motion,
        sectors: n / 2,
    })
}
