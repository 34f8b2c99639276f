//! The result files of one output directory as the transfer commands share it: one
//! configuration per directory, runs added one at a time under the directory's lock, runs
//! already there kept (an interrupted invocation resumes by being run again), and a file of
//! another configuration or one that cannot be read refused, never replaced, unless asked
//! to (`--replace`, which keeps the old file as a timestamped backup).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use serde_json::Value;

use super::algorithms::Algorithm;
use super::results::{ResultFile, RunRecord};
use crate::store::{self, Conflict, DirLock, refusal};

/// The options of a command line that say where and how to compute, not what: they are
/// left out of the command a result file records.
const PLACEMENT_OPTIONS: [(&str, bool); 8] = [
    ("--runs", true),
    ("--out", true),
    ("--threads", true),
    ("--quiet", false),
    ("--no-plots", false),
    ("--no-run", false),
    ("--replace", false),
    ("--check-gp-search", false),
];

/// `words` (a subcommand and its options) without the placement options (`--runs`, `--out`,
/// `--threads`, `--quiet`, `--no-plots`, `--no-run`, `--replace`, `--check-gp-search`), in either the
/// `--option value` or the `--option=value` form.
pub fn recorded_command(words: &[String]) -> Vec<String> {
    let mut kept = Vec::new();
    let mut skip_value = false;
    for w in words {
        if std::mem::take(&mut skip_value) {
            continue;
        }
        let placement = PLACEMENT_OPTIONS.iter().find(|(name, _)| {
            w == name
                || w.strip_prefix(name)
                    .is_some_and(|rest| rest.starts_with('='))
        });
        match placement {
            Some((name, takes_value)) => skip_value = *takes_value && w == name,
            None => kept.push(w.clone()),
        }
    }
    kept
}

/// Compares the file at `path` with the configuration `experiment` and, when given, the
/// algorithm's run `parameters`: `Ok(None)` when absent, `Ok(Some(file))` when it matches.
pub fn check(
    path: &Path,
    experiment: &Value,
    parameters: Option<&Value>,
) -> Result<Option<ResultFile>, Conflict> {
    if !path.exists() {
        return Ok(None);
    }
    let file = ResultFile::read(path).map_err(Conflict::Unreadable)?;
    let mut diff = store::differences("experiment", &file.experiment, experiment);
    if let Some(p) = parameters {
        // Every run of a file has its algorithm's parameters; the first that differs speaks
        // for the file.
        if let Some(r) = file.runs.iter().find(|r| r.parameters != *p) {
            let prefix = format!("runs[run {}].parameters", r.run);
            diff.extend(store::differences(&prefix, &r.parameters, p));
        }
    }
    if diff.is_empty() {
        Ok(Some(file))
    } else {
        Err(Conflict::Differs(diff))
    }
}

/// An output directory opened for the runs of one configuration.
#[derive(Debug)]
pub struct ResultDir {
    out: PathBuf,
    experiment: Value,
    parameters: BTreeMap<Algorithm, Value>,
    command: Vec<String>,
    replace: bool,
    present: Present,
}

/// `<out>/<algorithm>.json`.
pub fn result_path(out: &Path, algorithm: Algorithm) -> PathBuf {
    out.join(format!("{}.json", algorithm.name()))
}

impl ResultDir {
    /// Opens `out` (which must exist) for runs `runs` of the configuration `experiment`,
    /// whose algorithms have the run `parameters`, recorded with the command line `words`
    /// without its placement options ([`recorded_command`]).
    ///
    /// Every `<algorithm>.json` in `out` must hold this configuration (and, for the
    /// algorithms of `parameters`, these parameters). Errors: a file that cannot be read or
    /// holds another configuration, named with the differing fields; nothing is written.
    /// With `replace`, such files are moved aside as backups instead, and a file whose runs
    /// this invocation recomputes is copied to a backup first. Returns the directory and
    /// the notes to print (backups made).
    pub fn open(
        out: &Path,
        experiment: Value,
        parameters: BTreeMap<Algorithm, Value>,
        runs: &[usize],
        words: &[String],
        replace: bool,
    ) -> anyhow::Result<(Self, Vec<String>)> {
        let command = recorded_command(words);
        let _lock = DirLock::acquire(out)?;
        let (present, notes) = inspect(out, &experiment, &parameters, runs, replace)?;
        let dir = Self {
            out: out.to_path_buf(),
            experiment,
            parameters,
            command,
            replace,
            present,
        };
        Ok((dir, notes))
    }

    /// The runs of `algorithm` already in the directory when it was opened (with
    /// `--replace` they are recomputed; otherwise kept and skipped).
    pub fn present(&self, algorithm: Algorithm) -> Option<&BTreeSet<usize>> {
        self.present.get(&algorithm)
    }

    /// Whether runs already present are recomputed.
    pub fn replaces(&self) -> bool {
        self.replace
    }

    /// The directory's lock, for writes that must not interleave with another writer's.
    pub fn lock(&self) -> anyhow::Result<DirLock> {
        DirLock::acquire(&self.out)
    }

    /// Adds one finished run to `<out>/<algorithm>.json` under the directory's lock (the
    /// file as it is now: another writer may have added runs since). A run of the same
    /// index already there is kept unless replacing.
    ///
    /// Errors: the file now holds another configuration or cannot be read (another writer
    /// changed it), or the write fails; the file is then unchanged.
    pub fn save_run(&self, algorithm: Algorithm, record: RunRecord) -> anyhow::Result<()> {
        let _lock = self.lock()?;
        let path = result_path(&self.out, algorithm);
        let mut file = match check(&path, &self.experiment, self.parameters.get(&algorithm)) {
            Ok(Some(file)) => file,
            Ok(None) => ResultFile::new(self.experiment.clone(), Vec::new()),
            Err(conflict) => {
                return Err(refusal(&path, conflict))
                    .context("another writer changed the file since this invocation began");
            }
        };
        match file.runs.iter().position(|r| r.run == record.run) {
            Some(i) if self.replace => file.runs[i] = record,
            // Another writer saved this run meanwhile (the same run: same seed, index).
            Some(_) => return Ok(()),
            None => file.runs.push(record),
        }
        let command = std::mem::take(&mut file.command);
        file = ResultFile::new(file.experiment, file.runs)
            .with_command(&command)
            .with_command(&self.command);
        file.write(&path)
    }

    /// Every result file in the directory, which must all hold this configuration (call
    /// with the lock held, so no writer is half-way).
    pub fn load(&self) -> anyhow::Result<BTreeMap<Algorithm, ResultFile>> {
        let mut files = BTreeMap::new();
        for a in Algorithm::ALL {
            let path = result_path(&self.out, a);
            match check(&path, &self.experiment, None) {
                Ok(Some(file)) => {
                    files.insert(a, file);
                }
                Ok(None) => {}
                Err(conflict) => {
                    return Err(refusal(&path, conflict));
                }
            }
        }
        Ok(files)
    }

    /// Takes the directory's lock and loads every result file ([`ResultDir::load`]): the
    /// runs as they are with no writer half-way, and none until the lock is dropped.
    ///
    /// Errors: those of [`ResultDir::lock`] and [`ResultDir::load`].
    pub fn load_locked(&self) -> anyhow::Result<(DirLock, BTreeMap<Algorithm, ResultFile>)> {
        let lock = self.lock()?;
        Ok((lock, self.load()?))
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.out
    }

    /// Appends `text` to the log `<out>/<name>` (created with `header` when absent),
    /// rewriting it atomically under the caller's lock.
    pub fn append_log(&self, name: &str, header: &str, text: &str) -> anyhow::Result<()> {
        append_log(&self.out.join(name), header, text)
    }
}

/// The run indices in a directory's result files, per algorithm.
pub type Present = BTreeMap<Algorithm, BTreeSet<usize>>;

/// The runs present per algorithm in `out` and the notes of backups made: what
/// [`ResultDir::open`] checks and does, with the directory's lock held by the caller.
/// `--replace` starts anew only the files of the algorithms written (those of
/// `parameters`): a file of another algorithm that cannot take the runs is refused, and
/// every file is checked before any backup is made.
pub fn inspect(
    out: &Path,
    experiment: &Value,
    parameters: &BTreeMap<Algorithm, Value>,
    runs: &[usize],
    replace: bool,
) -> anyhow::Result<(Present, Vec<String>)> {
    let mut checked = Vec::new();
    for a in Algorithm::ALL {
        let path = result_path(out, a);
        match check(&path, experiment, parameters.get(&a)) {
            Err(conflict) if !(replace && parameters.contains_key(&a)) => {
                return Err(if replace {
                    store::conflict_error(
                        &path,
                        conflict,
                        "this invocation",
                        &format!(
                            "Nothing was written. --replace starts anew only the files of the \
                             algorithms written: add {} to them, or move the file away.",
                            a.name()
                        ),
                    )
                } else {
                    refusal(&path, conflict)
                });
            }
            result => checked.push((a, path, result)),
        }
    }
    let mut present = BTreeMap::new();
    let mut notes = Vec::new();
    for (a, path, result) in checked {
        match result {
            Ok(None) => {}
            Ok(Some(file)) => {
                let have: BTreeSet<usize> = file.runs.iter().map(|r| r.run).collect();
                if replace && parameters.contains_key(&a) && runs.iter().any(|r| have.contains(r)) {
                    let kept = store::copy_backup(&path)?;
                    notes.push(format!(
                        "kept a copy of {} as {}",
                        path.display(),
                        kept.display()
                    ));
                }
                present.insert(a, have);
            }
            Err(conflict) => {
                let kept = store::backup(&path)?;
                let why = match conflict {
                    Conflict::Unreadable(_) => "could not be read",
                    Conflict::Differs(_) => "held another configuration",
                };
                notes.push(format!(
                    "{} {why}: moved to {}",
                    path.display(),
                    kept.display()
                ));
            }
        }
    }
    Ok((present, notes))
}

/// Appends `text` to the log at `path` (created with `header` when absent) by rewriting it
/// atomically: a failed write leaves the log as it was.
pub fn append_log(path: &Path, header: &str, text: &str) -> anyhow::Result<()> {
    let mut all = match std::fs::read_to_string(path) {
        Ok(old) => old,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => header.to_string(),
        Err(e) => bail!("reading {}: {e}", path.display()),
    };
    all.push_str(text);
    store::write_atomic(path, all.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn the_recorded_command_leaves_out_where_and_how() {
        let got = recorded_command(&words(
            "puddle --runs 0..2 --steps 1 --out=D --threads 2 --quiet --algorithms fqi \
             --no-plots --replace --runs=3 --seed 7 --check-gp-search --no-run",
        ));
        assert_eq!(got, words("puddle --steps 1 --algorithms fqi --seed 7"));
        // An option whose name only starts like a placement option is kept.
        assert_eq!(
            recorded_command(&words("dam --outputs x")),
            words("dam --outputs x")
        );
    }
}
