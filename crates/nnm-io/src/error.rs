//! What the file formats share about errors: one-line messages of I/O failures.

/// One-line message of an I/O error (without the "(os error N)" suffix).
pub(crate) fn io_reason(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" (os error") {
        Some(k) => s[..k].to_string(),
        None => s,
    }
}
