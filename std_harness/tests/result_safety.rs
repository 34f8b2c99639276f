//! No finished run is ever lost: a result file of another configuration or one that cannot
//! be read is refused (nothing written) or, with `--replace`, kept as a backup; writers
//! sharing a directory lock it; `merge` combines shards into the files of one invocation;
//! a killed invocation resumes; a failed write leaves the old file. Each test runs the
//! built binary on a tiny configuration.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_awfqi-harness");

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("awfqi-safety-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `head`, then `--runs RUNS --out OUT`, then `extra`, as words.
fn words(head: &[&str], out: &Path, runs: &str, extra: &[&str]) -> Vec<String> {
    let out = out.display().to_string();
    let tail = ["--runs", runs, "--out", &out];
    head.iter()
        .chain(&tail)
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
}

/// `puddle` with FQI on a budget that runs in a debug build (one step unless `extra` says
/// otherwise), into `out`.
fn puddle(out: &Path, runs: &str, extra: &[&str]) -> Vec<String> {
    let steps: &[&str] = if extra.contains(&"--steps") {
        &[]
    } else {
        &["--steps", "1"]
    };
    let head = [
        "puddle",
        "--algorithms",
        "fqi",
        "--iterations",
        "2",
        "--trees",
        "2",
        "--threads",
        "1",
        "--quiet",
    ];
    words(&[&head[..], steps].concat(), out, runs, extra)
}

fn run(words: &[String]) -> Output {
    Command::new(BIN).args(words).output().unwrap()
}

fn ok(words: &[String]) -> Output {
    let out = run(words);
    assert!(
        out.status.success(),
        "{words:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn refused(words: &[String]) -> String {
    let out = run(words);
    assert!(!out.status.success(), "{words:?} should have failed");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&bytes(path)).unwrap()
}

fn run_indices(path: &Path) -> Vec<u64> {
    json(path)["runs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["run"].as_u64().unwrap())
        .collect()
}

/// Every file name in `dir` (not recursive).
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The outputs that must agree byte for byte (everything but the wall times).
const OUTPUTS: [&str; 10] = [
    "fqi.json",
    "summary.csv",
    "report.md",
    "transfer_metrics.csv",
    "learning_curves.png",
    "learning_curves.svg",
    "target_samples.png",
    "target_samples.svg",
    "samples/fqi.png",
    "samples/fqi.svg",
];

fn assert_same_outputs(a: &Path, b: &Path, files: &[&str]) {
    for f in files {
        // (As a boolean: a failure message with the files would be megabytes.)
        let same = bytes(&a.join(f)) == bytes(&b.join(f));
        assert!(
            same,
            "{f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

#[test]
fn a_file_of_another_configuration_is_refused_and_replace_keeps_a_backup() {
    let dir = scratch("config");
    let out = dir.join("out");
    ok(&puddle(&out, "0..1", &["--no-plots"]));
    let before: Vec<Vec<u8>> = ["fqi.json", "summary.csv", "report.md"]
        .iter()
        .map(|f| bytes(&out.join(f)))
        .collect();
    let listing = names(&out);
    // Another --steps: refused, naming the file and the field (old → new).
    let err = refused(&puddle(&out, "1..2", &["--no-plots", "--steps", "2"]));
    assert!(
        err.contains(&format!("{}", out.join("fqi.json").display())),
        "{err}"
    );
    assert!(err.contains("experiment.protocol.steps: 1 → 2"), "{err}");
    assert!(err.contains("runs[run 0].parameters.steps: 1 → 2"), "{err}");
    assert!(err.contains("Nothing was written"), "{err}");
    for (f, old) in ["fqi.json", "summary.csv", "report.md"].iter().zip(&before) {
        assert!(bytes(&out.join(f)) == *old, "{f} changed");
    }
    assert_eq!(names(&out), listing, "a file appeared or vanished");
    // With --replace: the old file is kept as fqi.json.<timestamp>.bak, the new one holds
    // only this configuration's run.
    ok(&puddle(
        &out,
        "1..2",
        &["--no-plots", "--steps", "2", "--replace"],
    ));
    let backups: Vec<String> = names(&out)
        .into_iter()
        .filter(|n| n.starts_with("fqi.json.") && n.ends_with(".bak"))
        .collect();
    assert_eq!(backups.len(), 1, "{:?}", names(&out));
    assert!(bytes(&out.join(&backups[0])) == before[0]);
    assert_eq!(run_indices(&out.join("fqi.json")), [1]);
    assert_eq!(
        json(&out.join("fqi.json"))["experiment"]["protocol"]["steps"],
        2
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unreadable_file_is_refused_and_left_as_it_is() {
    let dir = scratch("unreadable");
    let out = dir.join("out");
    ok(&puddle(&out, "0..1", &["--no-plots"]));
    let whole = bytes(&out.join("fqi.json"));
    let truncated = &whole[..whole.len() / 2];
    std::fs::write(out.join("fqi.json"), truncated).unwrap();
    std::fs::remove_file(out.join("summary.csv")).unwrap();
    let err = refused(&puddle(&out, "1..2", &["--no-plots"]));
    assert!(
        err.contains("fqi.json cannot be read as a result file"),
        "{err}"
    );
    assert!(bytes(&out.join("fqi.json")) == truncated);
    assert!(!out.join("summary.csv").exists(), "the summary was written");
    // An identification file too.
    let identify = dir.join("identify");
    std::fs::create_dir_all(&identify).unwrap();
    std::fs::write(identify.join("identify.json"), b"{\"config\": ").unwrap();
    let err = refused(&identify_words(&identify, "0..1", &[]));
    assert!(err.contains("identify.json cannot be read"), "{err}");
    assert_eq!(bytes(&identify.join("identify.json")), b"{\"config\": ");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn runs_already_present_are_kept_and_the_summary_says_so() {
    let dir = scratch("resume-skip");
    let (one, two) = (dir.join("one"), dir.join("two"));
    ok(&puddle(&one, "0..3", &["--no-plots"]));
    ok(&puddle(&two, "0..2", &["--no-plots"]));
    let stdout = ok(&puddle(&two, "0..3", &["--no-plots"])).stdout;
    let stdout = String::from_utf8_lossy(&stdout);
    assert!(stdout.contains("Kept 2 run(s) already in"), "{stdout}");
    assert!(stdout.contains("fqi: 0, 1"), "{stdout}");
    assert_same_outputs(&one, &two, &["fqi.json", "summary.csv", "report.md"]);
    // Only run 2 was computed by the second invocation: its timing rows say so.
    let timing = String::from_utf8(bytes(&two.join("timing.csv"))).unwrap();
    let whole_runs: Vec<&str> = timing
        .lines()
        .filter(|l| l.split(',').nth(2) == Some("0"))
        .collect();
    assert_eq!(whole_runs.len(), 3, "{timing}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn concurrent_writers_into_one_directory_keep_every_run() {
    let dir = scratch("concurrent");
    let (shared, single) = (dir.join("shared"), dir.join("single"));
    let children: Vec<_> = (0..4)
        .map(|i| {
            let runs = format!("{}..{}", 2 * i, 2 * i + 2);
            Command::new(BIN)
                .args(puddle(&shared, &runs, &["--no-plots"]))
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for child in children {
        let out = child.wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert_eq!(
        run_indices(&shared.join("fqi.json")),
        (0..8).collect::<Vec<_>>()
    );
    ok(&puddle(&single, "0..8", &["--no-plots"]));
    assert_same_outputs(&shared, &single, &["fqi.json", "summary.csv", "report.md"]);
    let timing = String::from_utf8(bytes(&shared.join("timing.csv"))).unwrap();
    assert_eq!(
        timing
            .lines()
            .filter(|l| l.starts_with("algorithm,"))
            .count(),
        1
    );
    assert_eq!(timing.lines().count(), 1 + 8 * 2, "{timing}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn identify_words(out: &Path, runs: &str, extra: &[&str]) -> Vec<String> {
    let head = [
        "identify",
        "--budgets",
        "1,4",
        "--criteria",
        "uniform,variance",
        "--mi-samples",
        "10",
    ];
    words(&head, out, runs, extra)
}

#[test]
fn merge_equals_one_invocation_and_refuses_overlap_and_mismatch() {
    let dir = scratch("merge");
    let (single, a, b) = (dir.join("single"), dir.join("a"), dir.join("b"));
    ok(&puddle(&single, "0..4", &[]));
    ok(&puddle(&a, "0..1", &["--no-plots"]));
    ok(&puddle(&a, "3..4", &["--no-plots"]));
    ok(&puddle(&b, "1..3", &["--no-plots"]));
    let merged = dir.join("merged");
    let merge = |out: &Path, shards: &[&Path]| -> Vec<String> {
        let mut merge = vec!["merge".to_string(), out.display().to_string()];
        merge.extend(shards.iter().map(|s| s.display().to_string()));
        merge
    };
    ok(&merge(&merged, &[&a, &b]));
    assert_same_outputs(&single, &merged, &OUTPUTS);
    // Merging again into the same directory changes nothing.
    ok(&merge(&merged, &[&a, &b]));
    assert_same_outputs(&single, &merged, &OUTPUTS);
    let timing = String::from_utf8(bytes(&merged.join("timing.csv"))).unwrap();
    assert_eq!(timing.lines().count(), 1 + 4 * 2, "{timing}");
    // Overlapping shards, or shards of two configurations: refused, nothing written.
    let err = refused(&merge(&dir.join("overlap"), &[&a, &b, &a]));
    assert!(err.contains("fqi run 0 is in both"), "{err}");
    assert!(!dir.join("overlap").join("fqi.json").exists());
    let other = dir.join("other");
    ok(&puddle(&other, "4..5", &["--no-plots", "--seed", "7"]));
    let err = refused(&merge(&dir.join("mismatch"), &[&a, &other]));
    // (The shard that does not fit is named, with its value first.)
    assert!(
        err.contains("other/fqi.json holds runs of another configuration"),
        "{err}"
    );
    assert!(err.contains("experiment.seed: 7 → 0"), "{err}");
    assert!(!dir.join("mismatch").join("fqi.json").exists());
    // The identification study merges the same way.
    let (whole, i1, i2) = (dir.join("i-whole"), dir.join("i1"), dir.join("i2"));
    ok(&identify_words(&whole, "0..3", &["--no-plots"]));
    ok(&identify_words(&i1, "0..1", &["--no-plots"]));
    ok(&identify_words(&i2, "1..3", &["--no-plots"]));
    let imerged = dir.join("i-merged");
    let mut words = merge(&imerged, &[&i2, &i1]);
    words.push("--no-plots".into());
    ok(&words);
    assert_same_outputs(&whole, &imerged, &["identify.json", "identify.csv"]);
    // Another identification configuration in the same directory: refused.
    let err = refused(&identify_words(&i1, "1..2", &["--gamma", "0.8"]));
    assert!(err.contains("config.gamma: 0.9 → 0.8"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_invocation_killed_mid_run_loses_only_unfinished_runs_and_resumes() {
    let dir = scratch("sigkill");
    let (killed, reference) = (dir.join("killed"), dir.join("reference"));
    // Runs long enough to be caught in the middle (tens of milliseconds each).
    let words = puddle(&killed, "0..40", &["--no-plots", "--steps", "3"]);
    let mut child = Command::new(BIN)
        .args(&words)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let file = killed.join("fqi.json");
    let start = Instant::now();
    let mut seen = 0;
    while seen < 2 {
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no run finished"
        );
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the invocation ended ({status}) before it could be killed");
        }
        if let Ok(text) = std::fs::read(&file)
            && let Ok(v) = serde_json::from_slice::<serde_json::Value>(&text)
        {
            seen = v["n_runs"].as_u64().unwrap();
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    let survived = run_indices(&file);
    eprintln!("killed with {} of 40 runs saved", survived.len());
    assert!(
        survived.len() >= 2 && survived.len() < 40,
        "killed after {} runs: choose a longer configuration",
        survived.len()
    );
    ok(&puddle(
        &reference,
        "0..40",
        &["--no-plots", "--steps", "3"],
    ));
    // Every run that survived is whole and equals the uninterrupted one.
    let reference_runs = json(&reference.join("fqi.json"))["runs"].clone();
    for r in json(&file)["runs"].as_array().unwrap() {
        let i = r["run"].as_u64().unwrap() as usize;
        assert_eq!(*r, reference_runs[i], "run {i}");
    }
    // The same command finishes the rest.
    let stdout = String::from_utf8(ok(&words).stdout).unwrap();
    let kept = format!("Kept {} run(s)", survived.len());
    assert!(stdout.contains(&kept), "{stdout}");
    assert_same_outputs(
        &killed,
        &reference,
        &["fqi.json", "summary.csv", "report.md"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Whether this process can write into a directory whose write bits are cleared (root
/// can: permissions then stop nobody, so the test drops to another user instead).
fn permissions_bind_us(dir: &Path) -> bool {
    let probe = dir.join("probe");
    let bound = std::fs::write(&probe, b"").is_err();
    let _ = std::fs::remove_file(&probe);
    bound
}

/// `command.output()`, retried while the fresh copy of the binary is still open for
/// writing in a child another test thread forked meanwhile (`ETXTBSY`).
fn output_retrying_busy(command: &mut Command) -> Output {
    for _ in 0..100 {
        match command.output() {
            Err(e) if e.kind() == std::io::ErrorKind::ExecutableFileBusy => {
                std::thread::sleep(Duration::from_millis(20));
            }
            result => return result.unwrap(),
        }
    }
    panic!("the binary's copy stayed busy");
}

#[test]
fn a_write_that_fails_is_an_error_and_leaves_the_old_file() {
    use std::os::unix::fs::PermissionsExt as _;
    use std::os::unix::process::CommandExt as _;
    let dir = scratch("failed-write");
    // 1. A directory without write permission.
    let out = dir.join("read-only");
    ok(&puddle(&out, "0..1", &["--no-plots"]));
    let old = bytes(&out.join("fqi.json"));
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o555)).unwrap();
    let mut command = Command::new(BIN);
    if !permissions_bind_us(&out) {
        // Root: run as `nobody`, whom the permissions do stop, from a copy of the binary
        // that `nobody` can reach (the build directory may sit under a private home).
        let copy = dir.join("awfqi-harness");
        std::fs::copy(BIN, &copy).unwrap();
        std::fs::set_permissions(&copy, std::fs::Permissions::from_mode(0o755)).unwrap();
        command = Command::new(&copy);
        command.current_dir(&dir).uid(65_534).gid(65_534);
    }
    command.args(puddle(&out, "1..2", &["--no-plots"]));
    let result = output_retrying_busy(&mut command);
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o755)).unwrap();
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success(), "the write succeeded: {err}");
    assert!(err.contains("cannot be written"), "{err}");
    assert!(bytes(&out.join("fqi.json")) == old);

    // 2. A file-size limit (RLIMIT_FSIZE, as a full disk: the write fails part-way). The
    // harness ignores SIGXFSZ, so the write fails with EFBIG: an error naming the file, an
    // exit status of 1 (not death by the signal), and no temporary file left behind.
    let out = dir.join("limited");
    ok(&puddle(&out, "0..1", &["--no-plots"]));
    let old = bytes(&out.join("fqi.json"));
    let listing = names(&out);
    // 4 blocks of 512 bytes: the lock and probe files (empty) fit, two runs do not.
    assert!(
        old.len() > 4 * 512,
        "the result file is too small for the limit"
    );
    let result = Command::new("/bin/sh")
        .arg("-c")
        .arg("ulimit -f 4; exec \"$0\" \"$@\"")
        .arg(BIN)
        .args(puddle(&out, "1..2", &["--no-plots"]))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(1), "{:?}: {err}", result.status);
    assert!(
        err.contains("fqi.json failed; the previous file, if any, is unchanged"),
        "{err}"
    );
    assert!(bytes(&out.join("fqi.json")) == old);
    assert_eq!(names(&out), listing, "a temporary file was left behind");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_result_file_holding_a_run_index_twice_is_refused_in_runs_and_merges() {
    let dir = scratch("duplicate");
    let (edited, shard) = (dir.join("edited"), dir.join("shard"));
    ok(&puddle(&edited, "0..2", &["--no-plots"]));
    ok(&puddle(&shard, "2..3", &["--no-plots"]));
    // A hand edit: run 1 saved twice, the copy with another value.
    let path = edited.join("fqi.json");
    let mut v = json(&path);
    let mut copy = v["runs"][1].clone();
    copy["steps"][0]["perf_disc_greedy_mean"] = serde_json::json!(0.0);
    v["runs"].as_array_mut().unwrap().push(copy);
    v["n_runs"] = serde_json::json!(3);
    let text = serde_json::to_string_pretty(&v).unwrap();
    std::fs::write(&path, &text).unwrap();
    let named = format!("{} holds run 1 more than once", path.display());
    // Summarising, adding runs, merging it as a shard or into it: refused, nothing written.
    for words in [
        puddle(&edited, "0..2", &["--no-plots", "--no-run"]),
        puddle(&edited, "2..3", &["--no-plots"]),
        vec![
            "merge".into(),
            dir.join("merged").display().to_string(),
            edited.display().to_string(),
            shard.display().to_string(),
        ],
        vec![
            "merge".into(),
            edited.display().to_string(),
            shard.display().to_string(),
        ],
    ] {
        let err = refused(&words);
        assert!(err.contains(&named), "{words:?}: {err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
    }
    assert!(!dir.join("merged").join("fqi.json").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replace_starts_anew_only_the_files_of_the_algorithms_asked_for() {
    let dir = scratch("replace-only");
    let out = dir.join("out");
    ok(&puddle(&out, "0..1", &["--no-plots"]));
    // Another algorithm's file of this configuration (a copy stands in for it).
    std::fs::copy(out.join("fqi.json"), out.join("rbt.json")).unwrap();
    let (fqi, rbt) = (bytes(&out.join("fqi.json")), bytes(&out.join("rbt.json")));
    let listing = names(&out);
    // Another configuration with --replace for fqi only: rbt.json would have to go too,
    // so nothing is touched and the error names it.
    let err = refused(&puddle(
        &out,
        "0..1",
        &["--no-plots", "--steps", "2", "--replace"],
    ));
    assert!(
        err.contains(&format!("{}", out.join("rbt.json").display())),
        "{err}"
    );
    assert!(err.contains("add rbt to them"), "{err}");
    assert_eq!(names(&out), listing, "a file was moved or written");
    assert!(bytes(&out.join("fqi.json")) == fqi && bytes(&out.join("rbt.json")) == rbt);
    // Without the other file, --replace starts fqi.json anew as before.
    std::fs::remove_file(out.join("rbt.json")).unwrap();
    ok(&puddle(
        &out,
        "0..1",
        &["--no-plots", "--steps", "2", "--replace"],
    ));
    assert_eq!(
        json(&out.join("fqi.json"))["experiment"]["protocol"]["steps"],
        2
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn merge_names_shards_without_an_algorithm_s_file_and_refuses_an_empty_shard() {
    let dir = scratch("merge-shapes");
    let (a, b, empty) = (dir.join("a"), dir.join("b"), dir.join("empty"));
    ok(&puddle(&a, "0..1", &["--no-plots"]));
    ok(&puddle(&b, "1..2", &["--no-plots"]));
    std::fs::create_dir_all(&empty).unwrap();
    let merge = |out: &Path, shards: &[&Path]| -> Vec<String> {
        let mut words = vec!["merge".to_string(), out.display().to_string()];
        words.extend(shards.iter().map(|s| s.display().to_string()));
        words.push("--no-plots".into());
        words
    };
    // An empty shard: refused by name, and OUT is not created.
    let merged = dir.join("merged");
    let err = refused(&merge(&merged, &[&a, &empty, &b]));
    assert!(
        err.contains(&format!(
            "shard(s) {} hold no result files",
            empty.display()
        )),
        "{err}"
    );
    assert!(
        !merged.exists(),
        "the refused merge created {}",
        merged.display()
    );
    // A shard without an algorithm's file (here: a's rbt.json, which b lacks) is named.
    std::fs::copy(a.join("fqi.json"), a.join("rbt.json")).unwrap();
    let out = ok(&merge(&merged, &[&a, &b]));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!(
            "rbt.json is in {} but not in {}",
            a.display(),
            b.display()
        )),
        "{err}"
    );
    assert_eq!(run_indices(&merged.join("rbt.json")), [0]);
    assert_eq!(run_indices(&merged.join("fqi.json")), [0, 1]);
    let _ = std::fs::remove_dir_all(&dir);
}
