//! Property tests of the command line on bad input (issue 29): small jobs generated from the
//! job file's grammar — valid, with a setting, a name, a mode, the damping or a forced
//! response's key changed to an edge value (zero, negative, NaN, infinite, huge, out of range,
//! a wrong type) — run by `nnm run` and `nnm modes`. Each ends in exit 0 (3 when a branch could
//! not go on), or in exit 1 with one `error:` line on stderr and nothing written (unless a branch
//! or curve failed once computing began: the others' files stay). The crate's
//! job-file properties (crates/nnm-io/tests/properties.rs) try many more inputs on the reader
//! alone; these few cases check that the run as a whole keeps the promise.

use std::path::Path;
use std::process::Output;

#[allow(dead_code)] // the helpers other test files use
mod common;
use common::{nnm, scratch, write};
use proptest::prelude::*;
use proptest::sample::select;

/// The two-DOF model, damped (so that responses are well posed), as a general model so that
/// `fixed_dofs` and file-free edits apply.
const MODEL: &str = "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\ndamping = { rayleigh = [0.02, 0.0] }\n[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.5\n";

/// A value for `key`: mostly of its type, valid or at an edge (zero, negative, NaN,
/// infinite, huge, out of range), now and then of another type.
fn value(key: &'static str) -> impl Strategy<Value = String> {
    let typed: &'static [&'static str] = match key {
        "max_points" | "max_iterations" | "target_iterations" | "samples" => {
            &["1", "2", "3", "8", "0", "-1", "9223372036854775807"]
        }
        "at_energies" | "at_frequencies" | "amplitudes" => {
            &["[]", "[0.5]", "[0.5, 0.8]", "[nan]", "[-1.0]", "[1e308]"]
        }
        "output_dofs" => &["[]", "[0]", "[1]", "[0, 1]", "[1, 1]", "[99]"],
        "half_period" => &["true", "false"],
        "phase" => &["\"zero-velocity\"", "\"flow-orthogonal\""],
        "formulation" => &["\"auto\"", "\"dense\"", "\"matrix-free\""],
        "integrator" => &[
            "\"auto\"",
            "\"dop853\"",
            "\"dopri5\"",
            "\"gauss6\"",
            "\"radau5\"",
        ],
        "parameter" => &["\"frequency\"", "\"amplitude\""],
        "pattern" => &["\"cos\"", "\"sin\"", "\"travelling\""],
        "mode" => &["0", "1", "2", "-1", "\"0,1\""],
        _ => &[
            "0.5", "1.0", "2.0", "1e-8", "0.0", "-1.0", "1e-300", "1e308", "nan", "inf",
        ],
    };
    prop_oneof![
        6 => select(typed).prop_map(str::to_string),
        1 => select(vec!["true", "\"\"", "\"x\"", "[]", "{}", "1", "0.5"]).prop_map(str::to_string),
    ]
}

/// Keys a branch takes (its settings and its own), with a mode's and a name's values.
fn branch_change() -> impl Strategy<Value = String> {
    let keys = select(vec![
        "energy_max",
        "frequency_shift_max",
        "max_points",
        "at_energies",
        "at_frequencies",
        "tolerance",
        "initial_step",
        "min_step",
        "max_step",
        "max_iterations",
        "target_iterations",
        "max_turn_angle",
        "energy_start",
        "phase",
        "half_period",
        "formulation",
        "integrator",
        "integration_factor",
        "stability_tolerance",
        "invariant_step",
        "output_dofs",
        "pattern",
        "mode",
    ]);
    prop_oneof![
        6 => keys.prop_flat_map(|k| value(k).prop_map(move |v| format!("{k} = {v}"))),
        1 => select(vec![
            "name = \"\"", "name = \"a/b\"", "name = \"b.events\"", "name = \"a\"", "name = 3",
            "mode = 5", "mode = \"1,2\"", "bogus = 1",
        ]).prop_map(str::to_string),
        1 => (200usize..300).prop_map(|n| format!("name = \"{}\"", "a".repeat(n))),
    ]
}

/// Keys a forced response takes.
fn response_change() -> impl Strategy<Value = String> {
    let keys = select(vec![
        "frequency_start",
        "frequency_end",
        "amplitudes",
        "parameter",
        "frequency",
        "amplitude_max",
        "output_dofs",
        "tolerance",
        "max_points",
        "samples",
        "target_iterations",
        "integrator",
        "half_period",
    ]);
    prop_oneof![
        4 => keys.prop_flat_map(|k| value(k).prop_map(move |v| format!("{k} = {v}"))),
        1 => select(vec![
            "force = { dofs = [5], amplitude = 0.1 }",
            "force = { dofs = [0], amplitude = 0.0 }",
            "force = { vector = [nan, 0.0] }",
            "force = { engine_order = 1, amplitude = 0.1, sector_dof = 0 }",
            "name = \"a\"",
        ]).prop_map(str::to_string),
    ]
}

/// A job: the model (its damping perhaps changed), a branch `a` and perhaps a response `r`,
/// each with up to two keys changed.
fn job() -> impl Strategy<Value = String> {
    let damping = select(vec![
        "",
        "",
        "",
        "",
        "",
        "",
        "",
        "",
        "",
        "damping = { rayleigh = [-1.0, 0.0] }",
        "damping = { modal = [nan] }",
        "damping = { matrix = [[0.1, 1.0], [0.0, 0.1]] }",
        "damping = { modal = [0.1, 0.1, 0.1] }",
    ]);
    (
        damping,
        proptest::collection::vec(branch_change(), 0..=2),
        proptest::option::of(proptest::collection::vec(response_change(), 0..=2)),
    )
        .prop_map(|(damping, branch, response)| {
            let mut text = MODEL.to_string();
            if !damping.is_empty() {
                text = text.replace("damping = { rayleigh = [0.02, 0.0] }", damping);
            }
            text += &section(
                "branch",
                "name = \"a\"\nmode = 0\nmax_points = 3\nenergy_max = 1.0\n",
                &branch,
            );
            if let Some(response) = response {
                text += &section(
                    "response",
                    "name = \"r\"\nforce = { dofs = [0], amplitude = 0.1 }\nfrequency_start = 1.2\nfrequency_end = 1.3\nmax_points = 3\n",
                    &response,
                );
            }
            text
        })
}

/// `[[kind]]` with the lines of `base`, each replaced by the change of the same key.
fn section(kind: &str, base: &str, changes: &[String]) -> String {
    let key = |line: &str| line.split(" = ").next().unwrap_or("").to_string();
    let mut lines: Vec<String> = base.lines().map(str::to_string).collect();
    for change in changes {
        match lines.iter_mut().find(|l| key(l) == key(change)) {
            Some(l) => *l = change.clone(),
            None => lines.push(change.clone()),
        }
    }
    format!("[[{kind}]]\n{}\n", lines.join("\n"))
}

/// Exit 0 (or 3: a branch that could not go on, its files written), or exit 1 with one
/// `error:` line and no file in `out` — but those of the branches and curves that ran, when
/// one failed once computing began.
fn assert_clean(output: &Output, out: &Path, job: &str) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    let code = output.status.code();
    assert!(
        matches!(code, Some(0 | 1 | 3)),
        "exit {code:?}, stderr {stderr}\nfor\n{job}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}\nfor\n{job}");
    if code == Some(1) {
        assert_eq!(
            stderr.lines().count(),
            1,
            "not one line: {stderr}\nfor\n{job}"
        );
        assert!(stderr.starts_with("error: "), "{stderr}\nfor\n{job}");
        for noise in ["Some(", "None", "Ok(", "Err("] {
            assert!(!stderr.contains(noise), "{stderr}\nfor\n{job}");
        }
        // A branch or curve that failed once computing began (README: exit 1, "a branch
        // that failed") leaves what the others wrote — valid input at an edge the numerics
        // cannot follow, such as a force amplitude of 1e308. Bad input writes nothing.
        let computed = ["branches failed (", "response curves failed ("]
            .iter()
            .any(|m| stderr.contains(m));
        let written: Vec<_> = std::fs::read_dir(out)
            .map(|d| d.map(|e| e.unwrap().file_name()).collect())
            .unwrap_or_default();
        assert!(
            computed || written.is_empty(),
            "{written:?} written before `{stderr}`\nfor\n{job}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, failure_persistence: None, ..ProptestConfig::default() })]

    /// `nnm run` on a generated job: a run, or one line and nothing written.
    #[test]
    fn run_ends_cleanly_or_refuses_in_one_line(text in job()) {
        let dir = scratch("props-run");
        let path = write(&dir, "job.toml", &text);
        let out = dir.join("out");
        let output = nnm(&["run", &path, "--out", out.to_str().unwrap(), "--quiet", "--threads", "1"]);
        assert_clean(&output, &out, &text);
    }

    /// `nnm modes --out` on the same jobs: the modes, or one line and nothing written.
    #[test]
    fn modes_end_cleanly_or_refuse_in_one_line(text in job()) {
        let dir = scratch("props-modes");
        let path = write(&dir, "job.toml", &text);
        let out = dir.join("out");
        let output = nnm(&["modes", &path, "--out", out.to_str().unwrap()]);
        assert_clean(&output, &out, &text);
    }
}
