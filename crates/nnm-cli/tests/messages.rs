//! Messages that said something untrue or unreadable (issue 29, "Messages"): each the exact
//! lines a user sees on stderr.

use std::process::Output;

#[allow(dead_code)] // the helpers other test files use
mod common;
use common::{nnm, scratch, write};

/// The stiff two-DOF model (ω = 1 and √401) of `damped_multipliers_are_said` in cli.rs, one
/// branch of three points by `integrator` with `keys`.
fn stiff_branch(integrator: &str, keys: &str) -> String {
    format!(
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[201.0, -200.0], [-200.0, 201.0]]\n\
         [[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.1\n\
         [[branch]]\nname = \"slow\"\nmode = 0\nfrequency_shift_max = 1e-4\nmax_points = 3\n\
         integrator = \"{integrator}\"\n{keys}\n"
    )
}

fn stderr_lines(output: &Output) -> Vec<String> {
    String::from_utf8_lossy(&output.stderr)
        .lines()
        .map(str::to_string)
        .collect()
}

/// The reciprocity warning says what is true of the integrator the branch ran: radau5's
/// damping by design, but for dop853 (which damps nothing by design) an integration not
/// accurate enough, with the setting that makes it more accurate — not radau5's damping.
#[test]
fn the_reciprocity_warning_names_the_integrator_that_ran() {
    let dir = scratch("reciprocity");
    let prefix = "[slow] warning: Floquet multipliers lack reciprocal partners by up to ";
    for (integrator, keys, cause) in [
        (
            "radau5",
            "",
            ": radau5 damps the modes its step does not resolve (by design), so the stability verdicts see only the resolved modes",
        ),
        (
            "dop853",
            "tolerance = 1e-3\nintegration_factor = 1.0",
            ": dop853 damps no mode by design, so this is the integration's error and the stability verdicts may be wrong; a smaller `integration_factor` (or `tolerance`) makes it more accurate",
        ),
    ] {
        let job = write(
            &dir,
            &format!("{integrator}.toml"),
            &stiff_branch(integrator, keys),
        );
        let out = dir.join(integrator);
        let output = nnm(&["run", &job, "--out", out.to_str().unwrap()]);
        let lines = stderr_lines(&output);
        assert!(output.status.success(), "{lines:#?}");
        let warnings: Vec<&String> = lines.iter().filter(|l| l.contains("warning")).collect();
        assert_eq!(warnings.len(), 1, "{integrator}: {lines:#?}");
        let warning = warnings[0];
        let defect = warning
            .strip_prefix(prefix)
            .and_then(|rest| rest.strip_suffix(cause))
            .unwrap_or_else(|| panic!("{integrator}: `{warning}`"));
        let defect: f64 = defect.parse().unwrap();
        assert!(defect > 1e-3, "{warning}");
    }
}

/// A refused number is printed short, as written (`{}` of 1e300 is 301 digits).
#[test]
fn refused_numbers_are_printed_short() {
    let dir = scratch("numbers");
    let job = write(
        &dir,
        "job.toml",
        "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"a\"\nmode = 0\nenergy_max = -1e300\n",
    );
    let out = dir.join("out");
    let output = nnm(&["run", &job, "--out", out.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1), "{:?}", stderr_lines(&output));
    assert_eq!(
        stderr_lines(&output),
        [format!(
            "error: {job}: branch 1: invalid setting: energy_max must be positive, got -1e300"
        )]
    );
    assert!(!out.exists());
}

/// `nnm modes` prints a frequency far from 1 rad/s in ten significant digits, not nine
/// decimals: with `K` of order 1e152 (ω of order 1e76) those were 86 characters, most of them
/// digits double precision does not hold; with `K` of order 1e-24 they were all zeros.
/// Frequencies of order one keep their nine decimals.
#[test]
fn modes_print_extreme_frequencies_short() {
    let dir = scratch("frequencies");
    let table = |scale: &str| {
        let job = write(
            &dir,
            "job.toml",
            &format!(
                "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\n\
                 stiffness = [[2{scale}, -1{scale}], [-1{scale}, 2{scale}]]\n"
            ),
        );
        let output = nnm(&["modes", &job]);
        assert!(output.status.success(), "{:?}", stderr_lines(&output));
        String::from_utf8_lossy(&output.stdout).into_owned()
    };
    // ω² = 1 and 3, times the scale.
    assert_eq!(
        table(".0"),
        "index   frequency_rad_s   label  pattern\n    \
             0       1.000000000                 \n    \
             1       1.732050808                 \n"
    );
    assert_eq!(
        table("e152"),
        "index   frequency_rad_s   label  pattern\n    \
             0    1.000000000e76                 \n    \
             1    1.732050808e76                 \n"
    );
    assert_eq!(
        table("e-24"),
        "index   frequency_rad_s   label  pattern\n    \
             0   1.000000000e-12                 \n    \
             1   1.732050808e-12                 \n"
    );
}

/// A refused branch name is told the characters at fault and the rule, not the characters it
/// may use as if they were the fault.
#[test]
fn a_refused_branch_name_names_the_characters_at_fault() {
    let dir = scratch("names");
    for (name, why) in [
        (
            "mode 1.5",
            "name `mode 1.5` holds ' ', which a branch name cannot: it names the branch's files, so it may use only ASCII letters, digits, '-', '_' and '.'",
        ),
        (
            ".x",
            "name `.x` starts with '.', which would hide the branch's files: start it with a letter, a digit, '-' or '_'",
        ),
    ] {
        let job = write(
            &dir,
            "job.toml",
            &format!(
                "[model]\nfamily = \"two-dof\"\n[[branch]]\nname = \"{name}\"\nmode = 0\nenergy_max = 1.0\n"
            ),
        );
        let output = nnm(&["run", &job, "--out", dir.join("out").to_str().unwrap()]);
        assert_eq!(output.status.code(), Some(1));
        assert_eq!(
            stderr_lines(&output),
            [format!("error: {job}: branch 1: {why}")]
        );
    }
}

/// A run whose only branch fails at its first point says its error on stderr, and nothing
/// before it: no blank line (the separator from progress lines there were none of).
#[test]
fn a_failed_branch_leaves_no_leading_blank_line() {
    let dir = scratch("failed");
    let job = write(
        &dir,
        "job.toml",
        "[model]\nmass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n\
         [[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.5\n\
         [[branch]]\nname = \"b\"\nmode = 0\nenergy_max = 1e6\nenergy_start = 1e5\nmax_iterations = 1\n",
    );
    let output = nnm(&["run", &job, "--out", dir.join("out").to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    let lines = stderr_lines(&output);
    assert_eq!(lines.len(), 1, "{lines:#?}");
    assert!(
        lines[0].starts_with("error: 1 of 1 branches failed (b: the first point did not converge"),
        "{lines:#?}"
    );
    // With a progress line before it, the blank line still separates them.
    let job = write(
        &dir,
        "two.toml",
        &format!(
            "{}[[branch]]\nname = \"fine\"\nmode = 1\nenergy_max = 0.1\n",
            std::fs::read_to_string(&job).unwrap()
        ),
    );
    let output = nnm(&["run", &job, "--out", dir.join("two").to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    let lines = stderr_lines(&output);
    assert!(!lines[0].is_empty(), "{lines:#?}");
    assert_eq!(lines[lines.len() - 2], "", "{lines:#?}");
    assert!(lines[lines.len() - 1].starts_with("error: 1 of 2 branches failed (b: "));
}
