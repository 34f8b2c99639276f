//! A result file holds each run index once: a repeated index (a hand edit, a bad copy)
//! would count one run twice in every mean and let a merge keep the wrong copy.

use std::collections::BTreeSet;
use std::path::Path;

use anyhow::bail;

/// Refuses the file at `path` whose runs have the indices `runs` when one repeats; the
/// error names the file and the index.
pub fn unique_runs(path: &Path, runs: impl IntoIterator<Item = usize>) -> anyhow::Result<()> {
    let mut seen = BTreeSet::new();
    for run in runs {
        if !seen.insert(run) {
            bail!(
                "{} holds run {run} more than once; a result file holds each run index once",
                path.display()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_repeated_index_is_named_with_the_file() {
        let path = Path::new("out/fqi.json");
        assert!(unique_runs(path, [0, 2, 1]).is_ok());
        let e = unique_runs(path, [0, 3, 1, 3]).unwrap_err().to_string();
        assert!(
            e.contains("out/fqi.json") && e.contains("run 3 more than once"),
            "{e}"
        );
    }
}
