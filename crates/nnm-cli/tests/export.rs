//! `nnm export` (issues 27 and 28): a built-in model written as finite-element files, read
//! back by the job reader and run, against the built-in model itself; and jobs that cannot
//! be exported refused with one line, nothing written.

#[allow(dead_code)] // the helpers other test files use
mod common;
use std::path::Path;

use common::{nnm, scratch, write};

/// `examples/forced-von-karman-beam.toml`: the 20-element von Kármán beam (57 dofs) with
/// Rayleigh damping, driven at its middle across its first resonance, whose peak folds twice.
const FORCED_VON_KARMAN: &str = include_str!("../../../examples/forced-von-karman-beam.toml");

/// The CSV file's rows as records (the header by name).
fn records(path: &Path) -> Vec<csv::StringRecord> {
    let mut reader =
        csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    reader.records().map(Result::unwrap).collect()
}

fn column(path: &Path, name: &str) -> usize {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header = reader.headers().unwrap().clone();
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("{}: no column {name}", path.display()))
}

/// `(frequency, label, pattern)` of every row of a `modes.csv`.
fn modes(path: &Path) -> Vec<(f64, String, String)> {
    let (f, l, p) = (
        column(path, "frequency_rad_s"),
        column(path, "label"),
        column(path, "pattern"),
    );
    records(path)
        .iter()
        .map(|r| (r[f].parse().unwrap(), r[l].to_string(), r[p].to_string()))
        .collect()
}

/// The two `modes.csv` give the same modes: frequencies to 1e-12, the same labels.
fn assert_same_modes(original: &Path, exported: &Path) {
    let (a, b) = (modes(original), modes(exported));
    assert!(!a.is_empty());
    assert_eq!(a.len(), b.len());
    for ((fa, la, pa), (fb, lb, pb)) in a.iter().zip(&b) {
        assert!((fa - fb).abs() <= 1e-12 * fa.abs(), "{fa} vs {fb}");
        assert_eq!((la, pa), (lb, pb));
    }
}

fn succeeds(args: &[&str]) -> String {
    let output = nnm(args);
    assert!(
        output.status.success(),
        "nnm {args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// The forced von Kármán beam exported and run from its files gives the built-in model's
/// linear modes (to 1e-12) and its curve's two folds (to 1e-9): the files' M and K, and the
/// force as summed tensor terms read by the `tensor` element, are the model's own. The
/// exported job is a general model (no `family`) that reads its files, and the response
/// table came with it.
#[test]
fn exported_von_karman_beam_runs_as_the_built_in_one() {
    let dir = scratch("export-von-karman");
    let job = write(&dir, "forced-von-karman-beam.toml", FORCED_VON_KARMAN);
    let files = dir.join("files");
    let stdout = succeeds(&["export", &job, "--out", files.to_str().unwrap()]);
    let exported = files.join("forced-von-karman-beam.toml");
    assert!(stdout.contains(exported.to_str().unwrap()), "{stdout}");
    for file in ["M.mtx", "K.mtx", "f2.txt", "f3.txt"] {
        assert!(files.join(file).exists(), "{file} missing");
    }
    let text = std::fs::read_to_string(&exported).unwrap();
    assert!(!text.contains("family"), "{text}");
    for line in [
        "mass = { file = \"M.mtx\" }",
        "quadratic = { file = \"f2.txt\" }",
        "cubic = { file = \"f3.txt\" }",
        "[[response]]",
    ] {
        assert!(text.contains(line), "{line} missing: {text}");
    }

    let (original, imported) = (dir.join("original"), dir.join("imported"));
    succeeds(&["run", &job, "--out", original.to_str().unwrap(), "-q"]);
    succeeds(&[
        "run",
        exported.to_str().unwrap(),
        "--out",
        imported.to_str().unwrap(),
        "-q",
    ]);
    assert_same_modes(&original.join("modes.csv"), &imported.join("modes.csv"));

    let folds = |out: &Path| -> Vec<f64> {
        let path = out.join("middle.events.csv");
        let (kind, frequency) = (column(&path, "type"), column(&path, "frequency_rad_s"));
        records(&path)
            .iter()
            .filter(|r| &r[kind] == "fold")
            .map(|r| r[frequency].parse().unwrap())
            .collect()
    };
    let (a, b) = (folds(&original), folds(&imported));
    assert_eq!(a.len(), 2, "the built-in beam's curve folds twice: {a:?}");
    assert_eq!(a.len(), b.len(), "{a:?} vs {b:?}");
    for (fa, fb) in a.iter().zip(&b) {
        assert!((fa - fb).abs() <= 1e-9 * fa, "fold at {fa} vs {fb}");
    }
}

/// The 30-sector bladed disk (cubic springs between disk and blade, a cyclic symmetry)
/// exported: the same modes, frequencies to 1e-12 and `(n, d)` labels alike (the exported
/// job declares the symmetry), and its branches copied.
#[test]
fn exported_bladed_disk_keeps_its_modes_and_labels() {
    let dir = scratch("export-bladed-disk");
    let job = write(
        &dir,
        "bladed-disk.toml",
        include_str!("../../../examples/bladed-disk.toml"),
    );
    let files = dir.join("files");
    succeeds(&["export", &job, "--out", files.to_str().unwrap()]);
    assert!(
        !files.join("f2.txt").exists(),
        "a cubic force has no quadratic terms"
    );
    let exported = files.join("bladed-disk.toml");
    let text = std::fs::read_to_string(&exported).unwrap();
    assert!(
        text.contains("cyclic = { sectors = 30, dofs_per_sector = 2 }"),
        "{text}"
    );
    assert!(text.contains("name = \"mode-1-5\""), "{text}");
    let (original, imported) = (dir.join("original"), dir.join("imported"));
    succeeds(&["modes", &job, "--out", original.to_str().unwrap()]);
    succeeds(&[
        "modes",
        exported.to_str().unwrap(),
        "--out",
        imported.to_str().unwrap(),
    ]);
    assert_same_modes(&original.join("modes.csv"), &imported.join("modes.csv"));
}

/// One line on stderr, exit code 1, and nothing written: a model with a quintic spring (not
/// quadratic and cubic terms), a job file that does not exist, and a folder that already
/// holds one of the files (left as it was).
#[test]
fn jobs_that_cannot_be_exported_write_nothing() {
    let dir = scratch("export-refused");
    let quintic = write(
        &dir,
        "quintic.toml",
        "[model]\nmass = [[1.0]]\nstiffness = [[1.0]]\n\n[[model.nonlinear]]\ntype = \"polynomial\"\ndofs = [0]\ncoefficient = 1.0\nexponent = 5\n",
    );
    let missing = dir.join("missing.toml");
    let cases = [
        (
            quintic.as_str(),
            "nonlinear element 1 is not a sum of quadratic and cubic terms",
        ),
        (missing.to_str().unwrap(), "cannot read"),
    ];
    for (job, expected) in cases {
        let out = dir.join("out");
        let output = nnm(&["export", job, "--out", out.to_str().unwrap()]);
        assert_eq!(output.status.code(), Some(1));
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.starts_with("error: ") && stderr.contains(expected),
            "{stderr}"
        );
        assert!(!out.exists(), "{job}: the output folder was created");
    }

    let duffing = write(
        &dir,
        "duffing.toml",
        include_str!("../../../examples/duffing.toml"),
    );
    let out = dir.join("taken");
    std::fs::create_dir_all(&out).unwrap();
    let mine = write(&out, "K.mtx", "not the model's");
    let output = nnm(&["export", &duffing, "--out", out.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("K.mtx already exists"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&mine).unwrap(), "not the model's");
    let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
    assert_eq!(left.len(), 1, "only the file that was there");
}
