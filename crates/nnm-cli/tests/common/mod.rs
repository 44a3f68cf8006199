//! Running the `nnm` binary from the command-line tests: each test file includes this module.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

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

/// A bladed-disk branch of a thousand small steps: still running when a test interrupts it.
pub const LONG_BRANCH: &str = "[model]\nfamily = \"bladed-disk\"\n[[branch]]\nname = \"long\"\nmode = \"0,6\"\nmax_points = 1000\nmax_step = 0.02\n";

/// Data rows of a CSV file (0 while it does not exist).
pub fn csv_rows(path: &Path) -> usize {
    std::fs::read_to_string(path).map_or(0, |s| s.lines().count().saturating_sub(1))
}

/// Waits (up to two minutes) until `path` has `rows` data rows.
pub fn wait_for_rows(path: &Path, rows: usize) {
    let started = std::time::Instant::now();
    while csv_rows(path) < rows && started.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// Starts `nnm` with `args` in the background, its output captured (`wait_with_output`).
pub fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_nnm"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the nnm binary starts")
}
