//! The study's CSV tables, written from the sections' numbers: `modes.csv`, `similarity.csv`,
//! `backbones.csv`, `localization.csv` and `tongue.csv` (the branches' own files are written
//! as they are computed).

use std::path::Path;

use anyhow::Result;
use nnm::modes::LinearMode;
use nnm_io::output::{number, write_modes_csv, write_table};

use super::localization::Localization;
use super::similarity::ShapeChange;
use super::tongue::Tongue;

pub(super) fn modes(modes: &[LinearMode], out: &Path) -> Result<()> {
    write_modes_csv(&out.join("modes.csv"), modes)?;
    Ok(())
}

/// A frequency shift as tabulated (percent, two decimals, signed), `—` where there is none.
fn shift_text(shift: Option<f64>) -> String {
    shift.map_or(String::from("—"), |s| format!("{s:+.2}"))
}

/// `similarity.csv`: the shape angle at every point of every backbone; `backbones.csv`: one
/// line a backbone (frequency shifts, largest shape angle, size, cost).
pub(super) fn similarity(changes: &[ShapeChange], out: &Path) -> Result<()> {
    let per_point = changes.iter().flat_map(|c| {
        c.points.iter().map(|p| {
            vec![
                c.name.clone(),
                c.label.clone(),
                number(p.energy),
                number(p.frequency),
                number(p.angle),
            ]
        })
    });
    write_table(
        &out.join("similarity.csv"),
        &[
            "branch",
            "label",
            "energy",
            "frequency_rad_s",
            "shape_angle_deg",
        ],
        per_point,
    )?;
    let summary = changes.iter().map(|c| {
        vec![
            c.label.clone(),
            number(c.linear_frequency),
            shift_text(c.shifts[0]),
            shift_text(c.shifts[1]),
            number(c.max_angle),
            c.points.len().to_string(),
            number(c.seconds),
        ]
    });
    write_table(
        &out.join("backbones.csv"),
        &[
            "label",
            "linear_frequency_rad_s",
            "shift_at_E10_percent",
            "shift_at_E100_percent",
            "max_shape_angle_deg",
            "points",
            "time_s",
        ],
        summary,
    )?;
    Ok(())
}

pub(super) fn localization(localization: &Localization, out: &Path) -> Result<()> {
    let rows = localization.points.iter().map(|s| {
        vec![
            number(s.energy),
            number(s.frequency),
            number(s.top3_share),
            number(s.participation),
        ]
    });
    write_table(
        &out.join("localization.csv"),
        &[
            "energy",
            "frequency_rad_s",
            "top3_share",
            "participation_sectors",
        ],
        rows,
    )?;
    Ok(())
}

/// `tongue.csv`: every point of the (0,6) branch and its tongue with its harmonic content.
pub(super) fn tongue(tongue: &Tongue, out: &Path) -> Result<()> {
    let rows = tongue.points.iter().map(|t| {
        vec![
            t.point.index.to_string(),
            number(t.point.energy),
            number(t.point.frequency),
            number(t.a1),
            number(t.a3),
            number(t.a3 / t.a1.abs()),
            t.point.floquet.stable.to_string(),
            number(t.point.floquet.max_modulus),
            t.point
                .regime
                .map_or(String::new(), |r| r.kind.name().to_string()),
        ]
    });
    write_table(
        &out.join("tongue.csv"),
        &[
            "index",
            "energy",
            "frequency_rad_s",
            "fundamental",
            "third_harmonic",
            "third_over_fundamental",
            "stable",
            "max_floquet_modulus",
            "regime",
        ],
        rows,
    )?;
    Ok(())
}
