//! The study's CSV tables, written from the sections' numbers: `modes.csv`, `similarity.csv`,
//! `backbones.csv`, `localization.csv` and `tongue.csv` (the branches' own files are written
//! as they are computed).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use nnm::modes::LinearMode;
use nnm_io::output::write_modes_csv;

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
    let mut per_point = String::from("branch,label,energy,frequency_rad_s,shape_angle_deg\n");
    let mut summary = String::from(
        "label,linear_frequency_rad_s,shift_at_E10_percent,shift_at_E100_percent,max_shape_angle_deg,points,time_s\n",
    );
    for c in changes {
        for p in &c.points {
            let _ = writeln!(
                per_point,
                "{},\"{}\",{},{},{}",
                c.name, c.label, p.energy, p.frequency, p.angle
            );
        }
        let _ = writeln!(
            summary,
            "\"{}\",{},{},{},{},{},{}",
            c.label,
            c.linear_frequency,
            shift_text(c.shifts[0]),
            shift_text(c.shifts[1]),
            c.max_angle,
            c.points.len(),
            c.seconds
        );
    }
    std::fs::write(out.join("similarity.csv"), per_point)?;
    std::fs::write(out.join("backbones.csv"), summary)?;
    Ok(())
}

pub(super) fn localization(localization: &Localization, out: &Path) -> Result<()> {
    let mut csv = String::from("energy,frequency_rad_s,top3_share,participation_sectors\n");
    for s in &localization.points {
        let _ = writeln!(
            csv,
            "{},{},{},{}",
            s.energy, s.frequency, s.top3_share, s.participation
        );
    }
    std::fs::write(out.join("localization.csv"), csv)?;
    Ok(())
}

/// `tongue.csv`: every point of the (0,6) branch and its tongue with its harmonic content.
pub(super) fn tongue(tongue: &Tongue, out: &Path) -> Result<()> {
    let mut csv = String::from(
        "index,energy,frequency_rad_s,fundamental,third_harmonic,third_over_fundamental,stable,max_floquet_modulus\n",
    );
    for t in &tongue.points {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{}",
            t.point.index,
            t.point.energy,
            t.point.frequency,
            t.a1,
            t.a3,
            t.a3 / t.a1.abs(),
            t.point.floquet.stable,
            t.point.floquet.max_modulus
        );
    }
    std::fs::write(out.join("tongue.csv"), csv)?;
    Ok(())
}
