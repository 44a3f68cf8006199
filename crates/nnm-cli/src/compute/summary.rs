//! The closing summary of a command's branches on stdout: one line per branch, then where
//! each changed regime.

use nnm::BranchPoint;
use nnm::analysis::{RegimeKind, regime_changes};
use nnm::modes::LinearMode;
use nnm::shooting::Travel;
use nnm_io::output::BranchInfo;

use super::outcome::{NotStarted, Outcome};

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
