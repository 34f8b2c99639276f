//! `--runs`: a half-open range of run indices, so a study can be computed in slices whose
//! results merge (the transfer and identification studies share it).

use serde::{Deserialize, Serialize};

/// The most runs one range holds: every run of an invocation is planned up front, so a
/// mistyped count (`0..100000000`) would fill the memory before the first run is saved.
pub const MAX_RUNS: usize = 100_000;

/// A half-open range of run indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunRange {
    /// First run index.
    pub start: usize,
    /// One past the last run index.
    pub end: usize,
}

impl std::str::FromStr for RunRange {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parse = |x: &str| x.trim().parse::<usize>().map_err(|e| format!("{x:?}: {e}"));
        let (start, end) = match s.split_once("..") {
            Some((a, b)) => (parse(a)?, parse(b)?),
            None => (0, parse(s)?),
        };
        if end <= start {
            return Err(format!("empty run range {start}..{end}"));
        }
        if end - start > MAX_RUNS {
            return Err(format!(
                "{} runs, more than the {MAX_RUNS} one invocation takes: split them into \
                 ranges A..B (each its own invocation or shard) and merge the results",
                end - start
            ));
        }
        Ok(Self { start, end })
    }
}

impl std::fmt::Display for RunRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}..{}", self.start, self.end)
    }
}
