//! The beam example's files, written from the numbers of `BeamStudy`: `modes.csv`, `fep`,
//! `fep-normalised` and `mode-shapes` (each `.png` and `.svg`), and `report.md`. Wording,
//! units and layout are chosen here; nothing is computed.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use nnm::Branch;
use nnm_io::output::{number, write_table};
use nnm_plot::{FrequencyEnergyPlot, Line, LinePlot, PlotGrid, Series};

use super::{BeamStudy, Deflection, hz};
use crate::compute::Outcome;

/// `modes.csv`: the model's first linear frequencies beside Euler–Bernoulli theory.
pub(super) fn modes_csv(study: &BeamStudy, path: &Path) -> Result<()> {
    let rows = study.frequencies.iter().enumerate().map(|(k, f)| {
        vec![
            k.to_string(),
            number(hz(f.model)),
            number(f.model),
            number(hz(f.theory)),
            number(f.theory),
            format!("{:e}", f.relative_difference()),
        ]
    });
    write_table(
        path,
        &[
            "index",
            "frequency_hz",
            "frequency_rad_s",
            "euler_bernoulli_hz",
            "euler_bernoulli_rad_s",
            "relative_difference",
        ],
        rows,
    )?;
    Ok(())
}

/// The legend entry of a branch: its mode (1-based, as in the report) and linear frequency.
fn mode_name(o: &Outcome) -> String {
    format!(
        "mode {} ({:.2} Hz)",
        o.info.mode_index + 1,
        hz(o.info.linear_frequency_rad_s)
    )
}

/// `fep`: every branch in Hz against the total energy in J, events marked.
pub(super) fn frequency_energy_plot(study: &BeamStudy, stem: &Path) -> Result<()> {
    let title = "ECL cantilever beam: nonlinear normal modes";
    let Some(mut fep) = crate::fep::frequency_energy_plot(&study.outcomes, &[], title, hz(1.0))
    else {
        return Ok(());
    };
    for series in &mut fep.series {
        if let Some(o) = study.outcomes.iter().find(|o| o.info.name == series.label) {
            series.label = mode_name(o);
        }
    }
    fep.frequency_label = "frequency (Hz)".into();
    fep.energy_label = "total energy E = kinetic + potential (J)".into();
    fep.write(stem)?;
    Ok(())
}

/// `amplitude`: the tip's peak deflection (mm) against frequency (Hz) along every branch — the
/// amplitude–frequency backbone a vibration test measures.
pub(super) fn amplitude_plot(study: &BeamStudy, stem: &Path) -> Result<()> {
    let lines: Vec<Line> = study
        .outcomes
        .iter()
        .filter_map(|o| Some((o, o.result.as_ref().ok()?)))
        .filter(|(_, b)| !b.points.is_empty())
        .map(|(o, branch)| Line {
            label: mode_name(o),
            xy: branch
                .points
                .iter()
                .filter_map(|p| Some((hz(p.frequency), 1e3 * p.peak_displacements.first()?)))
                .collect(),
            ..Default::default()
        })
        .collect();
    if lines.is_empty() {
        return Ok(());
    }
    LinePlot {
        title: "ECL cantilever beam: tip deflection along each branch".into(),
        x_label: "frequency (Hz)".into(),
        y_label: "peak tip deflection over the period (mm)".into(),
        lines,
        ..Default::default()
    }
    .write(stem)?;
    Ok(())
}

/// `fep-normalised`: the same branches with each one's frequencies divided by its linear
/// frequency, so that the modes' hardening compares on one scale.
pub(super) fn normalised_frequency_energy_plot(study: &BeamStudy, stem: &Path) -> Result<()> {
    let (mut series, mut markers) = (Vec::new(), Vec::new());
    for o in &study.outcomes {
        let scale = 1.0 / o.info.linear_frequency_rad_s;
        let one = std::slice::from_ref(o);
        let Some(fep) = crate::fep::frequency_energy_plot(one, &[], "", scale) else {
            continue;
        };
        series.extend(fep.series.into_iter().map(|s| Series {
            label: mode_name(o),
            ..s
        }));
        markers.extend(fep.markers);
    }
    if series.is_empty() {
        return Ok(());
    }
    FrequencyEnergyPlot {
        title: "ECL cantilever beam: frequency relative to the linear one".into(),
        series,
        frequency_label: "frequency / linear frequency".into(),
        energy_label: "total energy E = kinetic + potential (J)".into(),
        marker_key: crate::fep::marker_key(&markers),
        markers,
        ..Default::default()
    }
    .write(stem)?;
    Ok(())
}

/// The legend entry of a deflection along the branch.
fn point_name(d: &Deflection, linear: f64) -> String {
    format!(
        "E = {:.2e} J, {:.2} Hz ({:+.1}%)",
        d.energy,
        hz(d.frequency),
        100.0 * (d.frequency / linear - 1.0)
    )
}

/// `mode-shapes`: the first NNM's deflection at several energies, normalised to the tip,
/// beside the linear mode shape; and each one's difference from the linear shape.
pub(super) fn mode_shapes(study: &BeamStudy, stem: &Path) -> Result<()> {
    let shapes = &study.shapes;
    let linear = &shapes.linear;
    let difference = |d: &Deflection| -> Vec<(f64, f64)> {
        d.shape
            .iter()
            .zip(&linear.shape)
            .map(|(&(x, w), &(_, w_lin))| (x, w - w_lin))
            .collect()
    };
    let reference = |xy: Vec<(f64, f64)>, label: String| Line {
        label,
        xy,
        dashed: true,
        reference: true,
        ..Default::default()
    };
    let deflections = LinePlot {
        title: "Deflection at t = 0, divided by the tip's".into(),
        x_label: "x (m)".into(),
        y_label: "w(x) / w(L)".into(),
        lines: std::iter::once(reference(
            linear.shape.clone(),
            format!("linear mode ({:.2} Hz)", hz(linear.frequency)),
        ))
        .chain(shapes.points.iter().map(|d| Line {
            label: point_name(d, linear.frequency),
            xy: d.shape.clone(),
            ..Default::default()
        }))
        .collect(),
        ..Default::default()
    };
    let changes = LinePlot {
        title: "Change from the linear mode shape".into(),
        x_label: "x (m)".into(),
        y_label: "w(x) / w(L) - linear".into(),
        lines: std::iter::once(reference(difference(linear), String::new()))
            .chain(shapes.points.iter().map(|d| Line {
                xy: difference(d),
                ..Default::default()
            }))
            .collect(),
        ..Default::default()
    };
    PlotGrid {
        title: "First NNM of the ECL beam: deflected shape along the branch".into(),
        columns: 2,
        panels: vec![deflections, changes],
    }
    .write(stem)?;
    Ok(())
}

/// A branch's stability in words: stable throughout, or where it is not.
fn stability(branch: &Branch) -> String {
    let unstable: Vec<_> = branch.points.iter().filter(|p| !p.floquet.stable).collect();
    match unstable.first() {
        None => "stable at every point".into(),
        Some(first) => format!(
            "unstable at {} of {} points, the first at E = {:.3e} J ({:.2} Hz)",
            unstable.len(),
            branch.points.len(),
            first.energy,
            hz(first.frequency)
        ),
    }
}

/// `report.md`: the numbers of every section, with the figures.
pub(super) fn report(study: &BeamStudy, seconds: f64, path: &Path) -> Result<()> {
    let beam = &study.beam;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Nonlinear normal modes of the ECL cantilever beam\n\n\
         `nnm example cantilever-beam{}` ran the job [`cantilever-beam.toml`](cantilever-beam.toml) \
         (rerun its branches with `nnm run cantilever-beam.toml --out DIR`). The model is the ECL \
         benchmark as NLvib's example 09 sets it up: a clamped–free steel beam, L = {} m, \
         {} × {} mm, E = {} GPa, ρ = {} kg/m³, with a cubic spring {:.1e}·w(L)³ N from its tip \
         to ground; {} Euler–Bernoulli (Hermite) elements with consistent mass, {} dofs (deflection \
         w and rotation θ at each free node). Frequencies in Hz, energies in J (the total energy \
         of the motion).\n",
        if study.quick { " --quick" } else { "" },
        beam.length,
        beam.width * 1e3,
        beam.height * 1e3,
        beam.youngs_modulus / 1e9,
        beam.density,
        beam.cubic,
        beam.elements,
        2 * beam.elements
    );

    let _ = writeln!(t, "## Linear modes\n");
    let _ = writeln!(
        t,
        "| mode | model (Hz) | model (rad/s) | Euler–Bernoulli (Hz) | relative difference |\n|---|---|---|---|---|"
    );
    for (k, f) in study.frequencies.iter().enumerate() {
        let _ = writeln!(
            t,
            "| {} | {:.4} | {:.3} | {:.4} | {:+.2e} |",
            k + 1,
            hz(f.model),
            f.model,
            hz(f.theory),
            f.relative_difference()
        );
    }
    let above = study
        .frequencies
        .iter()
        .all(|f| f.relative_difference() > 0.0);
    let _ = writeln!(
        t,
        "\n`modes.csv` lists them. Theory: ω_k = (β_k L)² √(EI / (ρ A L⁴)) with β_k L = 1.8751, \
         4.6941, 7.8548, 10.9955 (the roots of cos βL cosh βL = −1).{}\n",
        if above {
            " The model is stiffer than theory on every mode, as a consistent-mass \
             (Rayleigh–Ritz) discretisation must be."
        } else {
            ""
        }
    );

    let _ = writeln!(t, "## Nonlinear normal modes\n");
    let _ = writeln!(
        t,
        "![Frequency–energy plot](fep.png)\n\n*Frequency against total energy along each \
         branch, from the linear limit until the frequency has moved by {:.0}% (solid: stable, \
         dashed: unstable; F fold, BP branch point, PD period doubling, NS Krein collision).*\n\n\
         ![Frequency relative to the linear one](fep-normalised.png)\n\n*The same, each branch's \
         frequency divided by its linear frequency.*\n",
        100.0 * super::FREQUENCY_SHIFT_MAX
    );
    let _ = writeln!(
        t,
        "| branch | mode | points | linear (Hz) | at the end (Hz) | shift | energy at the end (J) | events | time (s) |\n|---|---|---|---|---|---|---|---|---|"
    );
    let mut notes = String::new();
    for o in &study.outcomes {
        let Ok(branch) = &o.result else { continue };
        let Some(last) = branch.points.last() else {
            continue;
        };
        let linear = o.info.linear_frequency_rad_s;
        let _ = writeln!(
            t,
            "| `{}` | {} | {} | {:.4} | {:.4} | {:+.2}% | {:.3e} | {} | {:.1} |",
            o.info.name,
            o.info.mode_index + 1,
            branch.points.len(),
            hz(linear),
            hz(last.frequency),
            100.0 * (last.frequency / linear - 1.0),
            last.energy,
            branch.events.len(),
            o.seconds
        );
        let _ = write!(notes, "- `{}`: {}", o.info.name, stability(branch));
        if !branch.events.is_empty() {
            let events: Vec<String> = branch
                .events
                .iter()
                .map(|e| {
                    format!(
                        "{} at E = {:.3e} J, {:.2} Hz",
                        e.kind.name(),
                        e.point.energy,
                        hz(e.point.frequency)
                    )
                })
                .collect();
            let _ = write!(notes, "; events: {}", events.join("; "));
        }
        let _ = writeln!(notes, "; {}.", branch.stop);
    }
    let _ = writeln!(
        t,
        "\n{notes}\nEach branch's points are in `<branch>.csv` (one row a point) and \
         `<branch>.json` (every point's initial state `z0`, multipliers), its events in \
         `<branch>.events.csv`. {} in {:.1} s.\n",
        if study.outcomes.len() > 1 {
            "Branches computed in parallel (one a core)"
        } else {
            "Computed"
        },
        study.branch_seconds
    );

    let shapes = &study.shapes;
    let _ = writeln!(t, "## Shape of the first nonlinear normal mode\n");
    let _ = writeln!(
        t,
        "![Deflected shapes](mode-shapes.png)\n\n*The first NNM's deflection w(x) at t = 0 — \
         where the motion starts at rest, every point at its largest displacement — divided by \
         the tip's, at points along its branch (Hermite interpolation inside the elements), \
         beside the linear mode shape (grey); right: the difference from the linear shape.*\n"
    );
    let _ = writeln!(
        t,
        "| energy (J) | frequency (Hz) | shift | w(L/2) / w(L) |\n|---|---|---|---|"
    );
    let linear = &shapes.linear;
    let _ = writeln!(
        t,
        "| linear mode | {:.4} | — | {:.4} |",
        hz(linear.frequency),
        linear.midspan
    );
    for d in &shapes.points {
        let _ = writeln!(
            t,
            "| {:.3e} | {:.4} | {:+.2}% | {:.4} |",
            d.energy,
            hz(d.frequency),
            100.0 * (d.frequency / linear.frequency - 1.0),
            d.midspan
        );
    }
    if let Some(end) = shapes.points.last() {
        let _ = writeln!(
            t,
            "\nThe tip spring stiffens with the amplitude, so relative to the tip the rest of the \
             beam deflects {} as the energy grows: w(L/2)/w(L) goes from {:.4} in the linear mode \
             to {:.4} at the end of the branch ({:+.1}%).",
            if end.midspan > linear.midspan {
                "more"
            } else {
                "less"
            },
            linear.midspan,
            end.midspan,
            100.0 * (end.midspan / linear.midspan - 1.0)
        );
    }
    let _ = writeln!(t, "\nTotal wall time: {seconds:.1} s.");
    std::fs::write(path, t).with_context(|| format!("cannot write {}", path.display()))
}
