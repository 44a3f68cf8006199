//! Renders demo plots from synthetic data so the look of every plot kind can
//! be checked: FEPs (log energy axis, stable/unstable styles, palette), a
//! zoomed FEP of a 3:1 tongue with markers and a grey reference curve, a
//! line plot, and grids of mode shapes and time series.
//!
//! `cargo run --release -p nnm-plot --example fep_demo [-- OUT_DIR]`

use std::f64::consts::PI;

use nnm_plot::{FrequencyEnergyPlot, Line, LinePlot, Marker, PlotGrid, Series, SeriesPoint};

/// Hardening backbone w(E) = w0 (1 + 0.1 log10(1 + E/E0)^1.5).
fn hardening(w0: f64, e0: f64, energy: f64) -> f64 {
    w0 * (1.0 + 0.1 * (1.0 + energy / e0).log10().powf(1.5))
}

/// Backbone for E in 1e-4..1e3, with points whose index lies in a half-open
/// `unstable` interval marked unstable.
fn backbone(label: String, w0: f64, e0: f64, unstable: &[(usize, usize)]) -> Series {
    let n = 120;
    let points = (0..n)
        .map(|i| {
            let energy = 10f64.powf(-4.0 + 7.0 * i as f64 / (n - 1) as f64);
            SeriesPoint {
                energy,
                frequency: hardening(w0, e0, energy),
                stable: !unstable.iter().any(|&(a, b)| (a..b).contains(&i)),
            }
        })
        .collect();
    Series {
        label,
        points,
        ..Default::default()
    }
}

/// NNM 1 with a 3:1 tongue: it follows its backbone up to E = 1, leaves it
/// along a third of NNM 3's frequency up to a fold near E = 30 and comes back
/// (unstable) to E = 1.4, where it continues on its backbone. Returns the
/// branch, the reference curve and the markers.
fn tongue() -> (Series, Series, Vec<Marker>) {
    let w1 = |e: f64| hardening(1.0, 0.01, e);
    let w3 = |e: f64| hardening(3.75, 10.0, e) / 3.0;
    // Where the backbone meets the reference (bisection on log E).
    let (mut lo, mut hi) = (-3.0f64, 2.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        let e = 10f64.powf(mid);
        if w1(e) < w3(e) { lo = mid } else { hi = mid }
    }
    let (e1, e2, top) = (10f64.powf(lo), 1.3 * 10f64.powf(lo), 1.6);
    let mut points = Vec::new();
    let point = |energy: f64, frequency: f64, stable| SeriesPoint {
        energy,
        frequency,
        stable,
    };
    for i in 0..60 {
        let e = 10f64.powf(-3.0 + 3.0 * f64::from(i) / 60.0);
        points.push(point(e, w1(e), true));
    }
    let u_of = |i: i32| f64::from(i) / 80.0;
    let e_of = |u: f64| 10f64.powf(e1.log10() + (e2 / e1).log10() * u + top * (PI * u).sin());
    let offset = |u: f64| (w1(e1) - w3(e1)) * (1.0 - u) + (w1(e2) - w3(e2)) * u;
    let mut markers = Vec::new();
    for i in 0..=80 {
        let u = u_of(i);
        let e = e_of(u);
        let w = w3(e) + offset(u) + 0.006 * (PI * u).sin();
        points.push(point(e, w, u < 0.5));
        match i {
            20 => markers.push(("M1", e, w)),
            40 => markers.push(("fold", e, w)),
            60 => markers.push(("M2", e, w)),
            _ => {}
        }
    }
    for i in 1..40 {
        let e = e2 * 10f64.powf(2.5 * f64::from(i) / 39.0);
        points.push(point(e, w1(e), true));
        if i == 12 {
            markers.push(("M3", e, w1(e)));
        }
    }
    let reference: Vec<SeriesPoint> = (0..100)
        .map(|i| {
            let e = 10f64.powf(-3.0 + 6.0 * f64::from(i) / 99.0);
            point(e, w3(e), true)
        })
        .collect();
    let markers = markers
        .into_iter()
        .map(|(label, x, y)| Marker {
            x,
            y,
            label: label.into(),
            ..Default::default()
        })
        .collect();
    (
        Series {
            label: "NNM 1".into(),
            points,
            ..Default::default()
        },
        Series {
            label: "NNM 3 (frequency / 3)".into(),
            points: reference,
            reference: true,
            ..Default::default()
        },
        markers,
    )
}

fn line(label: &str, xy: Vec<(f64, f64)>, dashed: bool) -> Line {
    Line {
        label: label.into(),
        xy,
        dashed,
        ..Default::default()
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args_os()
        .nth(1)
        .map_or_else(std::env::temp_dir, std::path::PathBuf::from);
    std::fs::create_dir_all(&dir)?;

    let few = FrequencyEnergyPlot {
        title: "Backbones of a cyclic structure (synthetic)".into(),
        series: (0..5)
            .map(|k| {
                let unstable = [(40 + 10 * k, 55 + 10 * k), (100, 108)];
                backbone(
                    format!("NNM {} (k = {k})", k + 1),
                    1.0 + 0.8 * k as f64,
                    0.01,
                    &unstable,
                )
            })
            .collect(),
        frequency_label: "frequency (rad/s)".into(),
        ..Default::default()
    };
    few.write(&dir.join("fep_demo"))?;

    let many = FrequencyEnergyPlot {
        title: "35 branches (no legend)".into(),
        series: (0..35)
            .map(|k| {
                backbone(
                    format!("b{k}"),
                    1.0 + 0.15 * k as f64,
                    0.05,
                    &[(k * 3, k * 3 + 12)],
                )
            })
            .collect(),
        frequency_label: "frequency (Hz)".into(),
        ..Default::default()
    };
    many.write(&dir.join("fep_demo_many"))?;

    let (branch, reference, markers) = tongue();
    let full = FrequencyEnergyPlot {
        title: "NNM 1 with a 3:1 tongue (synthetic)".into(),
        series: vec![branch, reference],
        frequency_label: "frequency (rad/s)".into(),
        markers,
        ..Default::default()
    };
    full.write(&dir.join("fep_tongue"))?;
    let zoom = FrequencyEnergyPlot {
        title: "3:1 tongue, zoomed".into(),
        x_range: Some((0.3, 60.0)),
        y_range: Some((1.22, 1.36)),
        ..full
    };
    zoom.write(&dir.join("fep_tongue_zoom"))?;

    let t: Vec<f64> = (0..400).map(|i| i as f64 * 0.025).collect();
    let lines = LinePlot {
        title: "Periodic motion over one period".into(),
        x_label: "time (s)".into(),
        y_label: "displacement (m)".into(),
        lines: vec![
            line(
                "dof 1",
                t.iter().map(|&t| (t, 1e-3 * t.sin())).collect(),
                false,
            ),
            line(
                "dof 2",
                t.iter().map(|&t| (t, 4e-4 * (3.0 * t).sin())).collect(),
                true,
            ),
        ],
        markers: vec![Marker {
            x: PI / 2.0,
            y: 1e-3,
            label: "peak".into(),
            ..Default::default()
        }],
        ..Default::default()
    };
    lines.write(&dir.join("line_demo"))?;

    // Mode shapes of a 12-sector structure, nodal diameter k = 0..3.
    let sectors = 12;
    let shapes = PlotGrid {
        title: "Mode shapes per sector (synthetic)".into(),
        columns: 2,
        panels: (0..4)
            .map(|k| {
                let cos = |j: i32, a: f64| {
                    let phase = 2.0 * PI * f64::from(k) * f64::from(j) / f64::from(sectors);
                    (j.into(), a * (phase + 0.3).cos())
                };
                LinePlot {
                    title: format!("NNM {} (k = {k})", k + 1),
                    x_label: "sector".into(),
                    y_label: "amplitude (mm)".into(),
                    lines: vec![
                        line("blade", (0..sectors).map(|j| cos(j, 1.0)).collect(), false),
                        line("disk", (0..sectors).map(|j| cos(j, 0.25)).collect(), true),
                    ],
                    ..Default::default()
                }
            })
            .collect(),
    };
    shapes.write(&dir.join("grid_shapes"))?;

    let series = PlotGrid {
        title: "Motions M1, M2, M3 over one period".into(),
        columns: 3,
        panels: (1..=3)
            .map(|m| LinePlot {
                title: format!("M{m}"),
                x_label: "time (s)".into(),
                y_label: "displacement (m)".into(),
                lines: vec![
                    line(
                        "blade 1",
                        t.iter().map(|&t| (t, 1e-3 * t.sin())).collect(),
                        false,
                    ),
                    line(
                        "blade 2",
                        t.iter()
                            .map(|&t| (t, 1e-3 * t.sin() + 3e-4 * f64::from(m) * (3.0 * t).sin()))
                            .collect(),
                        false,
                    ),
                ],
                ..Default::default()
            })
            .collect(),
    };
    series.write(&dir.join("grid_series"))?;
    println!("wrote plots to {}", dir.display());
    Ok(())
}
