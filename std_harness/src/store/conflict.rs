//! Why an existing result file cannot take new runs, and the error that says so: the file,
//! the fields that differ, and what to do.

use std::path::Path;

use super::diff::{Difference, describe};

/// How many differing fields an error lists before it counts the rest.
const SHOWN_DIFFERENCES: usize = 12;

/// Why an existing result file cannot take new runs.
#[derive(Debug)]
pub enum Conflict {
    /// It cannot be read or parsed.
    Unreadable(anyhow::Error),
    /// It holds runs of another configuration: the fields that differ (old → new).
    Differs(Vec<Difference>),
}

/// What a writer refused by a [`Conflict`] can do.
pub fn writer_remedy(path: &Path) -> String {
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    format!(
        "Nothing was written. Use another --out, or --replace to start the file anew (the old \
         one is kept as {name}.<timestamp>.bak)."
    )
}

/// The error that refuses this invocation's writes into the file at `path`.
pub fn refusal(path: &Path, conflict: Conflict) -> anyhow::Error {
    conflict_error(path, conflict, "this invocation", &writer_remedy(path))
}

/// The error for a [`Conflict`] at `path`: `what` names what was compared with it ("this
/// invocation", "shard b/fqi.json"), `remedy` ends the message.
pub fn conflict_error(path: &Path, conflict: Conflict, what: &str, remedy: &str) -> anyhow::Error {
    match conflict {
        Conflict::Unreadable(e) => anyhow::anyhow!(
            "{} cannot be read as a result file ({e:#}). {remedy}",
            path.display()
        ),
        Conflict::Differs(diff) => anyhow::anyhow!(
            "{} holds runs of another configuration; {} field(s) differ (field: in the file → \
             in {what}):\n{}\n{remedy}",
            path.display(),
            diff.len(),
            describe(&diff, SHOWN_DIFFERENCES)
        ),
    }
}
