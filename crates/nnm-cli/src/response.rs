//! `nnm run`'s forced responses (`[[response]]`): every curve computed, written point by point
//! as it comes (`<name>.csv`, `.events.csv`, `.json`), its figure, and a summary line per curve.
//! Ctrl-C stops the curve in progress at its next point and skips the rest.

use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use nnm::continuation::Item;
use nnm::forced::{
    ResponseCurve, ResponseEventKind, ResponseItem, ResponseStop, Sweep, forced_response,
};
use nnm::model::{ForcedSystem, Matrix, Structure};
use nnm_io::job::ResponseJob;
use nnm_io::output::{CurveRecord, OutputError, ResponseWriter, stop_name};
use nnm_plot::{Marker, MarkerShape, ResponsePlot, ResponseSeries};

use crate::interrupt;
use crate::progress::say;
use crate::resonance::{Backbone, ComputedBranch};

/// How one curve went.
pub struct CurveOutcome {
    pub response: String,
    pub curve: usize,
    pub sweep: Sweep,
    /// The curve, or why it could not start (`None` when an interrupt came before it).
    pub result: Option<Result<ResponseCurve, String>>,
    pub seconds: f64,
    /// The job's branch that is the backbone of this resonance, if one is (docs/method.md
    /// §21).
    pub backbone: Option<Backbone>,
}

/// Computes every response of a job into `out`, in the order of the file; `branches`, the
/// job's computed branches, give each frequency sweep its backbone (figure, summary and the
/// `backbone_peak` of phase resonances).
pub fn run_responses(
    structure: &Structure,
    damping: &Matrix,
    responses: &[ResponseJob],
    branches: &[ComputedBranch<'_>],
    out: &Path,
) -> Result<Vec<CurveOutcome>> {
    let mut outcomes = Vec::new();
    for response in responses {
        let body = &response.body;
        let system = ForcedSystem::new(structure, damping, body.force.clone())?;
        let mut writer = interrupt::writing(|| {
            ResponseWriter::create(out, &response.name, &body.output_dofs, &body.force)
        })?;
        let mut curves: Vec<(Sweep, ResponseCurve)> = Vec::new();
        let first_outcome = outcomes.len();
        for (k, sweep) in body.curves.iter().enumerate() {
            let backbone = body
                .output_dofs
                .first()
                .and_then(|&dof| Backbone::find(branches, sweep, dof, &body.force));
            if interrupt::requested() {
                outcomes.push(CurveOutcome {
                    response: response.name.clone(),
                    curve: k,
                    sweep: *sweep,
                    result: None,
                    seconds: 0.0,
                    backbone,
                });
                continue;
            }
            let started = Instant::now();
            let mut error: Option<OutputError> = None;
            let name = &response.name;
            let observer = |item: &ResponseItem| {
                let written = interrupt::writing(|| match item {
                    Item::Point(p) => writer.write_point(k, p),
                    Item::Event(e) => writer.write_event(
                        k,
                        e,
                        backbone
                            .as_ref()
                            .filter(|_| e.kind == ResponseEventKind::PhaseResonance)
                            .and_then(|b| b.peak_at(e.point.frequency)),
                    ),
                });
                if let Err(e) = written {
                    error = Some(e);
                    return ControlFlow::Break(());
                }
                match item {
                    Item::Point(p) => say!(
                        "[{name}] curve {k} point {:>3}  Ω = {:.6} rad/s  a = {:.4e}  peak = {:.6e}  {}  |mu|max = {:.6}",
                        p.index,
                        p.frequency,
                        p.force_amplitude,
                        p.peaks.first().copied().unwrap_or(f64::NAN),
                        if p.stable { "stable  " } else { "unstable" },
                        p.max_floquet_modulus
                    ),
                    Item::Event(e) => say!(
                        "[{name}] curve {k} event: {} at Ω = {:.9} rad/s, a = {:.6e}, peak = {:.6e}, multiplier ({:.6}, {:.6})",
                        e.kind.name(),
                        e.point.frequency,
                        e.point.force_amplitude,
                        e.point.peaks.first().copied().unwrap_or(f64::NAN),
                        e.critical_multiplier.0,
                        e.critical_multiplier.1
                    ),
                }
                if interrupt::requested() {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            };
            let result =
                forced_response(&system, *sweep, &body.output_dofs, &body.settings, observer);
            if let Some(e) = error {
                return Err(e.into());
            }
            let seconds = started.elapsed().as_secs_f64();
            let result = match result {
                Ok(curve) => {
                    let record = CurveRecord::finished(k, sweep, &curve, seconds);
                    interrupt::writing(|| writer.end_curve(record))?;
                    say!(
                        "[{name}] curve {k} done: {} points, {} events, {}",
                        curve.points.len(),
                        curve.events.len(),
                        stop_name(&curve.stop)
                    );
                    curves.push((*sweep, curve.clone()));
                    Ok(curve)
                }
                Err(e) => {
                    let reason = e.to_string();
                    let record = CurveRecord::failed(k, sweep, &format!("failed: {reason}"));
                    interrupt::writing(|| writer.end_curve(record))?;
                    Err(reason)
                }
            };
            outcomes.push(CurveOutcome {
                response: response.name.clone(),
                curve: k,
                sweep: *sweep,
                result: Some(result),
                seconds,
                backbone,
            });
        }
        interrupt::writing(|| writer.finish())?;
        plot(
            &response.name,
            body.output_dofs.first().copied(),
            &curves,
            outcomes[first_outcome..]
                .iter()
                .find_map(|o| o.backbone.as_ref()),
            out,
        )?;
    }
    Ok(outcomes)
}

/// `<name>.png` and `.svg`: the peak of the first output dof against the frequency (or the
/// force amplitude), a curve per level, unstable dashed, events marked; with a `backbone`, the
/// backbone within the sweep and the peak energy balance predicts for each level.
pub(crate) fn plot(
    name: &str,
    dof: Option<usize>,
    curves: &[(Sweep, ResponseCurve)],
    backbone: Option<&Backbone>,
    out: &Path,
) -> Result<()> {
    let Some(dof) = dof else { return Ok(()) };
    if curves.iter().all(|(_, c)| c.points.is_empty()) {
        return Ok(());
    }
    let in_amplitude = matches!(curves[0].0, Sweep::Amplitude { .. });
    let x = |p: &nnm::forced::ResponsePoint| {
        if in_amplitude {
            p.force_amplitude
        } else {
            p.frequency
        }
    };
    let mut series: Vec<ResponseSeries> = curves
        .iter()
        .map(|(sweep, c)| ResponseSeries {
            label: match *sweep {
                Sweep::Frequency { amplitude, .. } => format!("a = {}", short(amplitude)),
                Sweep::Amplitude { frequency, .. } => format!("Ω = {} rad/s", short(frequency)),
            },
            points: c
                .points
                .iter()
                .map(|p| (x(p), p.peaks.first().copied().unwrap_or(f64::NAN), p.stable))
                .collect(),
            color: None,
        })
        .collect();
    let mut markers: Vec<Marker> = curves
        .iter()
        .flat_map(|(_, c)| &c.events)
        .map(|e| Marker {
            x: x(&e.point),
            y: e.point.peaks.first().copied().unwrap_or(f64::NAN),
            label: String::new(),
            shape: event_shape(e.kind),
        })
        .collect();
    let mut key = format!(
        "{} fold   {} bifurcation   {} phase resonance",
        event_shape(ResponseEventKind::Fold).glyph(),
        event_shape(ResponseEventKind::NeimarkSacker).glyph(),
        event_shape(ResponseEventKind::PhaseResonance).glyph()
    );
    if let Some(backbone) = backbone {
        let (from, to) = curves[0].0.range();
        series.push(backbone.series(from, to));
        let predicted: Vec<Marker> = curves
            .iter()
            .filter_map(|(sweep, _)| match *sweep {
                Sweep::Frequency { amplitude, .. } => backbone.predicted_peak(amplitude),
                Sweep::Amplitude { .. } => None,
            })
            .map(|(frequency, peak)| Marker {
                x: frequency,
                y: peak,
                label: String::new(),
                shape: PREDICTED_PEAK,
            })
            .collect();
        if !predicted.is_empty() {
            key += &format!("   {} energy balance", PREDICTED_PEAK.glyph());
        }
        markers.extend(predicted);
    }
    ResponsePlot {
        title: format!("Forced response `{name}`"),
        x_label: if in_amplitude {
            "force amplitude".into()
        } else {
            "forcing frequency (rad/s)".into()
        },
        y_label: format!("peak of x{dof}"),
        series,
        markers,
        marker_key: key,
    }
    .write(&out.join(name))?;
    Ok(())
}

/// A level for a legend: as written when short (`0.05`), else to five significant digits (a
/// level computed from a backbone, `3.4608e-3`).
fn short(value: f64) -> String {
    let written = value.to_string();
    if written.len() <= 8 {
        written
    } else {
        format!("{value:.4e}")
    }
}

/// The marker of a resonance peak predicted by energy balance (docs/method.md eq. (111c)).
const PREDICTED_PEAK: MarkerShape = MarkerShape::Ring;

/// The marker of an event on a response's figure: folds, bifurcations, phase resonances.
fn event_shape(kind: ResponseEventKind) -> MarkerShape {
    match kind {
        ResponseEventKind::Fold => MarkerShape::Dot,
        ResponseEventKind::PhaseResonance => MarkerShape::Triangle,
        ResponseEventKind::NeimarkSacker
        | ResponseEventKind::PeriodDoubling
        | ResponseEventKind::BranchPoint => MarkerShape::Diamond,
    }
}

/// One line per curve on stdout: points, folds, largest peak, time, how it ended.
pub fn print_summary(outcomes: &[CurveOutcome]) {
    if outcomes.is_empty() {
        return;
    }
    println!(
        "{:<16} {:>5} {:>12} {:>7} {:>5} {:>12} {:>8}  stop",
        "response", "curve", "level", "points", "folds", "peak_max", "time_s"
    );
    for o in outcomes {
        let level = match o.sweep {
            Sweep::Frequency { amplitude, .. } => format!("a={amplitude}"),
            Sweep::Amplitude { frequency, .. } => format!("Ω={frequency}"),
        };
        match &o.result {
            None => println!(
                "{:<16} {:>5} {:>12} not started (interrupted)",
                o.response, o.curve, level
            ),
            Some(Err(e)) => println!(
                "{:<16} {:>5} {:>12} failed: {e}",
                o.response, o.curve, level
            ),
            Some(Ok(c)) => {
                let folds = c
                    .events
                    .iter()
                    .filter(|e| e.kind == ResponseEventKind::Fold)
                    .count();
                let peak = c
                    .points
                    .iter()
                    .filter_map(|p| p.peaks.first().copied())
                    .fold(f64::NAN, f64::max);
                println!(
                    "{:<16} {:>5} {:>12} {:>7} {:>5} {:>12.6e} {:>8.2}  {}",
                    o.response,
                    o.curve,
                    level,
                    c.points.len(),
                    folds,
                    peak,
                    o.seconds,
                    stop_name(&c.stop)
                );
            }
        }
    }
    for o in outcomes {
        if let (Some(backbone), Some(Ok(curve))) = (&o.backbone, &o.result) {
            print_resonance(o, curve, backbone);
        }
    }
}

/// The lines under the summary that set a curve beside its backbone (docs/method.md §21): the
/// peak energy balance predicts for its level, and each phase resonance with the backbone's
/// peak at its frequency (interpolated between the branch's points).
fn print_resonance(o: &CurveOutcome, curve: &ResponseCurve, backbone: &Backbone) {
    let level = match o.sweep {
        Sweep::Frequency { amplitude, .. } => format!("a = {amplitude}"),
        Sweep::Amplitude { frequency, .. } => format!("Ω = {frequency} rad/s"),
    };
    println!(
        "{} curve {} ({level}) beside backbone `{}`:",
        o.response, o.curve, backbone.name
    );
    if let Sweep::Frequency { amplitude, .. } = o.sweep
        && let Some((frequency, peak)) = backbone.predicted_peak(amplitude)
    {
        println!("  energy-balance peak {peak:.6e} at {frequency:.6} rad/s");
    }
    for e in curve
        .events
        .iter()
        .filter(|e| e.kind == ResponseEventKind::PhaseResonance)
    {
        let Some(&peak) = e.point.peaks.first() else {
            continue;
        };
        let beside = backbone
            .peak_at(e.point.frequency)
            .map_or(String::new(), |on| {
                format!("; the backbone there {on:.6e} ({:+.1e})", peak / on - 1.0)
            });
        println!(
            "  phase resonance     {peak:.6e} at {:.6} rad/s{beside}",
            e.point.frequency
        );
    }
}

/// `(interrupted, failed, stopped early)` descriptions of the curves that did not finish.
pub fn unfinished(outcomes: &[CurveOutcome]) -> (usize, Vec<String>, Vec<String>) {
    let mut interrupted = 0;
    let (mut failed, mut early) = (Vec::new(), Vec::new());
    for o in outcomes {
        let who = format!("{} curve {}", o.response, o.curve);
        match &o.result {
            None => interrupted += 1,
            Some(Err(e)) => failed.push(format!("{who}: {e}")),
            Some(Ok(c)) => match &c.stop {
                ResponseStop::Stopped => interrupted += 1,
                ResponseStop::Failed(why) => early.push(format!("{who}: {why}")),
                ResponseStop::Closed(_) => early.push(format!("{who}: {}", stop_name(&c.stop))),
                _ => {}
            },
        }
    }
    (interrupted, failed, early)
}
