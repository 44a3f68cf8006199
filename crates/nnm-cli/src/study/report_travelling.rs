//! The report's section on travelling waves: wording only, the numbers come from
//! `travelling`.

use super::report::Report;
use super::travelling::Travelling;

impl Report {
    /// The travelling waves of (1,5) and (1,14) beside their standing waves.
    pub fn travelling(&mut self, travelling: &Travelling) {
        self.heading("Travelling waves");
        self.line(
            "A degenerate pair has, besides its two standing waves, travelling waves whose pattern \
             turns round the disk at constant shape (docs/method.md §17; `pattern = \"travelling\"` in \
             a job file). Each is shot over a fraction T/q of its period with the sector shift it \
             satisfies (q = 6 for (1,5), 15 for (1,14)), and its periodicity over the whole period \
             checked apart. Files: `travelling/travelling-<n>-<d>.*`.",
        );
        let mut table = String::from(
            "| pair | points | E compared | ω travelling | ω standing | stable points | events | largest full-period residual | time |\n|---|---|---|---|---|---|---|---|---|\n",
        );
        for w in &travelling.waves {
            let b = &w.branch;
            let stable = b.points.iter().filter(|p| p.floquet.stable).count();
            let residual = b
                .points
                .iter()
                .map(|p| p.full_period_residual)
                .fold(0.0f64, f64::max);
            table.push_str(&format!(
                "| ({}) | {} | {:.4} | {} | {} | {stable} of {} | {} | {residual:.1e} | {:.1} s |\n",
                w.label,
                b.points.len(),
                w.energy,
                folds_or(w.frequencies.0),
                folds_or(w.frequencies.1),
                b.points.len(),
                b.events.len(),
                w.seconds,
            ));
        }
        self.line(&table);
        let lower: Vec<String> = travelling
            .waves
            .iter()
            .filter(|w| matches!(w.frequencies, (Some(t), Some(s)) if t < s))
            .map(|w| format!("({})", w.label))
            .collect();
        if !lower.is_empty() {
            let (wave, has) = if lower.len() == 1 {
                ("wave", "has")
            } else {
                ("waves", "have")
            };
            self.line(&format!(
                "At the same energy the travelling {wave} of {} {has} the lower frequency: a \
                 travelling wave spreads its amplitude evenly over the sectors, where a standing \
                 wave concentrates it on the antinodes, so the cubic springs stiffen it less.",
                lower.join(" and ")
            ));
        }
        self.figure(
            "fep-travelling.png",
            "Frequency–energy plot of the travelling waves (solid: stable, dashed: unstable) beside \
             the standing waves of the same pairs.",
        );
        self.figure(
            "travelling-orbits.png",
            "The motion over one period in the plane of the pair's two standing waves (modal \
             coordinates q_cos, q_sin), at the energy compared above: the travelling wave goes round \
             a closed curve (a circle in the linear limit), the standing wave back and forth along a \
             line.",
        );
    }
}

/// A frequency, or a dash where the branch folds at that energy.
fn folds_or(frequency: Option<f64>) -> String {
    frequency.map_or("— (folds)".into(), |f| format!("{f:.6}"))
}
