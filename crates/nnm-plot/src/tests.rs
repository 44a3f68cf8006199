use std::path::{Path, PathBuf};

use plotters::style::RGBColor;

use super::*;
use crate::axes::{tick_decimals, tick_label, x_tick_label, x_ticks};
use crate::clip::{clip_polyline, contains};
use crate::panel::polyline_paths;
use crate::style::{REFERENCE_GREY, palette};

/// A fresh directory per test so parallel tests never share files.
fn temp_dir(name: &str) -> PathBuf {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let dir = std::env::temp_dir().join(format!("nnm-plot-{name}-{}-{nanos}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn check_files(stem: &Path, texts: &[&str]) {
    let png = std::fs::read(stem.with_extension("png")).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"));
    let svg = std::fs::read_to_string(stem.with_extension("svg")).unwrap();
    assert!(svg.contains("<svg"));
    for t in texts {
        assert!(svg.contains(t), "SVG lacks {t:?}");
    }
}

fn branch(label: &str, w0: f64, unstable: std::ops::Range<usize>) -> Series {
    let points = (0..60)
        .map(|i| {
            let energy = 10f64.powf(-4.0 + 7.0 * f64::from(i) / 59.0);
            let frequency = w0 * (1.0 + 0.1 * (1.0 + energy).ln());
            SeriesPoint {
                energy,
                frequency,
                stable: !unstable.contains(&(i as usize)),
            }
        })
        .collect();
    Series {
        label: label.into(),
        points,
        ..Default::default()
    }
}

/// A model in physical units names them on both axes; without `energy_label` the energy axis
/// stays "total energy".
#[test]
fn fep_energy_label_replaces_the_default() {
    let dir = temp_dir("fep-units");
    let plot = FrequencyEnergyPlot {
        series: vec![branch("NNM 1", 1.0, 0..0)],
        frequency_label: "frequency (Hz)".into(),
        energy_label: "total energy (J)".into(),
        ..Default::default()
    };
    let stem = dir.join("fep");
    plot.write(&stem).unwrap();
    check_files(&stem, &["total energy (J)", "frequency (Hz)"]);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn fep_writes_png_and_svg() {
    let dir = temp_dir("fep");
    let plot = FrequencyEnergyPlot {
        title: "test FEP".into(),
        series: vec![branch("NNM 1", 1.0, 30..40), branch("NNM 2", 2.5, 0..0)],
        frequency_label: "frequency (rad/s)".into(),
        ..Default::default()
    };
    let stem = dir.join("fep");
    plot.write(&stem).unwrap();
    check_files(
        &stem,
        &[
            "frequency (rad/s)",
            "total energy",
            "test FEP",
            "NNM 2",
            "10⁻⁴",
        ],
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn fep_many_series_single_point_and_bad_values() {
    let dir = temp_dir("fep-many");
    let mut series: Vec<Series> = (0..35)
        .map(|i| branch(&format!("b{i}"), 1.0 + 0.1 * f64::from(i), 0..5))
        .collect();
    series[0].points[3].energy = -1.0;
    series[1].points[7].frequency = f64::NAN;
    let plot = FrequencyEnergyPlot {
        title: "many".into(),
        series,
        frequency_label: "w".into(),
        ..Default::default()
    };
    let stem = dir.join("many");
    plot.write(&stem).unwrap();
    check_files(&stem, &["total energy"]);

    let one = FrequencyEnergyPlot {
        title: "one".into(),
        series: vec![Series {
            label: "p".into(),
            points: vec![SeriesPoint {
                energy: 0.5,
                frequency: 3.0,
                stable: true,
            }],
            ..Default::default()
        }],
        frequency_label: "w".into(),
        ..Default::default()
    };
    let stem = dir.join("one");
    one.write(&stem).unwrap();
    check_files(&stem, &["w"]);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn empty_input_is_an_error() {
    let dir = temp_dir("empty");
    let empty = FrequencyEnergyPlot {
        title: "e".into(),
        series: vec![],
        frequency_label: "w".into(),
        ..Default::default()
    };
    assert!(matches!(
        empty.write(&dir.join("a")),
        Err(PlotError::NoData(_))
    ));
    let no_points = FrequencyEnergyPlot {
        title: "e".into(),
        series: vec![Series {
            label: "s".into(),
            points: vec![],
            ..Default::default()
        }],
        frequency_label: "w".into(),
        ..Default::default()
    };
    assert!(matches!(
        no_points.write(&dir.join("b")),
        Err(PlotError::NoData(_))
    ));
    let bad = SeriesPoint {
        energy: 0.0,
        frequency: 1.0,
        stable: true,
    };
    let only_bad = FrequencyEnergyPlot {
        title: "e".into(),
        series: vec![Series {
            label: "s".into(),
            points: vec![bad, bad],
            ..Default::default()
        }],
        frequency_label: "w".into(),
        ..Default::default()
    };
    assert!(matches!(
        only_bad.write(&dir.join("c")),
        Err(PlotError::NoData(_))
    ));
    let lines = LinePlot {
        title: "t".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        log_x: false,
        lines: vec![],
        ..Default::default()
    };
    assert!(matches!(
        lines.write(&dir.join("d")),
        Err(PlotError::NoData(_))
    ));
    assert!(!dir.join("a.png").exists());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn line_plot_writes_png_and_svg() {
    let dir = temp_dir("line");
    let xy: Vec<(f64, f64)> = (0..200)
        .map(|i| (f64::from(i) * 0.05, (f64::from(i) * 0.05).sin()))
        .collect();
    let plot = LinePlot {
        title: "motion".into(),
        x_label: "time (s)".into(),
        y_label: "displacement (m)".into(),
        log_x: false,
        lines: vec![
            Line {
                label: "x1".into(),
                xy: xy.clone(),
                dashed: false,
                ..Default::default()
            },
            Line {
                label: "x2".into(),
                xy: xy.iter().map(|&(t, y)| (t, 0.5 * y)).collect(),
                dashed: true,
                ..Default::default()
            },
        ],
        ..Default::default()
    };
    let stem = dir.join("line");
    plot.write(&stem).unwrap();
    check_files(&stem, &["time (s)", "displacement (m)", "x2"]);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn missing_directory_is_an_error_not_a_panic() {
    let plot = LinePlot {
        title: "t".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        log_x: true,
        lines: vec![Line {
            label: String::new(),
            xy: vec![(1.0, 1.0), (10.0, 2.0)],
            dashed: false,
            ..Default::default()
        }],
        ..Default::default()
    };
    let stem = std::env::temp_dir().join("nnm-plot-no-such-dir-xyz/sub/p");
    assert!(matches!(plot.write(&stem), Err(PlotError::Draw { .. })));
}

#[test]
fn log_ticks_and_labels() {
    assert_eq!(x_tick_label(true, -4.0, false), "10⁻⁴");
    assert_eq!(x_tick_label(true, 3.0, false), "10³");
    assert_eq!(x_tick_label(true, 2f64.log10() - 1.0, false), "2×10⁻¹");
    assert_eq!(x_tick_label(true, 5f64.log10() - 2.0, true), "0.05");
    assert_eq!(x_tick_label(true, 3f64.log10() + 2.0, true), "300");
    assert_eq!(x_tick_label(true, 2f64.log10() - 5.0, true), "2×10⁻⁵");
    assert_eq!(x_ticks(true, -4.2, 3.1, 12, false).len(), 8);
    // Less than a decade: mantissa ticks instead of (at most one) decade.
    assert!(x_ticks(true, 0.1, 0.9, 12, false).len() >= 3);
}

#[test]
fn dotted_stem_extreme_values_and_empty_labels() {
    let dir = temp_dir("odd");
    let plot = LinePlot {
        title: String::new(),
        x_label: String::new(),
        y_label: String::new(),
        log_x: false,
        lines: vec![Line {
            label: String::new(),
            xy: vec![
                (0.0, -1e308),
                (1.0, f64::INFINITY),
                (2.0, 1e308),
                (f64::NAN, 0.0),
            ],
            dashed: true,
            ..Default::default()
        }],
        ..Default::default()
    };
    let stem = dir.join("amp0.5");
    plot.write(&stem).unwrap();
    assert!(dir.join("amp0.5.png").exists() && dir.join("amp0.5.svg").exists());
    // Identical points: degenerate ranges must still give a finite axis.
    let flat = LinePlot {
        log_x: true,
        lines: vec![Line {
            xy: vec![(2.0, 0.0); 3],
            ..plot.lines[0].clone()
        }],
        ..plot
    };
    flat.write(&dir.join("flat")).unwrap();
    check_files(&dir.join("flat"), &[]);
    std::fs::remove_dir_all(dir).ok();
}

fn marker(label: &str, x: f64, y: f64) -> Marker {
    Marker {
        x,
        y,
        label: label.into(),
        ..Default::default()
    }
}

fn sine_plot(title: &str) -> LinePlot {
    let xy: Vec<(f64, f64)> = (0..100)
        .map(|i| (f64::from(i) * 0.1, (f64::from(i) * 0.1).sin()))
        .collect();
    LinePlot {
        title: title.into(),
        x_label: "time (s)".into(),
        y_label: "q".into(),
        lines: vec![
            Line {
                label: "blade".into(),
                xy: xy.clone(),
                ..Default::default()
            },
            Line {
                label: "disk".into(),
                xy: xy.iter().map(|&(t, y)| (t, 0.3 * y)).collect(),
                dashed: true,
                ..Default::default()
            },
        ],
        ..Default::default()
    }
}

#[test]
fn zoomed_fep_with_markers_and_reference() {
    let dir = temp_dir("fep-zoom");
    let mut reference = branch("NNM 3 / 3", 0.9, 0..0);
    reference.reference = true;
    let plot = FrequencyEnergyPlot {
        title: "tongue".into(),
        series: vec![reference, branch("NNM 1", 1.0, 30..40)],
        frequency_label: "frequency (rad/s)".into(),
        markers: vec![
            marker("M1", 0.1, 1.01),
            marker("M2", 1.0, 1.07),
            marker("fold", 10.0, 1.24),
            // Outside the x range: not drawn.
            marker("far", 1e3, 1.7),
        ],
        x_range: Some((0.01, 100.0)),
        y_range: None,
        ..Default::default()
    };
    let stem = dir.join("zoom");
    plot.write(&stem).unwrap();
    check_files(
        &stem,
        &["M1", "M2", "fold", "NNM 3 / 3", "NNM 1", "10⁻²", "10²"],
    );
    let svg = std::fs::read_to_string(stem.with_extension("svg")).unwrap();
    assert!(!svg.contains("far"));
    // Grey reference, thin; the other branch keeps the first palette colour.
    assert!(svg.contains("stroke=\"#969696\" stroke-width=\"1\""));
    assert!(svg.contains("stroke=\"#1F77B4\""));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn reference_and_explicit_colours_take_no_palette_slot() {
    let mut reference = branch("ref", 0.9, 0..0);
    reference.reference = true;
    let mut red = branch("red", 1.1, 0..0);
    red.color = Some((200, 0, 0));
    let plot = FrequencyEnergyPlot {
        series: vec![reference, red, branch("a", 1.0, 0..0)],
        ..Default::default()
    };
    let fig = plot.figure().unwrap();
    assert_eq!(fig.curves[0].color, REFERENCE_GREY);
    assert_eq!(fig.curves[1].color, RGBColor(200, 0, 0));
    assert_eq!(fig.curves[2].color, palette(0, 1));
}

#[test]
fn fixed_x_range_fits_y_to_the_visible_data() {
    let plot = LinePlot {
        lines: vec![Line {
            xy: (0..=100).map(|i| (f64::from(i), f64::from(i))).collect(),
            ..Default::default()
        }],
        x_range: Some((40.0, 20.0)), // either order
        ..Default::default()
    };
    let fig = plot.figure().unwrap();
    assert_eq!(fig.xr, 20.0..40.0);
    assert!(fig.yr.start > 18.0 && fig.yr.start < 20.0, "{:?}", fig.yr);
    assert!(fig.yr.end > 40.0 && fig.yr.end < 42.0, "{:?}", fig.yr);
    // Everything drawn lies inside the axes.
    for (xy, _) in &fig.curves[0].pieces {
        assert!(xy.iter().all(|&p| contains(&fig.xr, &fig.yr, p)));
    }

    // Log axis: the range is given in data units.
    let fep = FrequencyEnergyPlot {
        series: vec![branch("b", 1.0, 0..0)],
        x_range: Some((1e-2, 1e2)),
        y_range: Some((1.0, 1.2)),
        ..Default::default()
    };
    let fig = fep.figure().unwrap();
    assert_eq!(fig.xr, -2.0..2.0);
    assert_eq!(fig.yr, 1.0..1.2);
}

#[test]
fn bad_ranges_are_errors() {
    let dir = temp_dir("bad-range");
    let base = FrequencyEnergyPlot {
        series: vec![branch("b", 1.0, 0..0)],
        ..Default::default()
    };
    for (x, y) in [
        (Some((0.0, 1.0)), None),
        (Some((-1.0, 1.0)), None),
        (Some((1.0, 1.0)), None),
        (None, Some((f64::NAN, 1.0))),
        (None, Some((2.0, 2.0))),
        (None, Some((0.0, f64::INFINITY))),
    ] {
        let plot = FrequencyEnergyPlot {
            x_range: x,
            y_range: y,
            ..base.clone()
        };
        let r = plot.write(&dir.join("p"));
        assert!(matches!(r, Err(PlotError::BadRange { .. })), "{x:?} {y:?}");
    }
    // A range with no data in it is fine: empty axes.
    let off = LinePlot {
        x_range: Some((50.0, 60.0)),
        y_range: Some((5.0, 6.0)),
        ..sine_plot("off")
    };
    off.write(&dir.join("off")).unwrap();
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn grid_writes_one_image_with_all_panels() {
    let dir = temp_dir("grid");
    let mut panels: Vec<LinePlot> = (1..=4).map(|k| sine_plot(&format!("NNM {k}"))).collect();
    panels[2].markers = vec![marker("M2", 1.5, 1.0)];
    panels[3].log_x = true;
    let grid = PlotGrid {
        title: "mode shapes".into(),
        columns: 2,
        panels,
    };
    let stem = dir.join("grid");
    grid.write(&stem).unwrap();
    check_files(
        &stem,
        &[
            "mode shapes",
            "NNM 1",
            "NNM 2",
            "NNM 3",
            "NNM 4",
            "M2",
            "disk",
        ],
    );
    let svg = std::fs::read_to_string(stem.with_extension("svg")).unwrap();
    assert!(svg.contains("width=\"1280\"") && svg.contains("height=\"932\""));

    // Three panels in one row; columns beyond the panel count are clamped.
    let row = PlotGrid {
        title: String::new(),
        columns: 9,
        panels: (1..=3).map(|k| sine_plot(&format!("M{k}"))).collect(),
    };
    row.write(&dir.join("row")).unwrap();
    let svg = std::fs::read_to_string(dir.join("row.svg")).unwrap();
    assert!(svg.contains("width=\"1920\"") && svg.contains("height=\"440\""));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn empty_grid_or_panel_is_an_error() {
    let dir = temp_dir("grid-empty");
    let none = PlotGrid {
        title: "g".into(),
        columns: 2,
        panels: vec![],
    };
    assert!(matches!(
        none.write(&dir.join("a")),
        Err(PlotError::NoData(_))
    ));
    let one_empty = PlotGrid {
        title: "g".into(),
        columns: 0,
        panels: vec![sine_plot("ok"), LinePlot::default()],
    };
    assert!(matches!(
        one_empty.write(&dir.join("b")),
        Err(PlotError::NoData(_))
    ));
    assert!(!dir.join("a.png").exists() && !dir.join("b.png").exists());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn markers_alone_are_drawable() {
    let dir = temp_dir("markers");
    let plot = LinePlot {
        title: "folds".into(),
        markers: vec![marker("fold", 1.0, 2.0), marker("", 2.0, 3.0)],
        ..Default::default()
    };
    plot.write(&dir.join("m")).unwrap();
    check_files(&dir.join("m"), &["fold"]);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn clipping_cuts_segments_at_the_frame() {
    let (xr, yr) = (0.0..1.0, 0.0..1.0);
    // In, out, back in: two runs, cut exactly at x = 1.
    let runs = clip_polyline(&[(0.5, 0.5), (1.5, 0.5), (0.5, 0.6)], &xr, &yr);
    assert_eq!(
        runs,
        vec![vec![(0.5, 0.5), (1.0, 0.5)], vec![(1.0, 0.55), (0.5, 0.6)]]
    );
    // Crossing the whole box without a vertex inside.
    let runs = clip_polyline(&[(-1.0, 0.5), (2.0, 0.5)], &xr, &yr);
    assert_eq!(runs, vec![vec![(0.0, 0.5), (1.0, 0.5)]]);
    // Entirely outside, and a lone point outside.
    assert!(clip_polyline(&[(2.0, 2.0), (3.0, 5.0)], &xr, &yr).is_empty());
    assert!(clip_polyline(&[(2.0, 0.5)], &xr, &yr).is_empty());
    // Infinite bounds clip nothing.
    let all = f64::NEG_INFINITY..f64::INFINITY;
    let xy = vec![(-1e300, 3.0), (0.0, -1e300), (5.0, 5.0)];
    assert_eq!(clip_polyline(&xy, &all, &all), vec![xy]);
}

#[test]
fn strokes_split_at_sharp_turns_and_dashes() {
    // A fold: out and straight back. Two paths sharing the tip.
    let fold = [(0, 0), (50, 0), (10, 2)];
    let paths = polyline_paths(&fold, None);
    assert_eq!(paths, vec![vec![(0, 0), (50, 0)], vec![(50, 0), (10, 2)]]);
    // A gentle bend stays one path; near-duplicate points are thinned out.
    let bend = [(0, 0), (20, 0), (21, 0), (40, 10)];
    assert_eq!(
        polyline_paths(&bend, None),
        vec![vec![(0, 0), (20, 0), (40, 10)]]
    );
    // Dashes of 8 on, 6 off along 40 px: 0-8, 14-22, 28-36.
    let dashes = polyline_paths(&[(0, 0), (40, 0)], Some((8.0, 6.0)));
    assert_eq!(
        dashes,
        vec![
            vec![(0, 0), (8, 0)],
            vec![(14, 0), (22, 0)],
            vec![(28, 0), (36, 0)],
        ]
    );
    assert!(polyline_paths(&[(3, 3), (3, 3)], None).is_empty());
}

#[test]
fn linear_tick_labels_share_their_decimals() {
    let d = tick_decimals(&[0.0, 0.5, 1.0, 1.5]);
    assert_eq!(d, Some(1));
    assert_eq!(tick_label(1.0, d), "1.0");
    assert_eq!(tick_label(-1e-17, d), "0.0");
    assert_eq!(tick_decimals(&[0.0, 2.0, 4.0]), Some(0));
    assert_eq!(tick_decimals(&[-0.001, -0.0005, 0.0]), Some(4));
    assert_eq!(tick_decimals(&[0.0, 1e6, 2e6]), None);
    assert_eq!(tick_decimals(&[0.0, 1e-7]), None);
}
