//! Running the `nnm` binary from the command-line tests: each test file includes this module.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn nnm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nnm"))
        .args(args)
        .output()
        .expect("the nnm binary runs")
}

/// A fresh folder for one test (the process id keeps concurrent test runs apart).
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nnm-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `text` to `dir/file`; returns the path as a string (for `nnm`'s arguments).
pub fn write(dir: &Path, file: &str, text: &str) -> String {
    let path = dir.join(file);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}
