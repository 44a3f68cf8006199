//! The bladed-disk study of the paper (docs/method.md §11), end to end: linear modes, every backbone,
//! similar vs nonsimilar modes, localization along (1,14), the bifurcations along the
//! backbones, the travelling waves of (1,5) and (1,14), the forced resonance of (1,5) under
//! engine order 5 beside its backbone's energy balance, the 3:1 tongue between (0,6) and
//! (1,12), the sensitivity / finite-difference cost comparison, figures and `report.md`.
//!
//! Numerics and output are kept apart so that rewording the report or redrawing a figure never
//! touches a computation, and a computation can be read (and checked) without wading through
//! formatting: `backbones`, `similarity`, `localization`, `bifurcations`, `tongue` and
//! `junction` compute and return plain structs; `tables` (CSV), `figures` (PNG/SVG through
//! nnm-plot) and `report` / `report_tongue` (Markdown) only present them. This module runs the
//! sections in the report's order, each computed and then written.

use crate::progress::say;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use nnm::modes::{find_mode, linear_modes};
use nnm::shooting::JacobianMethod;
use nnm_io::job::load_job;

use crate::exit::Unfinished;
use crate::interrupt;
use crate::out_dir::OutDir;
use report::Report;

mod backbones;
mod bifurcations;
mod figures;
mod forced;
mod junction;
mod localization;
mod report;
mod report_forced;
mod report_tongue;
mod report_travelling;
mod similarity;
mod tables;
mod tongue;
mod travelling;

/// What to run.
pub struct StudyOptions {
    /// A subset of backbones and no finite-difference comparison: a first look in seconds.
    pub quick: bool,
    pub threads: Option<usize>,
}

/// Modes the sections are built on: the tongue's two ends, the localizing backbone and the
/// travelling waves' pairs.
const REQUIRED_MODES: [&str; 4] = ["0,6", "1,5", "1,12", "1,14"];
/// Samples per period for time series and harmonics.
const SAMPLES: usize = 256;

/// Runs the whole study on the model of `job_path` (its default settings for every branch) and
/// writes everything into `out`; fails on the first section that cannot be computed.
pub fn bladed_disk_study(job_path: &Path, out: &Path, options: &StudyOptions) -> Result<()> {
    let clock = Instant::now();
    let job = load_job(job_path)?;
    let structure = &job.structure;
    let settings = &job.default_settings;
    let modes = linear_modes(structure).context("modal analysis failed")?;
    for label in REQUIRED_MODES.iter().chain(&figures::SHAPE_MODES) {
        if find_mode(&modes, label, None).is_none() {
            bail!(
                "{}: the bladed-disk study needs mode ({label}); use a cyclic model with (n,d) labels and at least 30 sectors",
                job_path.display()
            );
        }
    }
    let _lock = OutDir::lock(out)?;
    let mut report = Report::new(job_path, options.quick);

    // 1. Linear modes.
    tables::modes(&modes, out)?;
    figures::mode_shapes(structure, &modes, out)?;
    report.linear_modes(modes.len());

    // 2. Backbones of every distinct mode.
    let backbones = backbones::compute(structure, &modes, settings, options, out)?;
    figures::backbones(&backbones, out)?;
    report.backbones(&backbones, &backbones::turning_back(&backbones));
    section(&mut report, out, clock, Ok(()))?;

    // 3. Similar and nonsimilar modes.
    let shape_changes = similarity::shape_changes(structure, &modes, &backbones);
    tables::similarity(&shape_changes, out)?;
    report.similarity(&shape_changes);

    // 4. Localization along (1,14).
    let localization = localization::along(structure, &modes, backbones.branch("1,14"))?;
    tables::localization(&localization, out)?;
    figures::localization(&localization, out)?;
    report.localization(&localization);

    // Bifurcations along the backbones and the switch at a branch point of (1,5).
    let events = section(
        &mut report,
        out,
        clock,
        bifurcations::analyse(structure, &modes, &backbones, settings, out),
    )?;
    if let Some(switched) = &events.switched {
        figures::bifurcations(switched, out)?;
    }
    report.bifurcations(&events);

    // Travelling waves of (1,5) and (1,14) beside their standing waves.
    let travelling = section(
        &mut report,
        out,
        clock,
        travelling::compute(structure, &modes, &backbones, settings, options, out),
    )?;
    figures::travelling(&travelling, &backbones, out)?;
    report.travelling(&travelling);

    // The forced resonance of (1,5): its travelling backbone's energy balance, three curves.
    let forced = section(
        &mut report,
        out,
        clock,
        forced::compute(structure, &modes, settings, out),
    )?;
    report.forced(&forced);

    // 5. The 3:1 tongue, with sensitivities, checked against (1,12).
    let tongue_with =
        |jacobian, dir: &Path| tongue::continue_tongue(structure, &modes, settings, jacobian, dir);
    let tongue = section(
        &mut report,
        out,
        clock,
        tongue_with(JacobianMethod::Sensitivity, out),
    )?;
    let junction = section(
        &mut report,
        out,
        clock,
        junction::check(structure, &modes, &tongue, settings, out),
    )?;
    let motions = tongue::representative_motions(structure, &tongue)?;
    tables::tongue(&tongue, out)?;
    figures::tongue(&tongue, &junction, &motions, backbones.branch("0,6"), out)?;
    report.tongue(&tongue, &junction, &modes);

    // 6. The tongue again with finite differences (full study only): the cost comparison.
    if options.quick {
        report.cost_comparison_skipped();
    } else {
        say!("study: the tongue again with the finite-difference Jacobian (slow) ...");
        let fd_out = out.join("finite-difference");
        let fd = section(
            &mut report,
            out,
            clock,
            tongue_with(JacobianMethod::FiniteDifference, &fd_out),
        )?;
        report.cost_comparison(&tongue, &fd);
    }

    report.wall_time(clock.elapsed().as_secs_f64());
    report.write(&out.join("report.md"))?;
    if !crate::progress::quiet() {
        println!(
            "study finished in {:.1} s; report: {}",
            clock.elapsed().as_secs_f64(),
            out.join("report.md").display()
        );
    }
    Ok(())
}

/// A section's result, unless Ctrl-C came (whatever the section returned: an interrupted
/// branch can make it fail): then `report.md` is written as far as the study got, and the
/// study ends as interrupted (the sections after this one need what it did not finish).
fn section<T>(report: &mut Report, out: &Path, clock: Instant, result: Result<T>) -> Result<T> {
    if !interrupt::requested() {
        return result;
    }
    report.interrupted();
    report.wall_time(clock.elapsed().as_secs_f64());
    let path = out.join("report.md");
    report.write(&path)?;
    Err(Unfinished::Interrupted(format!(
        "interrupted: the study stopped; {} has the sections finished",
        path.display()
    ))
    .into())
}
