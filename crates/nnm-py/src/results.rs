//! Results as Python values: a branch's points as numpy columns with its events, stop and
//! counters, linear modes as arrays, and the names Python sees for patterns and stop reasons.

use nnm::analysis::ModalComponent;
use nnm::modes::{LinearMode, StandingWave};
use nnm::{Branch, BranchPoint, StopReason};
use numpy::ndarray::Array2;
use numpy::{Complex64, IntoPyArray};
use pyo3::prelude::*;
use pyo3::types::{PyComplex, PyDict, PyList};

pub fn wave_name(pattern: Option<StandingWave>) -> Option<&'static str> {
    pattern.map(|p| match p {
        StandingWave::Cos => "cos",
        StandingWave::Sin => "sin",
    })
}

/// Linear modes in ascending frequency as a dict of `frequency` (rad/s), `shapes` (`n` rows,
/// one mass-normalised column per mode), `rigid`, `label` (`"n,d"` or `None`) and `pattern`.
pub fn modes_dict<'py>(
    py: Python<'py>,
    modes: &[LinearMode],
    n: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let frequency: Vec<f64> = modes.iter().map(|m| m.frequency).collect();
    out.set_item("frequency", frequency.into_pyarray(py))?;
    let shapes = Array2::from_shape_fn((n, modes.len()), |(i, k)| modes[k].shape[i]);
    out.set_item("shapes", shapes.into_pyarray(py))?;
    let rigid: Vec<bool> = modes.iter().map(|m| m.rigid).collect();
    out.set_item("rigid", rigid.into_pyarray(py))?;
    let labels: Vec<Option<String>> = modes.iter().map(|m| m.cyclic.map(|_| m.label())).collect();
    out.set_item("label", labels)?;
    let patterns: Vec<Option<&str>> = modes
        .iter()
        .map(|m| wave_name(m.cyclic.and_then(|c| c.pattern)))
        .collect();
    out.set_item("pattern", patterns)?;
    Ok(out)
}

/// The machine-readable name of a stop reason (the text is `StopReason`'s `Display`).
pub fn stop_kind(stop: &StopReason) -> &'static str {
    match stop {
        StopReason::EnergyMax => "energy-max",
        StopReason::FrequencyShiftMax => "frequency-shift-max",
        StopReason::MaxPoints => "max-points",
        StopReason::Interrupted => "interrupted",
        StopReason::StepTooSmall(_) => "step-too-small",
    }
}

/// The branch's points as columns (numpy arrays), its events, stop reason and counters, into
/// `out`. Multipliers are a `points × m` complex array (NaN where a point has fewer); peak
/// displacements `points × output_dofs`; the regime's partner columns NaN (strings empty)
/// where a point has no partner.
pub fn branch_dict<'py>(
    py: Python<'py>,
    branch: &Branch,
    output_dofs: usize,
    out: &Bound<'py, PyDict>,
) -> PyResult<()> {
    let points = &branch.points;
    type Column = (&'static str, fn(&BranchPoint) -> f64);
    let columns: [Column; 9] = [
        ("energy", |p| p.energy),
        ("frequency", |p| p.frequency),
        ("period", |p| p.period),
        ("energy_slope", |p| p.energy_slope),
        ("max_floquet_modulus", |p| p.floquet.max_modulus),
        ("relative_residual", |p| p.relative_residual),
        ("full_period_residual", |p| p.full_period_residual),
        ("reciprocity_defect", |p| p.floquet.reciprocity_defect),
        ("step", |p| p.step),
    ];
    for (name, value) in columns {
        let values: Vec<f64> = points.iter().map(value).collect();
        out.set_item(name, values.into_pyarray(py))?;
    }
    type Count = (&'static str, fn(&BranchPoint) -> usize);
    let counts: [Count; 3] = [
        ("index", |p| p.index),
        ("iterations", |p| p.iterations),
        ("unstable_pairs", |p| p.floquet.unstable_pairs),
    ];
    for (name, value) in counts {
        let values: Vec<i64> = points.iter().map(|p| value(p) as i64).collect();
        out.set_item(name, values.into_pyarray(py))?;
    }
    let stable: Vec<bool> = points.iter().map(|p| p.floquet.stable).collect();
    out.set_item("stable", stable.into_pyarray(py))?;
    let labels: Vec<&str> = points
        .iter()
        .map(|p| p.label.map_or("", |l| l.name()))
        .collect();
    out.set_item("label", labels)?;
    let peaks = Array2::from_shape_fn((points.len(), output_dofs), |(k, d)| {
        points[k]
            .peak_displacements
            .get(d)
            .copied()
            .unwrap_or(f64::NAN)
    });
    out.set_item("peak_displacement", peaks.into_pyarray(py))?;
    let regimes: Vec<&str> = points
        .iter()
        .map(|p| p.regime.map_or("", |r| r.kind.name()))
        .collect();
    out.set_item("regime", regimes)?;
    type Partner = (&'static str, fn(&ModalComponent) -> f64);
    let partner_columns: [Partner; 3] = [
        ("partner_mode", |c| c.mode as f64),
        ("partner_harmonic", |c| c.harmonic as f64),
        ("partner_share", |c| c.share),
    ];
    for (name, value) in partner_columns {
        let values: Vec<f64> = points
            .iter()
            .map(|p| {
                p.regime
                    .and_then(|r| r.partner)
                    .map_or(f64::NAN, |c| value(&c))
            })
            .collect();
        out.set_item(name, values.into_pyarray(py))?;
    }
    let ratios: Vec<String> = points
        .iter()
        .map(|p| {
            p.regime
                .and_then(|r| r.ratio)
                .map_or(String::new(), |(m, n)| format!("{m}:{n}"))
        })
        .collect();
    out.set_item("ratio", ratios)?;
    let missed = PyList::empty(py);
    for m in &branch.missed_requests {
        let d = PyDict::new(py);
        d.set_item("label", m.label.name())?;
        d.set_item("value", m.value)?;
        d.set_item("why", &m.why)?;
        missed.append(d)?;
    }
    out.set_item("missed_requests", missed)?;
    let width = points.first().map_or(0, |p| p.z0.len());
    let state0 = Array2::from_shape_fn((points.len(), width), |(k, i)| points[k].z0[i]);
    out.set_item("state0", state0.into_pyarray(py))?;
    let m = points
        .iter()
        .map(|p| p.floquet.multipliers.len())
        .max()
        .unwrap_or(0);
    let multipliers = Array2::from_shape_fn((points.len(), m), |(k, i)| {
        points[k]
            .floquet
            .multipliers
            .get(i)
            .map_or(Complex64::new(f64::NAN, f64::NAN), |c| {
                Complex64::new(c.0, c.1)
            })
    });
    out.set_item("multipliers", multipliers.into_pyarray(py))?;
    let events = PyList::empty(py);
    for e in &branch.events {
        let d = PyDict::new(py);
        d.set_item("kind", e.kind.name())?;
        d.set_item("abbreviation", e.kind.abbreviation())?;
        d.set_item("energy", e.point.energy)?;
        d.set_item("frequency", e.point.frequency)?;
        d.set_item("period", e.point.period)?;
        d.set_item(
            "multiplier",
            PyComplex::from_doubles(py, e.multiplier.0, e.multiplier.1),
        )?;
        d.set_item("multiplicity", e.multiplicity)?;
        d.set_item("after_point", e.after)?;
        d.set_item("arclength_uncertainty", e.arclength_uncertainty)?;
        d.set_item("converged", e.converged)?;
        d.set_item("state0", e.point.z0.clone().into_pyarray(py))?;
        events.append(d)?;
    }
    out.set_item("events", events)?;
    out.set_item("stop", branch.stop.to_string())?;
    let stats = PyDict::new(py);
    let s = &branch.stats;
    stats.set_item("points", s.points)?;
    stats.set_item("events", s.events)?;
    stats.set_item("newton_iterations", s.newton_iterations)?;
    stats.set_item("rejected_steps", s.rejected_steps)?;
    stats.set_item("location_steps", s.location_steps)?;
    stats.set_item("integrations", s.shooting.integrations)?;
    stats.set_item("steps", s.shooting.integration.steps)?;
    stats.set_item("factorisations", s.shooting.integration.factorisations)?;
    out.set_item("stats", stats)?;
    Ok(())
}
