use super::*;

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
    }
}

#[test]
fn fep_writes_png_and_svg() {
    let dir = temp_dir("fep");
    let plot = FrequencyEnergyPlot {
        title: "test FEP".into(),
        series: vec![branch("NNM 1", 1.0, 30..40), branch("NNM 2", 2.5, 0..0)],
        frequency_label: "frequency (rad/s)".into(),
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
        }],
        frequency_label: "w".into(),
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
        }],
        frequency_label: "w".into(),
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
        }],
        frequency_label: "w".into(),
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
            },
            Line {
                label: "x2".into(),
                xy: xy.iter().map(|&(t, y)| (t, 0.5 * y)).collect(),
                dashed: true,
            },
        ],
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
        }],
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
        }],
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
