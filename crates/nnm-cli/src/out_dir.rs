//! The output folder of a command, held by one run at a time: two runs into one `--out` would
//! interleave their files, and the CSV/JSON of a branch could hold points of both.
//!
//! A run takes `DIR/.nnm.lock` (created exclusively, holding its process id) and removes it
//! when done (a second Ctrl-C or SIGTERM, which quits at once, removes it too: see
//! [`crate::interrupt`]). A lock left by a run that no longer exists (killed) is taken over; one held by
//! a live process fails the run at once with a one-line error.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// Creates `dir` and its parents if missing.
pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))
}

/// The lock file's name inside the output folder.
pub const LOCK_FILE: &str = ".nnm.lock";

/// An output folder held by this process until dropped.
pub struct OutDir {
    lock: PathBuf,
}

impl OutDir {
    /// Creates `dir` if missing and takes its lock.
    pub fn lock(dir: &Path) -> Result<Self> {
        create_dir(dir)?;
        let lock = dir.join(LOCK_FILE);
        // Twice at most: the second attempt follows the removal of a stale lock.
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&lock)
            {
                Ok(mut file) => {
                    writeln!(file, "{}", std::process::id())
                        .with_context(|| format!("cannot write {}", lock.display()))?;
                    // A signal that quits at once removes it too.
                    crate::interrupt::hold_lock(&lock);
                    return Ok(Self { lock });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let holder = std::fs::read_to_string(&lock)
                        .ok()
                        .and_then(|s| s.trim().parse::<u32>().ok());
                    if let Some(pid) = holder.filter(|&pid| alive(pid)) {
                        bail!(
                            "{} is in use by another nnm run (process {pid}); wait for it to finish or choose another --out (remove {} if no such run exists)",
                            dir.display(),
                            lock.display()
                        );
                    }
                    // Left by a run that was killed: not held any more.
                    let _ = std::fs::remove_file(&lock);
                }
                Err(e) => {
                    return Err(e).with_context(|| format!("cannot create {}", lock.display()));
                }
            }
        }
        bail!(
            "cannot take {}: another nnm run took it at the same time",
            lock.display()
        )
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        crate::interrupt::release_lock();
        let _ = std::fs::remove_file(&self.lock);
    }
}

/// Whether process `pid` exists (signal 0 checks without sending anything; EPERM means it
/// exists under another user).
#[cfg(unix)]
fn alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: kill with signal 0 sends nothing; it only checks the process.
    let result = unsafe { libc::kill(pid, 0) };
    result == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// Without a way to check, a lock is taken to be held (the message says how to remove it).
#[cfg(not(unix))]
fn alive(_pid: u32) -> bool {
    true
}

/// Branch result files in `dir` (`<stem>.csv` beside `<stem>.json`) whose stem is not one of
/// `names`: results of another job, which this run neither overwrites nor plots. Sorted stems.
pub fn foreign_branches(dir: &Path, names: &[String]) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut stems: Vec<String> = entries
        .filter_map(|e| {
            let path = e.ok()?.path();
            if path.extension()? != "json" {
                return None;
            }
            let stem = path.file_stem()?.to_str()?.to_string();
            let csv = dir.join(format!("{stem}.csv"));
            (csv.exists() && !names.contains(&stem)).then_some(stem)
        })
        .collect();
    stems.sort();
    stems
}
