//! A job's model written as the files a finite-element code exports (`nnm export`): `M` and
//! `K` as Matrix Market files, the nonlinear force as polynomial term files (docs/method.md
//! eq. (57)), and a job file whose `[model]` reads them, the rest of the job copied.
//!
//! Why: an imported model must run as fast as the built-in family it came from, and a user's
//! own export can be checked against a built-in model, file by file. The dofs are those of
//! the model computed, so the `[[branch]]` and `[[response]]` tables apply unchanged.
//!
//! Everything is made in memory and checked before the first file is written: a model that
//! cannot be exported, or a file that already exists, leaves the folder as it was.

use std::path::{Path, PathBuf};

use nnm::MechanicalSystem;
use nnm::model::PolynomialTerms;

use crate::error::io_reason;
use crate::job::{DampingSpec, JobError, load_job};
use crate::matrix_market::format_coordinate;
use crate::tensor_file::format_terms;

/// Why a job could not be exported. One line each.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The job itself is refused (as `nnm run` would refuse it).
    #[error(transparent)]
    Job(#[from] JobError),
    /// The job is valid but its model cannot be written as these files.
    #[error("{}: cannot export: {message}", .path.display())]
    NotExportable { path: PathBuf, message: String },
    /// A file to write is already there.
    #[error("{} already exists: nnm export does not overwrite files (choose an empty --out folder)", .path.display())]
    Exists { path: PathBuf },
    /// Creating the folder or writing a file failed.
    #[error("cannot write {}: {reason}", .path.display())]
    Write { path: PathBuf, reason: String },
}

/// The files of an exported job: `(name, text)` pairs, the job file last.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportedJob {
    pub files: Vec<(String, String)>,
}

/// The file names of the matrices and term files.
pub const MASS_FILE: &str = "M.mtx";
pub const STIFFNESS_FILE: &str = "K.mtx";
pub const DAMPING_FILE: &str = "C.mtx";
pub const QUADRATIC_FILE: &str = "f2.txt";
pub const CUBIC_FILE: &str = "f3.txt";

/// The files that export the job `job_path` (read and checked as `nnm run` reads it), made in
/// memory: `M.mtx`, `K.mtx`, `f2.txt`/`f3.txt` (the degrees the force has), `C.mtx` when the
/// damping is a matrix, and `<stem>.toml`. Refused: a nonlinear element whose force is not
/// quadratic and cubic terms ([`nnm::model::NonlinearElement::polynomial_terms`]); a job
/// with `fixed_dofs` and `[[response]]` tables (their forces are given in the numbering
/// before `fixed_dofs`, the export writes the reduced model).
pub fn export_job(job_path: &Path) -> Result<ExportedJob, ExportError> {
    let job = load_job(job_path)?;
    let refuse = |message: String| ExportError::NotExportable {
        path: job_path.to_owned(),
        message,
    };
    let text = std::fs::read_to_string(job_path).map_err(|e| JobError::Read {
        path: job_path.to_owned(),
        reason: io_reason(&e),
    })?;
    let source: toml::Table = text
        .parse()
        .expect("the job file was parsed when it was loaded");
    let s = &job.structure;
    let n = s.dofs();

    let mut terms = PolynomialTerms::default();
    for (k, e) in s.elements().iter().enumerate() {
        let own = e.polynomial_terms().ok_or_else(|| {
            refuse(format!(
                "nonlinear element {} is not a sum of quadratic and cubic terms (a polynomial spring of exponent other than 2 or 3), which is all a tensor file holds",
                k + 1
            ))
        })?;
        terms.append(own);
    }
    let terms = terms.summed();
    if job.fixed_dofs.is_some() && !job.responses.is_empty() {
        return Err(refuse(
            "the model has `fixed_dofs`, and the forces of [[response]] are given in the numbering before them, but the export writes the reduced model (remove the responses, or number the model without fixed dofs)".into(),
        ));
    }

    let name = job_path.display().to_string();
    let stem = job_path
        .file_stem()
        .map_or_else(|| "model".into(), |s| s.to_string_lossy().into_owned());
    let dofs = if n == 1 {
        "1 dof".into()
    } else {
        format!("{n} dofs")
    };
    let origin = |what: &str| {
        vec![
            format!("{what} of {name} ({}, {dofs}), written by `nnm export`.", job.family),
            "Rows and columns are the dofs of the model computed (1-based here, 0-based in outputs).".into(),
        ]
    };
    let mut files = vec![
        (
            MASS_FILE.to_string(),
            format_coordinate(s.mass_matrix(), &origin("The mass matrix M")),
        ),
        (
            STIFFNESS_FILE.to_string(),
            format_coordinate(s.stiffness(), &origin("The stiffness matrix K")),
        ),
    ];
    let mut model = format!(
        "[model]\nmass = {{ file = \"{MASS_FILE}\" }}\nstiffness = {{ file = \"{STIFFNESS_FILE}\" }}\n"
    );
    if let Some(c) = s.cyclic_symmetry() {
        model += &format!(
            "cyclic = {{ sectors = {}, dofs_per_sector = {} }}\n",
            c.sectors, c.dofs_per_sector
        );
    }
    match (&job.damping_spec, &job.damping) {
        // C = αM + βK and modal ratios are the same matrix on the same M and K.
        (Some(spec @ (DampingSpec::Rayleigh(_) | DampingSpec::Modal(_))), _) => {
            let value = toml::Value::try_from(spec).expect("a damping spec is a TOML table");
            model += &format!("damping = {value}\n");
        }
        // A matrix (or file) was given in the full numbering: written as the model computed
        // has it, after `fixed_dofs`.
        (Some(_), Some(c)) => {
            files.push((
                DAMPING_FILE.to_string(),
                format_coordinate(c, &origin("The damping matrix C")),
            ));
            model += &format!("damping = {{ file = \"{DAMPING_FILE}\" }}\n");
        }
        _ => {}
    }
    if !terms.is_empty() {
        model += "\n[[model.nonlinear]]\ntype = \"tensor\"\n";
    }
    if !terms.quadratic.is_empty() {
        let mut comments = origin("The quadratic force terms \"i j k c\", f_i += c x_j x_k,");
        comments.push("One term per monomial (j <= k), the elements' coefficients summed.".into());
        files.push((
            QUADRATIC_FILE.to_string(),
            format_terms(&terms.quadratic, &comments),
        ));
        model += &format!("quadratic = {{ file = \"{QUADRATIC_FILE}\" }}\n");
    }
    if !terms.cubic.is_empty() {
        let mut comments = origin("The cubic force terms \"i j k l c\", f_i += c x_j x_k x_l,");
        comments
            .push("One term per monomial (j <= k <= l), the elements' coefficients summed.".into());
        files.push((
            CUBIC_FILE.to_string(),
            format_terms(&terms.cubic, &comments),
        ));
        model += &format!("cubic = {{ file = \"{CUBIC_FILE}\" }}\n");
    }

    let base = job_path.parent().unwrap_or(Path::new("."));
    let mut job_text = format!(
        "# Written by `nnm export` from\n#   {name}\n\
         # its model ({}, {dofs}) as a finite-element code exports it: M and K as Matrix\n\
         # Market files, the nonlinear force as polynomial terms (docs/job-files.md\n\
         # \"Finite-element models\"). The dofs are the same; [settings], [[branch]] and\n\
         # [[response]] are copied.\n",
        job.family
    );
    job_text += &model;
    if let Some(settings) = source.get("settings").and_then(|s| s.as_table()) {
        job_text += "\n[settings]\n";
        job_text += &key_values(settings);
    }
    for key in ["branch", "response"] {
        let tables = source.get(key).and_then(|a| a.as_array());
        for table in tables.into_iter().flatten().filter_map(|t| t.as_table()) {
            let mut table = table.clone();
            if key == "response" {
                absolute_force_file(&mut table, base);
            }
            job_text += &format!("\n[[{key}]]\n");
            job_text += &key_values(&table);
        }
    }
    files.push((format!("{stem}.toml"), job_text));
    Ok(ExportedJob { files })
}

/// `key = value` lines of a table, `name` first, values inline (`force = { dofs = [28], ... }`,
/// as a job file writes them; TOML's own writer would make sub-tables of them).
fn key_values(table: &toml::Table) -> String {
    let bare = |k: &str| {
        !k.is_empty()
            && k.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    };
    let mut keys: Vec<&String> = table.keys().collect();
    keys.sort_by_key(|k| k.as_str() != "name");
    keys.iter()
        .map(|k| {
            let key = if bare(k) {
                k.to_string()
            } else {
                toml::Value::String(k.to_string()).to_string()
            };
            format!("{key} = {}\n", table[k.as_str()])
        })
        .collect()
}

/// A response's `force = { file = "..." }` is found relative to its job file: made absolute,
/// so that the exported job (in another folder) reads the same file.
fn absolute_force_file(response: &mut toml::Table, base: &Path) {
    let file = response
        .get_mut("force")
        .and_then(|f| f.get_mut("file"))
        .filter(|f| f.is_str());
    if let Some(file) = file {
        let path = base.join(file.as_str().expect("a string"));
        let path = std::path::absolute(&path).unwrap_or(path);
        *file = toml::Value::String(path.display().to_string());
    }
}

impl ExportedJob {
    /// Writes the files into `out` (created if missing), none of which may exist yet: checked
    /// for all before the first is written. Returns their paths, the job file last.
    pub fn write(&self, out: &Path) -> Result<Vec<PathBuf>, ExportError> {
        let paths: Vec<PathBuf> = self.files.iter().map(|(name, _)| out.join(name)).collect();
        if let Some(path) = paths.iter().find(|p| p.exists()) {
            return Err(ExportError::Exists { path: path.clone() });
        }
        let write_error = |path: &Path, e: std::io::Error| ExportError::Write {
            path: path.to_owned(),
            reason: io_reason(&e),
        };
        std::fs::create_dir_all(out).map_err(|e| write_error(out, e))?;
        for (path, (_, text)) in paths.iter().zip(&self.files) {
            std::fs::write(path, text).map_err(|e| write_error(path, e))?;
        }
        Ok(paths)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nnm::model::Matrix;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("nnm-export-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn same_matrix(a: &Matrix, b: &Matrix) {
        assert_eq!(a.to_dense(), b.to_dense());
    }

    /// A general model with `fixed_dofs`, a spring, a tensor and a damping matrix (in the
    /// full numbering): exported, it is the model computed — the reduced one — with the same
    /// `M`, `K` and `C` bit for bit and the same force (the spring's terms and the tensor's,
    /// summed, to round-off), and its branch copied. The exported job reads no file of the
    /// original's folder.
    #[test]
    fn a_reduced_general_model_exports_as_computed() {
        let dir = scratch("reduced");
        let original = dir.join("original");
        std::fs::create_dir_all(&original).unwrap();
        std::fs::write(original.join("f2.txt"), "2 3 4 0.5\n3 2 4 0.5\n4 2 3 0.5\n").unwrap();
        let job_path = original.join("chain.toml");
        std::fs::write(
            &job_path,
            r#"[model]
mass = [[2.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
stiffness = [[2.0, -1.0, 0.0, 0.0], [-1.0, 2.0, -1.0, 0.0], [0.0, -1.0, 2.0, -1.0], [0.0, 0.0, -1.0, 1.0]]
fixed_dofs = [0]
damping = { matrix = [[0.1, 0.0, 0.0, 0.0], [0.0, 0.1, 0.0, 0.0], [0.0, 0.0, 0.2, -0.1], [0.0, 0.0, -0.1, 0.1]] }

[[model.nonlinear]]
type = "cubic"
dofs = [0, 3]
coefficient = 0.7

[[model.nonlinear]]
type = "tensor"
quadratic = { file = "f2.txt" }

[[branch]]
name = "first"
mode = 0
energy_max = 0.5
"#,
        )
        .unwrap();
        let exported = export_job(&job_path).unwrap();
        let names: Vec<&str> = exported.files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            ["M.mtx", "K.mtx", "C.mtx", "f2.txt", "f3.txt", "chain.toml"]
        );
        let out = dir.join("out");
        let paths = exported.write(&out).unwrap();
        assert_eq!(paths.last().unwrap(), &out.join("chain.toml"));
        let text = std::fs::read_to_string(out.join("chain.toml")).unwrap();
        assert!(!text.contains("fixed_dofs"), "{text}");

        let (a, b) = (
            load_job(&job_path).unwrap(),
            load_job(&out.join("chain.toml")).unwrap(),
        );
        let (sa, sb) = (&a.structure, &b.structure);
        assert_eq!(sb.dofs(), 3);
        same_matrix(sa.mass_matrix(), sb.mass_matrix());
        same_matrix(sa.stiffness(), sb.stiffness());
        same_matrix(a.damping.as_ref().unwrap(), b.damping.as_ref().unwrap());
        for x in [[0.3, -0.7, 1.1], [-1.3, 0.2, 0.5]] {
            let (mut fa, mut fb) = ([0.0; 3], [0.0; 3]);
            sa.internal_force(&x, &mut fa);
            sb.internal_force(&x, &mut fb);
            for (p, q) in fa.iter().zip(&fb) {
                assert!((p - q).abs() < 1e-14 * p.abs().max(1.0), "{fa:?} vs {fb:?}");
            }
        }
        assert_eq!(b.branches.len(), 1);
        assert_eq!(b.branches[0].name, "first");
        assert_eq!(b.branches[0].settings, a.branches[0].settings);

        // Exported again into the same folder: refused, the files left as they were.
        let before = std::fs::read_to_string(out.join("M.mtx")).unwrap();
        let e = exported.write(&out).unwrap_err().to_string();
        assert!(e.contains("M.mtx already exists"), "{e}");
        assert_eq!(std::fs::read_to_string(out.join("M.mtx")).unwrap(), before);
    }

    /// With `fixed_dofs`, a response's force is numbered before them, and the export writes the
    /// reduced model: refused, naming why.
    #[test]
    fn fixed_dofs_with_responses_are_refused() {
        let dir = scratch("fixed-response");
        let job_path = dir.join("job.toml");
        std::fs::write(
            &job_path,
            r#"[model]
mass = [[1.0, 0.0], [0.0, 1.0]]
stiffness = [[2.0, -1.0], [-1.0, 1.0]]
fixed_dofs = [0]
damping = { rayleigh = [0.01, 0.0] }

[[response]]
name = "r"
force = { dofs = [1], amplitude = 0.1 }
frequency_start = 0.5
frequency_end = 1.0
"#,
        )
        .unwrap();
        let e = export_job(&job_path).unwrap_err().to_string();
        assert!(!e.contains('\n'));
        assert!(
            e.contains("cannot export: the model has `fixed_dofs`"),
            "{e}"
        );
    }
}
