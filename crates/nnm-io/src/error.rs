//! What the file formats share about errors: one-line messages of I/O failures.

/// One-line message of an I/O error (without the "(os error N)" suffix).
pub(crate) fn io_reason(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" (os error") {
        Some(k) => s[..k].to_string(),
        None => s,
    }
}

/// A file refused (a mesh that cannot be read) or not written (ParaView output): one line,
/// naming the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", .path.display())]
pub struct FileError {
    /// The file.
    pub path: std::path::PathBuf,
    /// What is wrong, or what went wrong.
    pub message: String,
}
