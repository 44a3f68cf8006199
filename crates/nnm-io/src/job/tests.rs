use super::*;
use std::path::Path;

use nnm::forced::{ResponseSettings, Sweep};
use nnm::model::{Matrix, MechanicalSystem, PolynomialSpring, PolynomialTensor};

/// Family keys without a default value (left out: none): a solid's `mesh`.
const OPTIONAL_FAMILY_KEYS: [&str; 1] = ["mesh"];
use nnm::shooting::{JacobianMethod, PhaseCondition};

fn parse(text: &str) -> Result<Job, JobError> {
    parse_job(text, Path::new("job.toml"))
}

fn error(text: &str) -> String {
    let e = parse(text)
        .expect_err("the job must be rejected")
        .to_string();
    assert!(!e.contains('\n'), "error must be one line: {e}");
    e
}

#[test]
fn spec_example_parses() {
    let job = parse(
        r#"
        [model]
        family = "bladed-disk"
        sectors = 30
        disk_mass = 1.0
        blade_mass = 0.3
        disk_coupling = 1.0
        blade_stiffness = 1.0
        cubic = 0.1

        [[branch]]
        name = "mode-1-5"
        mode = "1,5"
        energy_max = 10.0
        jacobian = "finite-difference"
        "#,
    )
    .unwrap();
    assert_eq!(job.branches.len(), 1);
    let b = &job.branches[0];
    assert_eq!((b.name.as_str(), b.mode.as_str()), ("mode-1-5", "1,5"));
    assert_eq!(b.settings.limits.energy_max, 10.0);
    assert_eq!(
        b.settings.shooting.jacobian,
        JacobianMethod::FiniteDifference
    );
    use nnm::MechanicalSystem;
    assert_eq!(job.structure.dofs(), 60);
}

#[test]
fn settings_section_gives_defaults_that_branches_override() {
    let job = parse(
        r#"
        [model]
        family = "two-dof"
        [settings]
        tolerance = 1e-10
        energy_max = 5.0
        [[branch]]
        name = "a"
        mode = 0
        [[branch]]
        name = "b"
        mode = 1
        energy_max = 7.0
        phase = "flow-orthogonal"
        "#,
    )
    .unwrap();
    assert_eq!(job.branches[0].settings.continuation.tolerance, 1e-10);
    assert_eq!(job.branches[0].settings.limits.energy_max, 5.0);
    assert_eq!(job.branches[1].settings.limits.energy_max, 7.0);
    assert_eq!(
        job.branches[1].settings.shooting.phase,
        PhaseCondition::FlowOrthogonal
    );
}

/// `at_energies` / `at_frequencies` are lists (integers read as numbers), given in
/// `[settings]` or per branch (a branch's list replaces the section's, as any key does).
#[test]
fn requested_values_are_read_as_lists() {
    let job = parse(
        r#"
        [model]
        family = "two-dof"
        [settings]
        energy_max = 5.0
        at_energies = [1, 2.5]
        [[branch]]
        name = "a"
        mode = 0
        [[branch]]
        name = "b"
        mode = 1
        at_energies = [3.0]
        at_frequencies = [1.8]
        "#,
    )
    .unwrap();
    let requests = |k: usize| &job.branches[k].settings.requests;
    assert_eq!(requests(0).at_energies, [1.0, 2.5]);
    assert!(requests(0).at_frequencies.is_empty());
    assert_eq!(requests(1).at_energies, [3.0]);
    assert_eq!(requests(1).at_frequencies, [1.8]);
    let e = error(
        "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a\"\nmode = 0\nenergy_max = 1.0\nat_energies = [0.5, -1.0]",
    );
    assert!(
        e.contains("at_energies must hold positive, finite energies, got -1"),
        "{e}"
    );
}

#[test]
fn general_model_with_dense_rows_and_elements() {
    let job = parse(
        r#"
        [model]
        mass = [[1.0, 0.0], [0.0, 1.0]]
        stiffness = [[2.0, -1.0], [-1.0, 2.0]]
        [[model.nonlinear]]
        type = "cubic"
        dofs = [0]
        coefficient = 0.5
        [[model.nonlinear]]
        type = "polynomial"
        dofs = [0, 1]
        coefficient = 0.1
        exponent = 5
        "#,
    )
    .unwrap();
    assert_eq!(job.family, "general");
    assert_eq!(job.structure.elements().len(), 2);
    assert!(job.branches.is_empty());
}

#[test]
fn bad_jobs_get_one_line_errors() {
    let cases: &[(&str, &str)] = &[
        ("[model\nfamily = 1", "job.toml:1:"),
        (
            "[model]\nfamily = \"bladed\"",
            "unknown model family `bladed`",
        ),
        (
            "[model]\nfamily = \"duffing\"\nsectors = 3",
            "`sectors` does not apply",
        ),
        ("[model]\nfamily = \"duffing\"\ncubc = 3.0", "cubc"),
        (
            "[model]\nmass = [[1.0, 0.0], [0.0]]\nstiffness = [[1.0, 0.0], [0.0, 1.0]]",
            "mass matrix row 2 has 1 entries",
        ),
        (
            "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[1.0]]",
            "stiffness matrix is 1x1, expected 2x2",
        ),
        (
            "[model]\nmass = [[1.0, 2.0], [2.0, 1.0]]\nstiffness = [[1.0, 0.0], [0.0, 1.0]]",
            "mass matrix is not positive definite",
        ),
        (
            "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = { file = \"missing.mtx\" }",
            "cannot read",
        ),
        (
            "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a\"\nmode = 0",
            "give a stop limit",
        ),
        (
            "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a/b\"\nmode = 0\nenergy_max = 1.0",
            "name `a/b`",
        ),
        (
            "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a\"\nmode = 0\nenergy_max = 1.0\njacobian = \"exact\"",
            "branch 1",
        ),
        (
            "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a\"\nmode = 0\nenergy_max = 1.0\n[[branch]]\nname = \"a\"\nmode = 1\nenergy_max = 1.0",
            "duplicate branch name",
        ),
        (
            "[model]\nfamily = \"bladed-disk\"\nblade_mass = -1.0",
            "blade_mass must be positive",
        ),
        (
            "[model]\nmass = [[1.0]]\nstiffness = [[1.0]]\n[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [3]\ncoefficient = 1.0",
            "uses dof 3",
        ),
    ];
    for (text, expected) in cases {
        let e = error(text);
        assert!(
            e.contains(expected),
            "for {text:?}: got `{e}`, expected `{expected}`"
        );
    }
}

#[test]
fn matrix_market_files_resolve_relative_to_the_job() {
    let dir = scratch("relative");
    std::fs::write(
        dir.join("K.mtx"),
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 2.0\n2 1 -1.0\n2 2 2.0\n",
    )
    .unwrap();
    let job_path = dir.join("job.toml");
    std::fs::write(
        &job_path,
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = { file = \"K.mtx\" }\n",
    )
    .unwrap();
    let job = load_job(&job_path).unwrap();
    assert_eq!(job.structure.stiffness().get(0, 1), -1.0);
    assert_eq!(job.structure.stiffness().get(1, 1), 2.0);
    std::fs::remove_dir_all(&dir).ok();
}

/// `Settings::KEYS` (what job files accept) is exactly the set of keys the settings
/// serialize to, so no setting can be added without becoming settable, and no typo passes.
#[test]
fn settings_keys_are_the_serialized_fields() {
    let table = toml::Table::try_from(Settings::default()).unwrap();
    let mut serialized: Vec<&str> = table.keys().map(String::as_str).collect();
    // `energy_start` is `None` by default, which TOML leaves out.
    serialized.push("energy_start");
    serialized.sort_unstable();
    let mut keys = Settings::KEYS.to_vec();
    keys.sort_unstable();
    assert_eq!(serialized, keys);
    let e = error(
        "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a\"\nmode = 0\nenergy_max = 1.0\ntolerence = 1e-9",
    );
    assert!(e.contains("unknown field `tolerence`"), "{e}");
}

/// A scratch folder for files a job refers to.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("nnm-job-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `(row, col, value)` triplets (0-based) as a Matrix Market coordinate file, values to
/// full precision.
fn write_mtx(path: &Path, n: usize, symmetry: &str, entries: &[(usize, usize, f64)]) {
    let mut text = format!(
        "%%MatrixMarket matrix coordinate real {symmetry}\n% written by a test\n{n} {n} {}\n",
        entries.len()
    );
    for (i, j, v) in entries {
        text.push_str(&format!("{} {} {v:.17e}\n", i + 1, j + 1));
    }
    std::fs::write(path, text).unwrap();
}

fn internal_force(s: &Structure, x: &[f64]) -> Vec<f64> {
    use nnm::MechanicalSystem;
    let mut f = vec![0.0; x.len()];
    s.internal_force(x, &mut f);
    f
}

/// Largest `|a - b|` over the entries of two `n × n` matrices, relative to the largest `|b|`.
fn matrix_difference(a: &Matrix, b: &Matrix) -> f64 {
    let n = b.nrows();
    assert_eq!(a.nrows(), n);
    let (mut diff, mut scale) = (0.0_f64, 0.0_f64);
    for i in 0..n {
        for j in 0..n {
            diff = diff.max((a.get(i, j) - b.get(i, j)).abs());
            scale = scale.max(b.get(i, j).abs());
        }
    }
    diff / scale
}

/// `|a - b|∞ / |b|∞`.
fn vector_difference(a: &[f64], b: &[f64]) -> f64 {
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0_f64, |d, (x, y)| d.max((x - y).abs()));
    diff / b.iter().fold(0.0_f64, |s, y| s.max(y.abs()))
}

/// A 4-mass chain whose first mass is fixed through `fixed_dofs` (sparse files, a cubic spring
/// from the fixed mass to mass 1, a tensor with terms on the fixed dof) is the 3-mass chain
/// built by hand: a ground spring where the chain was fixed, the tensor's terms on the fixed
/// dof gone (docs/method.md eq. (61)).
#[test]
fn fixed_dofs_give_the_reduced_model() {
    use nnm::model::SparseMatrix;
    let dir = scratch("fixed");
    let (k, m) = (3.0, 2.0);
    let mut stiffness = Vec::new();
    for e in 0..3 {
        // Element e joins masses e and e + 1: an assembly with duplicates on the diagonal.
        stiffness.extend([(e, e, k), (e + 1, e, -k), (e, e + 1, -k), (e + 1, e + 1, k)]);
    }
    write_mtx(&dir.join("K.mtx"), 4, "general", &stiffness);
    write_mtx(
        &dir.join("M.mtx"),
        4,
        "symmetric",
        &[(0, 0, m), (1, 1, m), (2, 2, m), (3, 3, m)],
    );
    // V = x0 x1 x3 + 0.5 x2² x3 (quadratic forces), V = 0.25 x1⁴ + x0 x2³ (cubic).
    std::fs::write(
        dir.join("f2.txt"),
        "% i j k c\n1 2 4 1.0\n2 1 4 1.0\n4 1 2 1.0\n\n3 3 4 1.0\n4 3 3 0.5\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("f3.txt"),
        "2 2 2 2 1.0\n1 3 3 3 1.0\n3 1 3 3 3.0\n",
    )
    .unwrap();
    let job_path = dir.join("job.toml");
    std::fs::write(
        &job_path,
        r#"
        [model]
        mass = { file = "M.mtx" }
        stiffness = { file = "K.mtx" }
        fixed_dofs = [0]
        [[model.nonlinear]]
        type = "cubic"
        dofs = [0, 1]
        coefficient = 0.5
        [[model.nonlinear]]
        type = "tensor"
        quadratic = { file = "f2.txt" }
        cubic = { file = "f3.txt" }
        "#,
    )
    .unwrap();
    let job = load_job(&job_path).unwrap();
    assert!(matches!(job.structure.stiffness(), Matrix::Sparse(_)));
    // By hand, free masses 1, 2, 3 → 0, 1, 2: the chain clamped at its left end.
    let k_hand = SparseMatrix::from_triplets(
        3,
        &[
            (0, 0, 2.0 * k),
            (0, 1, -k),
            (1, 0, -k),
            (1, 1, 2.0 * k),
            (1, 2, -k),
            (2, 1, -k),
            (2, 2, k),
        ],
    )
    .unwrap();
    let hand = Structure::new(
        Matrix::from_fn(3, 3, |i, j| if i == j { m } else { 0.0 }),
        k_hand,
        vec![
            // c (x0 − x1)³ with x0 = 0: −c (−x1)³ = c x1³ on dof 1, to ground.
            Box::new(PolynomialSpring::cubic(0, None, 0.5)),
            // 0.5 x2² x3 → x_1 x_2 on 1, 0.5 x_1² on 2; 0.25 x1⁴ → x_0³ on 0.
            Box::new(
                PolynomialTensor::new(
                    3,
                    vec![(1, 1, 2, 1.0), (2, 1, 1, 0.5)],
                    vec![(0, 0, 0, 0, 1.0)],
                )
                .unwrap(),
            ),
        ],
    )
    .unwrap();
    assert_eq!(
        matrix_difference(job.structure.stiffness(), hand.stiffness()),
        0.0
    );
    assert_eq!(
        matrix_difference(job.structure.mass_matrix(), hand.mass_matrix()),
        0.0
    );
    use nnm::MechanicalSystem;
    for x in [[0.3, -0.7, 1.1], [-1.3, 0.2, 0.05]] {
        let (a, b) = (
            internal_force(&job.structure, &x),
            internal_force(&hand, &x),
        );
        assert!(vector_difference(&a, &b) < 1e-14, "{a:?} vs {b:?}");
        let (va, vb) = (
            job.structure.potential_energy(&x),
            hand.potential_energy(&x),
        );
        assert!((va - vb).abs() < 1e-14 * vb.abs(), "{va} vs {vb}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The ECL cantilever beam as a finite-element code exports it: the unconstrained mass and
/// stiffness of all `elements + 1` nodes (stiffness element by element, duplicates summed;
/// mass assembled, lower triangle of a symmetric file), the root's two dofs removed by
/// `fixed_dofs`, the tip spring as one cubic tensor term — is the built-in family: same `M`,
/// `K`, internal force and tangent to round-off.
#[test]
fn exported_cantilever_beam_is_the_family() {
    use nnm::MechanicalSystem;
    use nnm::model::CantileverBeam;
    let beam = CantileverBeam::default();
    let family = beam.build().unwrap();
    let e = beam.elements;
    let n = 2 * e; // clamped model; full model has n + 2 dofs
    // One element's 4 × 4 matrix from the clamped assembly (all elements are equal): the tip
    // block is its (2..4, 2..4) block, the last coupling its (0..2, 2..4) block, and the
    // node before the tip holds (2..4, 2..4) + (0..2, 0..2).
    let element = |a: &Matrix| -> [[f64; 4]; 4] {
        let mut out = [[0.0; 4]; 4];
        let (before, tip) = (n - 4, n - 2);
        for p in 0..2 {
            for q in 0..2 {
                out[2 + p][2 + q] = a.get(tip + p, tip + q);
                out[p][2 + q] = a.get(before + p, tip + q);
                out[2 + q][p] = a.get(tip + q, before + p);
                out[p][q] = a.get(before + p, before + q) - a.get(tip + p, tip + q);
            }
        }
        out
    };
    let (m_e, k_e) = (element(family.mass_matrix()), element(family.stiffness()));
    // Full numbering: node i has dofs 2i, 2i + 1 (node 0 the root).
    let mut k_full = Vec::new();
    let mut m_full = Vec::new();
    for el in 0..e {
        for (a, row) in k_e.iter().enumerate() {
            for (b, &v) in row.iter().enumerate() {
                k_full.push((2 * el + a, 2 * el + b, v));
            }
        }
    }
    // Mass: the clamped assembly shifted by one node, plus the root's rows from element 0.
    let clamped = family.mass_matrix();
    for i in 0..n {
        for j in 0..=i {
            let v = clamped.get(i, j);
            if v != 0.0 {
                m_full.push((i + 2, j + 2, v));
            }
        }
    }
    for (a, row) in m_e.iter().enumerate().take(2) {
        for (b, &v) in row.iter().enumerate().skip(a) {
            m_full.push((b, a, v));
        }
    }
    let dir = scratch("beam");
    write_mtx(&dir.join("K.mtx"), n + 2, "general", &k_full);
    write_mtx(&dir.join("M.mtx"), n + 2, "symmetric", &m_full);
    let tip = n + 1; // 1-based: the tip's displacement in the full numbering
    std::fs::write(
        dir.join("tip.txt"),
        format!(
            "% the tip spring, f = c w^3\n{tip} {tip} {tip} {tip} {:e}\n",
            beam.cubic
        ),
    )
    .unwrap();
    let job_path = dir.join("beam.toml");
    std::fs::write(
        &job_path,
        "[model]\nmass = { file = \"M.mtx\" }\nstiffness = { file = \"K.mtx\" }\n\
         fixed_dofs = [0, 1]\n[[model.nonlinear]]\ntype = \"tensor\"\ncubic = { file = \"tip.txt\" }\n",
    )
    .unwrap();
    let job = load_job(&job_path).unwrap();
    let s = &job.structure;
    assert_eq!(s.dofs(), n);
    assert!(matrix_difference(s.stiffness(), family.stiffness()) < 1e-14);
    assert!(matrix_difference(s.mass_matrix(), family.mass_matrix()) < 1e-14);
    assert!(
        s.tangent_pattern().is_some(),
        "sparse K + tensor keep an assembled tangent"
    );
    // Displacements of the first mode's size (1 cm at the tip), rotations ~ w / L.
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut random = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for _ in 0..3 {
        let x: Vec<f64> = (0..n)
            .map(|d| 1e-2 * random() * if d % 2 == 0 { 1.0 } else { 10.0 })
            .collect();
        let (a, b) = (internal_force(s, &x), internal_force(&family, &x));
        let error = vector_difference(&a, &b);
        assert!(error < 1e-12, "internal force differs by {error:e}");
        let v: Vec<f64> = (0..n).map(|_| random()).collect();
        let (mut ta, mut tb) = (vec![0.0; n], vec![0.0; n]);
        use nnm::model::{Block, BlockMut};
        s.tangent_stiffness(&x, Block::new(&v, n, 1, n), BlockMut::new(&mut ta, n, 1, n));
        family.tangent_stiffness(&x, Block::new(&v, n, 1, n), BlockMut::new(&mut tb, n, 1, n));
        assert!(vector_difference(&ta, &tb) < 1e-12);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Input errors of sparse files, fixed dofs and tensor elements: one line, naming the file
/// and the place.
#[test]
fn sparse_model_errors_name_the_file() {
    let dir = scratch("errors");
    let path = |f: &str| dir.join(f).display().to_string();
    write_mtx(
        &dir.join("M.mtx"),
        2,
        "symmetric",
        &[(0, 0, 1.0), (1, 1, 1.0)],
    );
    write_mtx(
        &dir.join("K.mtx"),
        2,
        "general",
        &[(0, 0, 2.0), (0, 1, -1.0), (1, 0, -1.0 + 1e-9), (1, 1, 2.0)],
    );
    write_mtx(&dir.join("K3.mtx"), 3, "symmetric", &[(0, 0, 1.0)]);
    // 10⁹ dofs announced, one entry: refused before any O(n) storage.
    std::fs::write(
        dir.join("huge.mtx"),
        "%%MatrixMarket matrix coordinate real symmetric\n1000000000 1000000000 1\n1 1 1.0\n",
    )
    .unwrap();
    std::fs::write(dir.join("bad-gradient.txt"), "1 2 2 1.0\n").unwrap();
    std::fs::write(dir.join("bad-line.txt"), "% ok\n1 1 1 1 1.0\n2 1 1 9 1.0\n").unwrap();
    std::fs::write(dir.join("ok2.txt"), "1 1 1 1.0\n").unwrap();
    std::fs::write(dir.join("empty.txt"), "% no terms yet\n\n").unwrap();
    let good = "mass = { file = \"M.mtx\" }\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n";
    let cases = [
        (
            "mass = { file = \"M.mtx\" }\nstiffness = { file = \"K.mtx\" }\n".to_string(),
            format!("{}: stiffness matrix is not symmetric: entry (1, 2) = -1e0 but (2, 1) = -9.99999999e-1 (1-based", path("K.mtx")),
        ),
        (
            "mass = { file = \"M.mtx\" }\nstiffness = { file = \"K3.mtx\" }\n".to_string(),
            format!("{}: stiffness matrix is 3x3, expected 2x2", path("K3.mtx")),
        ),
        (
            "mass = { file = \"huge.mtx\" }\nstiffness = { file = \"huge.mtx\" }\n".to_string(),
            "mass matrix is 1000000000x1000000000 but stores 1 entries: it cannot be positive definite".to_string(),
        ),
        (format!("{good}fixed_dofs = [2]\n"), "fixed dof 2 is outside the 2 dofs".to_string()),
        (format!("{good}fixed_dofs = [0, 1]\n"), "model has no degrees of freedom".to_string()),
        (
            format!("{good}[[model.nonlinear]]\ntype = \"tensor\"\nquadratic = {{ file = \"bad-gradient.txt\" }}\n"),
            format!("{}: quadratic terms are not the gradient of a potential", path("bad-gradient.txt")),
        ),
        (
            format!("{good}[[model.nonlinear]]\ntype = \"tensor\"\ncubic = {{ file = \"bad-line.txt\" }}\n"),
            format!("{}: line 3: index 9 out of range for a model of 2 dofs", path("bad-line.txt")),
        ),
        (
            format!("{good}[[model.nonlinear]]\ntype = \"tensor\"\ncubic = {{ file = \"ok2.txt\" }}\n"),
            format!("{}: line 1: expected `i j k l c` (5 numbers), found 4", path("ok2.txt")),
        ),
        (
            // An empty file is not "no nonlinearity": the file is named.
            format!("{good}[[model.nonlinear]]\ntype = \"tensor\"\nquadratic = {{ file = \"ok2.txt\" }}\ncubic = {{ file = \"empty.txt\" }}\n"),
            format!("{}: no terms: expected one `i j k l c` per line", path("empty.txt")),
        ),
        (
            format!("{good}[[model.nonlinear]]\ntype = \"tensor\"\n"),
            "nonlinear element 1: a tensor element needs `quadratic".to_string(),
        ),
        (
            format!("{good}[[model.nonlinear]]\ntype = \"tensor\"\ndofs = [0]\nquadratic = {{ file = \"ok2.txt\" }}\n"),
            "`dofs` does not apply to a tensor element".to_string(),
        ),
        (
            format!("{good}[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 1.0\ncubic = {{ file = \"ok2.txt\" }}\n"),
            "belong to a \"tensor\" element".to_string(),
        ),
        (
            format!("{good}[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\n"),
            "a cubic element needs `coefficient`".to_string(),
        ),
    ];
    for (model, expected) in cases {
        let text = format!("[model]\n{model}");
        let e = parse_job(&text, &dir.join("job.toml"))
            .expect_err(&text)
            .to_string();
        assert!(!e.contains('\n'), "{e}");
        assert!(
            e.contains(&expected),
            "for {text:?}:\n got `{e}`\nwant `{expected}`"
        );
    }
    // The family models take no fixed dofs.
    let e = error("[model]\nfamily = \"duffing\"\nfixed_dofs = [0]");
    assert!(
        e.contains("`fixed_dofs` does not apply to family `duffing`"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The example `examples/tensor-model/` is the clamped chain it describes: its expanded
/// quartic link potentials and quadratic term are the springs they stand for.
#[test]
fn tensor_model_example_is_the_clamped_chain() {
    let job = load_job(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/tensor-model/tensor-model.toml"
    )))
    .unwrap();
    let hand = Structure::new(
        Matrix::identity(2),
        Matrix::from_fn(2, 2, |i, j| [[2.0, -1.0], [-1.0, 1.0]][i][j]),
        vec![
            Box::new(PolynomialSpring::cubic(0, None, 0.5)),
            Box::new(PolynomialSpring::cubic(0, Some(1), 0.5)),
            Box::new(PolynomialSpring::new(1, None, 0.1, 2)),
        ],
    )
    .unwrap();
    assert_eq!(job.branches.len(), 1);
    for x in [[0.4, -1.2], [1.5, 0.7]] {
        let (a, b) = (
            internal_force(&job.structure, &x),
            internal_force(&hand, &x),
        );
        assert!(vector_difference(&a, &b) < 1e-14, "{a:?} vs {b:?}");
    }
}

/// The von Kármán beam family takes its geometry and material from the job (here a thicker,
/// steel beam of 6 elements) and refuses the cantilever's keys.
#[test]
fn von_karman_beam_family_takes_its_parameters() {
    use nnm::model::{MechanicalSystem, VonKarmanBeam};
    let job = parse(
        "[model]\nfamily = \"von-karman-beam\"\nelements = 6\nthickness = 0.02\nyoungs_modulus = 2.1e11\ndensity = 7850\n[[branch]]\nname = \"a\"\nmode = 0\nenergy_max = 1.0",
    )
    .unwrap();
    let direct = VonKarmanBeam {
        elements: 6,
        thickness: 0.02,
        youngs_modulus: 2.1e11,
        density: 7850.0,
        ..VonKarmanBeam::default()
    }
    .build()
    .unwrap();
    assert_eq!(job.family, "von-karman-beam");
    assert_eq!(job.structure.dofs(), 15);
    assert!(matrix_difference(job.structure.stiffness(), direct.stiffness()) == 0.0);
    assert!(matrix_difference(job.structure.mass_matrix(), direct.mass_matrix()) == 0.0);
    let x: Vec<f64> = (0..15).map(|k| 1e-3 * (k as f64).cos()).collect();
    assert_eq!(
        internal_force(&job.structure, &x),
        internal_force(&direct, &x)
    );
    let e = error("[model]\nfamily = \"von-karman-beam\"\nheight = 0.01");
    assert!(e.contains("`height` does not apply"), "{e}");
    let e = error("[model]\nfamily = \"von-karman-beam\"\nelements = 1");
    assert!(e.contains("elements"), "{e}");
}

/// Overrides replace a job's keys as if the file said so: a model parameter, a default
/// setting and one branch's setting; the blade mistuning reaches the stiffness matrix
/// (`k_i = k (1 + δ_i)` between disk `2i` and blade `2i+1`) and drops the cyclic symmetry.
/// Bad overrides are one-line errors naming the key.
#[test]
fn overrides_replace_keys_of_the_job_file() {
    let dir = scratch("overrides");
    let job_path = dir.join("job.toml");
    std::fs::write(
        &job_path,
        "[model]\nfamily = \"bladed-disk\"\nsectors = 3\n[settings]\nenergy_max = 2.0\n\
         [[branch]]\nname = \"a\"\nmode = \"1,0\"\n[[branch]]\nname = \"b\"\nmode = 0\n",
    )
    .unwrap();
    let overrides = [
        ("model.cubic".to_string(), toml::Value::Float(0.5)),
        (
            "model.blade_stiffness_mistuning".to_string(),
            toml::Value::Array(vec![0.1.into(), 0.0.into(), (-0.2).into()]),
        ),
        ("settings.tolerance".to_string(), toml::Value::Float(1e-9)),
        ("branch.b.energy_max".to_string(), toml::Value::Float(7.0)),
    ];
    let job = load_job_with(&job_path, &overrides).unwrap();
    let k = job.structure.stiffness();
    for (sector, deviation) in [0.1, 0.0, -0.2].into_iter().enumerate() {
        let (disk, blade) = (2 * sector, 2 * sector + 1);
        assert_eq!(k.get(disk, blade), -(1.0 + deviation));
        assert_eq!(k.get(blade, blade), 1.0 + deviation);
    }
    assert!(job.structure.cyclic_symmetry().is_none());
    let [a, b] = &job.branches[..] else {
        panic!("two branches")
    };
    assert_eq!(a.settings.limits.energy_max, 2.0);
    assert_eq!(b.settings.limits.energy_max, 7.0);
    assert_eq!(a.settings.continuation.tolerance, 1e-9);
    // Without overrides the file is read as is: tuned, cyclic.
    let tuned = load_job_with(&job_path, &[]).unwrap();
    assert!(tuned.structure.cyclic_symmetry().is_some());

    let one_line = |key: &str, value: toml::Value| {
        let e = load_job_with(&job_path, &[(key.to_string(), value)])
            .expect_err("refused")
            .to_string();
        assert!(!e.contains('\n') && e.contains("job.toml"), "{e}");
        e
    };
    assert!(one_line("branch.c.energy_max", 1.0.into()).contains("no branch `c`"));
    assert!(one_line("cubic", 1.0.into()).contains("expected `model.KEY`"));
    assert!(one_line("model.family", "duffing".into()).contains("cannot be overridden"));
    let short = toml::Value::Array(vec![0.1.into()]);
    assert!(
        one_line("model.blade_stiffness_mistuning", short).contains("one deviation per sector (3)")
    );
    let negative = toml::Value::Array(vec![0.0.into(), (-1.5).into(), 0.0.into()]);
    assert!(one_line("model.blade_stiffness_mistuning", negative).contains("[1] = -1.5"));
    assert!(one_line("model.elements", 4.into()).contains("does not apply to family"));
    let fractional = one_line("model.sectors", 2.5.into());
    assert!(
        fractional.contains("override `model.sectors`: invalid type"),
        "{fractional}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A family's default parameters, as `family_defaults` gives them to front ends, are what a
/// job with only `family = "..."` builds: written out in full, they build the same model.
#[test]
fn family_defaults_are_what_a_bare_family_builds() {
    assert_eq!(
        family_names(),
        [
            "bladed-disk",
            "duffing",
            "two-dof",
            "cantilever-beam",
            "von-karman-beam",
            "solid"
        ]
    );
    for &name in family_names() {
        let defaults = family_defaults(name).unwrap();
        let keys = families::family_keys(name).unwrap();
        let mut given: Vec<&str> = defaults.keys().map(String::as_str).collect();
        let mut fields = keys.to_vec();
        // Every parameter has its default, but the optional ones (absent: none), which
        // a bare family builds without.
        fields.retain(|k| !OPTIONAL_FAMILY_KEYS.contains(k));
        given.sort_unstable();
        fields.sort_unstable();
        assert_eq!(given, fields, "{name}: every parameter has its default");
        let bare = parse(&format!("[model]\nfamily = \"{name}\"\n")).unwrap();
        let mut table = defaults.clone();
        table.insert("family".into(), name.into());
        let built = model_from_table(table.clone()).unwrap();
        let (full, family) = (built.structure, built.family);
        assert_eq!(family, name);
        assert_eq!(
            format!("{:?}", full),
            format!("{:?}", bare.structure),
            "{name}"
        );
        // And as a job file's text.
        let text = format!("[model]\n{}", toml::to_string(&table).unwrap());
        let written = parse(&text).unwrap();
        assert_eq!(
            format!("{:?}", written.structure),
            format!("{:?}", bare.structure)
        );
    }
    assert_eq!(family_defaults("bladed"), None);
    assert_eq!(family_defaults("general"), None);
    let duffing = family_defaults("duffing").unwrap();
    assert_eq!(duffing["natural_frequency"].as_float(), Some(1.0));
    assert_eq!(duffing["cubic"].as_float(), Some(1.0));
    assert_eq!(
        family_defaults("two-dof").unwrap()["cubic"].as_float(),
        Some(0.5)
    );
}

/// `[model]`'s keys (listed in the unknown-key message, in that order) are exactly
/// `family`, the families' parameters and a general model's keys.
#[test]
fn model_keys_are_the_families_and_the_general_models() {
    let mut keys: Vec<&str> = vec!["family"];
    for &name in family_names() {
        keys.extend(families::family_keys(name).unwrap());
    }
    keys.extend(schema::GENERAL_KEYS);
    keys.sort_unstable();
    keys.dedup();
    let mut listed = schema::MODEL_KEYS.to_vec();
    listed.sort_unstable();
    assert_eq!(keys, listed);
}

/// A family parameter of the wrong type is reported where it stands, inside an array too;
/// a key that belongs to no family is refused at the key, listing every key of `[model]`.
#[test]
fn family_parameter_errors_keep_their_place() {
    let cases = [
        (
            "[model]\nfamily = \"bladed-disk\"\nsectors = \"x\"",
            "job.toml:3:11: invalid type: string \"x\", expected usize",
        ),
        (
            "[model]\nfamily = \"bladed-disk\"\nsectors = 3\nblade_stiffness_mistuning = [\"a\"]",
            "job.toml:4:30: invalid type: string \"a\", expected f64",
        ),
        (
            "[model]\nfamily = \"duffing\"\ncubc = 3.0",
            "job.toml:3:1: unknown field `cubc`, expected one of `family`, `sectors`, `disk_mass`, `blade_mass`, `disk_coupling`, `blade_stiffness`, `cubic`, `blade_stiffness_mistuning`, `natural_frequency`, `elements`, `length`, `width`, `height`, `thickness`, `youngs_modulus`, `density`, `element`, `box`, `clamped`, `poisson_ratio`, `mesh`, `mass`, `stiffness`, `nonlinear`, `cyclic`, `fixed_dofs`, `damping`",
        ),
        (
            "[model]\nfamily = \"bladed\"",
            "job.toml: unknown model family `bladed` (expected \"bladed-disk\", \"duffing\", \"two-dof\", \"cantilever-beam\", \"von-karman-beam\", \"solid\", or no family with mass and stiffness)",
        ),
    ];
    for (text, expected) in cases {
        assert_eq!(error(text), expected);
    }
}

/// A refused number is shown short and exact, the same way in every message: `{}` of an `f64`
/// prints 1e300 as 301 digits and 1e-300 as 302 characters (issue 29).
#[test]
fn refused_numbers_are_shown_short() {
    let branch = "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a\"\nmode = 0\n";
    let cases: &[(String, &str)] = &[
        (
            format!("{branch}energy_max = -1e300"),
            "job.toml: branch 1: invalid setting: energy_max must be positive, got -1e300",
        ),
        (
            format!("{branch}frequency_shift_max = -1e-300"),
            "job.toml: branch 1: invalid setting: frequency_shift_max must be positive, got -1e-300",
        ),
        (
            format!("{branch}energy_max = 1.0\ninitial_step = -1e300"),
            "job.toml: branch 1: invalid setting: initial_step must be positive and finite, got -1e300",
        ),
        (
            format!("{branch}energy_max = 1.0\ntolerance = 1e300"),
            "job.toml: branch 1: invalid setting: tolerance 1e300 is too loose (use < 1e-2)",
        ),
        (
            format!("{branch}energy_max = 1.0\nintegration_factor = 1e200"),
            "job.toml: branch 1: invalid setting: integration_factor 1e200 must not exceed 1 (the integrator must be at least as accurate as the shooting tolerance)",
        ),
        (
            format!("{branch}energy_max = 1.0\nformulation = \"matrix-free\"\nintegrator = \"dop853\""),
            "job.toml: branch 1: invalid setting: formulation = \"matrix-free\" needs an implicit collocation integrator (gauss4, gauss6, radau5, radau9), not dop853",
        ),
        (
            format!("{branch}energy_max = 1.0\nintegration_factor = 1e-300"),
            "job.toml: branch 1: invalid setting: integration_factor 1e-300 × tolerance 1e-8 = 1e-308 is below 1e-18, which double precision cannot meet",
        ),
        (
            format!("{branch}energy_max = 1.0\nmax_turn_angle = 1e100"),
            "job.toml: branch 1: invalid setting: max_turn_angle 1e100 exceeds π",
        ),
        (
            format!("{branch}energy_max = 1.0\ninvariant_step = 0.0"),
            "job.toml: branch 1: invalid setting: invariant_step must be positive, got 0",
        ),
        (
            format!("{branch}energy_max = 1.0\ninvariant_step = nan"),
            "job.toml: branch 1: invalid setting: invariant_step must be positive, got NaN",
        ),
        (
            format!("{branch}energy_max = 1.0\nstability_tolerance = -1e300"),
            "job.toml: branch 1: invalid setting: stability_tolerance must be finite and non-negative, got -1e300",
        ),
        (
            format!("{branch}energy_max = 1.0\nat_frequencies = [1.5, -1e300]"),
            "job.toml: branch 1: invalid setting: at_frequencies must hold positive, finite frequencies (rad/s), got -1e300",
        ),
        (
            format!("{branch}energy_max = 1e300\nenergy_start = 1e301"),
            "job.toml: branch 1: invalid setting: energy_start 1e301 must be below energy_max 1e300 (the branch starts there and rises towards it)",
        ),
        (
            "[model]\nfamily = \"bladed-disk\"\nblade_mass = -1e300".into(),
            "blade_mass must be positive and finite, got -1e300",
        ),
        (
            "[model]\nfamily = \"bladed-disk\"\nsectors = 2\nblade_stiffness_mistuning = [0.0, -1e300]"
                .into(),
            "blade_stiffness_mistuning[1] = -1e300: a deviation must be finite and above -1 (k_i = k (1 + deviation))",
        ),
        (
            "[model]\nfamily = \"cantilever-beam\"\nlength = -1e-300".into(),
            "length must be positive and finite, got -1e-300",
        ),
        (
            "[model]\nfamily = \"von-karman-beam\"\ndensity = -1e300".into(),
            "density must be positive and finite, got -1e300",
        ),
    ];
    for (text, expected) in cases {
        let e = error(text);
        assert!(
            e.ends_with(expected),
            "for {text:?}: got `{e}`, expected `{expected}`"
        );
        assert!(!e.contains("00000"), "{e}");
    }
}

/// A refused branch name is told the rule it breaks and the characters at fault, and never
/// has the characters it may use listed against it (issue 29).
#[test]
fn branch_names_are_refused_with_the_characters_at_fault() {
    let job = |name: &str| {
        format!(
            "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = {}\nmode = 0\nenergy_max = 1.0\n",
            toml::Value::String(name.into())
        )
    };
    let rule =
        "it names the branch's files, so it may use only ASCII letters, digits, '-', '_' and '.'";
    for (name, expected) in [
        (
            "mode 1.5",
            format!("job.toml: branch 1: name `mode 1.5` holds ' ', which a branch name cannot: {rule}"),
        ),
        (
            "a/b/c d",
            format!("job.toml: branch 1: name `a/b/c d` holds '/', ' ', which a branch name cannot: {rule}"),
        ),
        (
            "é-1",
            format!("job.toml: branch 1: name `é-1` holds 'é', which a branch name cannot: {rule}"),
        ),
        (
            "a\nb",
            format!("job.toml: branch 1: name `a\\nb` holds '\\n', which a branch name cannot: {rule}"),
        ),
        (
            ".hidden",
            "job.toml: branch 1: name `.hidden` starts with '.', which would hide the branch's files: start it with a letter, a digit, '-' or '_'".into(),
        ),
        (
            "modes",
            "job.toml: branch 1: name `modes` would overwrite the linear modes' file modes.csv: use a name that is not `modes`".into(),
        ),
        (
            "",
            "job.toml: branch 1: `name` is empty; a branch's name names its files".into(),
        ),
    ] {
        assert_eq!(error(&job(name)), expected, "{name:?}");
    }
    for name in ["mode-1.5_b", "_x", "-", "a.b.c", "A9"] {
        parse(&job(name)).unwrap_or_else(|e| panic!("{name:?}: {e}"));
    }
}

/// Settings a branch cannot start with are refused with the job: a step control aiming at no
/// iterations, a dof listed twice in `output_dofs` (two columns of one name).
#[test]
fn settings_a_branch_cannot_start_with_are_refused() {
    let model = "[model]\nfamily = \"duffing\"\n";
    for (keys, expected) in [
        (
            "target_iterations = 0",
            "job.toml: branch 1: invalid setting: target_iterations must be at least 1",
        ),
        (
            "output_dofs = [1, 0, 1]",
            "job.toml: branch 1: invalid setting: output_dofs: dof 1 is listed twice",
        ),
    ] {
        let text = format!("{model}[[branch]]\nname = \"b\"\nmode = 0\nenergy_max = 1.0\n{keys}\n");
        assert_eq!(error(&text), expected);
        let text = format!("{model}[settings]\n{keys}\n");
        assert!(error(&text).starts_with("job.toml: [settings]: invalid setting: "));
    }
}

/// Branches whose files would be one file (`b.events` writes `b.events.csv`, as `b` does;
/// `B.csv` is `b.csv` where names ignore case), one of the run's files, or a name too long for
/// a file name are refused with the job, naming both branches.
#[test]
fn branches_whose_files_collide_are_refused() {
    let model = "[model]\nfamily = \"duffing\"\n[settings]\nenergy_max = 1.0\n";
    let job = |names: &[&str]| {
        let branches: String = names
            .iter()
            .map(|n| format!("[[branch]]\nname = \"{n}\"\nmode = 0\n"))
            .collect();
        format!("{model}{branches}")
    };
    for (names, expected) in [
        (
            &["b", "b.events"][..],
            "job.toml: branches `b` and `b.events` would both write b.events.csv",
        ),
        (
            &["b.events", "b"][..],
            "job.toml: branches `b.events` and `b` would both write b.events.csv",
        ),
        (
            &["run", "x", "Run"][..],
            "job.toml: branches `run` and `Run` would both write run.csv (run.csv and Run.csv are one file where names ignore case, as on macOS and Windows)",
        ),
        (
            &["Modes"][..],
            "job.toml: branch `Modes` would write Modes.csv over the run's own modes.csv (modes.csv and Modes.csv are one file where names ignore case, as on macOS and Windows)",
        ),
    ] {
        assert_eq!(error(&job(names)), expected, "{names:?}");
    }
    // Names that only look alike are fine.
    let parsed = parse(&job(&[
        "b",
        "b.event",
        "b.json.x",
        "bjson",
        "fep",
        "amplitude",
    ]))
    .unwrap();
    assert_eq!(parsed.branches.len(), 6);

    let longest = "x".repeat(MAX_BRANCH_NAME);
    assert_eq!(MAX_BRANCH_NAME + ".resonance.png".len(), 255);
    assert!(parse(&job(&[&longest])).is_ok());
    let too_long = "x".repeat(MAX_BRANCH_NAME + 1);
    assert_eq!(
        error(&job(&[&too_long])),
        "job.toml: branch 1: name `xxxxxxxxxxxxxxxx...` has 242 characters, more than the 241 that leave room for its files' suffixes (`.resonance.png`) in a file name"
    );
}

/// The Duffing oscillator with damping and one frequency response.
fn duffing_response(damping: &str, response: &str) -> String {
    format!(
        "[model]\nfamily = \"duffing\"\ncubic = 1.0\ndamping = {damping}\n[[response]]\nname = \"frc\"\n{response}\n"
    )
}

/// The keys of `[model] damping` and `[[response]]` give the damping matrix, the force shape,
/// one sweep per force level and the settings, in a job without branches.
#[test]
fn responses_parse_into_damping_force_and_sweeps() {
    let job = parse(&duffing_response(
        "{ matrix = [[0.02]] }",
        "force = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 0.5\nfrequency_end = 3.5\namplitudes = [0.05, 0.1]\ntolerance = 1e-9\nmax_step = 0.04",
    ))
    .unwrap();
    assert!(job.branches.is_empty());
    assert_eq!(job.damping.as_ref().unwrap().get(0, 0), 0.02);
    let r = &job.responses[0];
    assert_eq!(r.name, "frc");
    assert_eq!(r.body.force.cosine, vec![1.0]);
    assert_eq!(
        r.body.curves,
        vec![
            Sweep::Frequency {
                from: 0.5,
                to: 3.5,
                amplitude: 0.05
            },
            Sweep::Frequency {
                from: 0.5,
                to: 3.5,
                amplitude: 0.1
            },
        ]
    );
    assert_eq!(r.body.output_dofs, vec![0]);
    assert_eq!(r.body.settings.continuation.tolerance, 1e-9);
    assert_eq!(r.body.settings.continuation.max_step, 0.04);
    // Defaults of a response, not of a branch, where nothing is said.
    assert_eq!(
        r.body.settings.continuation.initial_step,
        ResponseSettings::default().continuation.initial_step
    );

    // Rayleigh: C = αM + βK on the two-DOF model (M = I, K = [[2, -1], [-1, 2]]).
    let job = parse(
        "[model]\nfamily = \"two-dof\"\ndamping = { rayleigh = [0.1, 0.01] }\n[[response]]\nname = \"a\"\nforce = { vector = [1.0, 0.5] }\nparameter = \"amplitude\"\nfrequency = 1.2\namplitude_max = 2.0\noutput_dofs = [1]",
    )
    .unwrap();
    let c = job.damping.as_ref().unwrap();
    let k = job.structure.stiffness();
    for i in 0..2 {
        for j in 0..2 {
            let m = if i == j { 1.0 } else { 0.0 };
            assert!((c.get(i, j) - (0.1 * m + 0.01 * k.get(i, j))).abs() < 1e-15);
        }
    }
    let r = &job.responses[0].body;
    assert_eq!(r.force.cosine, vec![1.0, 0.5]);
    assert_eq!(
        r.curves,
        vec![Sweep::Amplitude {
            from: 2.0 * AMPLITUDE_START_RATIO,
            to: 2.0,
            frequency: 1.2
        }]
    );
    assert_eq!(r.output_dofs, vec![1]);
}

/// Forced dofs and force vectors are in the full numbering, like springs' dofs: dof 2 of a
/// three-dof chain with dof 0 fixed is reduced dof 1; `output_dofs` are after `fixed_dofs`.
#[test]
fn forced_dofs_follow_fixed_dofs() {
    let model = "[model]\nmass = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\nstiffness = [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]\nfixed_dofs = [0]\n";
    let job = parse(&format!(
        "{model}damping = {{ matrix = [[9.0, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.2]] }}\n[[response]]\nname = \"r\"\nforce = {{ dofs = [2], amplitude = 1.0 }}\nfrequency_start = 0.1\nfrequency_end = 1.0\n"
    ))
    .unwrap();
    let c = job.damping.as_ref().unwrap();
    assert_eq!((c.nrows(), c.get(0, 0), c.get(1, 1)), (2, 0.1, 0.2));
    assert_eq!(job.responses[0].body.force.cosine, vec![0.0, 1.0]);
    assert_eq!(job.responses[0].body.output_dofs, vec![1]);
    let job = parse(&format!(
        "{model}damping = {{ rayleigh = [0.0, 0.01] }}\n[[response]]\nname = \"r\"\nforce = {{ vector = [0.0, 3.0, 4.0] }}\nfrequency_start = 0.1\nfrequency_end = 1.0\n"
    ))
    .unwrap();
    assert_eq!(job.responses[0].body.force.cosine, vec![3.0, 4.0]);
    let fixed = |force: &str| {
        error(&format!(
            "{model}damping = {{ rayleigh = [0.0, 0.01] }}\n[[response]]\nname = \"r\"\nforce = {force}\nfrequency_start = 0.1\nfrequency_end = 1.0\n"
        ))
    };
    assert_eq!(
        fixed("{ dofs = [0], amplitude = 1.0 }"),
        "job.toml: response `r`: forced dof 0 is fixed (`fixed_dofs`): a support takes the force"
    );
    assert_eq!(
        fixed("{ dofs = [3], amplitude = 1.0 }"),
        "job.toml: response `r`: forced dof 3 is out of range (the model has 3 dofs)"
    );
    assert_eq!(
        fixed("{ vector = [1.0, 0.0, 0.0] }"),
        "job.toml: response `r`: the force vector has 1 at dof 0, which is fixed (`fixed_dofs`): a support takes the force"
    );
}

/// Every item of the issue's bad-input list is one line naming what is wrong, before anything
/// is computed.
#[test]
fn bad_responses_are_refused_with_one_line() {
    let force =
        "force = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 0.5\nfrequency_end = 3.5";
    let cases = [
        (
            duffing_response("{ rayleigh = [-0.1, 0.0] }", force),
            "job.toml: [model] damping: damping rayleigh α must be non-negative and finite, got -0.1",
        ),
        (
            duffing_response("{ rayleigh = [0.0, nan] }", force),
            "job.toml: [model] damping: damping rayleigh β must be non-negative and finite, got NaN",
        ),
        (
            duffing_response("{ modal = [0.01, 0.02] }", force),
            "job.toml: [model] damping: 2 modal damping ratios given, the model has 1 elastic modes",
        ),
        (
            duffing_response("{ matrix = [[-0.02]] }", force),
            "job.toml: [model] damping: the damping matrix is not positive semi-definite (eigenvalue -0.02)",
        ),
        (
            duffing_response("{ matrix = [[0.02, 0.0], [0.0, 0.02]] }", force),
            "job.toml: [model] damping: the damping matrix is 2x2, the model has 1 dofs",
        ),
        (
            duffing_response("{ viscous = 1.0 }", force),
            "job.toml:4:13: unknown variant `viscous`, expected one of `rayleigh`, `modal`, `matrix`, `file`",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 3.5\nfrequency_end = 0.5",
            ),
            "job.toml: response `frc`: frequency_end must exceed frequency_start (3.5), got 0.5",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 0.0\nfrequency_end = 0.5",
            ),
            "job.toml: response `frc`: frequency_start must be positive, got 0",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { dofs = [0], amplitude = 0.0 }\nfrequency_start = 0.5\nfrequency_end = 3.5",
            ),
            "job.toml: response `frc`: the force amplitude must be non-zero, got 0",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { vector = [0.0] }\nfrequency_start = 0.5\nfrequency_end = 3.5",
            ),
            "job.toml: response `frc`: the force is zero",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { engine_order = 1, amplitude = 0.1, sector_dof = 0 }\nfrequency_start = 0.5\nfrequency_end = 3.5",
            ),
            "job.toml: response `frc`: engine-order excitation needs a cyclic model (a bladed disk)",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { dofs = [1], amplitude = 0.1 }\nfrequency_start = 0.5\nfrequency_end = 3.5",
            ),
            "job.toml: response `frc`: forced dof 1 is out of range (the model has 1 dofs)",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { dofs = [0] }\nfrequency_start = 0.5\nfrequency_end = 3.5",
            ),
            "job.toml: response `frc`: the force needs an `amplitude` (or give the response `amplitudes = [...]`)",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 0.5\nfrequency_end = 3.5\nenergy_max = 1.0",
            ),
            "job.toml: response `frc`: unknown field `energy_max`, expected one of `force`, `frequency_start`, `frequency_end`, `amplitudes`, `parameter`, `frequency`, `amplitude_max`, `amplitude_start`, `output_dofs`, `tolerance`, `initial_step`, `min_step`, `max_step`, `max_iterations`, `target_iterations`, `max_turn_angle`, `integrator`, `integration_factor`, `events`, `max_points`, `half_period`, `samples`, `formulation`",
        ),
        (
            duffing_response(
                "{ matrix = [[0.02]] }",
                "force = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 0.5\nfrequency_end = 3.5\ntolerance = 1e-20",
            ),
            "job.toml: response `frc`: invalid setting: tolerance 1e-20 is below 1e-14, which double precision cannot meet: the periodicity residual of an integrated orbit carries round-off of ~1e-15 of the state",
        ),
        (
            "[model]\nfamily = \"duffing\"\n[[response]]\nname = \"frc\"\nforce = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 0.5\nfrequency_end = 3.5".to_string(),
            "job.toml: response `frc`: a forced response needs `[model] damping` (e.g. `damping = { rayleigh = [0.01, 0.0] }`; `{ rayleigh = [0.0, 0.0] }` for none)",
        ),
    ];
    for (text, expected) in cases {
        assert_eq!(error(&text), expected, "{text}");
    }
    // A damping matrix that is not symmetric names the entry.
    let e = error(
        &duffing_response("{ matrix = [[1.0]] }", force)
            .replace(
                "family = \"duffing\"\ncubic = 1.0",
                "mass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]",
            )
            .replace("[[1.0]]", "[[1.0, 0.5], [0.0, 1.0]]"),
    );
    assert!(
        e.starts_with("job.toml: [model] damping: ")
            && e.contains("symmetric")
            && e.contains("(0, 1)"),
        "{e}"
    );
    // Engine order beyond N/2 on the bladed disk (30 sectors).
    let e = error(
        "[model]\nfamily = \"bladed-disk\"\ndamping = { rayleigh = [0.0, 0.001] }\n[[response]]\nname = \"eo\"\nforce = { engine_order = 16, amplitude = 0.1, sector_dof = 1 }\nfrequency_start = 0.5\nfrequency_end = 1.5",
    );
    assert_eq!(
        e,
        "job.toml: response `eo`: engine order 16 is beyond N/2 = 15 (the model has 30 sectors)"
    );
}

/// A response's files must not be a branch's, another response's or the run's.
#[test]
fn response_files_do_not_collide() {
    let job = |names: (&str, &str)| {
        format!(
            "[model]\nfamily = \"duffing\"\ndamping = {{ rayleigh = [0.0, 0.02] }}\n[[branch]]\nname = \"{}\"\nmode = 0\nenergy_max = 1.0\n[[response]]\nname = \"{}\"\nforce = {{ dofs = [0], amplitude = 0.1 }}\nfrequency_start = 0.5\nfrequency_end = 3.5\n",
            names.0, names.1
        )
    };
    assert_eq!(
        error(&job(("b", "B"))),
        "job.toml: branch `b` and response `B` would both write b.csv (b.csv and B.csv are one file where names ignore case, as on macOS and Windows)"
    );
    assert_eq!(
        error(&job(("b", "fep"))),
        "job.toml: response `fep` would write fep.png over the run's own fep.png"
    );
}

/// [`RESPONSE_SETTINGS_KEYS`] are exactly the fields of `ResponseSettings` as serde writes
/// them (flattened groups included), none of a branch's alone.
#[test]
fn response_settings_keys_are_the_structs_fields() {
    let fields: std::collections::BTreeSet<String> =
        toml::Table::try_from(ResponseSettings::default())
            .unwrap()
            .keys()
            .cloned()
            .collect();
    let keys: std::collections::BTreeSet<String> = RESPONSE_SETTINGS_KEYS
        .iter()
        .map(|k| k.to_string())
        .collect();
    assert_eq!(keys, fields);
    assert!(!keys.contains("energy_max"));
}

/// The settings alone (as the Python bindings give them): a misspelt key is refused listing
/// the settings; values out of range with the branch settings' messages; given values are
/// used and the others keep the response's own defaults (not a branch's).
#[test]
fn response_settings_are_checked_and_keep_the_response_defaults() {
    let table = |text: &str| -> toml::Table { text.parse().unwrap() };
    let e = response_settings(table("tolerence = 1e-9")).unwrap_err();
    assert!(
        e.starts_with("unknown field `tolerence`, expected one of `tolerance`, "),
        "{e}"
    );
    assert!(!e.contains("`force`"), "{e}");
    let e = response_settings(table("tolerance = 0.1")).unwrap_err();
    assert!(e.contains("tolerance 0.1 is too loose"), "{e}");
    let e = response_settings(table("max_points = 0")).unwrap_err();
    assert!(
        e.contains("max_points and max_iterations must be at least 1"),
        "{e}"
    );
    let e = response_settings(table("samples = 4")).unwrap_err();
    assert!(e.contains("samples must be at least 8"), "{e}");
    // Refused before anything is allocated for them (issue 29: 10^12 aborted the process).
    let e = response_settings(table("samples = 1000000000000")).unwrap_err();
    assert_eq!(
        e,
        "samples must be at most 100000 (each peak is refined between samples), got 1000000000000"
    );
    assert!(response_settings(table("samples = 100000")).is_ok());
    let s = response_settings(table("max_points = 7\ntolerance = 1e-10")).unwrap();
    assert_eq!(s.max_points, 7);
    assert_eq!(s.continuation.tolerance, 1e-10);
    // 0.02, not a branch's 0.1: serde alone would fill the flattened group from its own
    // default.
    assert_eq!(s.continuation.initial_step, 0.02);
    assert_eq!(
        s.continuation.initial_step,
        ResponseSettings::default().continuation.initial_step
    );
}

/// `resonance_force` (in `[settings]` or a branch) takes a response force's forms, an
/// amplitude optional, and is balanced against `[model] damping`: the branch's settings carry
/// the energy balance; without damping, with a dof out of range or with a zero shape, a
/// one-line error names what is wrong.
#[test]
fn resonance_force_is_resolved_against_the_damping_or_refused() {
    let job = |damping: &str, branch: &str| {
        format!(
            "[model]\nfamily = \"two-dof\"\n{damping}\n[settings]\nresonance_force = {{ dofs = [1] }}\n[[branch]]\nname = \"b\"\nmode = 0\nmax_points = 3\n{branch}\n[[branch]]\nname = \"c\"\nmode = 1\nmax_points = 3\n"
        )
    };
    let parsed = parse(&job("damping = { rayleigh = [0.1, 0.0] }", "")).unwrap();
    for b in &parsed.branches {
        let balance = b.settings.output.energy_balance.as_ref().unwrap();
        assert_eq!(balance.dofs(), 2);
    }
    // A branch's own overrides `[settings]`, amplitude and all.
    let parsed = parse(&job(
        "damping = { rayleigh = [0.1, 0.0] }",
        "resonance_force = { dofs = [0], amplitude = 3.0 }",
    ))
    .unwrap();
    let (own, shared) = (&parsed.branches[0].settings, &parsed.branches[1].settings);
    assert_ne!(own.output.energy_balance, shared.output.energy_balance);
    let cases = [
        (
            job("", ""),
            "job.toml: branch 1: `resonance_force` needs `[model] damping`: the energy balance weighs the force's work against what damping dissipates (e.g. `damping = { modal = [0.01] }`)",
        ),
        (
            job(
                "damping = { rayleigh = [0.1, 0.0] }",
                "resonance_force = { dofs = [2] }",
            ),
            "job.toml: branch 1: resonance_force: forced dof 2 is out of range (the model has 2 dofs)",
        ),
        (
            job(
                "damping = { rayleigh = [0.1, 0.0] }",
                "resonance_force = { vector = [0.0, 0.0] }",
            ),
            "job.toml: branch 1: resonance_force: the resonance force's shape is zero",
        ),
        (
            job(
                "damping = { rayleigh = [0.1, 0.0] }",
                "resonance_force = { dofs = [0], phase = 1.0 }",
            ),
            "job.toml: branch 1: resonance_force: the force has an unknown key `phase`: `force` must be { dofs = [..], amplitude = a }, { vector = [...] }, { file = \"f.mtx\" } or { engine_order = k, amplitude = a, sector_dof = j }",
        ),
    ];
    for (text, expected) in cases {
        assert_eq!(error(&text), expected, "{text}");
    }
}
