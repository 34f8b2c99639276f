//! Every door of the harness refuses bad input with a clear error — naming the file, the
//! line and the field, or the option — and a non-zero exit, before any result file is
//! written: source CSVs (column set, numbers, states inside the environment's space —
//! Puddle World's [0, 10]², the Dam's storage ≥ 0 and integer day in 1..=360, Acrobot's
//! angles and velocity ranges —, actions, absorbing flags), GP case JSON, CLI ranges and an
//! output directory that cannot be written. The binary is run as a user would run it.

use std::path::{Path, PathBuf};
use std::process::Command;

const PUBLISHED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/data/puddle-sources");

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("awfqi-bad-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the harness; returns (exit success, stderr).
fn harness(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_awfqi-harness"))
        .args(args)
        .output()
        .expect("the harness runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A copy of the published shared-dynamics sources in `dir`, with line `line` (1-based,
/// the header is line 1) of source 2 changed by `edit`.
fn sources_with(dir: &Path, line: usize, edit: impl Fn(&mut Vec<String>)) {
    for k in 1..=3 {
        let name = format!("shared_dynamics_source_{k}.csv");
        let text = std::fs::read_to_string(Path::new(PUBLISHED).join(&name)).unwrap();
        let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
        if k == 2 {
            let mut cells: Vec<String> = lines[line - 1].split(',').map(str::to_owned).collect();
            edit(&mut cells);
            lines[line - 1] = cells.join(",");
        }
        std::fs::write(dir.join(&name), lines.join("\n") + "\n").unwrap();
    }
}

/// `puddle` on `sources` with a budget that would finish in a second, into `out`.
fn puddle_on(sources: &Path, out: &Path) -> (bool, String) {
    harness(&[
        "puddle",
        "--sources",
        sources.to_str().unwrap(),
        "--algorithms",
        "fqi",
        "--steps",
        "1",
        "--runs",
        "1",
        "--iterations",
        "1",
        "--trees",
        "1",
        "--quiet",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ])
}

/// Asserts the run failed, its message names every part, and no result file was written.
fn refused(result: (bool, String), parts: &[&str], out: &Path) {
    let (ok, stderr) = result;
    assert!(!ok, "accepted; stderr:\n{stderr}");
    for part in parts {
        assert!(stderr.contains(part), "{part:?} not named in:\n{stderr}");
    }
    let written: Vec<_> = std::fs::read_dir(out)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name()).collect())
        .unwrap_or_default();
    assert!(
        written
            .iter()
            .all(|n| !n.to_string_lossy().ends_with(".json")
                && !n.to_string_lossy().ends_with(".csv")),
        "result files left behind: {written:?}"
    );
}

#[test]
fn a_state_outside_the_world_names_file_line_and_field() {
    let dir = scratch("state");
    // Line 5 of source 2: s_x = 55, outside [0, 10]².
    sources_with(&dir, 5, |c| c[1] = "55".into());
    let out = dir.join("out");
    refused(
        puddle_on(&dir, &out),
        &[
            "shared_dynamics_source_2.csv",
            "line 5",
            "`s_x`",
            "55",
            "[0, 10]",
        ],
        &out,
    );
    // A next state too.
    sources_with(&dir, 7, |c| c[6] = "-0.5".into());
    refused(
        puddle_on(&dir, &out),
        &[
            "shared_dynamics_source_2.csv",
            "line 7",
            "`next_s_y`",
            "-0.5",
        ],
        &out,
    );
}

#[test]
fn bad_actions_flags_numbers_and_columns_are_named() {
    let dir = scratch("cells");
    let out = dir.join("out");
    sources_with(&dir, 3, |c| c[3] = "7".into());
    refused(puddle_on(&dir, &out), &["line 3", "`a`", "action 7"], &out);
    sources_with(&dir, 3, |c| c[3] = "1.5".into());
    refused(puddle_on(&dir, &out), &["line 3", "`a`", "1.5"], &out);
    sources_with(&dir, 4, |c| c[7] = "2".into());
    refused(
        puddle_on(&dir, &out),
        &["line 4", "`absorbing`", "not 0 or 1"],
        &out,
    );
    sources_with(&dir, 6, |c| c[4] = "NaN".into());
    refused(
        puddle_on(&dir, &out),
        &["line 6", "`r`", "non-finite"],
        &out,
    );
    sources_with(&dir, 6, |c| c[4] = "inf".into());
    refused(
        puddle_on(&dir, &out),
        &["line 6", "`r`", "non-finite"],
        &out,
    );
    sources_with(&dir, 6, |c| c[2] = "one".into());
    refused(
        puddle_on(&dir, &out),
        &["line 6", "`s_y`", "not a number"],
        &out,
    );
    sources_with(&dir, 8, |c| c[0] = "-1".into());
    refused(
        puddle_on(&dir, &out),
        &["line 8", "`t`", "time index"],
        &out,
    );
    sources_with(&dir, 8, |c| c[9] = "-0.5".into());
    refused(
        puddle_on(&dir, &out),
        &["line 8", "`src_gp_r_std_noise_subtracted`", "negative"],
        &out,
    );
    sources_with(&dir, 9, |c| {
        c.pop();
    });
    refused(
        puddle_on(&dir, &out),
        &["line 9", "13 columns instead of 14"],
        &out,
    );
    // The column set: a header without `absorbing`.
    sources_with(&dir, 1, |c| c[7] = "done".into());
    refused(
        puddle_on(&dir, &out),
        &[
            "shared_dynamics_source_2.csv",
            "line 1",
            "missing columns [\"absorbing\"]",
            "done",
        ],
        &out,
    );
    // A missing file.
    sources_with(&dir, 2, |_| {});
    std::fs::remove_file(dir.join("shared_dynamics_source_3.csv")).unwrap();
    refused(
        puddle_on(&dir, &out),
        &["shared_dynamics_source_3.csv"],
        &out,
    );
}

#[test]
fn the_published_sources_pass_the_same_checks() {
    let dir = scratch("published");
    sources_with(&dir, 2, |_| {});
    let out = dir.join("out");
    let (ok, stderr) = puddle_on(&dir, &out);
    assert!(ok, "{stderr}");
    assert!(out.join("fqi.json").exists());
    assert!(!out.join("fqi.json.partial").exists());
}

#[test]
fn cli_ranges_are_checked_before_anything_runs() {
    let dir = scratch("cli");
    let out = dir.join("out");
    let out_s = out.to_str().unwrap();
    let base = [
        "puddle",
        "--algorithms",
        "fqi",
        "--quiet",
        "--no-plots",
        "--out",
        out_s,
    ];
    for (extra, named) in [
        (&["--steps", "0"][..], "--steps 0"),
        (&["--steps", "100000"], "--steps 100000"),
        (&["--episodes-per-step", "0"], "--episodes-per-step 0"),
        (&["--runs", "0"], "empty run range 0..0"),
        (&["--iterations", "0"], "--iterations 0"),
        (&["--trees", "0"], "--trees 0"),
        (&["--max-gp", "0"], "--max-gp 0"),
        (&["--rbt-total", "0"], "--rbt-total 0"),
        (&["--gp-restarts", "1000000"], "--gp-restarts 1000000"),
        (&["--spacing", "0"], "--spacing 0"),
        (&["--spacing", "NaN"], "--spacing NaN"),
        (&["--seed", "1e3"], "--seed <SEED>"),
        (&["--runs", "5..2"], "5..2"),
    ] {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        refused(harness(&args), &[named], &out);
    }
}

#[test]
fn an_output_directory_that_cannot_be_written_is_named() {
    let dir = scratch("unwritable");
    // A regular file where the output directory should be: nothing can be created under it
    // (a permission test would not hold for root).
    let blocker = dir.join("not-a-directory");
    std::fs::write(&blocker, "x").unwrap();
    let out = blocker.join("results");
    let (ok, stderr) = harness(&[
        "puddle",
        "--algorithms",
        "fqi",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        stderr.contains("output directory") && stderr.contains("not-a-directory/results"),
        "{stderr}"
    );
}

#[test]
fn a_malformed_gp_case_file_names_file_line_and_field() {
    let dir = scratch("gp");
    let file = dir.join("cases.json");
    std::fs::write(
        &file,
        "{\"cases\": [\n  {\"name\": \"a\", \"x\": [[0.0]], \"y\": [1.0],\n   \"signal_variance\": 1.0, \"length_scales\": [1.0],\n   \"x_test\": [[0.5]]}\n]}\n",
    )
    .unwrap();
    let (ok, stderr) = harness(&["gp", "--cases", file.to_str().unwrap()]);
    assert!(!ok);
    for part in ["cases.json", "line 4", "noise_variance"] {
        assert!(stderr.contains(part), "{part:?} not in {stderr}");
    }
    let (ok, stderr) = harness(&["gp", "--cases", dir.join("absent.json").to_str().unwrap()]);
    assert!(!ok && stderr.contains("absent.json"), "{stderr}");
}

/// The IWFQI paper's published Dam and Acrobot source files (gzip-compressed CSV, see
/// `data/iwfqi-sources/README.md`).
const IWFQI_PUBLISHED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/data/iwfqi-sources");

/// Copies of `prefix`'s `count` published source files in `dir`, with line `line` of source
/// `k` changed by `edit`.
fn iwfqi_sources_with(
    dir: &Path,
    prefix: &str,
    count: usize,
    (k, line): (usize, usize),
    edit: impl Fn(&mut Vec<String>),
) {
    use std::io::Read;
    for j in 1..=count {
        let name = format!("{prefix}_source_{j}.csv");
        let gz = std::fs::read(Path::new(IWFQI_PUBLISHED).join(format!("{name}.gz"))).unwrap();
        let mut text = String::new();
        flate2::read::GzDecoder::new(&gz[..])
            .read_to_string(&mut text)
            .unwrap();
        let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
        if j == k {
            let mut cells: Vec<String> = lines[line - 1].split(',').map(str::to_owned).collect();
            edit(&mut cells);
            lines[line - 1] = cells.join(",");
        }
        std::fs::write(dir.join(&name), lines.join("\n") + "\n").unwrap();
    }
}

/// `command` (`dam` or `acrobot`) on the source directory `sources`, into `out`.
fn transfer_on(command: &str, sources: &Path, out: &Path) -> (bool, String) {
    harness(&[
        command,
        "--sources",
        sources.to_str().unwrap(),
        "--algorithms",
        "fqi",
        "--steps",
        "1",
        "--runs",
        "1",
        "--iterations",
        "1",
        "--trees",
        "1",
        "--quiet",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ])
}

#[test]
fn dam_sources_outside_the_reservoirs_state_space_are_named() {
    let dir = scratch("dam");
    let out = dir.join("out");
    // Columns: t, storage, day, a, r, next_storage, next_day, absorbing, ….
    iwfqi_sources_with(&dir, "dam", 6, (4, 5), |c| c[1] = "-3".into());
    refused(
        transfer_on("dam", &dir, &out),
        &["dam_source_4.csv", "line 5", "`storage`", "-3", "[0, inf]"],
        &out,
    );
    iwfqi_sources_with(&dir, "dam", 6, (2, 9), |c| c[2] = "361".into());
    refused(
        transfer_on("dam", &dir, &out),
        &["dam_source_2.csv", "line 9", "`day`", "361", "[1, 360]"],
        &out,
    );
    iwfqi_sources_with(&dir, "dam", 6, (6, 3), |c| c[6] = "12.5".into());
    refused(
        transfer_on("dam", &dir, &out),
        &["dam_source_6.csv", "line 3", "`next_day`", "not an integer"],
        &out,
    );
    // A release that is not one of the eight, a flag other than 0/1, a non-finite reward.
    iwfqi_sources_with(&dir, "dam", 6, (1, 4), |c| c[3] = "4".into());
    refused(
        transfer_on("dam", &dir, &out),
        &["dam_source_1.csv", "line 4", "`a`", "action 4"],
        &out,
    );
    iwfqi_sources_with(&dir, "dam", 6, (3, 7), |c| c[7] = "0.5".into());
    refused(
        transfer_on("dam", &dir, &out),
        &["dam_source_3.csv", "line 7", "`absorbing`", "not 0 or 1"],
        &out,
    );
    iwfqi_sources_with(&dir, "dam", 6, (5, 8), |c| c[4] = "NaN".into());
    refused(
        transfer_on("dam", &dir, &out),
        &["dam_source_5.csv", "line 8", "`r`", "non-finite"],
        &out,
    );
}

#[test]
fn acrobot_sources_outside_the_arms_state_space_are_named() {
    let dir = scratch("acrobot");
    let out = dir.join("out");
    // Columns: t, θ₁, θ₂, θ̇₁, θ̇₂, a, r, next θ₁, next θ₂, next θ̇₁, next θ̇₂, absorbing, ….
    // θ̇₂ = 30 > 9π.
    iwfqi_sources_with(&dir, "acrobot", 2, (1, 3), |c| c[4] = "30".into());
    refused(
        transfer_on("acrobot", &dir, &out),
        &["acrobot_source_1.csv", "line 3", "`dtheta2`", "30"],
        &out,
    );
    // A next angle beyond π.
    iwfqi_sources_with(&dir, "acrobot", 2, (2, 6), |c| c[7] = "3.2".into());
    refused(
        transfer_on("acrobot", &dir, &out),
        &["acrobot_source_2.csv", "line 6", "`next_theta1`", "3.2"],
        &out,
    );
    iwfqi_sources_with(&dir, "acrobot", 2, (2, 4), |c| c[5] = "2".into());
    refused(
        transfer_on("acrobot", &dir, &out),
        &["acrobot_source_2.csv", "line 4", "`a`", "action 2"],
        &out,
    );
    iwfqi_sources_with(&dir, "acrobot", 2, (1, 2), |c| c[11] = "-1".into());
    refused(
        transfer_on("acrobot", &dir, &out),
        &[
            "acrobot_source_1.csv",
            "line 2",
            "`absorbing`",
            "not 0 or 1",
        ],
        &out,
    );
    iwfqi_sources_with(&dir, "acrobot", 2, (1, 9), |c| c[2] = "inf".into());
    refused(
        transfer_on("acrobot", &dir, &out),
        &["acrobot_source_1.csv", "line 9", "`theta2`", "non-finite"],
        &out,
    );
}

#[test]
fn the_published_dam_and_acrobot_sources_pass_the_same_checks() {
    use awfqi_harness::transfer::domain_data::{acrobot, dam};
    use awfqi_harness::transfer::sources::SourceSet;
    let dir = scratch("iwfqi-published");
    // Unchanged copies (line 1 edited by nothing), read through the `--sources DIR` door.
    iwfqi_sources_with(&dir, "dam", 6, (1, 1), |_| {});
    iwfqi_sources_with(&dir, "acrobot", 2, (1, 1), |_| {});
    let dam = SourceSet::<2>::read_layout(&dir, &dam::layout(), 6, 8).unwrap();
    assert_eq!(dam.total_records(), 6 * 10_800);
    // The storage exceeds the 500 that forces a release (the space is unbounded above).
    let max_storage = dam
        .sources
        .iter()
        .flat_map(|s| &s.records)
        .map(|r| r.next_state[0])
        .fold(0.0, f64::max);
    assert!(max_storage > 500.0, "{max_storage}");
    let acrobot = SourceSet::<4>::read_layout(&dir, &acrobot::layout(), 2, 2).unwrap();
    assert_eq!(acrobot.total_records(), 3_400 + 5_000);
}

#[test]
fn run_counts_and_threads_have_upper_bounds() {
    let dir = scratch("bounds");
    let out = dir.join("out");
    let out_s = out.to_str().unwrap();
    let base = ["puddle", "--algorithms", "fqi", "--quiet", "--out", out_s];
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let too_many = (4 * cores + 1).to_string();
    for (extra, named) in [
        (
            &["--runs", "0..100000000"][..],
            "100000000 runs, more than the 100000",
        ),
        (&["--runs", "100001"], "100001 runs"),
        (&["--threads", "100000"], "--threads 100000 is out of range"),
        (&["--threads", &too_many], "4 per core"),
    ] {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        refused(harness(&args), &[named], &out);
        assert!(!out.exists(), "{extra:?} created {}", out.display());
    }
    // The identification study shares `--runs`.
    let (ok, stderr) = harness(&["identify", "--runs", "0..200000", "--out", out_s]);
    assert!(!ok && stderr.contains("200000 runs"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn a_refused_invocation_creates_no_output_directory() {
    let dir = scratch("no-dir");
    // Sources that cannot be read, and a range error: refused before anything is created.
    let out = dir.join("out");
    std::fs::create_dir_all(dir.join("sources")).unwrap();
    refused(
        puddle_on(&dir.join("sources"), &out),
        &["shared_dynamics_source_1.csv"],
        &out,
    );
    assert!(!out.exists(), "{} was created", out.display());
    // The identification study too: a configuration the core refuses creates nothing.
    let (ok, stderr) = harness(&["identify", "--gamma", "2", "--out", out.to_str().unwrap()]);
    assert!(!ok && stderr.contains("gamma"), "{stderr}");
    assert!(!out.exists(), "{} was created", out.display());
    // An existing file that is not a directory is named as such.
    for blocker in [Path::new("/dev/null").to_path_buf(), dir.join("a-file")] {
        if !blocker.exists() {
            std::fs::write(&blocker, "x").unwrap();
        }
        let (ok, stderr) = harness(&[
            "puddle",
            "--algorithms",
            "fqi",
            "--steps",
            "1",
            "--runs",
            "1",
            "--quiet",
            "--out",
            blocker.to_str().unwrap(),
        ]);
        assert!(!ok);
        assert!(
            stderr.contains(&format!(
                "{}: it exists and is not a directory",
                blocker.display()
            )),
            "{stderr}"
        );
    }
    assert_eq!(std::fs::read(dir.join("a-file")).unwrap(), b"x");
}

#[test]
fn a_source_file_that_is_not_utf8_names_the_line() {
    let dir = scratch("utf8");
    sources_with(&dir, 2, |_| {});
    let path = dir.join("shared_dynamics_source_2.csv");
    let mut bytes = std::fs::read(&path).unwrap();
    // Line 4 starts after the third newline; put a Latin-1 byte two bytes into it.
    let at = bytes
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .nth(2)
        .unwrap()
        .0
        + 3;
    bytes[at] = 0xE9;
    std::fs::write(&path, bytes).unwrap();
    let out = dir.join("out");
    refused(
        puddle_on(&dir, &out),
        &[
            "shared_dynamics_source_2.csv",
            "line 4, byte 3",
            "not UTF-8",
        ],
        &out,
    );
}

#[test]
fn long_values_are_cut_in_messages() {
    let dir = scratch("long");
    let out = dir.join("out");
    let long = "9".repeat(5_000) + "x";
    sources_with(&dir, 5, |c| c[4] = long.clone());
    let (ok, stderr) = puddle_on(&dir, &out);
    assert!(!ok);
    let shown = format!("\"{}\"… ({} bytes in all)", "9".repeat(80), long.len());
    assert!(stderr.contains("line 5, field `r`"), "{stderr}");
    assert!(stderr.contains(&shown), "{stderr}");
    assert!(stderr.len() < 1_000, "{} bytes of stderr", stderr.len());
    // A header of one huge column name too.
    sources_with(&dir, 1, |c| c[7] = "y".repeat(100_000));
    let (ok, stderr) = puddle_on(&dir, &out);
    assert!(
        !ok && stderr.contains("line 1") && stderr.len() < 2_000,
        "{stderr}"
    );
}

#[test]
fn errors_are_plain_messages_unless_a_debug_report_is_asked_for() {
    let dir = scratch("backtrace");
    let out = dir.join("out");
    let words = [
        "puddle",
        "--algorithms",
        "fqi",
        "--steps",
        "0",
        "--out",
        out.to_str().unwrap(),
    ];
    let run = |env: &[(&str, &str)]| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_awfqi-harness"));
        command.args(words).env_remove("AWFQI_DEBUG");
        for (k, v) in env {
            command.env(k, v);
        }
        let output = command.output().unwrap();
        assert_eq!(output.status.code(), Some(1));
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    for env in [
        &[][..],
        &[("RUST_BACKTRACE", "1")],
        &[("RUST_BACKTRACE", "full")],
    ] {
        let stderr = run(env);
        assert!(
            stderr.starts_with("Error: --steps 0 is out of range"),
            "{stderr}"
        );
        assert!(
            !stderr.to_lowercase().contains("backtrace"),
            "{env:?}: {stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
    let stderr = run(&[("AWFQI_DEBUG", "1")]);
    assert!(stderr.contains("--steps 0 is out of range"), "{stderr}");
    assert!(stderr.contains("Stack backtrace"), "{stderr}");
}
