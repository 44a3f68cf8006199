//! The report's section on the forced resonance of (1,5): wording only, the numbers come from
//! `forced`.

use super::forced::{BETA, Forced, PAIR};
use super::report::Report;

impl Report {
    /// The (1,5) travelling backbone's resonance forces and the forced curves at three levels.
    pub fn forced(&mut self, forced: &Forced) {
        self.heading("Forced resonance of (1,5) under engine order 5");
        self.line(&format!(
            "Damped by `C = βK` (β = {BETA}, ζ = {:.2}% at ({PAIR}), ω0 = {:.6} rad/s) and driven at the blades in \
             engine order 5, `a cos(Ωt − 2π·5s/N)`, the disk answers with a travelling wave: its \
             resonances lie on the travelling ({PAIR}) backbone. Each backbone point's \
             `resonance_force` is the force amplitude whose resonance peak it is, by energy \
             balance (docs/method.md §21); the three levels below are those of the points at +1%, \
             +2% and +3%, and each forced curve's phase resonance (its blade in quadrature with \
             the force, eq. (113)) is set beside the backbone at its frequency (interpolated \
             between the backbone's {} points). The phase resonance and the predicted peak agree \
             to the order of ζ² in frequency and amplitude (the `Δ` columns); at equal frequency \
             the distance to the backbone looks larger near the linear limit, where the backbone \
             is steep (`d ln X / d ln ω = ω/(2(ω − ω0))`, about 50 at +1%): a frequency offset of \
             ζ² shows there fifty times over. Files: `forced/`, `forced-1-5.png`.",
            100.0 * forced.zeta,
            forced.linear_frequency,
            forced.backbone.points.len()
        ));
        let mut table = String::from(
            "| level a | energy-balance peak (Ω, blade) | phase resonance (Ω, blade) | Δ Ω, Δ blade | backbone at that Ω | distance | folds | points | time |\n|---|---|---|---|---|---|---|---|---|\n",
        );
        for level in &forced.levels {
            let folds = level
                .curve
                .events
                .iter()
                .filter(|e| e.kind == nnm::forced::ResponseEventKind::Fold)
                .count();
            let (predicted_frequency, predicted_peak) = level.predicted;
            let (resonance, delta, there, distance) = match level.phase_resonance {
                Some((frequency, peak, on)) => (
                    format!("{frequency:.6}, {peak:.6e}"),
                    format!(
                        "{:+.1e}, {:+.1e}",
                        frequency / predicted_frequency - 1.0,
                        peak / predicted_peak - 1.0
                    ),
                    on.map_or("—".into(), |x| format!("{x:.6e}")),
                    on.map_or("—".into(), |x| format!("{:+.1e}", peak / x - 1.0)),
                ),
                None => ("none".into(), "—".into(), "—".into(), "—".into()),
            };
            table.push_str(&format!(
                "| {:.4e} (+{:.0}%) | {:.6}, {:.6e} | {resonance} | {delta} | {there} | {distance} | {folds} | {} | {:.1} s |\n",
                level.force,
                100.0 * level.shift,
                level.predicted.0,
                level.predicted.1,
                level.curve.points.len(),
                level.seconds,
            ));
        }
        self.line(&table);
        self.figure(
            "forced-1-5.png",
            "The blade's peak against the forcing frequency at the three levels (solid: stable, \
             dashed: unstable), the travelling (1,5) backbone in black, the peaks energy balance \
             predicts (○), the phase resonances (▲) and folds (●).",
        );
    }
}
