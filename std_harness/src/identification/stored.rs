//! `identify.json` as invocations share it: the configuration it holds must be this one
//! (its run range aside: records of any ranges merge), and its records are kept.

use std::path::Path;

use super::{Study, StudyConfig};
use crate::store::{self, Conflict};

/// The result file's name in the output directory.
pub const FILE: &str = "identify.json";

/// The study in the file at `path` if it holds the configuration `config` (`Ok(None)`:
/// absent).
pub fn check(path: &Path, config: &StudyConfig) -> Result<Option<Study>, Conflict> {
    if !path.exists() {
        return Ok(None);
    }
    let read = || -> anyhow::Result<Study> {
        let text = std::fs::read_to_string(path)?;
        let study: Study = serde_json::from_str(&text)?;
        store::unique_runs(path, study.records.iter().map(|r| r.run))?;
        Ok(study)
    };
    let study = read().map_err(Conflict::Unreadable)?;
    let comparable = |c: &StudyConfig| {
        let mut v = serde_json::to_value(c).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.remove("runs");
        }
        v
    };
    let diff = store::differences("config", &comparable(&study.config), &comparable(config));
    if diff.is_empty() {
        Ok(Some(study))
    } else {
        Err(Conflict::Differs(diff))
    }
}
