//! What a probe of bad inputs and interrupts found (issue 13, item 4), each as a contract: limits
//! and tolerances refused before any computation, exit codes a script can tell apart (README
//! "Command line", docs/job-files.md "Running a job"), Ctrl-C that still writes what was finished, one run per output folder.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::{LONG_BRANCH, csv_rows, nnm, scratch, spawn, wait_for_rows, write};

const MODEL: &str = "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.5\n";

/// The bladed-disk study's job: the paper's model, backbones to E = 10.
const STUDY_JOB: &str = "[model]\nfamily = \"bladed-disk\"\n[settings]\nenergy_max = 10.0\n";

/// A branch of the two-DOF model with `keys` (one per line).
fn job(name: &str, mode: usize, keys: &str) -> String {
    format!("[[branch]]\nname = \"{name}\"\nmode = {mode}\n{keys}\n")
}

fn stderr_of(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A single `error: ...` line on stderr, exit code `code`, no panic.
fn assert_one_error_line(output: &Output, code: i32, expected: &str) -> String {
    let stderr = stderr_of(output);
    assert_eq!(output.status.code(), Some(code), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line expected: {stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(stderr.contains(expected), "`{stderr}` lacks `{expected}`");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

/// Limits at or below zero (or NaN), a start above the energy limit and a tolerance double
/// precision cannot meet are refused from the job file alone: nothing is created, and the
/// half-period hint (meant for motions that are not half-wave symmetric) is not given.
#[test]
fn limits_and_tolerances_are_refused_before_anything_is_computed() {
    let dir = scratch("limits");
    for (keys, expected) in [
        ("energy_max = -1.0", "energy_max must be positive, got -1"),
        ("energy_max = 0.0", "energy_max must be positive, got 0"),
        (
            "frequency_shift_max = -0.1",
            "frequency_shift_max must be positive, got -0.1",
        ),
        (
            "frequency_shift_max = nan",
            "frequency_shift_max must be positive, got NaN",
        ),
        (
            "energy_max = 1.0\nenergy_start = 5.0",
            "energy_start 5 must be below energy_max 1",
        ),
        (
            "energy_max = 1.0\nat_energies = [0.5, nan]",
            "at_energies must hold positive, finite energies, got NaN",
        ),
        (
            "energy_max = 1.0\nat_energies = [-2.0]",
            "at_energies must hold positive, finite energies, got -2",
        ),
        (
            "energy_max = 1.0\nat_frequencies = [inf]",
            "at_frequencies must hold positive, finite frequencies (rad/s), got inf",
        ),
        (
            "energy_max = 1.0\nat_frequencies = [0.0]",
            "at_frequencies must hold positive, finite frequencies (rad/s), got 0",
        ),
        (
            "energy_max = 1.0\ntolerance = 1e-17",
            "tolerance 1e-17 is below 1e-14, which double precision cannot meet",
        ),
    ] {
        let path = write(&dir, "job.toml", &format!("{MODEL}{}", job("b", 0, keys)));
        let out = dir.join("out");
        let output = nnm(&["run", &path, "--out", out.to_str().unwrap()]);
        let stderr = assert_one_error_line(&output, 1, expected);
        assert!(!stderr.contains("half_period"), "{stderr}");
        assert!(!out.exists(), "{keys}: nothing may be written");
    }
    // The smallest tolerance accepted converges (the bound is not too strict).
    let path = write(
        &dir,
        "job.toml",
        &format!(
            "{MODEL}{}",
            job("b", 0, "energy_max = 1.0\ntolerance = 1e-14")
        ),
    );
    let output = nnm(&[
        "run",
        &path,
        "--out",
        dir.join("out").to_str().unwrap(),
        "-q",
    ]);
    assert!(output.status.success(), "{}", stderr_of(&output));
}

/// A matrix given in neither accepted form names the forms (not serde's "untagged enum"), and
/// a Matrix Market error is said once.
#[test]
fn matrix_errors_say_what_is_accepted_once() {
    let dir = scratch("matrix");
    let job = write(
        &dir,
        "job.toml",
        "[model]\nmass = \"M.mtx\"\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n",
    );
    let stderr = assert_one_error_line(
        &nnm(&["modes", &job]),
        1,
        "job.toml:2:8: expected a matrix as rows of numbers, e.g. [[2.0, -1.0], [-1.0, 2.0]], or as a Matrix Market file, { file = \"K.mtx\" }",
    );
    assert!(!stderr.contains("untagged"), "{stderr}");
    write(
        &dir,
        "M.mtx",
        "%%MatrixMarket matrix coordinate real general\n2 2 x\n",
    );
    let job = write(
        &dir,
        "job.toml",
        "[model]\nmass = { file = \"M.mtx\" }\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n",
    );
    let stderr = assert_one_error_line(&nnm(&["modes", &job]), 1, "M.mtx: line 2: ");
    assert_eq!(stderr.matches("line 2").count(), 1, "{stderr}");
}

/// A branch that cannot converge even at its minimum step (one Newton iteration allowed, steps
/// of at least 0.2) stops early: its points and the other branch are written, the summary says
/// so, and the exit code is 3 — not 0 (success) nor 1 (failure).
#[test]
fn branch_stopped_before_its_limit_exits_3() {
    let dir = scratch("early");
    let text = format!(
        "{MODEL}{}{}",
        job(
            "stuck",
            0,
            "energy_max = 100.0\nmax_iterations = 1\nmin_step = 0.2\ninitial_step = 0.25"
        ),
        job("fine", 1, "energy_max = 1.0")
    );
    let path = write(&dir, "job.toml", &text);
    let out = dir.join("out");
    let output = nnm(&["run", &path, "--out", out.to_str().unwrap(), "--quiet"]);
    assert_one_error_line(
        &output,
        3,
        "1 of 2 branches stopped before their limits (stuck: no convergence at the minimum step",
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("; 1 branch stopped before its limit"),
        "{stdout}"
    );
    let rows = |name: &str| {
        std::fs::read_to_string(out.join(format!("{name}.csv")))
            .unwrap()
            .lines()
            .count()
            - 1
    };
    assert!(rows("stuck") > 1 && rows("fine") > 1);
    let stop = |name: &str| stop_reason(&out.join(format!("{name}.json")));
    assert!(stop("stuck").starts_with("no convergence at the minimum step"));
    assert_eq!(stop("fine"), "reached energy_max");
    assert!(out.join("fep.png").exists());
}

fn stop_reason(json: &Path) -> String {
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    doc["stop_reason"].as_str().unwrap_or_default().to_string()
}

/// Ctrl-C during `nnm run`: a line says so at once; the branch in progress stops at its next
/// point with its files complete ("interrupted"), the branch not yet started is skipped, the
/// summary and the frequency–energy plot are written, the exit code is 130 and the output
/// folder's lock is released.
#[cfg(unix)]
#[test]
fn ctrl_c_writes_what_was_finished() {
    stop_writes_what_was_finished(
        "sigint",
        libc::SIGINT,
        130,
        "interrupted: finishing the points in progress and writing what is done (Ctrl-C again to quit at once)\n",
    );
}

/// SIGTERM (what `kill`, `timeout` and schedulers send) stops `nnm run` as Ctrl-C does, its own
/// line first, with exit code 143 (128 + 15).
#[cfg(unix)]
#[test]
fn sigterm_writes_what_was_finished() {
    stop_writes_what_was_finished(
        "sigterm",
        libc::SIGTERM,
        143,
        "terminated (SIGTERM): finishing the points in progress and writing what is done (a second signal quits at once)\n",
    );
}

/// The signal's line starts stderr when no progress line came before (`--quiet` above: no
/// blank line first, issue 29), and is set off from progress lines by one blank line.
#[cfg(unix)]
#[test]
fn the_signal_line_follows_progress_lines_after_a_blank_line() {
    let dir = scratch("signal-line");
    let path = write(&dir, "job.toml", LONG_BRANCH);
    let out = dir.join("out");
    let child = spawn(&[
        "run",
        &path,
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ]);
    wait_for_rows(&out.join("long.csv"), 3);
    let output = send(child, &[libc::SIGTERM]);
    let stderr = stderr_of(&output);
    assert_eq!(output.status.code(), Some(143), "{stderr}");
    assert!(stderr.starts_with("[long] "), "{stderr}");
    assert!(
        stderr.contains("\n\nterminated (SIGTERM): finishing the points in progress"),
        "{stderr}"
    );
}

#[cfg(unix)]
fn stop_writes_what_was_finished(name: &str, signal: i32, code: i32, first_line: &str) {
    let dir = scratch(name);
    let text =
        format!("{LONG_BRANCH}[[branch]]\nname = \"later\"\nmode = \"1,5\"\nenergy_max = 10.0\n");
    let path = write(&dir, "job.toml", &text);
    let out = dir.join("out");
    let out_dir = out.to_str().unwrap();
    let child = spawn(&["run", &path, "--out", out_dir, "--quiet", "--threads", "1"]);
    wait_for_rows(&out.join("long.csv"), 5);
    let output = send(child, &[signal]);
    let stderr = stderr_of(&output);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert_eq!(output.status.code(), Some(code), "{stderr}");
    assert!(stderr.starts_with(first_line), "{stderr}");
    assert!(
        stderr.contains("error: interrupted: 0 of 2 branches finished"),
        "{stderr}"
    );
    let summary: Vec<&str> = stdout.lines().collect();
    assert!(
        summary
            .iter()
            .any(|l| l.starts_with("long ") && l.ends_with("  interrupted")),
        "{stdout}"
    );
    assert!(
        summary
            .iter()
            .any(|l| l.starts_with("later ") && l.ends_with("not started (interrupted)")),
        "{stdout}"
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("long.json")).unwrap()).unwrap();
    assert_eq!(doc["status"], "finished");
    assert_eq!(doc["stop_reason"], "interrupted");
    assert_eq!(
        doc["points"].as_array().unwrap().len(),
        csv_rows(&out.join("long.csv"))
    );
    assert!(!out.join("later.csv").exists());
    assert!(out.join("fep.png").exists() && out.join("fep.svg").exists());
    assert!(!out.join(".nnm.lock").exists());
}

/// One run per output folder: a lock held by a live process refuses the run at once (nothing
/// written); a lock left by a process that is gone is taken over and released at the end.
/// Branch files of another job are kept and named in one warning line, even with `--quiet`.
/// (Unix: elsewhere a lock cannot be told stale and is always taken to be held.)
#[cfg(unix)]
#[test]
fn an_output_folder_is_used_by_one_run_at_a_time() {
    let dir = scratch("lock");
    let path = write(
        &dir,
        "job.toml",
        &format!("{MODEL}{}", job("b", 0, "energy_max = 1.0")),
    );
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let lock = out.join(".nnm.lock");
    // This test's own process is alive.
    std::fs::write(&lock, format!("{}\n", std::process::id())).unwrap();
    let output = nnm(&["run", &path, "--out", out.to_str().unwrap(), "--quiet"]);
    assert_one_error_line(
        &output,
        1,
        &format!(
            "is in use by another nnm run (process {})",
            std::process::id()
        ),
    );
    assert!(!out.join("b.csv").exists() && lock.exists());

    // A process that has ended.
    let mut gone = Command::new("true").spawn().unwrap();
    let pid = gone.id();
    gone.wait().unwrap();
    std::fs::write(&lock, format!("{pid}\n")).unwrap();
    write(&out, "old.csv", "index,energy\n");
    write(&out, "old.json", "{}");
    let output = nnm(&["run", &path, "--out", out.to_str().unwrap(), "--quiet"]);
    let stderr = stderr_of(&output);
    assert!(output.status.success(), "{stderr}");
    assert_eq!(
        stderr.trim_end(),
        format!(
            "warning: {} holds results of branches not in this job (old); they are left as they are and not plotted",
            out.display()
        )
    );
    assert!(out.join("b.csv").exists() && out.join("old.csv").exists());
    assert!(!lock.exists());
}

/// `--threads 0` is refused (leaving it out means one per core); `nnm study --threads 1`
/// reports one thread; the tongue's deliberate stop at the junction is recorded as such, not
/// as an interrupt.
#[test]
fn threads_are_reported_as_asked_and_the_junction_is_no_interrupt() {
    let dir = scratch("threads");
    let path = write(&dir, "job.toml", STUDY_JOB);
    let out = dir.join("out");
    for command in ["run", "study"] {
        let output = nnm(&[
            command,
            &path,
            "--out",
            out.to_str().unwrap(),
            "--threads",
            "0",
        ]);
        assert_one_error_line(&output, 1, "--threads must be at least 1");
    }
    let output = nnm(&[
        "study",
        &path,
        "--out",
        out.to_str().unwrap(),
        "--quick",
        "--threads",
        "1",
    ]);
    let stderr = stderr_of(&output);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("study: 7 backbones on 1 thread\n"),
        "{stderr}"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains(" wall time on 1 thread. "), "{report}");
    assert_eq!(
        stop_reason(&out.join("tongue-0-6.json")),
        "reached the junction with (1,12)"
    );
}

/// Ctrl-C during `nnm study` (here in the tongue): the report is written with the sections
/// finished and says where it stopped, the tongue's files say "interrupted", exit code 130.
#[cfg(unix)]
#[test]
fn ctrl_c_during_a_study_writes_its_report_so_far() {
    let dir = scratch("study-sigint");
    let path = write(&dir, "job.toml", STUDY_JOB);
    let out = dir.join("out");
    let child = spawn(&["study", &path, "--out", out.to_str().unwrap(), "--quick"]);
    wait_for_rows(&out.join("tongue-0-6.csv"), 5);
    let output = interrupt(child);
    let stderr = stderr_of(&output);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("error: interrupted: the study stopped;"),
        "{stderr}"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    for heading in ["## 2. Backbones", "## Interrupted"] {
        assert!(report.contains(heading), "{report}");
    }
    assert!(!report.contains("## 5."), "{report}");
    assert_eq!(stop_reason(&out.join("tongue-0-6.json")), "interrupted");
    assert!(!out.join(".nnm.lock").exists());
}

/// SIGTERM during `nnm study` stops it as Ctrl-C does: the report so far, exit code 143, the
/// lock released.
#[cfg(unix)]
#[test]
fn sigterm_during_a_study_writes_its_report_so_far() {
    let dir = scratch("study-sigterm");
    let path = write(&dir, "job.toml", STUDY_JOB);
    let out = dir.join("out");
    let child = spawn(&["study", &path, "--out", out.to_str().unwrap(), "--quick"]);
    wait_for_rows(&out.join("backbones").join("mode-0-2.csv"), 3);
    let output = send(child, &[libc::SIGTERM]);
    let stderr = stderr_of(&output);
    assert_eq!(output.status.code(), Some(143), "{stderr}");
    assert!(
        stderr.contains("error: interrupted: the study stopped;"),
        "{stderr}"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Interrupted"), "{report}");
    assert!(!out.join(".nnm.lock").exists());
}

/// A second signal quits at once (the process ends by it, without waiting for the point in
/// progress), yet the files hold every point written, whole — the CSV and the JSON the same
/// points, the JSON a valid document — and the output folder's lock is removed.
#[cfg(unix)]
#[test]
fn a_second_signal_quits_at_once_leaving_every_point() {
    use std::io::BufRead;
    use std::os::unix::process::ExitStatusExt;
    let dir = scratch("second-signal");
    let path = write(&dir, "job.toml", LONG_BRANCH);
    for (first, said) in [
        (libc::SIGINT, "interrupted: "),
        (libc::SIGTERM, "terminated (SIGTERM): "),
    ] {
        let out = dir.join(format!("out{first}"));
        let mut child = spawn(&["run", &path, "--out", out.to_str().unwrap(), "--quiet"]);
        wait_for_rows(&out.join("long.csv"), 3);
        let pid = libc::pid_t::try_from(child.id()).unwrap();
        // SAFETY: kill has no memory-safety preconditions; the child is ours and not reaped.
        assert_eq!(unsafe { libc::kill(pid, first) }, 0);
        // The second signal once the first is heard (two alike sent at once would merge).
        let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
        let mut line = String::new();
        while !line.starts_with(said) {
            line.clear();
            assert!(stderr.read_line(&mut line).unwrap() > 0, "no `{said}` line");
        }
        assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
        let status = child.wait().unwrap();
        assert_eq!(status.signal(), Some(libc::SIGINT), "after signal {first}");
        assert!(!out.join(".nnm.lock").exists(), "after signal {first}");
        // The branch may have written its last point and closed its JSON between the two
        // signals (a short branch stops at its next point): every point is there either way.
        assert_json_holds_the_csv_as(&out, "long", &["running", "finished"]);
    }
}

/// SIGHUP (the terminal gone) quits at once like a second signal: every point and every event
/// written, the events in the JSON with their states `z0`, the lock removed. Under `nohup`
/// (SIGHUP ignored) the run goes on.
#[cfg(unix)]
#[test]
fn sighup_quits_at_once_leaving_every_point_and_event() {
    use std::os::unix::process::ExitStatusExt;
    // The two-DOF backbone in small steps, on past its branch point near E = 41.
    let job = "[model]\nfamily = \"two-dof\"\ncubic = 0.5\n[settings]\nenergy_max = 1e4\nmax_step = 0.002\nmax_points = 1000000\n[[branch]]\nname = \"b\"\nmode = 0\n";
    let dir = scratch("sighup");
    let path = write(&dir, "job.toml", job);
    let out = dir.join("out");
    let child = spawn(&["run", &path, "--out", out.to_str().unwrap(), "--quiet"]);
    wait_for_rows(&out.join("b.events.csv"), 1);
    let output = send(child, &[libc::SIGHUP]);
    assert_eq!(
        output.status.signal(),
        Some(libc::SIGHUP),
        "{}",
        stderr_of(&output)
    );
    assert!(!out.join(".nnm.lock").exists());
    let events = assert_json_holds_the_csv(&out, "b");
    assert_eq!(events[0]["type"], "branch-point");
    for e in &events {
        assert_eq!(e["z0"].as_array().unwrap().len(), 4);
    }

    let out = dir.join("nohup");
    let child = Command::new("nohup")
        .arg(env!("CARGO_BIN_EXE_nnm"))
        .args(["run", &path, "--quiet", "--out"])
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_rows(&out.join("b.csv"), 3);
    let output = send(child, &[libc::SIGHUP, libc::SIGTERM]);
    assert_eq!(output.status.code(), Some(143), "{}", stderr_of(&output));
}

/// `<name>.json` in `out` is a valid document of a branch still running, with the points of
/// `<name>.csv` and the events of `<name>.events.csv`; returns its events.
fn assert_json_holds_the_csv(out: &Path, name: &str) -> Vec<serde_json::Value> {
    assert_json_holds_the_csv_as(out, name, &["running"])
}

/// [`assert_json_holds_the_csv`] for a JSON whose `status` is one of `statuses`.
fn assert_json_holds_the_csv_as(
    out: &Path,
    name: &str,
    statuses: &[&str],
) -> Vec<serde_json::Value> {
    let json = std::fs::read_to_string(out.join(format!("{name}.json"))).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&json).expect("the JSON is valid");
    assert!(
        statuses.iter().any(|s| doc["status"] == *s),
        "status {} not one of {statuses:?}",
        doc["status"]
    );
    assert_eq!(
        doc["points"].as_array().unwrap().len(),
        csv_rows(&out.join(format!("{name}.csv")))
    );
    let events = doc["events"]
        .as_array()
        .expect("the events are in the JSON");
    assert_eq!(
        events.len(),
        csv_rows(&out.join(format!("{name}.events.csv")))
    );
    events.clone()
}

/// Sends SIGINT to `child` and collects its output.
#[cfg(unix)]
fn interrupt(child: std::process::Child) -> Output {
    send(child, &[libc::SIGINT])
}

/// Sends `signals` to `child`, one right after the other, and collects its output.
#[cfg(unix)]
fn send(child: std::process::Child, signals: &[i32]) -> Output {
    let pid = libc::pid_t::try_from(child.id()).unwrap();
    for &signal in signals {
        // SAFETY: kill has no memory-safety preconditions; the child is ours and not reaped.
        assert_eq!(unsafe { libc::kill(pid, signal) }, 0);
    }
    child.wait_with_output().unwrap()
}

/// Requested energies and frequencies get points exactly on them, flagged in the CSV's `label`
/// column (the last point, on `energy_max`, too); a value the branch cannot reach is said on
/// stderr and kept in the JSON; and `--quiet` prints nothing at all on a successful run.
#[test]
fn requested_points_are_labelled_and_quiet_is_silent() {
    let dir = scratch("requested");
    let keys = "energy_max = 1.0\nat_energies = [0.25, 50.0]\nat_frequencies = [1.02]";
    let path = write(&dir, "job.toml", &format!("{MODEL}{}", job("b", 0, keys)));
    let out = dir.join("out");
    let output = nnm(&["run", &path, "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(output.status.success(), "{}", stderr_of(&output));
    assert_eq!(String::from_utf8_lossy(&output.stdout), "");
    assert_eq!(stderr_of(&output), "");
    let csv = std::fs::read_to_string(out.join("b.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (label, energy, frequency) = (column("label"), column("energy"), column("frequency_rad_s"));
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let labelled =
        |name: &str| -> Vec<&Vec<&str>> { rows.iter().filter(|r| r[label] == name).collect() };
    let value = |r: &Vec<&str>, k: usize| r[k].parse::<f64>().unwrap();
    let at_energy = labelled("at_energy");
    assert_eq!(at_energy.len(), 1);
    assert!((value(at_energy[0], energy) / 0.25 - 1.0).abs() <= 1e-10);
    let at_frequency = labelled("at_frequency");
    assert_eq!(at_frequency.len(), 1);
    assert!((value(at_frequency[0], frequency) / 1.02 - 1.0).abs() <= 1e-10);
    let last = rows.last().unwrap();
    assert_eq!(last[label], "energy_max");
    assert!((value(last, energy) - 1.0).abs() <= 1e-10);
    assert_eq!(labelled("").len() + 3, rows.len());
    let json = std::fs::read_to_string(out.join("b.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&json).unwrap();
    let missed = json["missed_requests"].as_array().unwrap();
    assert_eq!(missed.len(), 1);
    assert_eq!(missed[0]["value"], 50.0);
    assert_eq!(
        json["points"].as_array().unwrap().last().unwrap()["label"],
        "energy_max"
    );

    // Not quiet: progress on stderr, the unreachable value in a warning, the summary on stdout.
    let output = nnm(&["run", &path, "--out", out.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr_of(&output));
    let stderr = stderr_of(&output);
    assert!(
        stderr.contains("[b] warning: at_energies value 50 has no point: beyond energy_max = 1"),
        "{stderr}"
    );
    assert!(stderr.contains("(at_energy)"), "{stderr}");
    assert!(!String::from_utf8_lossy(&output.stdout).is_empty());

    // The examples are as quiet (the beam's report study too).
    for which in [&["duffing"][..], &["cantilever-beam", "--quick"]] {
        let example = dir.join(which[0]);
        let mut args = vec!["example"];
        args.extend(which);
        args.extend(["--out", example.to_str().unwrap(), "-q"]);
        let output = nnm(&args);
        assert!(output.status.success(), "{args:?}: {}", stderr_of(&output));
        assert_eq!(String::from_utf8_lossy(&output.stdout), "", "{args:?}");
        assert_eq!(stderr_of(&output), "", "{args:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A job `nnm run` must refuse whole, before anything is computed or written: exit 1, the
/// one-line `expected` message, and no output folder, although its first branch is good.
fn refused_before_anything_runs(dir: &Path, text: &str, expected: &str) {
    let path = write(dir, "job.toml", text);
    let out = dir.join("out");
    let _ = std::fs::remove_dir_all(&out);
    let output = nnm(&["run", &path, "--out", out.to_str().unwrap()]);
    assert_one_error_line(&output, 1, expected);
    assert!(!out.exists(), "{text}: nothing may be written");
}

/// Branch settings wrong for the model (issue 29, "checked too late") fail the job before any
/// branch starts, not once the branches before them are written: a travelling wave of a mode
/// that is not one of a pair, a name too long for its files, a dof listed twice in
/// `output_dofs`, a step control aiming at no iterations.
#[test]
fn branch_settings_wrong_for_the_model_are_refused_before_any_branch_starts() {
    let dir = scratch("too-late");
    let good = job("good", 0, "energy_max = 1.0");
    let long = "x".repeat(245);
    for (bad, expected) in [
        (
            format!(
                "{}pattern = \"travelling\"\n",
                job("t", 1, "energy_max = 1.0")
            ),
            "branch `t`: invalid start: mode 1 has no travelling wave: the model declares no cyclic symmetry",
        ),
        (
            job(&long, 1, "energy_max = 1.0"),
            "branch 2: name `xxxxxxxxxxxxxxxx...` has 245 characters, more than the 241",
        ),
        (
            job("d", 1, "energy_max = 1.0\noutput_dofs = [1, 1]"),
            "branch 2: invalid setting: output_dofs: dof 1 is listed twice",
        ),
        (
            job("i", 1, "energy_max = 1.0\ntarget_iterations = 0"),
            "branch 2: invalid setting: target_iterations must be at least 1",
        ),
    ] {
        refused_before_anything_runs(&dir, &format!("{MODEL}{good}{bad}"), expected);
    }
    // On a cyclic model, a travelling wave of a single (n,0) mode.
    refused_before_anything_runs(
        &dir,
        "[model]\nfamily = \"bladed-disk\"\n[settings]\nenergy_max = 1.0\n[[branch]]\nname = \"good\"\nmode = \"1,5\"\n[[branch]]\nname = \"t\"\nmode = \"1,0\"\npattern = \"travelling\"\n",
        "branch `t`: invalid start: mode (1,0) has no travelling wave: it is not a member of a degenerate pair",
    );
}

/// A tensor file without a term is refused naming the file, not read as "no nonlinearity".
#[test]
fn an_empty_tensor_file_is_refused_naming_it() {
    let dir = scratch("empty-tensor");
    write(&dir, "cubic.txt", "% terms i j k l c\n\n");
    let text = format!(
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n[[model.nonlinear]]\ntype = \"tensor\"\ncubic = {{ file = \"cubic.txt\" }}\n{}",
        job("good", 0, "energy_max = 1.0")
    );
    let expected = format!(
        "{}: no terms: expected one `i j k l c` per line",
        dir.join("cubic.txt").display()
    );
    refused_before_anything_runs(&dir, &text, &expected);
}

/// Branches whose files would be one file (issue 29, "files that collide": `b.events` writes
/// `b.events.csv`, as `b` does) are refused naming both, before anything is written; so are
/// names equal but for case (one file on macOS and Windows) and one that is the run's file.
#[test]
fn branches_whose_files_collide_are_refused_naming_both() {
    let dir = scratch("collide");
    let good = job("b", 0, "energy_max = 1.0");
    for (bad, expected) in [
        (
            job("b.events", 1, "energy_max = 1.0"),
            "job.toml: branches `b` and `b.events` would both write b.events.csv",
        ),
        (
            job("B", 1, "energy_max = 1.0"),
            "job.toml: branches `b` and `B` would both write b.csv (b.csv and B.csv are one file where names ignore case, as on macOS and Windows)",
        ),
        (
            job("MODES", 1, "energy_max = 1.0"),
            "job.toml: branch `MODES` would write MODES.csv over the run's own modes.csv",
        ),
    ] {
        refused_before_anything_runs(&dir, &format!("{MODEL}{good}{bad}"), expected);
    }
}

/// A two-dof general model `K = a K0`, `M = b M0` (`K0 = [[1, -0.5], [-0.5, 1]]`,
/// `M0 = diag(1, 0.5)`) with one branch.
fn scaled_model(a: f64, b: f64) -> String {
    format!(
        "[model]\nmass = [[{b:e}, 0.0], [0.0, {:e}]]\nstiffness = [[{a:e}, {:e}], [{:e}, {a:e}]]\n{}",
        0.5 * b,
        -0.5 * a,
        -0.5 * a,
        job("b", 0, "energy_max = 1.0\nmax_points = 3"),
    )
}

/// `nnm modes`' frequencies (rad/s), and whether any mode is called rigid.
fn listed_modes(output: &Output) -> (Vec<f64>, bool) {
    assert!(output.status.success(), "{}", stderr_of(output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let rows: Vec<&str> = stdout.lines().skip(1).collect();
    let frequencies = rows
        .iter()
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect();
    (frequencies, stdout.contains("rigid"))
}

/// Extreme scales (issue 29): a model's modes do not depend on its units. `K` of order 1e154
/// (or a mass of order 1e-300) used to read both elastic modes as rigid at 0 rad/s (`nnm
/// modes` exit 0, `nnm run` refused with "rigid-body mode"); now the frequencies are
/// `√(a/b)` times the unscaled model's, and `K` and `M` scaled together run the same branch.
/// Entries double precision cannot hold in full — subnormal, or whose square overflows — are
/// refused in one line naming the matrix, the entry and the remedy, before anything is
/// written (job-file rows 0-based as every model error, Matrix Market files 1-based).
#[test]
fn extreme_scales_give_the_model_s_own_modes_or_a_reason() {
    let dir = scratch("scales");
    let modes_of = |a: f64, b: f64| {
        let path = write(&dir, "job.toml", &scaled_model(a, b));
        listed_modes(&nnm(&["modes", &path]))
    };
    let (reference, rigid) = modes_of(1.0, 1.0);
    assert!(!rigid && reference.len() == 2);
    for (a, b) in [(1e154, 1.0), (1e154, 1e154), (1.0, 1e-300), (1e100, 1e-200)] {
        let (frequencies, rigid) = modes_of(a, b);
        assert!(!rigid, "K x {a:e}, M x {b:e}: a mode called rigid");
        for (f, r) in frequencies.iter().zip(&reference) {
            let expected = r * (a / b).sqrt();
            assert!(
                (f / expected - 1.0).abs() < 1e-8,
                "K x {a:e}, M x {b:e}: {f} vs {expected}"
            );
        }
    }
    // The branch: K = 1e154 K0 alone (once refused as a rigid-body mode) runs, and K and M
    // scaled together give the unscaled model's frequencies.
    let frequencies_of_run = |a: f64, b: f64| {
        let path = write(&dir, "job.toml", &scaled_model(a, b));
        let out = dir.join("out");
        let output = nnm(&["run", &path, "--out", out.to_str().unwrap(), "-q"]);
        assert!(output.status.success(), "{}", stderr_of(&output));
        let csv = std::fs::read_to_string(out.join("b.csv")).unwrap();
        let column = csv
            .lines()
            .next()
            .unwrap()
            .split(',')
            .position(|c| c == "frequency_rad_s")
            .unwrap();
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').nth(column).unwrap().parse::<f64>().unwrap())
            .collect::<Vec<f64>>()
    };
    let unscaled = frequencies_of_run(1.0, 1.0);
    let scaled = frequencies_of_run(1e154, 1e154);
    assert_eq!(unscaled.len(), scaled.len());
    for (f, r) in scaled.iter().zip(&unscaled) {
        assert!((f / r - 1.0).abs() < 1e-9, "{f} vs {r}");
    }
    let stiff = frequencies_of_run(1e154, 1.0);
    assert!(
        (stiff[0] / (reference[0] * 1e77) - 1.0).abs() < 1e-4,
        "{stiff:?}"
    );
    // Refused, by `nnm modes` and `nnm run` alike, nothing written.
    for (a, b, expected) in [
        (
            1.0,
            1e-310,
            "mass matrix entry (0, 0) = 1.000e-310 is subnormal (below 2.2e-308) and has lost digits in double precision: rescale the model's units",
        ),
        (
            1e300,
            1.0,
            "stiffness matrix entry (0, 0) = 1.000e300 is beyond 1.3e154, where its square overflows double precision: rescale the model's units",
        ),
        (
            1.7e308,
            1e308,
            "mass matrix entry (0, 0) = 1.000e308 is beyond 1.3e154",
        ),
    ] {
        let path = write(&dir, "job.toml", &scaled_model(a, b));
        assert_one_error_line(&nnm(&["modes", &path]), 1, expected);
        let out = dir.join("refused");
        let output = nnm(&["run", &path, "--out", out.to_str().unwrap()]);
        assert_one_error_line(&output, 1, expected);
        assert!(!out.exists(), "{expected}: nothing may be written");
    }
    write(
        &dir,
        "K.mtx",
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 1.0\n2 1 -0.5\n2 2 3e-320\n",
    );
    let path = write(
        &dir,
        "job.toml",
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = { file = \"K.mtx\" }\n",
    );
    assert_one_error_line(
        &nnm(&["modes", &path]),
        1,
        "K.mtx: stiffness matrix entry (2, 2) = 3.000e-320 is subnormal (below 2.2e-308) and has lost digits in double precision: rescale the model's units",
    );
}
