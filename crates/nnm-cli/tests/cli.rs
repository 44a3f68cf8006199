//! The command-line contract (README "Command line", docs/job-files.md "Running a job"): outputs, and one-line errors with a non-zero exit for
//! bad input (never a panic).

mod common;
use common::{LONG_BRANCH, csv_rows, nnm, scratch, spawn, wait_for_rows, write};

/// Runs `nnm run JOB` expecting failure; returns the single stderr line.
fn expect_error(job_text: &str, expected: &str) {
    let dir = scratch("bad");
    let job = write(&dir, "job.toml", job_text);
    let out = dir.join("out");
    let output = nnm(&["run", &job, "--out", out.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "must fail: {job_text}");
    assert_eq!(output.status.code(), Some(1), "stderr: {stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "one line expected, got: {stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(lines[0].contains(expected), "`{stderr}` lacks `{expected}`");
    assert!(!stderr.contains("panicked"));
}

const TWO_DOF: &str =
    "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n";
const BRANCH: &str = "[[branch]]\nname = \"b\"\nmode = 0\nenergy_max = 1.0\n";

#[test]
fn bad_input_gives_one_line_errors() {
    expect_error("[model\nfamily = ", "job.toml:1:");
    expect_error(
        &format!("{TWO_DOF}{BRANCH}output_dofs = [0, 5]\n"),
        "branch 1: invalid setting: output_dofs: dof 5 does not exist (the model has 2 dofs",
    );
    expect_error(
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0, 0.0], [-1.0, 2.0, 0.0], [0.0, 0.0, 1.0]]\n",
        "stiffness matrix is 3x3, expected 2x2",
    );
    expect_error(
        "[model]\nmass = [[1.0, 2.0], [2.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n",
        "mass matrix is not positive definite",
    );
    expect_error(
        "[model]\nfamily = \"bladed-disk\"\n[[branch]]\nname = \"x\"\nmode = \"2,5\"\nenergy_max = 1.0\n",
        "unknown mode `2,5`",
    );
    expect_error(
        "[model]\nfamily = \"bladed-disk\"\n[[branch]]\nname = \"x\"\nmode = \"0,0\"\nenergy_max = 1.0\n",
        "rigid-body mode",
    );
    expect_error(
        "[model]\nmass = { file = \"nowhere.mtx\" }\nstiffness = [[1.0]]\n",
        "cannot read",
    );
    expect_error(
        &format!(
            "{TWO_DOF}[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = nan\n{BRANCH}"
        ),
        "coefficient must be finite",
    );
    expect_error(
        &format!("{TWO_DOF}{BRANCH}tolerance = -1.0\n"),
        "tolerance must be positive",
    );
    expect_error(
        "[model]\nfamily = \"bladed-disk\"\nsectors = 100000000\n",
        "sectors must be between 1 and",
    );
    expect_error(
        &format!(
            "{TWO_DOF}[[model.nonlinear]]\ntype = \"polynomial\"\ndofs = [0]\ncoefficient = 1.0\nexponent = 4294967295\n{BRANCH}"
        ),
        "exponent must be 2 to 31",
    );
    expect_error(
        &format!("{TWO_DOF}{BRANCH}energy_start = -1.0\n"),
        "energy_start must be positive",
    );
    expect_error(
        &format!("{TWO_DOF}{BRANCH}stability_tolerance = nan\n"),
        "stability_tolerance",
    );
    expect_error(
        &format!("{TWO_DOF}[[branch]]\nname = \"modes\"\nmode = 0\nenergy_max = 1.0\n"),
        "not `modes`",
    );
    expect_error(
        "[model]\nfamily = \"bladed-disk\"\n[[branch]]\nname = \"x\"\nmode = 2\npattern = \"cos\"\nenergy_max = 1.0\n",
        "asks for the other",
    );
    expect_error(
        &format!(
            "{TWO_DOF}[[branch]]\nname = \"c\"\nstart = {{ branch = \"b\", event = 0 }}\nenergy_max = 1.0\n{BRANCH}"
        ),
        "`start` refers to branch `b`, which must be defined above this one",
    );
    expect_error(
        &format!(
            "{TWO_DOF}{BRANCH}[[branch]]\nname = \"c\"\nmode = 1\nstart = {{ branch = \"b\", event = 0 }}\nenergy_max = 1.0\n"
        ),
        "either `mode` or `start`",
    );
    expect_error(
        &format!(
            "{TWO_DOF}{BRANCH}[[branch]]\nname = \"c\"\nstart = {{ branch = \"b\", point = 0 }}\nenergy_max = 1.0\n"
        ),
        "`start` must be { branch = \"NAME\", event = K }",
    );
    {
        // A Matrix Market header announcing 300000 dofs with one entry: coordinate files are
        // stored sparse (no size cap), and a mass with fewer entries than rows is refused
        // before anything of its size is allocated.
        let dir = scratch("big");
        write(
            &dir,
            "big.mtx",
            "%%MatrixMarket matrix coordinate real symmetric\n300000 300000 1\n1 1 1.0\n",
        );
        let job = write(
            &dir,
            "job.toml",
            "[model]\nmass = { file = \"big.mtx\" }\nstiffness = { file = \"big.mtx\" }\n",
        );
        let output = nnm(&["modes", &job]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains("cannot be positive definite"), "{stderr}");
    }
    {
        // A tensor element whose force is not a gradient, and one with a malformed line: a
        // one-line error naming the file (and the line), exit code 1.
        let dir = scratch("tensor");
        write(&dir, "f2.txt", "% f_1 += x_2^2 alone\n1 2 2 1.0\n");
        write(&dir, "f3.txt", "\n1 1 1 1\n");
        for (file, key, expected) in [
            (
                "f2.txt",
                "quadratic",
                "quadratic terms are not the gradient of a potential",
            ),
            (
                "f3.txt",
                "cubic",
                "line 2: expected `i j k l c` (5 numbers), found 4",
            ),
        ] {
            let job = write(
                &dir,
                "job.toml",
                &format!(
                    "{TWO_DOF}fixed_dofs = []\n[[model.nonlinear]]\ntype = \"tensor\"\n{key} = {{ file = \"{file}\" }}\n{BRANCH}"
                ),
            );
            let output = nnm(&["run", &job, "--out", dir.join("out").to_str().unwrap()]);
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(1), "{stderr}");
            assert_eq!(stderr.lines().count(), 1, "{stderr}");
            assert!(stderr.starts_with("error: "), "{stderr}");
            assert!(stderr.contains(&format!("{file}: {expected}")), "{stderr}");
            assert!(!stderr.contains("panicked"));
        }
    }
    // A missing job file.
    let output = nnm(&["run", "/nonexistent/job.toml", "--out", "/tmp/x"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1));
    assert_eq!(stderr.lines().count(), 1);
    assert!(
        stderr.starts_with("error: cannot read /nonexistent/job.toml"),
        "{stderr}"
    );
}

#[test]
fn help_on_every_subcommand() {
    for args in [
        vec!["--help"],
        vec!["modes", "--help"],
        vec!["run", "--help"],
        vec!["export", "--help"],
        vec!["example", "--help"],
        vec!["example", "bladed-disk", "--help"],
        vec!["example", "cantilever-beam", "--help"],
    ] {
        let output = nnm(&args);
        assert!(output.status.success(), "{args:?}");
        assert!(String::from_utf8_lossy(&output.stdout).contains("Usage"));
    }
}

#[test]
fn modes_writes_the_contract_columns() {
    let dir = scratch("modes");
    let job = write(&dir, "model.toml", "[model]\nfamily = \"bladed-disk\"\n");
    let output = nnm(&["modes", &job, "--out", dir.to_str().unwrap()]);
    assert!(output.status.success());
    let csv = std::fs::read_to_string(dir.join("modes.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("index,frequency_rad_s,label")
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 60);
    assert!(rows[0].starts_with("0,0,\"0,0\""), "{}", rows[0]);
    // (1,15), the highest mode: 2.485 rad/s in Table 1.
    let last: Vec<&str> = rows[59].split(',').collect();
    assert!((last[1].parse::<f64>().unwrap() - 2.485).abs() < 5e-4);
    assert_eq!(rows[59].split('"').nth(1), Some("1,15"));
}

/// A penalty spring (k = 1e12 between two unit masses grounded by unit springs): `nnm modes`
/// lists ω = 1 and √(1 + 2k), neither rigid (the old relative threshold called the first rigid
/// at 0 rad/s); with k = 1e14 the soft mode is within round-off of rigid and the command
/// fails with a one-line error instead of a wrong answer.
#[test]
fn modes_of_a_penalty_spring_are_right_or_refused() {
    let dir = scratch("penalty");
    let job = write(
        &dir,
        "job.toml",
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[1000000000001.0, -1000000000000.0], [-1000000000000.0, 1000000000001.0]]\n",
    );
    let output = nnm(&["modes", &job, "--out", dir.to_str().unwrap()]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let csv = std::fs::read_to_string(dir.join("modes.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 2);
    let w: Vec<f64> = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    assert!((w[0] - 1.0).abs() < 1e-12, "{csv}");
    assert!(
        (w[1] - (1.0 + 2e12f64).sqrt()).abs() < 1e-12 * w[1],
        "{csv}"
    );
    assert!(rows.iter().all(|r| r[4] == "false"), "{csv}");

    let job = write(
        &dir,
        "stiffer.toml",
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[100000000000001.0, -100000000000000.0], [-100000000000000.0, 100000000000001.0]]\n",
    );
    let output = nnm(&["modes", &job]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(
        stderr.contains("cannot be told from a rigid-body mode"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"));
}

#[test]
fn run_writes_csv_and_json_per_branch() {
    let dir = scratch("run");
    let job = write(
        &dir,
        "job.toml",
        &format!(
            "{TWO_DOF}[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.5\n{BRANCH}"
        ),
    );
    let out = dir.join("out");
    let output = nnm(&["run", &job, "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    // Quiet means errors only (issue 13 item 3): no point, branch or progress lines on
    // stderr, and no summary on stdout; the files say how the branch ended.
    assert!(
        output.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        output.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&output.stdout)
    );
    let csv = std::fs::read_to_string(out.join("b.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for column in [
        "energy",
        "frequency_rad_s",
        "period_s",
        "stable",
        "max_floquet_modulus",
    ] {
        assert!(header.contains(&column), "missing column {column}");
    }
    let rows = csv.lines().count() - 1;
    assert!(rows > 5);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("b.json")).unwrap()).unwrap();
    assert_eq!(json["status"], "finished");
    assert_eq!(json["stop_reason"], "reached energy_max");
    let points = json["points"].as_array().unwrap();
    assert_eq!(points.len(), rows);
    let last = &points[rows - 1];
    assert_eq!(last["z0"].as_array().unwrap().len(), 4);
    // The last point lies on energy_max = 1 (docs/method.md eq. (26a)).
    assert!((last["energy"].as_f64().unwrap() - 1.0).abs() < 1e-9);
    // Period and frequency agree, and the low-energy limit is the linear mode (ω = 1).
    let first = &points[0];
    let (f, t) = (
        first["frequency_rad_s"].as_f64().unwrap(),
        first["period_s"].as_f64().unwrap(),
    );
    assert!((f * t - 2.0 * std::f64::consts::PI).abs() < 1e-12);
    assert!((f - 1.0).abs() < 1e-3);
    assert!(out.join("fep.png").exists() && out.join("fep.svg").exists());
    // Every file the run wrote is one the job's check of colliding file names knows of (a
    // branch's, or the run's own): a new one must join that check.
    let known: Vec<String> = nnm_io::output::branch_files("b")
        .chain(nnm_io::output::RUN_FILES.iter().map(|f| f.to_string()))
        .collect();
    for entry in std::fs::read_dir(&out).unwrap() {
        let file = entry.unwrap().file_name().into_string().unwrap();
        assert!(known.contains(&file), "{file} is not in RUN_FILES");
    }
}

/// Every record of a CSV file, the header first (read with the `csv` crate).
fn read_csv(path: &std::path::Path) -> Vec<Vec<String>> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .from_path(path)
        .unwrap()
        .records()
        .map(|r| r.unwrap().iter().map(String::from).collect())
        .collect()
}

/// The fixed–free chain of crates/nnm/tests/regimes.rs: the summary says where its backbone
/// enters the 3:1 tongue and leaves for the fourth mode's family, the CSV's regime and peak
/// columns say the same per point, and `amplitude.png` is drawn from the peaks.
#[test]
fn run_says_where_a_branch_enters_a_tongue_and_leaves_its_family() {
    let dir = scratch("regime");
    let k = "[[2, -1, 0, 0, 0], [-1, 2, -1, 0, 0], [0, -1, 2, -1, 0], [0, 0, -1, 2, -1], [0, 0, 0, -1, 1]]";
    let m = "[[1, 0, 0, 0, 0], [0, 1, 0, 0, 0], [0, 0, 1, 0, 0], [0, 0, 0, 1, 0], [0, 0, 0, 0, 1]]";
    let job = write(
        &dir,
        "chain.toml",
        &format!(
            "[model]\nmass = {m}\nstiffness = {k}\n[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.5\n[[branch]]\nname = \"first\"\nmode = 0\nmax_points = 60\nenergy_max = 1e4\noutput_dofs = [0, 4]\n"
        ),
    );
    let out = dir.join("out");
    let output = nnm(&["run", &job, "--out", out.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    assert!(
        stdout.contains("in a 3:1 internal-resonance tongue with mode 1"),
        "{stdout}"
    );
    assert!(
        stdout.contains("left its family for that of mode 3 at 7ω (7:1)"),
        "{stdout}"
    );
    let rows = read_csv(&out.join("first.csv"));
    let header = &rows[0];
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (regime, ratio) = (column("regime"), column("ratio"));
    let (peak0, peak4) = (column("peak_x0"), column("peak_x4"));
    let kinds: Vec<&str> = rows[1..].iter().map(|r| r[regime].as_str()).collect();
    let tongue = kinds.iter().position(|k| *k == "tongue").unwrap();
    let other = kinds.iter().position(|k| *k == "other-family").unwrap();
    assert!(kinds[0] == "backbone" && tongue < other);
    assert_eq!(rows[1 + tongue][ratio], "3:1");
    assert_eq!(rows[1 + other][ratio], "7:1");
    // Peaks are positive lengths; the free end moves more than the grounded first mass in
    // the first mode.
    let first: Vec<f64> = [peak0, peak4]
        .iter()
        .map(|&c| rows[1][c].parse().unwrap())
        .collect();
    assert!(first[0] > 0.0 && first[1] > first[0], "{first:?}");
    assert!(out.join("amplitude.png").exists() && out.join("amplitude.svg").exists());
}

/// docs/job-files.md, "Running a job": an interrupted run loses nothing — every converged point is already in the CSV,
/// and the JSON is a valid document (status "running") holding the same points.
#[test]
fn interrupted_run_keeps_every_point() {
    let dir = scratch("interrupt");
    let job = write(&dir, "job.toml", LONG_BRANCH);
    let out = dir.join("out");
    let mut child = spawn(&["run", &job, "--out", out.to_str().unwrap(), "--quiet"]);
    let csv_path = out.join("long.csv");
    wait_for_rows(&csv_path, 5);
    child.kill().unwrap();
    child.wait().unwrap();
    let csv_rows = csv_rows(&csv_path);
    assert!(
        csv_rows >= 5,
        "only {csv_rows} rows written before the kill"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("long.json")).unwrap())
            .expect("the JSON is valid even when interrupted");
    assert_eq!(json["status"], "running");
    let points = json["points"].as_array().unwrap().len();
    // The kill can fall between the two files' writes of one point.
    assert!(
        points.abs_diff(csv_rows) <= 1,
        "{points} JSON points vs {csv_rows} CSV rows"
    );
}

/// Issue 4 from the command line: the events file beside the branch, and a branch switched
/// onto at an event; asking for an event that does not exist fails that branch with a clear
/// message and a non-zero exit, after the others are written.
#[test]
fn events_are_written_and_branches_switch_at_them() {
    let dir = scratch("events");
    let job = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/two-dof-bifurcation.toml"
    );
    let out = dir.join("out");
    let output = nnm(&["run", job, "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let events = std::fs::read_to_string(out.join("in-phase.events.csv")).unwrap();
    let mut lines = events.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for column in [
        "type",
        "energy",
        "frequency_rad_s",
        "multiplier_re",
        "multiplier_im",
    ] {
        assert!(header.contains(&column), "missing column {column}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 1, "{events}");
    let column = |name: &str| header.iter().position(|c| *c == name).unwrap();
    assert_eq!(rows[0][column("type")], "branch-point");
    let energy: f64 = rows[0][column("energy")].parse().unwrap();
    assert!((39.6..41.3).contains(&energy), "{energy}");
    let switched = std::fs::read_to_string(out.join("symmetry-broken.csv")).unwrap();
    assert!(switched.lines().count() > 3, "{switched}");
    let json = std::fs::read_to_string(out.join("symmetry-broken.json")).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(doc["switched_from"]["branch"], "in-phase");
    assert_eq!(doc["switched_from"]["type"], "branch-point");
    let parent: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("in-phase.json")).unwrap()).unwrap();
    assert_eq!(parent["events"].as_array().unwrap().len(), 1);

    let text = std::fs::read_to_string(job)
        .unwrap()
        .replace("event = 0", "event = 5");
    let bad = write(&dir, "bad.toml", &text);
    let output = nnm(&[
        "run",
        &bad,
        "--out",
        dir.join("bad").to_str().unwrap(),
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("has 1 event "), "{stderr}");
    assert!(!stderr.contains("panicked"));
    assert!(dir.join("bad/in-phase.csv").exists());

    // Parent and child posed with different phase conditions: the switch takes the parent's
    // direction from the event itself, not from the child's unknowns.
    let text = std::fs::read_to_string(job).unwrap().replace(
        "name = \"in-phase\"\nmode = 0",
        "name = \"in-phase\"\nmode = 0\nphase = \"flow-orthogonal\"",
    );
    assert!(text.contains("flow-orthogonal"));
    let mixed = write(&dir, "mixed.toml", &text);
    let output = nnm(&[
        "run",
        &mixed,
        "--out",
        dir.join("mixed").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(dir.join("mixed/symmetry-broken.csv").exists());
}

/// `nnm example cantilever-beam --quick`: the job file it ran (a valid job), the first branch's
/// files, the figures and the report; `modes.csv` holds the first frequency of the ECL beam,
/// checked against Euler-Bernoulli theory computed here.
#[test]
fn cantilever_beam_example_writes_its_study() {
    let dir = scratch("beam");
    let out = dir.join("out");
    let output = nnm(&[
        "example",
        "cantilever-beam",
        "--out",
        out.to_str().unwrap(),
        "--quick",
        "--quiet",
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for file in [
        "cantilever-beam.toml",
        "mode-1.csv",
        "mode-1.json",
        "mode-1.events.csv",
        "modes.csv",
        "fep.png",
        "fep-normalised.png",
        "mode-shapes.png",
        "report.md",
    ] {
        let size = std::fs::metadata(out.join(file)).map_or(0, |m| m.len());
        assert!(size > 0, "{file} missing or empty");
    }
    // Euler-Bernoulli: f1 = (beta1 L)^2 / (2 pi) sqrt(E I / (rho A L^4)), the ECL beam's 23.6615 Hz.
    let (length, side, youngs, density) = (0.7f64, 0.014f64, 2.05e11, 7800.0);
    let (area, inertia) = (side * side, side.powi(4) / 12.0);
    let theory = 1.875_104_068_711_961f64.powi(2) / (2.0 * std::f64::consts::PI)
        * (youngs * inertia / (density * area * length.powi(4))).sqrt();
    assert!((theory - 23.6615).abs() < 1e-4, "{theory}");
    let csv = std::fs::read_to_string(out.join("modes.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let first: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let hz = first[column("frequency_hz")];
    assert!((hz / theory - 1.0).abs() < 1e-4, "{hz} Hz vs {theory} Hz");
    assert!((first[column("euler_bernoulli_hz")] / theory - 1.0).abs() < 1e-12);
    assert!(
        (first[column("frequency_rad_s")] / (2.0 * std::f64::consts::PI * hz) - 1.0).abs() < 1e-12
    );
    assert_eq!(csv.lines().count(), 5, "{csv}");
    // The job file written is the job that ran: `nnm` reads it back, with its one branch.
    let job = out.join("cantilever-beam.toml");
    let text = std::fs::read_to_string(&job).unwrap();
    assert_eq!(text.matches("[[branch]]").count(), 1, "{text}");
    let modes = nnm(&["modes", job.to_str().unwrap()]);
    assert!(modes.status.success());
    let branch = std::fs::read_to_string(out.join("mode-1.csv")).unwrap();
    assert!(branch.lines().count() > 10, "{branch}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    for text in [
        "(fep.png)",
        "(mode-shapes.png)",
        "| 1 | 23.6615 |",
        "`mode-1`",
    ] {
        assert!(report.contains(text), "report.md lacks {text}");
    }
}

/// A branch integrated by radau5 on two DOF with ω = 1 and √401 (its fast pair damped to
/// |μ| ≈ 0.99) says so in a warning line; the same branch by dop853 (exact multipliers, the
/// sensitivities' error controlled) does not.
#[test]
fn damped_multipliers_are_said() {
    let dir = scratch("damped");
    for (integrator, warned) in [("radau5", true), ("dop853", false)] {
        let job = write(
            &dir,
            &format!("{integrator}.toml"),
            &format!(
                "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[201.0, -200.0], [-200.0, 201.0]]\n\
                 [[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.1\n\
                 [[branch]]\nname = \"slow\"\nmode = 0\nfrequency_shift_max = 1e-4\nmax_points = 3\n\
                 integrator = \"{integrator}\"\n"
            ),
        );
        let out = dir.join(integrator);
        let output = nnm(&["run", &job, "--out", out.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        assert_eq!(
            stderr.contains("lack reciprocal partners"),
            warned,
            "{integrator}: {stderr}"
        );
    }
}

/// `nnm run --vtk` on a beam: ParaView collections of the mode shapes and of the chosen
/// points' motions, each frame a VTK unstructured grid of the beam's 21 nodes and 20 line
/// cells with the `displacement` array; the frames' times a period cut in 32. A model without
/// nodes is refused with one line before anything is written.
#[test]
fn vtk_writes_paraview_collections_or_refuses_a_model_without_nodes() {
    let dir = scratch("vtk");
    let job = write(
        &dir,
        "job.toml",
        "[model]\nfamily = \"von-karman-beam\"\n[[branch]]\nname = \"b\"\nmode = 0\nmax_points = 3\n",
    );
    let out = dir.join("out");
    let output = nnm(&[
        "run",
        &job,
        "--out",
        out.to_str().unwrap(),
        "--vtk",
        "-1",
        "-q",
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let vtk = out.join("vtk");
    let mut files: Vec<String> = std::fs::read_dir(&vtk)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, ["b-2", "b-2.pvd", "modes", "modes.pvd"]);
    let collection = std::fs::read_to_string(vtk.join("b-2.pvd")).unwrap();
    let times: Vec<f64> = collection
        .split("timestep=\"")
        .skip(1)
        .map(|s| s.split('"').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(times.len(), 32);
    let period = times[1] * 32.0;
    let csv = std::fs::read_to_string(out.join("b.csv")).unwrap();
    let column = csv
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "period_s")
        .unwrap();
    let last: f64 = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .nth(column)
        .unwrap()
        .parse()
        .unwrap();
    assert!((period / last - 1.0).abs() < 1e-9, "{period} vs {last}");
    let frame = std::fs::read_to_string(vtk.join("b-2").join("frame-000.vtu")).unwrap();
    assert!(frame.contains("NumberOfPoints=\"21\"") && frame.contains("NumberOfCells=\"20\""));
    assert!(frame.contains("Name=\"displacement\""));

    let duffing = write(
        &dir,
        "duffing.toml",
        "[model]\nfamily = \"duffing\"\n[[branch]]\nname = \"d\"\nmode = 0\nmax_points = 2\n",
    );
    let refused = dir.join("refused");
    let output = nnm(&["run", &duffing, "--out", refused.to_str().unwrap(), "--vtk"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr
            .trim()
            .starts_with("error: --vtk draws on a model's nodes"),
        "{stderr}"
    );
    assert!(!refused.exists());
}
