//! Property tests of bad input (issue 29): job files, Matrix Market files and tensor term files
//! generated from their grammar — valid ones with values mutated (wrong types, NaN and
//! infinities, negatives, zeros, huge numbers, dofs out of range, unknown keys, empty and
//! overlong names, truncated files) — must be read or refused with a one-line message, never
//! a panic. A bounded number of cases per property keeps them in the regular test run.

use std::path::{Path, PathBuf};

use nnm::Settings;
use nnm_io::job::{RESPONSE_KEYS, RESPONSE_SETTINGS_KEYS, parse_job};
use nnm_io::matrix_market::parse_matrix_market;
use nnm_io::tensor_file::parse_terms;
use proptest::prelude::*;
use proptest::sample::select;

/// An error message as the user sees it: one line, something in it, no Rust internals.
fn assert_one_line(message: &str, input: &str) {
    assert!(!message.trim().is_empty(), "empty message for {input:?}");
    assert!(
        !message.contains('\n') && !message.contains('\r'),
        "not one line: {message:?} for {input:?}"
    );
    for noise in ["Some(", "None", "panicked", "Ok(", "Err(", "unwrap"] {
        assert!(
            !message.contains(noise),
            "`{noise}` in {message:?} for {input:?}"
        );
    }
}

/// A folder of this process for one property (the files a job names are written there).
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nnm-io-props-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

// --- Values ---------------------------------------------------------------------------------

/// A TOML value that is wrong somewhere: every type, the numbers that break arithmetic, dofs
/// far out of range, names empty or too long.
fn bad_value() -> impl Strategy<Value = String> {
    let literals = select(vec![
        "0",
        "-1",
        "1",
        "2",
        "3",
        "7",
        "1000",
        "9223372036854775807",
        "-9223372036854775808",
        "0.0",
        "-0.0",
        "-1.0",
        "0.5",
        "1.0",
        "1e-300",
        "5e-324",
        "1e308",
        "1.7976931348623157e308",
        "-1e308",
        "nan",
        "inf",
        "-inf",
        "1e-17",
        "1e-2",
        "true",
        "false",
        "\"\"",
        "\"nan\"",
        "\"inf\"",
        "\"1,5\"",
        "\"0,1\"",
        "\"1\"",
        "\"x\"",
        "\"cos\"",
        "\"travelling\"",
        "\"sin\"",
        "\"auto\"",
        "\"radau5\"",
        "\"dop853\"",
        "\"gauss6\"",
        "\"dense\"",
        "\"matrix-free\"",
        "\"frequency\"",
        "\"amplitude\"",
        "\"flow-orthogonal\"",
        "\"finite-difference\"",
        "[]",
        "[0]",
        "[1]",
        "[0, 0]",
        "[0, 1]",
        "[-1]",
        "[nan]",
        "[inf]",
        "[1e308, 1e308]",
        "[0.5, 2.0]",
        "[1.0, -2.0]",
        "[[1.0]]",
        "[[]]",
        "[[1.0, 0.0], [0.0, 1.0]]",
        "[[nan, 0.0], [0.0, 1.0]]",
        "[\"a\"]",
        "{}",
        "{ file = \"missing.mtx\" }",
        "{ file = \"\" }",
        "{ file = \"m.mtx\" }",
        "{ branch = \"a\", event = 0 }",
        "{ branch = \"nope\", event = 99 }",
        "1979-05-27T07:32:00Z",
    ])
    .prop_map(str::to_string);
    prop_oneof![
        4 => literals,
        1 => any::<i64>().prop_map(|v| v.to_string()),
        1 => any::<f64>().prop_map(|v| toml_float(v)),
        1 => (0usize..400).prop_map(|n| format!("\"{}\"", "a".repeat(n))),
    ]
}

/// `v` as a TOML float literal (TOML spells the non-finite ones `nan`, `inf`, `-inf`).
fn toml_float(v: f64) -> String {
    if v.is_nan() {
        "nan".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        format!("{v:?}")
    }
}

/// A value of the type `key` takes, valid or at an edge (zero, negative, NaN, infinite,
/// huge, out of range), now and then one of any type ([`bad_value`]).
fn value_for(key: &str) -> BoxedStrategy<String> {
    const FLOATS: &[&str] = &[
        "1.0", "0.5", "2.0", "10.0", "0.1", "1e-8", "0.0", "-1.0", "nan", "inf", "-inf", "1e308",
        "1e-300",
    ];
    let plausible: &'static [&'static str] = match key {
        "max_points" | "max_iterations" | "target_iterations" | "samples" | "sectors"
        | "elements" | "exponent" => &["1", "2", "3", "8", "0", "-1", "100", "9223372036854775807"],
        "at_energies" | "at_frequencies" | "amplitudes" | "blade_stiffness_mistuning" => &[
            "[]",
            "[0.5]",
            "[0.5, 2.0]",
            "[nan]",
            "[-1.0]",
            "[0.0]",
            "[1e308]",
        ],
        "output_dofs" | "fixed_dofs" => &["[]", "[0]", "[1]", "[0, 1]", "[1, 1]", "[99]"],
        "symmetry" | "half_period" | "events" => &["true", "false"],
        "phase" => &["\"zero-velocity\"", "\"flow-orthogonal\"", "\"none\""],
        "jacobian" => &["\"sensitivity\"", "\"finite-difference\""],
        "formulation" => &["\"auto\"", "\"dense\"", "\"matrix-free\""],
        "integrator" => &[
            "\"auto\"",
            "\"dop853\"",
            "\"dopri5\"",
            "\"gauss6\"",
            "\"gauss4\"",
            "\"radau5\"",
            "\"euler\"",
        ],
        "parameter" => &["\"frequency\"", "\"amplitude\"", "\"energy\""],
        "pattern" => &[
            "\"cos\"",
            "\"sin\"",
            "\"travelling\"",
            "\"travelling-backward\"",
            "\"x\"",
        ],
        "mode" => &[
            "0", "1", "3", "-1", "99", "\"0,1\"", "\"1,2\"", "\"9,9\"", "\"x\"", "\"\"",
        ],
        "name" => &[
            "\"a\"",
            "\"b\"",
            "\"b.events\"",
            "\"B\"",
            "\"\"",
            "\".x\"",
            "\"a/b\"",
            "\"fep\"",
            "\"summary\"",
        ],
        "start" => &[
            "{ branch = \"a\", event = 0 }",
            "{ branch = \"b\", event = 3, direction = 1 }",
            "{ branch = \"nope\", event = 0 }",
            "{ branch = \"a\" }",
        ],
        "cyclic" => &[
            "{ sectors = 2, dofs_per_sector = 1 }",
            "{ sectors = 0, dofs_per_sector = 1 }",
            "{ sectors = 3, dofs_per_sector = 1 }",
        ],
        _ => FLOATS,
    };
    let values = prop_oneof![
        6 => select(plausible).prop_map(str::to_string),
        1 => bad_value(),
    ];
    if key == "name" {
        // Names up to and beyond the limit of 244 characters.
        let long = (200usize..300).prop_map(|n| format!("\"{}\"", "a".repeat(n)));
        prop_oneof![3 => values, 1 => long].boxed()
    } else {
        values.boxed()
    }
}

/// Up to `n` lines `key = value` of a section: keys of `known` (now and then an unknown key),
/// each once.
fn mutations(known: &'static [&'static str], n: usize) -> impl Strategy<Value = String> {
    let line = prop_oneof![
        12 => select(known).prop_flat_map(|k| value_for(k).prop_map(move |v| (k.to_string(), v))),
        1 => (
            select(vec!["energy", "tolerence", "Name", "\"\"", "\"a b\"", "mode_", "dof"]),
            bad_value()
        ).prop_map(|(k, v)| (k.to_string(), v)),
    ];
    proptest::collection::vec(line, 0..=n).prop_map(|pairs| {
        // TOML refuses a key given twice: that syntax error is tried once is enough elsewhere.
        let mut seen = std::collections::HashSet::new();
        pairs
            .into_iter()
            .filter(|(k, _)| seen.insert(k.clone()))
            .map(|(k, v)| format!("{k} = {v}\n"))
            .collect::<String>()
    })
}

// --- Job files ------------------------------------------------------------------------------

/// Lines of `base` with those of `changes` replacing the lines of the same key (and added
/// when the base has no such key): a valid section with some values mutated.
fn merge(base: &str, changes: &str) -> String {
    let key = |line: &str| line.split(" = ").next().unwrap_or("").to_string();
    let mut lines: Vec<String> = base.lines().map(str::to_string).collect();
    for change in changes.lines() {
        match lines.iter_mut().find(|l| key(l) == key(change)) {
            Some(l) => *l = change.to_string(),
            None => lines.push(change.to_string()),
        }
    }
    lines.join("\n") + "\n"
}

/// A model section: a small built-in family or a general model (rows or files), valid, with
/// at most one key's value mutated (or a key added), and `[[model.nonlinear]]` elements for a
/// general model (after every other section, as TOML allows).
fn model_section() -> impl Strategy<Value = (String, String)> {
    let base = select(vec![
        ("family = \"two-dof\"\n", &["cubic", "damping"][..]),
        (
            "family = \"duffing\"\n",
            &["natural_frequency", "cubic", "damping"][..],
        ),
        (
            "family = \"bladed-disk\"\nsectors = 4\n",
            &[
                "sectors",
                "disk_mass",
                "blade_mass",
                "disk_coupling",
                "blade_stiffness",
                "cubic",
                "blade_stiffness_mistuning",
                "damping",
            ][..],
        ),
        (
            "family = \"cantilever-beam\"\nelements = 3\n",
            &[
                "elements",
                "length",
                "width",
                "height",
                "youngs_modulus",
                "density",
                "cubic",
            ][..],
        ),
        (
            "family = \"von-karman-beam\"\nelements = 3\n",
            &[
                "elements",
                "length",
                "width",
                "thickness",
                "youngs_modulus",
                "density",
            ][..],
        ),
        (
            "mass = [[1.0, 0.0], [0.0, 1.0]]\nstiffness = [[2.0, -1.0], [-1.0, 2.0]]\n",
            &["fixed_dofs", "cyclic", "mass", "stiffness", "family"][..],
        ),
        (
            "mass = { file = \"m.mtx\" }\nstiffness = { file = \"k.mtx\" }\n",
            &["fixed_dofs", "mass", "stiffness"][..],
        ),
    ]);
    let valid_damping = select(vec![
        "",
        "damping = { rayleigh = [0.01, 0.0] }",
        "damping = { rayleigh = [0.01, 0.001] }",
        "damping = { modal = [0.01] }",
        "damping = { matrix = [[0.1, 0.0], [0.0, 0.1]] }",
        "damping = { file = \"c.mtx\" }",
    ]);
    let damping = select(vec![
        "damping = { rayleigh = [-1.0, 0.0] }",
        "damping = { rayleigh = [nan, inf] }",
        "damping = { rayleigh = [1e308, 1e308] }",
        "damping = { modal = [0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09] }",
        "damping = { modal = [-0.1] }",
        "damping = { modal = [] }",
        "damping = { matrix = [[0.1, 1.0], [0.0, 0.1]] }",
        "damping = { matrix = [[-1.0]] }",
        "damping = { file = \"missing.mtx\" }",
        "damping = { rayleigh = [0.0, 0.0], modal = [0.1] }",
        "damping = 0.1",
    ]);
    let damping = prop_oneof![4 => valid_damping, 1 => damping];
    let nonlinear = select(vec![
        "",
        "[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 0.5\n",
        "[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0, 1]\ncoefficient = 1.0\n",
        "[[model.nonlinear]]\ntype = \"tensor\"\ncubic = { file = \"f3.txt\" }\n",
        "[[model.nonlinear]]\ntype = \"tensor\"\nquadratic = { file = \"f2.txt\" }\n",
        "[[model.nonlinear]]\ntype = \"polynomial\"\ndofs = [1]\ncoefficient = 0.1\nexponent = 5\n",
    ]);
    let bad_nonlinear = select(vec![
        "[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0, 1]\ncoefficient = nan\n",
        "[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [9]\ncoefficient = 1.0\n",
        "[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0, 0]\ncoefficient = 1.0\n",
        "[[model.nonlinear]]\ntype = \"cubic\"\ndofs = []\ncoefficient = 1.0\n",
        "[[model.nonlinear]]\ntype = \"polynomial\"\ndofs = [1]\ncoefficient = 0.1\nexponent = 0\n",
        "[[model.nonlinear]]\ntype = \"polynomial\"\ndofs = [1]\ncoefficient = 0.1\nexponent = 4294967295\n",
        "[[model.nonlinear]]\ntype = \"tensor\"\n",
        "[[model.nonlinear]]\ntype = \"spring\"\ndofs = [0]\ncoefficient = 1.0\n",
        "[[model.nonlinear]]\ntype = \"cubic\"\ndofs = [0]\ncoefficient = 1.0\nextra = 1\n",
    ]);
    let nonlinear = prop_oneof![4 => nonlinear, 1 => bad_nonlinear];
    (base, damping, nonlinear, 0usize..4)
        .prop_flat_map(|((head, keys), damping, nonlinear, mutated)| {
            // A quarter of the models get one key changed.
            let change = if mutated == 0 {
                mutations(keys, 1).boxed()
            } else {
                Just(String::new()).boxed()
            };
            (Just(head), Just(damping), Just(nonlinear), change)
        })
        .prop_map(|(head, damping, nonlinear, change)| {
            let general = !head.starts_with("family");
            let text = format!("[model]\n{}", merge(&format!("{head}{damping}"), &change));
            (
                text,
                if general {
                    nonlinear.to_string()
                } else {
                    String::new()
                },
            )
        })
}

/// The keys of a `[[branch]]`: its settings' and its own.
static BRANCH_KEYS: std::sync::LazyLock<Vec<&'static str>> = std::sync::LazyLock::new(|| {
    let own = ["name", "mode", "pattern", "start"];
    Settings::KEYS.iter().chain(&own).copied().collect()
});

/// A `[[branch]]`: a name, a mode and a limit, then up to two keys changed or added.
fn branch(index: usize) -> impl Strategy<Value = String> {
    let base = format!(
        "name = \"b{index}\"\nmode = {}\nmax_points = 3\n",
        index % 2
    );
    mutations(&BRANCH_KEYS, 2)
        .prop_map(move |change| format!("[[branch]]\n{}", merge(&base, &change)))
}

/// The keys of a `[[response]]`: its own and its settings', as the job reads them.
static RESPONSE_ALL_KEYS: std::sync::LazyLock<Vec<&'static str>> = std::sync::LazyLock::new(|| {
    RESPONSE_KEYS
        .iter()
        .chain(&RESPONSE_SETTINGS_KEYS)
        .copied()
        .collect()
});

/// A `[[response]]`: a valid frequency sweep of a force on dof 0, then its force or up to two
/// keys changed.
fn response() -> impl Strategy<Value = String> {
    let force = prop_oneof![
        4 => Just("{ dofs = [0], amplitude = 0.1 }".to_string()),
        2 => select(vec![
            "{ dofs = [0, 1], amplitude = 1.0 }",
            "{ vector = [1.0, 0.0] }",
            "{ file = \"f.mtx\" }",
            "{ engine_order = 1, amplitude = 0.1, sector_dof = 1 }",
            "{ dofs = [99], amplitude = 0.1 }",
            "{ dofs = [0], amplitude = 0.0 }",
            "{ dofs = [0], amplitude = nan }",
            "{ dofs = [], amplitude = 1.0 }",
            "{ vector = [0.0] }",
            "{ vector = [nan, inf] }",
            "{ file = \"m.mtx\" }",
            "{ engine_order = 99, amplitude = 0.1, sector_dof = 1 }",
            "{ engine_order = 1, amplitude = 0.1, sector_dof = 7 }",
            "{ dofs = [0], amplitude = 0.1, vector = [1.0] }",
        ]).prop_map(str::to_string),
        1 => bad_value(),
    ];
    (force, mutations(&RESPONSE_ALL_KEYS, 2)).prop_map(|(force, change)| {
        let base = format!(
            "name = \"frc\"\nforce = {force}\nfrequency_start = 0.5\nfrequency_end = 2.0\nmax_points = 3\n"
        );
        format!("[[response]]\n{}", merge(&base, &change))
    })
}

/// A whole job file: model, optional `[settings]`, branches and responses.
fn job_file() -> impl Strategy<Value = String> {
    (
        model_section(),
        proptest::option::of(mutations(Settings::KEYS, 2)),
        0usize..3,
        proptest::collection::vec(response(), 0..2),
    )
        .prop_flat_map(|(model, settings, branches, responses)| {
            let branches: Vec<_> = (0..branches).map(branch).collect();
            (Just(model), Just(settings), branches, Just(responses))
        })
        .prop_map(|((model, nonlinear), settings, branches, responses)| {
            let mut text = model;
            if let Some(s) = settings {
                text.push_str(&format!("[settings]\n{s}"));
            }
            for b in branches {
                text.push_str(&b);
            }
            for r in responses {
                text.push_str(&r);
            }
            text.push_str(&nonlinear);
            text
        })
}

/// The files a job may name, each either valid for a 2-dof model or generated.
fn job_files() -> impl Strategy<Value = Vec<(&'static str, String)>> {
    (
        prop_oneof![6 => Just(SPD_2.to_string()), 1 => matrix_market_file()],
        prop_oneof![6 => Just(STIFF_2.to_string()), 1 => matrix_market_file()],
        prop_oneof![6 => Just(SPD_2.to_string()), 1 => matrix_market_file()],
        prop_oneof![6 => Just(FORCE_2.to_string()), 1 => matrix_market_file()],
        prop_oneof![6 => Just("1 1 1 1 0.5\n".to_string()), 1 => tensor_file(4)],
        prop_oneof![6 => Just("1 1 1 0.5\n".to_string()), 1 => tensor_file(3)],
    )
        .prop_map(|(m, k, c, f, f3, f2)| {
            vec![
                ("m.mtx", m),
                ("k.mtx", k),
                ("c.mtx", c),
                ("f.mtx", f),
                ("f3.txt", f3),
                ("f2.txt", f2),
            ]
        })
}

const SPD_2: &str = "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 1.0\n2 2 1.0\n";
const STIFF_2: &str =
    "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 2.0\n2 1 -1.0\n2 2 2.0\n";
const FORCE_2: &str = "%%MatrixMarket matrix array real general\n2 1\n1.0\n0.0\n";

// --- Matrix Market and tensor files ---------------------------------------------------------

/// A number token of a file: valid, or one that is not a number, not finite, or huge.
fn number_token() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => (0usize..4).prop_map(|v| v.to_string()),
        2 => select(vec![
            "0", "-1", "1.5", "-2.0", "1.5D+03", "1d-3", "nan", "NaN", "inf", "-inf", "1e309",
            "x", "1,0", "0x10", "", "18446744073709551615", "18446744073709551616",
            "9999999999999", "1e-320", "+1", "1.0.0", "--1", "١",
        ])
        .prop_map(str::to_string),
        1 => any::<f64>().prop_map(|v| format!("{v:e}")),
        1 => any::<u64>().prop_map(|v| v.to_string()),
    ]
}

/// A Matrix Market file: a valid one (coordinate or array, general, symmetric or
/// skew-symmetric, real or integer) with one change or none: a header word, the size line, an
/// entry's token replaced by [`number_token`]s, a line dropped or repeated, a cut anywhere.
fn matrix_market_file() -> impl Strategy<Value = String> {
    let header_word = select(vec![
        "%MatrixMarket",
        "MatrixMarket",
        "vector",
        "sparse",
        "complex",
        "pattern",
        "hermitian",
        "",
        "MATRIX",
        "Real",
    ]);
    let change = prop_oneof![
        3 => Just(Change::None),
        1 => (0usize..5, header_word).prop_map(|(k, w)| Change::Header(k, w.to_string())),
        1 => proptest::collection::vec(number_token(), 0..5).prop_map(|t| Change::Size(t.join(" "))),
        2 => (any::<prop::sample::Index>(), 0usize..3, number_token()).prop_map(|(l, k, t)| Change::Token(l, k, t)),
        1 => any::<prop::sample::Index>().prop_map(Change::Drop),
        1 => any::<prop::sample::Index>().prop_map(Change::Repeat),
        1 => any::<prop::sample::Index>().prop_map(Change::Cut),
    ];
    (
        any::<bool>(),
        select(vec!["general", "symmetric", "skew-symmetric"]),
        any::<bool>(),
        1usize..4,
        1usize..4,
        proptest::collection::vec((0usize..4, 0usize..4, -3i32..4), 0..8),
        change,
        any::<bool>(),
    )
        .prop_map(
            |(coordinate, symmetry, integer, rows, cols, entries, change, crlf)| {
                let cols = if symmetry == "general" { cols } else { rows };
                let field = if integer { "integer" } else { "real" };
                let format = if coordinate { "coordinate" } else { "array" };
                let mut header: Vec<String> = ["%%MatrixMarket", "matrix", format, field, symmetry]
                    .iter()
                    .map(|w| w.to_string())
                    .collect();
                let value = |v: i32| {
                    if integer {
                        v.to_string()
                    } else {
                        format!("{}.5e0", v)
                    }
                };
                // The stored triangle: the lower one (a diagonal too, except skew-symmetric).
                let stored = |i: usize, j: usize| match symmetry {
                    "general" => true,
                    "symmetric" => i >= j,
                    _ => i > j,
                };
                let mut body: Vec<String> = Vec::new();
                if coordinate {
                    let kept: Vec<_> = entries
                        .iter()
                        .filter(|(i, j, _)| *i < rows && *j < cols && stored(*i, *j))
                        .collect();
                    body.push(format!("{rows} {cols} {}", kept.len()));
                    body.extend(
                        kept.iter()
                            .map(|(i, j, v)| format!("{} {} {}", i + 1, j + 1, value(*v))),
                    );
                } else {
                    body.push(format!("{rows} {cols}"));
                    for j in 0..cols {
                        for i in 0..rows {
                            if stored(i, j) {
                                let v = entries
                                    .iter()
                                    .find(|e| e.0 == i && e.1 == j)
                                    .map_or(0, |e| e.2);
                                body.push(value(v));
                            }
                        }
                    }
                }
                let cut = match change {
                    Change::Cut(at) => Some(at),
                    _ => None,
                };
                match change {
                    Change::None | Change::Cut(_) => {}
                    Change::Header(k, w) => header[k] = w,
                    Change::Size(t) => body[0] = t,
                    Change::Token(l, k, t) => {
                        let at = l.index(body.len());
                        let line = &mut body[at];
                        let mut tokens: Vec<String> = line.split(' ').map(str::to_string).collect();
                        let k = k.min(tokens.len() - 1);
                        tokens[k] = t;
                        *line = tokens.join(" ");
                    }
                    Change::Drop(l) => {
                        body.remove(l.index(body.len()));
                    }
                    Change::Repeat(l) => {
                        let line = body[l.index(body.len())].clone();
                        body.push(line);
                    }
                }
                let eol = if crlf { "\r\n" } else { "\n" };
                let mut text =
                    header.join(" ") + eol + "% exported by a test" + eol + &body.join(eol) + eol;
                if let Some(at) = cut {
                    let mut at = at.index(text.len() + 1);
                    while !text.is_char_boundary(at) {
                        at -= 1;
                    }
                    text.truncate(at);
                }
                text
            },
        )
}

/// The change [`matrix_market_file`] makes to a valid file.
#[derive(Debug, Clone)]
enum Change {
    None,
    Header(usize, String),
    Size(String),
    Token(prop::sample::Index, usize, String),
    Drop(prop::sample::Index),
    Repeat(prop::sample::Index),
    Cut(prop::sample::Index),
}

/// A tensor term file of `columns` columns (`i j k c` or `i j k l c`), generated like a
/// Matrix Market file's entries.
fn tensor_file(columns: usize) -> impl Strategy<Value = String> {
    let line = prop_oneof![
        4 => (proptest::collection::vec(0usize..4, columns - 1), number_token())
            .prop_map(|(idx, v)| format!("{} {v}", idx.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(" "))),
        1 => proptest::collection::vec(number_token(), 0..7).prop_map(|t| t.join(" ")),
        1 => select(vec!["% f_i += c x_j x_k", "", "  "]).prop_map(str::to_string),
    ];
    (
        proptest::collection::vec(line, 0..8),
        proptest::option::of(any::<prop::sample::Index>()),
    )
        .prop_map(|(lines, cut)| {
            let mut text = lines.join("\n") + "\n";
            if let Some(cut) = cut {
                let mut at = cut.index(text.len() + 1);
                while !text.is_char_boundary(at) {
                    at -= 1;
                }
                text.truncate(at);
            }
            text
        })
}

// --- Properties -----------------------------------------------------------------------------

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    /// A Matrix Market file is read or refused in one line; what is read becomes the model's
    /// matrix when it is square and of a size a job would hold.
    #[test]
    fn matrix_market_files_are_read_or_refused_in_one_line(text in matrix_market_file()) {
        match parse_matrix_market(&text) {
            Ok(m) => {
                prop_assert!(m.stored() <= 2 * text.len());
                let _ = m.into_matrix();
            }
            Err(e) => assert_one_line(&e.to_string(), &text),
        }
    }

    /// A tensor term file is read or refused in one line; read terms are in range.
    #[test]
    fn tensor_files_are_read_or_refused_in_one_line(
        quadratic in tensor_file(4),
        cubic in tensor_file(5),
        dofs in 0usize..4,
    ) {
        match parse_terms::<2>(&quadratic, dofs) {
            Ok(terms) => prop_assert!(terms.iter().all(|(i, t, c)| *i < dofs && t.iter().all(|&j| j < dofs) && c.is_finite())),
            Err(e) => assert_one_line(&e, &quadratic),
        }
        match parse_terms::<3>(&cubic, dofs) {
            Ok(terms) => prop_assert!(terms.iter().all(|(i, t, c)| *i < dofs && t.iter().all(|&j| j < dofs) && c.is_finite())),
            Err(e) => assert_one_line(&e, &cubic),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    /// A job file — its model, damping, settings, branches and responses and the matrix and
    /// tensor files it names — is read or refused in one line naming the file, never a panic.
    #[test]
    fn job_files_are_read_or_refused_in_one_line(text in job_file(), files in job_files()) {
        check_job(&folder("jobs"), &text, &files);
    }
}

fn check_job(dir: &Path, text: &str, files: &[(&str, String)]) {
    for (name, content) in files {
        std::fs::write(dir.join(name), content).unwrap();
    }
    let path = dir.join("job.toml");
    if let Err(e) = parse_job(text, &path) {
        let message = e.to_string();
        let input = format!("{text}\n{files:?}");
        assert_one_line(&message, &input);
        assert!(
            message.contains(&*dir.to_string_lossy()),
            "the message names no file: {message:?} for {input}"
        );
    }
}
