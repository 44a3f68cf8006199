//! `nnm example cantilever-beam`: the ECL cantilever beam (NLvib's example 09) end to end. Its
//! linear frequencies against Euler–Bernoulli theory, its first nonlinear normal modes computed
//! by `nnm run`'s machinery (the same CSV and JSON per branch, beside the job file that was
//! run), and how the first mode's deflected shape changes with energy.
//!
//! This module computes and returns plain numbers; `output` writes them (`modes.csv`,
//! `fep.png`, `fep-normalised.png`, `mode-shapes.png`, `report.md`).

use std::f64::consts::PI;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use nnm::BranchPoint;
use nnm::model::{CantileverBeam, MechanicalSystem};
use nnm::modes::{LinearMode, linear_modes};
use nnm_io::job::load_job;

use crate::compute::{Outcome, compute_all, failures, print_summary, resolve};

mod output;

/// `β_k L` of the first clamped–free Euler–Bernoulli modes, the roots of
/// `cos βL · cosh βL = −1`.
pub const BETA_L: [f64; 4] = [
    1.875_104_068_711_961,
    4.694_091_132_974_175,
    7.854_757_438_237_613,
    10.995_540_734_875_467,
];
/// NNMs of the full example (modes 1, 2, 3) and of `--quick` (mode 1).
const MODES: usize = 3;
const QUICK_MODES: usize = 1;
/// Every branch runs from the linear limit until its frequency has moved by this fraction.
const FREQUENCY_SHIFT_MAX: f64 = 0.2;
/// The first NNM's deflection is drawn at its first point, at the points nearest to these
/// fractions of its final frequency shift, and at its last point.
const SHAPE_FRACTIONS: [f64; 3] = [0.25, 0.5, 0.75];
/// Samples of `w(x)` per element (Hermite interpolation inside the elements).
const SAMPLES_PER_ELEMENT: usize = 8;

/// What to run.
pub struct BeamOptions {
    /// The first NNM only.
    pub quick: bool,
    /// Only print the summary, not every point.
    pub quiet: bool,
}

/// A linear frequency of the finite-element model beside Euler–Bernoulli theory (rad/s).
pub(crate) struct LinearFrequency {
    pub model: f64,
    pub theory: f64,
}

impl LinearFrequency {
    pub fn relative_difference(&self) -> f64 {
        (self.model - self.theory) / self.theory
    }
}

/// The first NNM's deflection at `t = 0` at one point of its branch.
pub(crate) struct Deflection {
    pub energy: f64,
    /// rad/s.
    pub frequency: f64,
    /// `(x, w(x) / w(L))`, from the root to the tip.
    pub shape: Vec<(f64, f64)>,
    /// `w(L/2) / w(L)`.
    pub midspan: f64,
}

/// How the first NNM's shape changes along its branch.
pub(crate) struct ShapeChange {
    /// The linear mode shape, normalised as the others.
    pub linear: Deflection,
    /// The chosen points of the branch, in branch order.
    pub points: Vec<Deflection>,
}

/// Everything the outputs are written from.
pub(crate) struct BeamStudy {
    pub beam: CantileverBeam,
    pub quick: bool,
    pub frequencies: Vec<LinearFrequency>,
    pub outcomes: Vec<Outcome>,
    /// Wall time of the branches (computed in parallel).
    pub branch_seconds: f64,
    pub shapes: ShapeChange,
}

/// Writes the job file into `out`, computes its branches there and writes the beam's
/// outputs beside them.
pub fn cantilever_beam_example(out: &Path, options: &BeamOptions) -> Result<()> {
    let clock = Instant::now();
    let beam = CantileverBeam::default();
    let branches = if options.quick { QUICK_MODES } else { MODES };
    let _lock = crate::out_dir::OutDir::lock(out)?;
    let job_path = crate::write_example_job(out, "cantilever-beam", &job_text(&beam, branches))?;
    let job = load_job(&job_path)?;
    let structure = &job.structure;
    if structure.dofs() != 2 * beam.elements {
        bail!(
            "{}: the model has {} dofs, the beam of {} elements 2 a node",
            job_path.display(),
            structure.dofs(),
            beam.elements
        );
    }
    let modes = linear_modes(structure).context("modal analysis failed")?;
    let frequencies = linear_frequencies(&beam, &modes);
    let requests = resolve(structure, &job.branches, &modes)?;
    let started = Instant::now();
    let outcomes = compute_all(structure, requests, out, None, options.quiet)?;
    let branch_seconds = started.elapsed().as_secs_f64();
    let failed = failures(&outcomes);
    if !options.quiet {
        crate::progress::separate();
    }
    // Quiet: the summary only when something went wrong (it says which branch).
    if !options.quiet || !failed.is_empty() || crate::interrupt::requested() {
        print_summary(&outcomes, &modes);
    }
    if crate::interrupt::requested() {
        return Err(crate::exit::Unfinished::Interrupted(
            "interrupted: the summary above and the branch files hold what was computed".into(),
        )
        .into());
    }
    if !failed.is_empty() {
        bail!("branches failed: {}", failed.join("; "));
    }
    let first = outcomes
        .iter()
        .find(|o| o.info.mode_index == 0)
        .and_then(|o| o.result.as_ref().ok())
        .context("the job has no branch of the first mode")?;
    let shapes = shape_change(&beam, &modes[0], &first.points)?;
    let study = BeamStudy {
        beam,
        quick: options.quick,
        frequencies,
        outcomes,
        branch_seconds,
        shapes,
    };
    output::modes_csv(&study, &out.join("modes.csv"))?;
    output::frequency_energy_plot(&study, &out.join("fep"))?;
    output::amplitude_plot(&study, &out.join("amplitude"))?;
    output::normalised_frequency_energy_plot(&study, &out.join("fep-normalised"))?;
    output::mode_shapes(&study, &out.join("mode-shapes"))?;
    output::report(
        &study,
        clock.elapsed().as_secs_f64(),
        &out.join("report.md"),
    )?;
    if !options.quiet {
        println!(
            "example finished in {:.1} s; report: {}",
            clock.elapsed().as_secs_f64(),
            out.join("report.md").display()
        );
    }
    Ok(())
}

/// A TOML number that reads back as a float: `2.05e11` rather than `205000000000`.
fn toml_float(value: f64) -> String {
    if value.abs() >= 1e5 {
        format!("{value:e}")
    } else {
        format!("{value:?}")
    }
}

/// The job the example runs: `beam` with every parameter spelt out, and one branch from each
/// of the first `branches` modes to the frequency shift limit.
fn job_text(beam: &CantileverBeam, branches: usize) -> String {
    let mut text = String::from(
        "# Written by `nnm example cantilever-beam`: the ECL cantilever beam (NLvib's example 09),\n\
         # a clamped steel beam with a cubic spring from its tip to ground, Euler-Bernoulli\n\
         # elements with consistent mass. `nnm run` on this file recomputes the branches (their\n\
         # CSV and JSON); the example also compares the linear frequencies with theory and draws\n\
         # the first mode's deflection along its branch.\n\
         [model]\n\
         family = \"cantilever-beam\"\n",
    );
    for (key, value, comment) in [
        (
            "elements",
            beam.elements.to_string(),
            "Hermite elements, 2 dofs a node",
        ),
        ("length", toml_float(beam.length), "m"),
        ("width", toml_float(beam.width), "m"),
        (
            "height",
            toml_float(beam.height),
            "m, in the bending direction",
        ),
        ("youngs_modulus", toml_float(beam.youngs_modulus), "Pa"),
        ("density", toml_float(beam.density), "kg/m^3"),
        (
            "cubic",
            toml_float(beam.cubic),
            "N/m^3: tip force cubic * w_tip^3",
        ),
    ] {
        let assignment = format!("{key} = {value}");
        text.push_str(&format!("{assignment:<26}# {comment}\n"));
    }
    text.push_str(&format!(
        "\n[settings]\nfrequency_shift_max = {}\noutput_dofs = [{}]          # the tip's deflection w (node k: w is dof 2k-2, the rotation 2k-1)\n",
        toml_float(FREQUENCY_SHIFT_MAX),
        2 * beam.elements - 2
    ));
    for k in 0..branches {
        text.push_str(&format!(
            "\n[[branch]]\nname = \"mode-{}\"\nmode = {k}\n",
            k + 1
        ));
    }
    text
}

/// Euler–Bernoulli angular frequencies of the clamped–free beam,
/// `ω_k = (β_k L)² √(E I / (ρ A L⁴))`, for the `BETA_L` modes.
pub(crate) fn euler_bernoulli(beam: &CantileverBeam) -> [f64; 4] {
    let area = beam.width * beam.height;
    let inertia = beam.width * beam.height.powi(3) / 12.0;
    let scale =
        (beam.youngs_modulus * inertia / (beam.density * area * beam.length.powi(4))).sqrt();
    BETA_L.map(|b| b * b * scale)
}

fn linear_frequencies(beam: &CantileverBeam, modes: &[LinearMode]) -> Vec<LinearFrequency> {
    modes
        .iter()
        .zip(euler_bernoulli(beam))
        .map(|(m, theory)| LinearFrequency {
            model: m.frequency,
            theory,
        })
        .collect()
}

/// `Hz` of an angular frequency.
pub(crate) fn hz(omega: f64) -> f64 {
    omega / (2.0 * PI)
}

/// Transverse deflection at `s` (0 ≤ s ≤ L) of the beam in displacement state `x` (the model's
/// dofs: node `i ≥ 1` has `w` at `2(i−1)` and `θ` at `2(i−1)+1`; node 0 is clamped), by the
/// cubic Hermite interpolation of the element that holds `s` — the elements' own shape
/// functions, so a cubic `w` is reproduced exactly.
pub(crate) fn deflection_at(beam: &CantileverBeam, x: &[f64], s: f64) -> f64 {
    let le = beam.length / beam.elements as f64;
    let e = ((s / le).floor().max(0.0) as usize).min(beam.elements - 1);
    let xi = s / le - e as f64;
    let node = |i: usize| match i {
        0 => (0.0, 0.0),
        _ => (x[2 * (i - 1)], x[2 * (i - 1) + 1]),
    };
    let ((w0, t0), (w1, t1)) = (node(e), node(e + 1));
    let (xi2, xi3) = (xi * xi, xi * xi * xi);
    (1.0 - 3.0 * xi2 + 2.0 * xi3) * w0
        + le * (xi - 2.0 * xi2 + xi3) * t0
        + (3.0 * xi2 - 2.0 * xi3) * w1
        + le * (xi3 - xi2) * t1
}

/// The deflection of displacement state `x` divided by its tip deflection, sampled along the
/// beam; `None` if the tip does not move.
fn normalised_deflection(
    beam: &CantileverBeam,
    x: &[f64],
    energy: f64,
    frequency: f64,
) -> Option<Deflection> {
    let tip = x[beam.tip()];
    if tip == 0.0 || !tip.is_finite() {
        return None;
    }
    let samples = beam.elements * SAMPLES_PER_ELEMENT;
    let shape = (0..=samples)
        .map(|k| {
            let s = beam.length * k as f64 / samples as f64;
            (s, deflection_at(beam, x, s) / tip)
        })
        .collect();
    Some(Deflection {
        energy,
        frequency,
        shape,
        midspan: deflection_at(beam, x, beam.length / 2.0) / tip,
    })
}

/// Indices of the branch points (of these frequencies) whose deflection is drawn: the first,
/// those nearest to `SHAPE_FRACTIONS` of the final frequency shift, the last; in branch order,
/// each once.
fn shape_points(frequencies: &[f64]) -> Vec<usize> {
    let Some(last) = frequencies.len().checked_sub(1) else {
        return Vec::new();
    };
    let shift = |k: usize| frequencies[k] - frequencies[0];
    let end = shift(last);
    let mut picked = vec![0, last];
    for f in SHAPE_FRACTIONS {
        let distance = |k: usize| (shift(k) - f * end).abs();
        if let Some(k) = (0..=last).min_by(|&a, &b| distance(a).total_cmp(&distance(b))) {
            picked.push(k);
        }
    }
    picked.sort_unstable();
    picked.dedup();
    picked
}

/// The first NNM's deflection at `t = 0` — where its motion starts at rest, every point at its
/// largest displacement (`z0 = [x0; 0]`, the zero-velocity phase condition) — at the points of
/// `shape_points`, beside the linear mode's.
fn shape_change(
    beam: &CantileverBeam,
    mode: &LinearMode,
    points: &[BranchPoint],
) -> Result<ShapeChange> {
    let n = 2 * beam.elements;
    let linear = normalised_deflection(beam, &mode.shape, 0.0, mode.frequency)
        .context("the first linear mode does not move the tip")?;
    let frequencies: Vec<f64> = points.iter().map(|p| p.frequency).collect();
    let points = shape_points(&frequencies)
        .into_iter()
        .filter_map(|k| {
            let p = &points[k];
            normalised_deflection(beam, &p.z0[..n], p.energy, p.frequency)
        })
        .collect();
    Ok(ShapeChange { linear, points })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A static tip load bends a cantilever into a cubic, `w = P x² (3L − x) / (6 E I)`, which
    /// Hermite elements hold exactly: interpolated from its nodal values and slopes it is exact
    /// everywhere, inside elements too.
    #[test]
    fn hermite_interpolation_reproduces_a_cubic() {
        let beam = CantileverBeam {
            elements: 5,
            ..CantileverBeam::default()
        };
        let l = beam.length;
        let w = |x: f64| x * x * (3.0 * l - x);
        let slope = |x: f64| 6.0 * l * x - 3.0 * x * x;
        let le = l / beam.elements as f64;
        let state: Vec<f64> = (1..=beam.elements)
            .flat_map(|i| [w(i as f64 * le), slope(i as f64 * le)])
            .collect();
        for k in 0..=70 {
            let s = l * k as f64 / 70.0;
            let error = (deflection_at(&beam, &state, s) - w(s)).abs();
            assert!(error < 1e-14, "x = {s}: {error:e}");
        }
        let d = normalised_deflection(&beam, &state, 1.0, 1.0).unwrap();
        assert_eq!(d.shape.len(), 5 * SAMPLES_PER_ELEMENT + 1);
        assert_eq!(d.shape[0], (0.0, 0.0));
        assert!((d.shape.last().unwrap().1 - 1.0).abs() < 1e-15);
        assert!((d.midspan - w(l / 2.0) / w(l)).abs() < 1e-14);
    }

    /// The theory used for `modes.csv`: the first EB frequency of the ECL beam is the published
    /// 23.6615 Hz, and the 19-element model is within 1e-6 of theory on its first mode.
    #[test]
    fn euler_bernoulli_frequencies_of_the_ecl_beam() {
        let beam = CantileverBeam::default();
        let theory = euler_bernoulli(&beam);
        assert!((hz(theory[0]) - 23.6615).abs() < 1e-4, "{}", hz(theory[0]));
        let modes = linear_modes(&beam.build().unwrap()).unwrap();
        let table = linear_frequencies(&beam, &modes);
        assert_eq!(table.len(), 4);
        assert!(table[0].relative_difference().abs() < 1e-6);
        assert!(table.iter().all(|f| f.relative_difference() > 0.0));
    }

    #[test]
    fn the_job_reads_back_as_the_beam() {
        let beam = CantileverBeam::default();
        let text = job_text(&beam, 2);
        let job = nnm_io::job::parse_job(&text, Path::new("beam.toml")).unwrap();
        assert_eq!(job.family, "cantilever-beam");
        assert_eq!(job.branches.len(), 2);
        assert_eq!(job.branches[1].mode, "1");
        let expected = beam.build().unwrap();
        assert_eq!(job.structure.dofs(), expected.dofs());
        let (a, b) = (
            linear_modes(&job.structure).unwrap(),
            linear_modes(&expected).unwrap(),
        );
        assert_eq!(a[0].frequency, b[0].frequency);
        assert!(text.contains("youngs_modulus = 2.05e11"), "{text}");
    }

    #[test]
    fn shape_points_span_the_branch_once_each() {
        let frequencies: Vec<f64> = (0..21).map(|k| 1.0 + 0.01 * k as f64).collect();
        assert_eq!(shape_points(&frequencies), vec![0, 5, 10, 15, 20]);
        assert_eq!(shape_points(&frequencies[..2]), vec![0, 1]);
        assert!(shape_points(&[]).is_empty());
    }
}
