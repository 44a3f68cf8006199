//! Backbones beside forced curves (docs/method.md §21): which branch of a job is the backbone
//! of a response's resonance, the backbone's peak at a frequency (beside a phase resonance),
//! and the peak energy balance predicts for a force level — for `<response>.png`, the
//! `backbone_peak` of `<response>.events.csv` and the lines under `nnm run`'s summary.

use std::path::Path;

use nnm::BranchPoint;
use nnm::analysis::{EnergyBalance, first_reached, value_in};
use nnm::forced::Sweep;
use nnm::model::HarmonicForce;
use nnm_plot::{ResponsePlot, ResponseSeries};

/// A computed branch, as a response looks for its backbone among them.
pub struct ComputedBranch<'a> {
    pub name: &'a str,
    /// The dofs its points record peaks of.
    pub output_dofs: &'a [usize],
    pub points: &'a [BranchPoint],
    /// The force whose resonance force its points report (`resonance_force`), if any.
    pub balance: Option<&'a EnergyBalance>,
}

/// The backbone beside a response: one branch's points, reduced to what the response's
/// figure and summary need.
pub struct Backbone {
    pub name: String,
    /// `ln E` of each point: the branch's own parameter, in which its frequencies, log-peaks
    /// and log-forces are smooth (a peak against the frequency is not: `√(ω − ω₀)` near the
    /// linear limit).
    log_energy: Vec<f64>,
    frequencies: Vec<f64>,
    peaks: Vec<f64>,
    log_peaks: Vec<f64>,
    stable: Vec<bool>,
    /// `ln a` of each point's resonance force for the response's own force shape; `None`
    /// when the branch balanced another force (or none).
    log_force: Option<Vec<f64>>,
}

/// The colour of a backbone on a response's figure.
const BACKBONE_COLOR: (u8, u8, u8) = (0, 0, 0);

impl Backbone {
    /// The backbone of a frequency sweep over `[from, to]` whose figure shows `dof`, driven by
    /// `force`: among the branches that record `dof` and have a point in the sweep's range,
    /// the first that balances this force (`resonance_force`), else the first.
    pub fn find(
        branches: &[ComputedBranch<'_>],
        sweep: &Sweep,
        dof: usize,
        force: &HarmonicForce,
    ) -> Option<Self> {
        let Sweep::Frequency { from, to, .. } = *sweep else {
            return None;
        };
        let beside = |b: &&ComputedBranch<'_>| {
            b.output_dofs.contains(&dof)
                && b.points.iter().any(|p| (from..=to).contains(&p.frequency))
        };
        let balances = |b: &&ComputedBranch<'_>| b.balance.is_some_and(|x| x.force() == force);
        let chosen = branches
            .iter()
            .filter(beside)
            .find(balances)
            .or_else(|| branches.iter().find(beside));
        chosen.and_then(|b| {
            let column = b.output_dofs.iter().position(|&d| d == dof)?;
            let peak = |p: &BranchPoint| p.peak_displacements.get(column).copied();
            let points: Vec<&BranchPoint> = b.points.iter().filter(|p| peak(p).is_some()).collect();
            let same_force = b.balance.is_some_and(|balance| balance.force() == force);
            Some(Self {
                name: b.name.to_string(),
                log_energy: points.iter().map(|p| p.energy.ln()).collect(),
                frequencies: points.iter().map(|p| p.frequency).collect(),
                peaks: points.iter().filter_map(|p| peak(p)).collect(),
                log_peaks: points.iter().filter_map(|p| peak(p)).map(f64::ln).collect(),
                stable: points.iter().map(|p| p.floquet.stable).collect(),
                log_force: same_force.then(|| {
                    points
                        .iter()
                        .map(|p| p.resonance.map_or(f64::NAN, |r| r.amplitude.ln()))
                        .collect()
                }),
            })
        })
    }

    /// The backbone's peak at `frequency`, between its points (eq. (113)'s comparison): the
    /// energy where the branch reaches that frequency, then the peak at that energy.
    pub fn peak_at(&self, frequency: f64) -> Option<f64> {
        let at = first_reached(&self.log_energy, &self.frequencies, frequency)?;
        value_in(&self.log_energy, &self.log_peaks, at).map(f64::exp)
    }

    /// `(force amplitude, peak)` of the backbone point at `frequency`: the force whose
    /// resonance peak energy balance puts there (eq. (111c)); `None` where the branch does not
    /// reach the frequency or balances another force.
    pub fn at_frequency(&self, frequency: f64) -> Option<(f64, f64)> {
        let log_force = self.log_force.as_ref()?;
        let at = first_reached(&self.log_energy, &self.frequencies, frequency)?;
        Some((
            value_in(&self.log_energy, log_force, at)?.exp(),
            value_in(&self.log_energy, &self.log_peaks, at)?.exp(),
        ))
    }

    /// `(frequency, peak)` of the resonance peak energy balance predicts for force amplitude
    /// `level` (eq. (111c)): at the energy where the points' resonance force first reaches it.
    pub fn predicted_peak(&self, level: f64) -> Option<(f64, f64)> {
        let log_force = self.log_force.as_ref()?;
        let at = first_reached(&self.log_energy, log_force, level.ln())?;
        Some((
            value_in(&self.log_energy, &self.frequencies, at)?,
            value_in(&self.log_energy, &self.log_peaks, at)?.exp(),
        ))
    }

    /// The backbone as a curve of the response's figure, its points within `[from, to]`.
    pub fn series(&self, from: f64, to: f64) -> ResponseSeries {
        ResponseSeries {
            label: format!("backbone `{}`", self.name),
            points: (0..self.frequencies.len())
                .filter(|&i| (from..=to).contains(&self.frequencies[i]))
                .map(|i| (self.frequencies[i], self.peaks[i], self.stable[i]))
                .collect(),
            color: Some(BACKBONE_COLOR),
        }
    }
}

/// `<name>.resonance.png` and `.svg` of a branch with `resonance_force`: its resonance peaks
/// by energy balance, the peak of its first output dof against the force amplitude whose
/// resonance peak each point is (docs/method.md eq. (111c)) — how high the structure
/// resonates at each force level. Nothing for a branch without it.
pub fn plot_resonance_peaks(branch: &ComputedBranch<'_>, out: &Path) -> anyhow::Result<()> {
    let (Some(_), Some(&dof)) = (branch.balance, branch.output_dofs.first()) else {
        return Ok(());
    };
    let points: Vec<(f64, f64, bool)> = branch
        .points
        .iter()
        .filter_map(|p| {
            let force = p.resonance?.amplitude;
            let peak = *p.peak_displacements.first()?;
            force.is_finite().then_some((force, peak, p.floquet.stable))
        })
        .collect();
    if points.is_empty() {
        return Ok(());
    }
    ResponsePlot {
        title: format!("Resonance peaks of `{}` by energy balance", branch.name),
        x_label: "force amplitude a (resonance_force)".into(),
        y_label: format!("peak of x{dof}"),
        series: vec![ResponseSeries {
            label: format!("`{}`", branch.name),
            points,
            color: None,
        }],
        markers: Vec::new(),
        marker_key: String::new(),
    }
    .write(&out.join(format!("{}.resonance", branch.name)))?;
    Ok(())
}
