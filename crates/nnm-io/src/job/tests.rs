use super::*;
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
    let dir = std::env::temp_dir().join(format!("nnm-job-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
