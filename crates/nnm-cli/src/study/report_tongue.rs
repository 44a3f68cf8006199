//! The report's sections on the 3:1 tongue (5) and on the cost of its Jacobians (6): wording
//! only, the numbers come from `tongue` and `junction`.

use nnm::modes::LinearMode;

use super::junction::JunctionCheck;
use super::report::Report;
use super::tongue::{Tongue, junction_agreement};

impl Report {
    /// Section 5: the tongue, its junction with (1,12) and the check from the (1,12) side.
    pub fn tongue(&mut self, tongue: &Tongue, junction: &JunctionCheck, modes: &[LinearMode]) {
        let (e_junction, f_junction) = tongue.junction();
        let (f112, mismatch) = (junction.reference_frequency, junction.mismatch);
        let fold_energies: Vec<String> = tongue
            .folds
            .iter()
            .map(|&k| format!("{:.4e}", tongue.points[k].point.energy))
            .collect();
        let tongue_range = tongue.energy_span();
        self.heading("5. The 3:1 internal resonance between (0,6) and (1,12)");
        self.line(&format!(
            "Continued past E ≈ 1e3, the (0,6) backbone turns back in energy and travels along a \
             tongue on which a third harmonic grows while the fundamental shrinks (`tongue.csv`). \
             The branch passes {} turning point(s) in energy (at E = {}; the first is the fold \
             where it leaves the backbone, the last the energy minimum where it meets (1,12) and \
             would turn back onto the phase-shifted copy of the tongue — the continuation stops \
             there). The junction, where the fundamental vanishes, is at E = {e_junction:.4}, \
             ω = {f_junction:.6} rad/s. There \
             three times its frequency, {:.6}, matches the (1,12) backbone's {f112:.6} at the same \
             energy: mismatch {mismatch:.2e} rad/s ({:.1e} relative). The tongue spans E = {:.4} to \
             {:.4}.",
            tongue.folds.len(),
            fold_energies.join(", "),
            3.0 * f_junction,
            mismatch / f112,
            tongue_range.0,
            tongue_range.1,
        ));
        self.line(&match junction.tripling {
            Some(e) => format!(
                "Checked from the other side: along the (1,12) backbone, Floquet multipliers pass \
                 exp(±2πi/3) (period tripling) at {} energies below E = {:.0}; the crossing nearest \
                 the junction is at E = {e:.4}, {:.1e} relative to the junction energy found from \
                 the tongue.",
                junction.tripling_crossings.len(),
                3.0 * e_junction,
                (e - e_junction) / e_junction
            ),
            None => "No (1,12) multiplier pair was seen crossing exp(±2πi/3) below the junction \
                     energy."
                .into(),
        });
        self.line(&format!(
            "The linear frequencies are in ratio {:.2}, far from 3: the resonance exists because \
             (1,12) hardens much faster than (0,6).",
            junction.linear_ratio
        ));
        self.line(&regime_sentence(tongue, modes));
        self.figure(
            "tongue.png",
            "The (0,6) backbone, its continuation along the tongue, and the (1,12) backbone drawn at \
             a third of its frequency (grey): the tongue leaves (0,6) at its fold and ends on \
             (1,12)/3. M1–M3 mark the motions below.",
        );
        self.figure(
            "tongue-harmonics.png",
            "Amplitude of the fundamental and of the third harmonic of the motion along the branch: \
             the third harmonic takes over and the fundamental vanishes at the junction.",
        );
        self.figure(
            "tongue-motions.png",
            "Disk and blade of sector 1 over one period at the start (M1), middle (M2, equal \
             harmonics) and end (M3) of the tongue: from a (0,6)-like motion to one repeating three \
             times a period, the (1,12) motion.",
        );
    }

    /// In quick mode the finite-difference run is skipped, and so is section 6.
    pub fn cost_comparison_skipped(&mut self) {
        self.line("The finite-difference cost comparison is skipped in `--quick` mode.");
    }

    /// Section 6: the same tongue with sensitivities and with finite differences.
    pub fn cost_comparison(&mut self, sensitivity: &Tongue, fd: &Tongue) {
        let junction_difference =
            junction_agreement(sensitivity, fd).map_or("—".into(), |d| format!("{d:.1e}"));
        self.heading("6. Cost: sensitivity analysis vs finite differences");
        self.line(&format!(
            "The same continuation of the tongue (same tolerances and step rules), once with the \
             monodromy from the variational equations and once from finite differences (one extra \
             integration per unknown, steps replayed):\n\n\
             | Jacobian | points | Newton iterations | integrations | wall time (s) |\n|---|---|---|---|---|\n\
             | sensitivity | {} | {} | {} | {:.1} |\n| finite differences | {} | {} | {} | {:.1} |\n\n\
             Ratio of wall times: **{:.1}×** (the paper: 15 min vs 1 min in MATLAB). The junction \
             energies of the two runs agree to {junction_difference} (relative).\n\n\
             Why the gap is smaller than the paper's: our finite differences are done as well as \
             they can be — each perturbed motion replays the base run's steps, so it needs no error \
             control, never rejects a step, and is exactly as smooth as the base map; one such \
             column costs about as much arithmetic as one column of the variational equations done \
             naively. What separates them here is how the variational pass is done: all directions \
             are propagated as one block, with Φ stored direction-fastest so that the assembled \
             sparse tangent (about 4 non-zeros a row) is applied to every direction in one sweep, \
             the Runge–Kutta stages kept on the displacement half only (the velocity half of JΦ is \
             Φ itself), the stages reusing the motion's own, and the kernels vectorised. The \
             paper does not detail its finite differences; re-integrating each perturbed motion \
             with its own error control (and interpreted MATLAB overheads per integration) would \
             explain a larger gap. The sensitivity \
             Jacobian remains the accurate one (no increment to choose; \
             monodromy entries agree with differences to ~1e-7, the differences' own accuracy).",
            sensitivity.points.len(),
            sensitivity.stats.newton_iterations,
            sensitivity.stats.shooting.integrations,
            sensitivity.seconds,
            fd.points.len(),
            fd.stats.newton_iterations,
            fd.stats.shooting.integrations,
            fd.seconds,
            fd.seconds / sensitivity.seconds,
        ));
    }
}

/// What the points' own regime labels (docs/method.md §18) say along the tongue: where the
/// branch is first labelled a tongue and where it is on another family, with the partner.
fn regime_sentence(tongue: &Tongue, modes: &[LinearMode]) -> String {
    use nnm::analysis::RegimeKind;
    let first = |kind: RegimeKind| {
        tongue
            .points
            .iter()
            .map(|t| &t.point)
            .find(|p| p.regime.is_some_and(|r| r.kind == kind))
    };
    let describe = |p: &nnm::BranchPoint| {
        let r = p.regime.expect("found by its regime");
        let partner = r.partner.expect("a tongue or another family has a partner");
        format!(
            "point {} (E = {:.4e}, ω = {:.6}), ({}) at {}ω holding {:.0}% of the energy",
            p.index,
            p.energy,
            p.frequency,
            modes[partner.mode].label(),
            partner.harmonic,
            100.0 * partner.share
        )
    };
    match (first(RegimeKind::Tongue), first(RegimeKind::OtherFamily)) {
        (Some(t), Some(o)) => format!(
            "Each point's own regime label (the `regime` column of `tongue-0-6.csv`, read from \
             its modal harmonic content alone) finds the same story: `tongue` from {}; \
             `other-family` from {} — the (1,12) family at a third of the period.",
            describe(t),
            describe(o)
        ),
        (Some(t), None) => format!(
            "Each point's own regime label (the `regime` column of `tongue-0-6.csv`) marks the \
             tongue from {}, but no point as on the (1,12) family.",
            describe(t)
        ),
        _ => "The points' regime labels (`tongue-0-6.csv`) do not mark the tongue: its partner \
              never holds a tenth of the energy."
            .into(),
    }
}
