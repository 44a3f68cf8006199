//! `report.md`: the Markdown report, built section by section from the sections' numbers. The
//! report's wording is here (sections 5 and 6, the tongue and its cost, in `report_tongue.rs`);
//! its numbers are not computed here.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};

use super::backbones::{Backbones, TurnBack, threads_text};
use super::bifurcations::{Bifurcations, SWITCHED_SHIFT, Switched};
use super::localization::Localization;
use super::similarity::{ShapeChange, angle_from};

/// The Markdown report, built section by section.
pub(super) struct Report {
    text: String,
}

impl Report {
    pub fn new(job: &Path, quick: bool) -> Self {
        let mut text = String::new();
        let _ = writeln!(
            text,
            "# Nonlinear normal modes of a bladed disk\n\nJob: `{}`{}. Reproduces the study of the \
             paper (docs/method.md §11): 30 sectors, each a disk mass coupled to its neighbours and a blade \
             attached by a linear and a cubic spring. All frequencies in rad/s; energy is the total \
             energy of the motion.\n",
            job.display(),
            if quick {
                " (quick mode: a subset of backbones)"
            } else {
                ""
            }
        );
        Self { text }
    }
    pub(super) fn heading(&mut self, title: &str) {
        let _ = writeln!(self.text, "\n## {title}\n");
    }
    pub(super) fn figure(&mut self, file: &str, caption: &str) {
        let _ = writeln!(self.text, "![{caption}]({file})\n\n*{caption}*\n");
    }
    pub(super) fn line(&mut self, text: &str) {
        let _ = writeln!(self.text, "{text}\n");
    }

    /// Ctrl-C ended the study after the sections above.
    pub fn interrupted(&mut self) {
        self.heading("Interrupted");
        self.line(
            "The study was interrupted (Ctrl-C) here: the sections above hold what was \
             finished (a backbone ends where the interrupt found it), those below were not \
             computed. Every branch file holds the points computed before the interrupt.",
        );
    }

    pub fn wall_time(&mut self, seconds: f64) {
        self.line(&format!("Total wall time of the study: {seconds:.1} s."));
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, &self.text).with_context(|| format!("cannot write {}", path.display()))
    }

    /// Section 1: the linear modes and their shapes.
    pub fn linear_modes(&mut self, count: usize) {
        self.heading("1. Linear modes");
        self.line(&format!(
            "{count} modes (`modes.csv`), labelled (n, d): n = 0 when blade and disk move in phase, 1 when \
             out of phase; d nodal diameters. (0,0) is the rigid-body rotation. Pairs with the same \
             d (1 ≤ d ≤ 14) are degenerate; each is given as a cos and a sin standing wave.",
        ));
        self.figure(
            "mode-shapes.png",
            "Disk and blade amplitude per sector for four modes (cos standing waves). In-phase \
             (n = 0) and out-of-phase (n = 1) families; d sets the number of waves around the disk.",
        );
    }

    /// Section 2: the backbones, their cost, and those that turn back in energy.
    pub fn backbones(&mut self, backbones: &Backbones, turning_back: &[TurnBack]) {
        self.heading("2. Backbones");
        self.figure(
            "fep-backbones.png",
            "Frequency–energy plot of every backbone (solid: stable, dashed: unstable). All harden; \
             the n = 1 modes (top, near 2–2.5 rad/s) stretch the cubic springs and rise far more than \
             the n = 0 modes.",
        );
        self.line(&format!(
            "{} backbones, {} points, {:.1} s wall time on {}. Each \
             branch is in `backbones/<name>.csv` / `.json`; `backbones.csv` summarises them.",
            backbones.outcomes.len(),
            backbones.total_points(),
            backbones.seconds,
            threads_text(backbones.threads)
        ));
        if !turning_back.is_empty() {
            let s_shape = if turning_back.iter().any(|t| t.label == "1,14") {
                " The fold of (1,14) is the S-shape that precedes its localization (section 4)."
            } else {
                ""
            };
            let list: Vec<String> = turning_back
                .iter()
                .map(|t| {
                    format!(
                        "({}) from E ≈ {:.3e} ({} turning points)",
                        t.label, t.first_energy, t.reversals
                    )
                })
                .collect();
            self.line(&format!(
                "Branches that turn back in energy — a fold, or an internal resonance (a tongue, like \
                 the one of section 5) met before the energy limit: {}.{s_shape}",
                list.join("; ")
            ));
        }
    }

    /// Section 3: shape angles and frequency shifts of every backbone.
    pub fn similarity(&mut self, changes: &[ShapeChange]) {
        self.heading("3. Similar and nonsimilar modes");
        self.line(
            "The shape angle is the angle, in the mass metric, between the displacement at the \
             turning point of the motion and the linear mode shape: 0° for a similar NNM, whose shape \
             does not change with energy (`similarity.csv` has it for every point).",
        );
        let mut table = String::from(
            "| mode | linear ω | shift at E = 10 | shift at E = 100 | max shape angle | points | time (s) |\n|---|---|---|---|---|---|---|\n",
        );
        let shift = |s: Option<f64>| s.map_or(String::from("—"), |s| format!("{s:+.2}%"));
        for c in changes {
            let _ = writeln!(
                table,
                "| ({}) | {:.3} | {} | {} | {:.2}° | {} | {:.2} |",
                c.label,
                c.linear_frequency,
                shift(c.shifts[0]),
                shift(c.shifts[1]),
                c.max_angle,
                c.points.len(),
                c.seconds
            );
        }
        self.line(&table);
        self.line(
            "Shifts by cubic interpolation in log E between computed points; — where the branch \
             does not reach that energy or passes it more than once (it folds there).",
        );
        let angle = |label: &str| angle_from(changes, label, 100.0);
        if let (Some(a10), Some(a02), Some(a014)) = (angle("1,0"), angle("0,2"), angle("0,14")) {
            self.line(&format!(
                "At E ≈ 100: (1,0) {a10:.1e}° (similar: it reduces exactly to a Duffing oscillator), \
                 (0,2) {a02:.2}° (almost similar), (0,14) {a014:.1}° (markedly nonsimilar)."
            ));
        }
    }

    /// Section 4: localization along (1,14).
    pub fn localization(&mut self, localization: &Localization) {
        let (base, peak) = (localization.standing_wave_share, &localization.peak);
        self.heading("4. Localization along (1,14)");
        self.line(&format!(
            "Localization measure: the share of the energy held by the three most energetic sectors \
             (sector energy at the turning point of the motion, `localization.csv`, with the \
             participation number: how many sectors effectively share it). The linear standing wave \
             gives {base:.3}; the backbone starts there and reaches {:.3} (participation {:.1} of 30 \
             sectors) at E = {:.3}. Localization sets in (share above 1.5× the standing wave's) at \
             E ≈ {} — with no mistuning at all: the energy dependence of the frequency does it.",
            peak.top3_share,
            peak.participation,
            peak.energy,
            localization
                .onset
                .map_or("— (not reached)".into(), |e| format!("{e:.3}")),
        ));
        self.figure(
            "localization.png",
            "Share of the energy held by the three most energetic sectors along the (1,14) backbone \
             (grey: the linear standing wave). It rises from the uniform value to concentration in a \
             few sectors past the S-shaped fold of the branch.",
        );
        self.figure(
            "localized-motion.png",
            "Blade and disk displacements of all 30 sectors over one period at the most localized \
             point: a few blades vibrate strongly while the rest of the assembly is nearly still.",
        );
    }

    /// The bifurcations along the backbones and the switch at (1,5).
    pub fn bifurcations(&mut self, events: &Bifurcations) {
        self.heading("Bifurcations along the backbones");
        self.line(
            "Every backbone was scanned for events between consecutive points: folds (sign of dE/ds), \
             branch points (a multiplier pair through +1), period doublings (through -1) and Krein \
             collisions (two pairs meeting on the unit circle and leaving it as a complex quadruplet, \
             listed as `neimark-sacker`). Each event was located by regula falsi on a smooth test \
             function, every trial corrected onto the branch, to 1e-8 in arclength. The events of \
             each branch are in `backbones/<name>.events.csv`.",
        );
        let mut table = String::from(
            "| backbone | folds | branch points | period doublings | Krein collisions | first event |\n|---|---|---|---|---|---|\n",
        );
        for c in &events.counts {
            let _ = writeln!(
                table,
                "| ({}) | {} | {} | {} | {} | {} at E = {:.6} |",
                c.label,
                c.folds,
                c.branch_points,
                c.period_doublings,
                c.krein_collisions,
                c.first.0,
                c.first.1
            );
        }
        self.line(&table);
        self.line(&format!(
            "{} backbones have no event in the computed range.",
            events.quiet
        ));
        self.line(&format!(
            "**(1,14): the S-fold and its stability changes.** Folds at E = {}; Krein collisions at \
             E = {}. Between the two folds the energy decreases along the branch (the middle, \
             unstable part of the S).",
            energy_list(&events.s_folds),
            energy_list(&events.s_krein_collisions)
        ));
        match &events.switched {
            Some(switched) => self.switched(switched),
            None => self.line("(1,5) has no branch point in the computed range: no switch."),
        }
    }

    fn switched(&mut self, s: &Switched) {
        let (event, multiplicity) = (s.event, s.event.multiplicity);
        self.line(&format!(
            "**(1,5): branch switching.** The first branch point of the (1,5) cos wave is at \
             E = {:.8}, f = {:.8} rad/s, where {} multiplier pair{} reach +1{}. The switch found {} null \
             direction{} of the unrestricted, full-period shooting Jacobian beside the parent's \
             tangent (smallest singular values {}), and followed the family along the first, posed \
             with the {} phase condition: {} points to +{:.0}% frequency. On the parent the sin wave's share of the (1,5) pair is \
             {:.1e} and the travelling index {:+.1e}; on the new family:",
            event.point.energy,
            event.point.frequency,
            multiplicity,
            if multiplicity == 1 { "" } else { "s" },
            if multiplicity == 1 {
                ""
            } else {
                " together (a bifurcation made degenerate by a symmetry; the first null direction \
                 is followed, the others lead to further families)"
            },
            s.switch.null_directions,
            if s.switch.null_directions == 1 { "" } else { "s" },
            s.switch
                .singular_values
                .iter()
                .map(|v| format!("{v:.1e}"))
                .collect::<Vec<_>>()
                .join(", "),
            s.phase,
            s.branch.points.len(),
            100.0 * SWITCHED_SHIFT,
            s.parent_content.sin_share,
            s.parent_content.travelling,
        ));
        let mut rows = String::from(
            "| point | energy | frequency | sin share | travelling index | strongest other mode (energy share) | stable |\n|---|---|---|---|---|---|---|\n",
        );
        for p in &s.points {
            let _ = writeln!(
                rows,
                "| {} | {:.5} | {:.6} | {:.3} | {:+.3} | ({}) {:.3} | {} |",
                p.index,
                p.energy,
                p.frequency,
                p.content.sin_share,
                p.content.travelling,
                p.other_label,
                p.other_share,
                p.stable
            );
        }
        self.line(&rows);
        let last = s.last_point();
        self.line(&if s.breaks_mirror() {
            "The new motions carry the sin wave, which the cos-wave backbone never does: they break \
             the mirror symmetry of the standing wave. A travelling index between 0 and 1 means the \
             cos and sin parts are out of phase, so the vibration pattern turns round the disk as it \
             oscillates."
                .to_string()
        } else {
            format!(
                "The new motions leave the sin wave alone but mix in another standing wave: on the \
                 backbone at the branch point the strongest mode besides the (1,5) cos wave is ({}) \
                 with {:.1e} of the energy, while along the new family ({}) grows to \
                 {:.3} of it. The new family is a coupled (1,5)–({}) motion ({} has the linear \
                 frequency {:.6} rad/s, below the backbone's {:.6} at the branch point), \
                 so it breaks the backbone's single-wave pattern.",
                s.parent_other.0,
                s.parent_other.1,
                last.other_label,
                last.other_share,
                last.other_label,
                last.other_label,
                s.partner_frequency,
                event.point.frequency
            )
        });
        self.figure(
            "bifurcations.png",
            "The (1,5) backbone (dashed where unstable), its branch points (BP), and the family \
             switched onto at the first one, with its own Krein collisions (NS).",
        );
    }
}

/// Event energies as listed in the report, `none` if there are none.
fn energy_list(energies: &[f64]) -> String {
    if energies.is_empty() {
        return "none".into();
    }
    let list: Vec<String> = energies.iter().map(|e| format!("{e:.6}")).collect();
    list.join(", ")
}
