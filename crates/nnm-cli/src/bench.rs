//! `nnm bench`: the benchmark table — each case with the sensitivity Jacobian and with finite
//! differences, measured in the same run so the ratio is meaningful (absolute times depend on
//! the machine).

use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::{Context, Result};
use nnm::forced::damping::Damping;
use nnm::forced::{Force, ResponseSettings, Sweep, forced_response};
use nnm::integrate::IntegrationMethod;
use nnm::model::{
    BladedDisk, CantileverBeam, ForcedSystem, MechanicalSystem, Solid, Structure, VonKarmanBeam,
    duffing, two_dof,
};
use nnm::modes::{add_labelled_mode, find_mode, linear_modes};
use nnm::shooting::{Formulation, JacobianMethod, Travel};
use nnm::{Branch, Settings, Start, continue_branch};

struct Row {
    case: String,
    /// The variant measured (Jacobian or integrator); the ratio column compares the rows of a
    /// case with its first.
    method: &'static str,
    seconds: f64,
    points: usize,
    newton: usize,
    integrations: usize,
    steps: usize,
    rhs: usize,
    tangents: usize,
    /// Stage-system factorisations (implicit integrators).
    factorisations: usize,
    /// Monodromy–vector products (matrix-free formulation).
    products: usize,
}

const METHODS: [(JacobianMethod, &str); 2] = [
    (JacobianMethod::Sensitivity, "sensitivity"),
    (JacobianMethod::FiniteDifference, "finite-diff"),
];

fn start(structure: &Structure, label: &str) -> Result<Start> {
    start_at(structure, label, None)
}

/// The start of mode `label`, at linear energy `energy` (`None`: the default).
fn start_at(structure: &Structure, label: &str, energy: Option<f64>) -> Result<Start> {
    let modes = linear_modes(structure)?;
    let (index, _) = find_mode(&modes, label, None).context("mode")?;
    Ok(Start::from_linear_mode(structure, &modes, index, energy)?)
}

/// A case with the sensitivity and the finite-difference Jacobian.
fn branch_rows(
    case: &str,
    structure: &Structure,
    start: &Start,
    settings: &Settings,
) -> Result<Vec<Row>> {
    let variants: Vec<(&'static str, Settings)> = METHODS
        .iter()
        .map(|&(jacobian, method)| {
            let mut s = settings.clone();
            s.shooting.jacobian = jacobian;
            (method, s)
        })
        .collect();
    variant_rows(case, structure, start, &variants)
}

/// A case run once per variant (its name and settings).
fn variant_rows(
    case: &str,
    structure: &Structure,
    start: &Start,
    variants: &[(&'static str, Settings)],
) -> Result<Vec<Row>> {
    variants
        .iter()
        .map(|(method, settings)| {
            let method = *method;
            let clock = Instant::now();
            let branch: Branch =
                continue_branch(structure, start, settings, |_| ControlFlow::Continue(()))?;
            let s = branch.stats;
            Ok(Row {
                case: case.into(),
                method,
                seconds: clock.elapsed().as_secs_f64(),
                points: s.points,
                newton: s.newton_iterations,
                integrations: s.shooting.integrations,
                steps: s.shooting.integration.steps,
                rhs: s.shooting.integration.rhs_evaluations,
                tangents: s.shooting.integration.tangent_evaluations,
                factorisations: s.shooting.integration.factorisations,
                products: s.shooting.krylov_products,
            })
        })
        .collect()
}

/// A forced response curve at default settings (events on), as one row.
fn forced_row(
    case: &str,
    label: &'static str,
    structure: &Structure,
    damping: &Damping,
    force: &Force,
    sweep: Sweep,
) -> Result<Row> {
    let c = damping.matrix(structure)?;
    let system = ForcedSystem::new(structure, &c, force.shape(structure)?)?;
    let clock = Instant::now();
    let curve = forced_response(&system, sweep, &[], &ResponseSettings::default(), |_| {
        ControlFlow::Continue(())
    })?;
    let s = curve.stats;
    Ok(Row {
        case: case.into(),
        method: label,
        seconds: clock.elapsed().as_secs_f64(),
        points: curve.points.len(),
        newton: curve.continuation.newton_iterations,
        integrations: s.integrations,
        steps: s.integration.steps,
        rhs: s.integration.rhs_evaluations,
        tangents: s.integration.tangent_evaluations,
        factorisations: s.integration.factorisations,
        products: s.krylov_products,
    })
}

/// An ECL beam's first resonance forced at the tip: Rayleigh damping `1e-5 K`, 0.01 N from
/// 0.9 to 1.3 times its first frequency, through its two folds (at 1 N the upper fold lies
/// beyond 1.3 ω1).
fn beam_resonance_row(case: &str, beam: &Structure) -> Result<Row> {
    let w1 = mode_frequency(beam, "0")?;
    forced_row(
        case,
        "forced tip",
        beam,
        &Damping::Rayleigh([0.0, 1e-5]),
        &Force::Dofs {
            dofs: vec![beam.dofs() - 2],
            amplitude: 0.01,
        },
        Sweep::Frequency {
            from: 0.9 * w1,
            to: 1.3 * w1,
            amplitude: 0.01,
        },
    )
}

/// A von Kármán beam's first resonance forced at its middle node's transverse dof
/// (examples/forced-von-karman-beam.toml): Rayleigh damping `1e-5 K`, 3 N from 315 to
/// 370 rad/s, through its two folds.
fn von_karman_resonance_row(case: &str, label: &'static str, beam: &Structure) -> Result<Row> {
    let elements = von_karman_elements(beam);
    forced_row(
        case,
        label,
        beam,
        &Damping::Rayleigh([0.0, 1e-5]),
        &Force::Dofs {
            dofs: vec![3 * (elements / 2 - 1) + 1],
            amplitude: 3.0,
        },
        Sweep::Frequency {
            from: 315.0,
            to: 370.0,
            amplitude: 3.0,
        },
    )
}

/// The elements of a clamped von Kármán beam: `3 (elements − 1)` dofs (`u, w, θ` at each
/// interior node).
fn von_karman_elements(beam: &Structure) -> usize {
    beam.dofs() / 3 + 1
}

/// The default von Kármán beam as `nnm export` writes it (Matrix Market `M`, `K` and the
/// quadratic and cubic terms), read back by the job loader: the imported model's path.
fn exported_von_karman_beam(built_in: &Structure) -> Result<Structure> {
    let dir = std::env::temp_dir().join(format!("nnm-bench-export-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let job = dir.join("von-karman-beam.toml");
    std::fs::write(
        &job,
        format!(
            "[model]\nfamily = \"von-karman-beam\"\nelements = {}\n",
            von_karman_elements(built_in)
        ),
    )?;
    let files = dir.join("files");
    let exported = nnm_io::export::export_job(&job)?.write(&files)?;
    let loaded = nnm_io::job::load_job(exported.last().context("the exported job file")?);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(loaded?.structure)
}

/// The first mode's backbone of a von Kármán beam built in and of the same beam imported
/// from files, both from the default start, as a user has them (docs/method.md eq. (16a)).
fn backbone_built_in_and_imported(
    case: &str,
    (built_in, imported): (&Structure, &Structure),
    settings: &Settings,
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    for (label, model) in [("built-in", built_in), ("imported", imported)] {
        rows.extend(variant_rows(
            case,
            model,
            &start_at(model, "0", None)?,
            &[(label, settings.clone())],
        )?);
    }
    Ok(rows)
}

/// The linear frequency of mode `label`.
fn mode_frequency(structure: &Structure, label: &str) -> Result<f64> {
    let modes = linear_modes(structure)?;
    let (index, _) = find_mode(&modes, label, None).context("mode")?;
    Ok(modes[index].frequency)
}

/// One shooting evaluation (residual + Jacobian) and the monodromy at a converged point of
/// the (1,5) backbone near +5%, repeated.
fn shooting_rows(structure: &Structure, start: &Start, repeat: usize) -> Result<Vec<Row>> {
    let settings = {
        let mut s = Settings::default();
        s.limits.frequency_shift_max = 0.05;
        s
    };
    let branch = continue_branch(structure, start, &settings, |_| ControlFlow::Continue(()))?;
    let point = branch.points.last().context("no point")?;
    METHODS
        .iter()
        .map(|&(jacobian, method)| {
            let mut shooting = start.shooting(structure, &{
                let mut s = settings.clone();
                s.shooting.jacobian = jacobian;
                s
            });
            let clock = Instant::now();
            for _ in 0..repeat {
                let evaluation = shooting.evaluate_with_reference(&point.unknowns, &point.z0)?;
                shooting.monodromy(&evaluation)?;
            }
            let s = shooting.stats;
            Ok(Row {
                case: "(1,5) residual+Jacobian+monodromy".into(),
                method,
                seconds: clock.elapsed().as_secs_f64() / repeat as f64,
                points: 1,
                newton: 0,
                integrations: s.integrations / repeat,
                steps: s.integration.steps / repeat,
                rhs: s.integration.rhs_evaluations / repeat,
                tangents: s.integration.tangent_evaluations / repeat,
                factorisations: s.integration.factorisations / repeat,
                products: 0,
            })
        })
        .collect()
}

pub fn bench(repeat: usize, stiff: bool, large: bool) -> Result<()> {
    let disk = BladedDisk::default().build()?;
    let start_1_5 = start(&disk, "1,5")?;
    let mut rows = shooting_rows(&disk, &start_1_5, repeat.max(1))?;
    // The continuation itself (as the peers do it: no bifurcation location), then the same
    // branch with its events located (two branch points on the way to +10%).
    rows.extend(branch_rows(
        "(1,5) backbone to +10%",
        &disk,
        &start_1_5,
        &{
            let mut s = Settings::default();
            s.limits.frequency_shift_max = 0.10;
            s.stability.events = false;
            s
        },
    )?);
    rows.extend(branch_rows(
        "(1,5) to +10%, events located",
        &disk,
        &start_1_5,
        &{
            let mut s = Settings::default();
            s.limits.frequency_shift_max = 0.10;
            s
        },
    )?);
    // The (1,5) travelling wave (docs/method.md §17): every mode unknown, shot over T/6.
    let travelling = {
        let modes = linear_modes(&disk)?;
        let (index, _) = find_mode(&modes, "1,5", None).context("mode")?;
        Start::travelling_wave(&disk, &modes, index, Travel::Forward, None)?
    };
    rows.extend(branch_rows(
        "(1,5) travelling wave to +10%",
        &disk,
        &travelling,
        &{
            let mut s = Settings::default();
            s.limits.frequency_shift_max = 0.10;
            s.stability.events = false;
            s
        },
    )?);
    // A forced response against the backbone of the same mode (events on both): engine
    // order 5 at the blades, Rayleigh damping 2e-3 K (0.2% at the resonance), across the
    // (1,5) resonance and its two folds.
    let (fold_sizes, forced) = {
        let mut s = Settings::default();
        s.limits.frequency_shift_max = 0.10;
        let mut pair = variant_rows(
            "(1,5): backbone vs forced",
            &disk,
            &start_1_5,
            &[("backbone", s)],
        )?;
        let r = mode_frequency(&disk, "1,5")?;
        pair.push(forced_row(
            "(1,5): backbone vs forced",
            "forced EO5",
            &disk,
            &Damping::Rayleigh([0.0, 2e-3]),
            &Force::EngineOrder {
                engine_order: 5,
                amplitude: 0.005,
                sector_dof: 1,
            },
            Sweep::Frequency {
                from: 0.9 * r,
                to: 1.1 * r,
                amplitude: 0.005,
            },
        )?);
        (2, pair)
    };
    let duffing = duffing(1.0, 1.0)?;
    rows.extend(branch_rows(
        "Duffing backbone to +50%, tol 1e-10",
        &duffing,
        &start(&duffing, "0")?,
        &{
            let mut s = Settings::default();
            s.continuation.tolerance = 1e-10;
            s.limits.frequency_shift_max = 0.5;
            s.stability.events = false;
            s
        },
    )?);
    let two = two_dof(0.5)?;
    rows.extend(branch_rows(
        "two-DOF in-phase to E = 100",
        &two,
        &start(&two, "0")?,
        &{
            let mut s = Settings::default();
            s.limits.energy_max = 100.0;
            s.stability.events = false;
            s
        },
    )?);
    let groups = rows.len() / 2;
    let mut sizes = vec![2; groups];
    rows.extend(forced);
    sizes.push(fold_sizes);
    // The damped Duffing oscillator's curve through its two folds (docs/method.md §19).
    rows.push(forced_row(
        "Duffing forced, c = 0.02, F = 0.1",
        "dop853",
        &duffing,
        &Damping::Matrix(nnm::model::Matrix::from_rows(&[vec![0.02]]).map_err(anyhow::Error::msg)?),
        &Force::Dofs {
            dofs: vec![0],
            amplitude: 0.1,
        },
        Sweep::Frequency {
            from: 0.5,
            to: 3.5,
            amplitude: 0.1,
        },
    )?);
    sizes.push(1);
    let beam_settings = |shift: f64| {
        let mut s = Settings::default();
        s.limits.frequency_shift_max = shift;
        s.stability.events = false;
        s
    };
    if stiff {
        // Stiff finite-element models: the implicit integrator chosen automatically, the
        // beam's first mode to +20% as refinement grows, and on the
        // 19-element beam its first two points against the explicit integrator.
        // Dense and matrix-free formulations (docs/method.md §15) side by side on the same
        // damping integrator.
        let formulation = |f: Formulation| {
            let mut s = beam_settings(0.2);
            s.integration.integrator = IntegrationMethod::Radau5;
            s.shooting.formulation = f;
            s
        };
        for elements in [19, 50, 100, 200] {
            let beam = CantileverBeam {
                elements,
                ..CantileverBeam::default()
            }
            .build()?;
            eprintln!("bench: beam of {elements} elements");
            let case = format!("beam {elements} el. ({} dofs) to +20%", 2 * elements);
            let variants = match elements {
                // 19 elements: Gauss6, dense; 200: Radau5, matrix-free (dense takes ~110 s).
                19 | 200 => vec![("auto", beam_settings(0.2))],
                _ => vec![
                    ("dense", formulation(Formulation::Dense)),
                    ("matrix-free", formulation(Formulation::MatrixFree)),
                ],
            };
            sizes.push(variants.len());
            rows.extend(variant_rows(&case, &beam, &start(&beam, "0")?, &variants)?);
        }
        let beam = CantileverBeam::default().build()?;
        let two_points = |method: IntegrationMethod| {
            let mut s = beam_settings(0.2);
            s.limits.max_points = 2;
            s.integration.integrator = method;
            s
        };
        rows.extend(variant_rows(
            "beam 19 el., first 2 points",
            &beam,
            &start(&beam, "0")?,
            &[
                ("gauss6", two_points(IntegrationMethod::Gauss6)),
                ("dop853", two_points(IntegrationMethod::Dop853)),
            ],
        )?);
        sizes.push(2);
        // The 19-element beam's first resonance forced at the tip, against its backbone to
        // +20%; NLvib's harmonic balance on the same curve: scripts/nlvib/RESULTS.md.
        let mut pair = variant_rows(
            "beam 19 el.: backbone vs forced",
            &beam,
            &start(&beam, "0")?,
            &[("backbone", beam_settings(0.2))],
        )?;
        pair.push(beam_resonance_row(
            "beam 19 el.: backbone vs forced",
            &beam,
        )?);
        rows.extend(pair);
        sizes.push(2);
        let plate = VonKarmanBeam::default().build()?;
        // The same beam as a user of an FE code has it: M, K and the polynomial terms written
        // to files by `nnm export` and read back as `nnm run` reads them.
        let imported = exported_von_karman_beam(&plate)?;
        rows.extend(backbone_built_in_and_imported(
            "von Karman 20 el. (57 dofs) to +8%",
            (&plate, &imported),
            &beam_settings(0.08),
        )?);
        sizes.push(2);
        // The same at default settings, events on, as a user has them (issue 28).
        let mut defaults = Settings::default();
        defaults.limits.frequency_shift_max = 0.08;
        rows.extend(backbone_built_in_and_imported(
            "von Karman 20 el. to +8%, events on",
            (&plate, &imported),
            &defaults,
        )?);
        sizes.push(2);
        let case = "von Karman 20 el.: forced middle";
        for (label, model) in [("built-in", &plate), ("imported", &imported)] {
            rows.push(von_karman_resonance_row(case, label, model)?);
        }
        sizes.push(2);
    }
    if large {
        // Large models, matrix-free: the 1,000-element ECL beam (stiff, one nonlinear dof)
        // and the 5,000-sector disk's (1,0) mode in the full space (not stiff; every
        // multiplier from the sector harmonics, docs/method.md eq. (76e)).
        let beam = CantileverBeam {
            elements: 1000,
            ..CantileverBeam::default()
        }
        .build()?;
        eprintln!("bench: beam of 1,000 elements");
        rows.extend(variant_rows(
            "beam 1,000 el. (2,000 dofs) to +20%",
            &beam,
            &start(&beam, "0")?,
            &[("auto", beam_settings(0.2))],
        )?);
        sizes.push(1);
        // Its first resonance, forced as the 19-element beam's (matrix-free: eq. (102a)).
        eprintln!("bench: beam of 1,000 elements, forced");
        rows.push(beam_resonance_row(
            "beam 1,000 el. (2,000 dofs): forced",
            &beam,
        )?);
        sizes.push(1);
        let disk = BladedDisk {
            sectors: 5000,
            ..BladedDisk::default()
        }
        .build()?;
        eprintln!("bench: disk of 5,000 sectors");
        let mut modes = linear_modes(&disk)?;
        add_labelled_mode(&disk, &mut modes, "1,0", None)?;
        let (index, _) = find_mode(&modes, "1,0", None).context("mode")?;
        let mut settings = beam_settings(0.2);
        settings.start.symmetry = false;
        let start = Start::for_branch(&disk, &modes, index, None, &settings)?;
        rows.extend(variant_rows(
            "disk 5,000 sectors (1,0) to +20%",
            &disk,
            &start,
            &[("auto", settings)],
        )?);
        sizes.push(1);
        // The 10⁴-dof von Kármán beam: stiff, nonlinear on every dof, shot over half its
        // period with its parity (docs/method.md eq. (9b)), stage systems split (eq. (32f)).
        let plate = VonKarmanBeam {
            elements: 3333,
            ..VonKarmanBeam::default()
        }
        .build()?;
        eprintln!("bench: von Karman beam of 3,333 elements");
        // Built-in and imported as files (issue 28's case).
        let imported = exported_von_karman_beam(&plate)?;
        rows.extend(backbone_built_in_and_imported(
            "von Karman 3,333 el. (9,996 dofs) to +8%",
            (&plate, &imported),
            &beam_settings(0.08),
        )?);
        sizes.push(2);
        // Its first resonance at 10,005 dofs (3,336 elements: a middle node), built-in and
        // imported: issue 27's largest case.
        let plate = VonKarmanBeam {
            elements: 3336,
            ..VonKarmanBeam::default()
        }
        .build()?;
        let case = "von Karman 3,336 el.: forced middle";
        eprintln!("bench: von Karman beam of 3,336 elements, forced (built-in, then imported)");
        rows.push(von_karman_resonance_row(case, "built-in", &plate)?);
        let imported = exported_von_karman_beam(&plate)?;
        rows.push(von_karman_resonance_row(case, "imported", &imported)?);
        sizes.push(2);
        // Issue 31's ladder starts here: the default hex27 box (513 dofs), its first mode to
        // +5% at default settings (events on, the automatic start), as a user runs it.
        let solid = Solid::default().build()?;
        eprintln!("bench: solid box of 10 x 1 x 1 hex27 elements");
        let mut settings = Settings::default();
        settings.limits.frequency_shift_max = 0.05;
        rows.extend(variant_rows(
            "solid box 10x1x1 hex27 (513 dofs) to +5%",
            &solid,
            &start_at(&solid, "0", None)?,
            &[("default", settings)],
        )?);
        sizes.push(1);
    }
    println!(
        "{:<38} {:<12} {:>10} {:>7} {:>7} {:>8} {:>9} {:>10} {:>10} {:>8} {:>9} {:>7}",
        "case",
        "jacobian",
        "time_s",
        "points",
        "newton",
        "integr.",
        "steps",
        "rhs_evals",
        "tangents",
        "factor.",
        "products",
        "ratio"
    );
    let mut rest = rows.as_slice();
    for size in sizes {
        let (group, tail) = rest.split_at(size);
        rest = tail;
        let base = group[0].seconds;
        for r in group {
            println!(
                "{:<38} {:<12} {:>10.4} {:>7} {:>7} {:>8} {:>9} {:>10} {:>10} {:>8} {:>9} {:>7.2}",
                r.case,
                r.method,
                r.seconds,
                r.points,
                r.newton,
                r.integrations,
                r.steps,
                r.rhs,
                r.tangents,
                r.factorisations,
                r.products,
                r.seconds / base
            );
        }
    }
    println!(
        "ratio: time relative to the first row of the same case (same run, same machine). \
         The 3:1 tongue comparison is in the study report (`nnm example bladed-disk`)."
    );
    Ok(())
}
