//! Renders demo plots from synthetic hardening backbones so the look of the
//! FEP (log energy axis, stable/unstable styles, palette) can be checked.
//!
//! `cargo run --release -p nnm-plot --example fep_demo [-- OUT_DIR]`

use nnm_plot::{FrequencyEnergyPlot, Line, LinePlot, Series, SeriesPoint};

/// Hardening backbone w(E) = w0 (1 + 0.1 log10(1 + E/E0)^1.5), E in 1e-4..1e3,
/// with points whose index lies in a half-open `unstable` interval marked
/// unstable.
fn backbone(label: String, w0: f64, e0: f64, unstable: &[(usize, usize)]) -> Series {
    let n = 120;
    let points = (0..n)
        .map(|i| {
            let energy = 10f64.powf(-4.0 + 7.0 * i as f64 / (n - 1) as f64);
            let frequency = w0 * (1.0 + 0.1 * (1.0 + energy / e0).log10().powf(1.5));
            let stable = !unstable.iter().any(|&(a, b)| (a..b).contains(&i));
            SeriesPoint {
                energy,
                frequency,
                stable,
            }
        })
        .collect();
    Series { label, points }
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
    };
    many.write(&dir.join("fep_demo_many"))?;

    let t: Vec<f64> = (0..400).map(|i| i as f64 * 0.025).collect();
    let lines = LinePlot {
        title: "Periodic motion over one period".into(),
        x_label: "time (s)".into(),
        y_label: "displacement (m)".into(),
        log_x: false,
        lines: vec![
            Line {
                label: "dof 1".into(),
                xy: t.iter().map(|&t| (t, 1e-3 * t.sin())).collect(),
                dashed: false,
            },
            Line {
                label: "dof 2".into(),
                xy: t.iter().map(|&t| (t, 4e-4 * (3.0 * t).sin())).collect(),
                dashed: true,
            },
        ],
    };
    lines.write(&dir.join("line_demo"))?;
    println!("wrote plots to {}", dir.display());
    Ok(())
}
