//! `nnm run` on forced responses (`[[response]]`, issue 27): the example end to end against an
//! independent harmonic-balance reference, and bad input refused before anything is written.

#[allow(dead_code)] // the helpers other test files use
mod common;
use common::{nnm, scratch, write};

/// `examples/forced-duffing.toml` (x'' + 0.02 x' + x + x³ = a cos Ωt): the curve at a = 0.1
/// folds where an independent harmonic-balance computation (many harmonics, its own Newton and
/// arclength continuation, in crates/nnm's tests) puts the folds — Ω = 2.2115438 and
/// 1.1701620 — and the middle branch between them, on the way back down in Ω, is unstable;
/// each curve's phase resonance lies on the example's backbone.
#[test]
fn forced_duffing_folds_where_harmonic_balance_puts_them() {
    let dir = scratch("forced-duffing");
    let job = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/forced-duffing.toml"
    );
    let out = dir.join("out");
    let started = std::time::Instant::now();
    let output = nnm(&["run", job, "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(started.elapsed().as_secs_f64() < 10.0);
    for file in [
        "frc.csv",
        "frc.events.csv",
        "frc.json",
        "frc.png",
        "frc.svg",
    ] {
        assert!(out.join(file).exists(), "{file} missing");
    }
    let events = std::fs::read_to_string(out.join("frc.events.csv")).unwrap();
    let mut lines = events.lines();
    assert_eq!(
        lines.next().unwrap(),
        "curve,type,frequency_rad_s,force_amplitude,peak_x0,critical_multiplier_re,critical_multiplier_im,critical_multiplier_modulus,backbone_peak"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let folds: Vec<f64> = rows
        .iter()
        .filter(|f| f[0] == "1" && f[1] == "fold")
        .map(|f| f[2].parse().unwrap())
        .collect();
    // Each curve is in phase resonance once, just below its upper fold, on the example's
    // backbone: its peak equals the backbone's at that frequency (interpolated between the
    // branch's 29 points, to ~2e-5 here; docs/method.md §21).
    for curve in ["0", "1"] {
        let resonance: Vec<&Vec<&str>> = rows
            .iter()
            .filter(|f| f[0] == curve && f[1] == "phase-resonance")
            .collect();
        assert_eq!(resonance.len(), 1, "{events}");
        let (peak, on): (f64, f64) = (
            resonance[0][4].parse().unwrap(),
            resonance[0][8].parse().unwrap(),
        );
        assert!((peak / on - 1.0).abs() < 1e-4, "{peak} vs {on}");
    }
    for file in ["backbone.resonance.png", "backbone.resonance.svg"] {
        assert!(out.join(file).exists(), "{file} missing");
    }
    assert_eq!(folds.len(), 2, "{events}");
    let (upper, lower) = (2.2115438, 1.1701620);
    assert!((folds[0] - upper).abs() < 1e-6, "{folds:?}");
    assert!((folds[1] - lower).abs() < 1e-6, "{folds:?}");

    // Rows of curve 1 in order: after the upper fold and before the lower one the curve runs
    // back in Ω on the middle branch, where every point is unstable.
    let csv = std::fs::read_to_string(out.join("frc.csv")).unwrap();
    let mut rows = csv.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (curve, omega, stable) = (col("curve"), col("frequency_rad_s"), col("stable"));
    let points: Vec<(f64, bool)> = rows
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[curve] == "1")
        .map(|f| (f[omega].parse().unwrap(), f[stable] == "true"))
        .collect();
    // Where it turns back down in Ω: the upper fold, between two points (the fold itself is
    // located above; the points only have to come near it).
    let top = (0..points.len() - 1)
        .find(|&k| points[k + 1].0 < points[k].0)
        .expect("the curve turns back at the upper fold");
    assert!(points[top].0 > upper - 2e-2, "{points:?}");
    // Where it turns back up in Ω: the lower fold, between two points.
    let bottom = top
        + (0..points.len() - top)
            .min_by(|&a, &b| points[top + a].0.total_cmp(&points[top + b].0))
            .expect("points after the upper fold");
    assert!(
        points[bottom].0 < lower + 1e-2,
        "the curve comes back to the lower fold: {points:?}"
    );
    let middle: Vec<&(f64, bool)> = points[top..bottom]
        .iter()
        .filter(|p| p.0 < upper - 1e-2 && p.0 > lower + 1e-2)
        .collect();
    assert!(middle.len() > 5, "{points:?}");
    assert!(middle.iter().all(|p| !p.1), "{middle:?}");
    assert!(points[..top].iter().filter(|p| p.0 < lower).all(|p| p.1));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("frc.json")).unwrap()).unwrap();
    assert_eq!(json["status"], "finished");
    assert_eq!(json["curves"].as_array().unwrap().len(), 2);
    assert_eq!(json["points"][0]["z0"].as_array().unwrap().len(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A bad `[[response]]` is one `error:` line and exit code 1, with nothing written.
#[test]
fn a_bad_response_is_one_line_and_writes_nothing() {
    let dir = scratch("bad-response");
    let job = write(
        &dir,
        "job.toml",
        "[model]\nfamily = \"duffing\"\ndamping = { rayleigh = [0.02, 0.0] }\n[[response]]\nname = \"frc\"\nforce = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 3.5\nfrequency_end = 0.5\n",
    );
    let out = dir.join("out");
    assert_refused(
        &job,
        &out,
        &format!(
            "error: {job}: response `frc`: frequency_end must exceed frequency_start (3.5), got 0.5"
        ),
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `nnm run job --out out` ends with exit 1 and the one line `message` on stderr, `out` not
/// created.
fn assert_refused(job: &str, out: &std::path::Path, message: &str) {
    let output = nnm(&["run", job, "--out", out.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    assert_eq!(String::from_utf8_lossy(&output.stderr).trim_end(), message);
    assert!(!out.exists());
}

/// A sweep reaching far below the model's resonances (a forcing period of 10¹⁷ of its
/// longest) is refused before the job's branch is computed and written: one line, exit 1,
/// nothing written; at the lowest frequency allowed the curve runs.
#[test]
fn a_sweep_below_the_resolvable_frequencies_is_refused_before_any_branch() {
    let dir = scratch("low-frequency");
    let text = |start: &str| {
        format!(
            "[model]\nfamily = \"duffing\"\ndamping = {{ rayleigh = [0.02, 0.0] }}\n[[branch]]\nname = \"b\"\nmode = 0\nmax_points = 2\n[[response]]\nname = \"frc\"\nforce = {{ dofs = [0], amplitude = 0.1 }}\nfrequency_start = {start}\nfrequency_end = 1.3\nmax_points = 2\n"
        )
    };
    let job = write(&dir, "job.toml", &text("1e-17"));
    let out = dir.join("out");
    assert_refused(
        &job,
        &out,
        "error: response `frc`: frequency_start 1e-17 rad/s is below 0.001 of the model's lowest natural frequency (1 rad/s): a forcing period the integrators cannot resolve",
    );
    let job = write(&dir, "job.toml", &text("1e-3"));
    let output = nnm(&["run", &job, "--out", out.to_str().unwrap()]);
    assert_eq!(
        output.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ctrl-C during a response stops its curve at the next point and skips the others: every
/// point computed is in the CSV and in the JSON (a valid document), the summary says so and
/// the exit code is 130.
#[cfg(unix)]
#[test]
fn an_interrupted_response_keeps_every_point() {
    let dir = scratch("interrupt-response");
    let job = write(
        &dir,
        "job.toml",
        "[model]\nfamily = \"duffing\"\ndamping = { rayleigh = [0.02, 0.0] }\n[[response]]\nname = \"slow\"\nforce = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 0.5\nfrequency_end = 3.5\namplitudes = [0.05, 0.1]\nmax_step = 0.0002\ninitial_step = 0.0002\n",
    );
    let out = dir.join("out");
    let child = common::spawn(&["run", &job, "--out", out.to_str().unwrap(), "--quiet"]);
    let csv = out.join("slow.csv");
    common::wait_for_rows(&csv, 20);
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(130));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("not started (interrupted)"), "{stdout}");
    let rows = common::csv_rows(&csv);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("slow.json")).unwrap()).unwrap();
    assert_eq!(json["points"].as_array().unwrap().len(), rows);
    assert_eq!(json["curves"][0]["stop_reason"], "interrupted");
    assert!(rows >= 20 && rows < 10_000, "{rows}");
    let _ = std::fs::remove_dir_all(&dir);
}
