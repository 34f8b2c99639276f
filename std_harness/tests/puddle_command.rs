//! End-to-end: `awfqi-harness puddle` on a tiny budget writes every output, the same seed
//! gives the same files, and runs computed in two slices merge into the files of one
//! invocation.

use std::path::Path;

use awfqi_harness::commands::puddle::{Args, run};

mod common;

fn args(out: &Path, runs: &str, algorithms: &str) -> Args {
    args_with(out, runs, algorithms, &[])
}

/// [`args`] followed by `extra` options.
fn args_with(out: &Path, runs: &str, algorithms: &str, extra: &[&str]) -> Args {
    let fixed = [
        "puddle",
        "--setting",
        "source",
        "--steps",
        "2",
        "--runs",
        runs,
        "--algorithms",
        algorithms,
        "--iterations",
        "3",
        "--trees",
        "3",
        "--gp-restarts",
        "0",
        "--rbt-total",
        "50",
        "--threads",
        "2",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    common::parse(&[&fixed[..], extra].concat())
}

fn read(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap()
}

#[test]
fn outputs_are_complete_deterministic_and_mergeable() {
    let base = std::env::temp_dir().join(format!("awfqi-puddle-{}", std::process::id()));
    let (a, b, c) = (base.join("a"), base.join("b"), base.join("c"));
    // The GP-free algorithms (fast in debug builds) for the determinism and merge checks;
    // IWFQI and the kernel once more below.
    let cheap = "fqi,iwfqi-ideal,rbt,sdt,awfqi-oracle";
    run(&args(&a, "2", cheap)).unwrap();
    run(&args(&b, "2", cheap)).unwrap();
    run(&args(&c, "0..1", cheap)).unwrap();
    run(&args(&c, "1..2", cheap)).unwrap();
    let algorithms = ["fqi", "iwfqi-ideal", "rbt", "sdt", "awfqi-oracle"];
    for dir in [&a, &c] {
        for f in [
            "summary.csv",
            "report.md",
            "transfer_metrics.csv",
            "timing.csv",
        ] {
            assert!(dir.join(f).exists(), "{f}");
        }
        for f in ["learning_curves", "target_samples"] {
            assert!(dir.join(f).with_extension("png").exists(), "{f}.png");
            assert!(dir.join(f).with_extension("svg").exists(), "{f}.svg");
        }
    }
    for name in algorithms {
        let file = format!("{name}.json");
        let json: serde_json::Value = serde_json::from_str(&read(&a, &file)).unwrap();
        assert_eq!(json["n_runs"], 2);
        let runs = json["runs"].as_array().unwrap();
        for (i, r) in runs.iter().enumerate() {
            assert_eq!(r["run"], i);
            assert_eq!(r["parameters"]["algorithm"], name);
            let steps = r["steps"].as_array().unwrap();
            assert_eq!(steps.len(), 2);
            for (k, s) in steps.iter().enumerate() {
                assert_eq!(s["step"], k + 1);
                assert_eq!(s["n_episodes"], k + 1);
                for field in [
                    "n_target_samples",
                    "perf_disc_greedy_mean",
                    "perf_disc_greedy_std",
                ] {
                    assert!(s[field].is_number(), "{name}: {field}");
                }
            }
            // Active algorithms query exactly H·B = 50 pairs per step.
            if name.starts_with("awfqi") {
                assert_eq!(steps[1]["n_target_samples"], 100);
            }
        }
        // Same seed, same file; two slices merge into the same file as one invocation.
        // (Compared as booleans: a failure message with the files would be megabytes.)
        let same = read(&a, &file) == read(&b, &file);
        assert!(same, "{file} differs between identical invocations");
        let merged = read(&a, &file) == read(&c, &file);
        assert!(merged, "{file}: merged slices differ from one invocation");
    }
    assert!(read(&a, "summary.csv") == read(&c, "summary.csv"));
    let summary = read(&a, "summary.csv");
    assert!(summary.starts_with("algorithm,step,n_episodes,n_target_samples,mean,stderr,runs\n"));
    assert_eq!(summary.lines().count(), 1 + 2 * algorithms.len());
    // IWFQI and the core's algorithms report their weight diagnostics, RBT its compliances.
    let d = base.join("d");
    run(&args(&d, "1", "iwfqi,awfqi-embedded,awfqi-adaptive")).unwrap();
    for name in ["iwfqi", "awfqi-embedded", "awfqi-adaptive"] {
        let json: serde_json::Value =
            serde_json::from_str(&read(&d, &format!("{name}.json"))).unwrap();
        let step = &json["runs"][0]["steps"][1];
        assert!(step["wr_eff"].as_f64().unwrap() > 0.0, "{name}");
        assert!(step["reward_gp"]["noise_variance"].is_number(), "{name}");
    }
    // The adaptive AWFQI spends 50 queries per step and names its own approximator and GPs
    // (the recommended model sweep, 32 points, warm refits).
    let adaptive: serde_json::Value =
        serde_json::from_str(&read(&d, "awfqi-adaptive.json")).unwrap();
    let steps = &adaptive["runs"][0]["steps"];
    assert_eq!(steps[0]["n_target_samples"].as_f64(), Some(50.0));
    assert_eq!(steps[1]["n_target_samples"].as_f64(), Some(100.0));
    let embedded = &adaptive["runs"][0]["parameters"]["embedded"];
    assert_eq!(
        embedded["fqi_sweep_cells"],
        serde_json::json!(12),
        "{embedded}"
    );
    assert_eq!(embedded["fqi_sweep_rewards"], serde_json::json!("Pooled"));
    assert_eq!(embedded["gp_capacity"], serde_json::json!(32));
    let options = &adaptive["runs"][0]["parameters"]["adaptive"];
    assert_eq!(options["candidates"], serde_json::json!(250), "{options}");
    assert_eq!(options["refit"], serde_json::json!([30, 0]));
    let rbt: serde_json::Value = serde_json::from_str(&read(&a, "rbt.json")).unwrap();
    let c0 = rbt["runs"][0]["steps"][0]["compliances"]
        .as_array()
        .unwrap();
    let total: f64 = c0.iter().map(|v| v.as_f64().unwrap()).sum();
    assert!((total - 1.0).abs() < 1e-9);
    std::fs::remove_dir_all(&base).unwrap();
}

/// awfqi's, awfqi-oracle's and iwfqi-heuristic's default GP search is the screened one as
/// well (each checked on 10 runs): their fits run it (the check's file says which search
/// each fit kept), their result files and the report's header say so.
#[test]
fn awfqi_awfqi_oracle_and_iwfqi_heuristic_default_to_the_screened_search() {
    let dir = std::env::temp_dir().join(format!("awfqi-gp-search-awfqi-{}", std::process::id()));
    let extra = ["--episodes-per-step", "1", "--check-gp-search"];
    let algorithms = "iwfqi-heuristic,awfqi,awfqi-oracle";
    run(&args_with(&dir, "1", algorithms, &extra)).unwrap();
    let parameters = |file: &str| -> serde_json::Value {
        let v: serde_json::Value = serde_json::from_str(&read(&dir, file)).unwrap();
        v["runs"][0]["parameters"].clone()
    };
    for name in ["iwfqi-heuristic", "awfqi", "awfqi-oracle"] {
        assert_eq!(parameters(&format!("{name}.json"))["gp_search"], "screened");
    }
    let report = read(&dir, "report.md");
    assert!(
        report.contains("Spec (iwfqi-heuristic, awfqi, awfqi-oracle: Screened) search"),
        "{report}"
    );
    // Every target fit (3 algorithms × 2 steps) kept the screened search; the spec's is
    // kept only by the realistic score table's fits of the 3 published sources.
    let check = read(&dir, "gp_search_check.tsv");
    let rows: Vec<Vec<&str>> = check
        .lines()
        .skip(1)
        .map(|l| l.split('\t').collect())
        .collect();
    let screened = rows.iter().filter(|r| r[0] == "Screened").count();
    let spec: Vec<&str> = rows
        .iter()
        .filter(|r| r[0] == "Spec")
        .map(|r| r[1])
        .collect();
    assert_eq!(screened, 6, "{check}");
    assert_eq!(spec, ["291", "423", "319"], "{check}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// iwfqi's default GP search on Puddle World: the screened one with and without transition
/// weights (its result file says so), the spec's whenever `--gp-search` names it. Below 300
/// points the screened search is the spec's (docs/algorithms.md §4.6), so on this small
/// budget both give the same returns.
#[test]
fn iwfqi_defaults_to_the_screened_search_on_puddle_world() {
    let base = std::env::temp_dir().join(format!("awfqi-gp-search-{}", std::process::id()));
    let one = ["--episodes-per-step", "1"];
    let run_in = |name: &str, extra: &[&str]| -> serde_json::Value {
        let dir = base.join(name);
        let all: Vec<&str> = one.iter().chain(extra).copied().collect();
        run(&args_with(&dir, "1", "iwfqi", &all)).unwrap();
        serde_json::from_str(&read(&dir, "iwfqi.json")).unwrap()
    };
    let default = run_in("default", &[]);
    let spec = run_in("spec", &["--gp-search", "spec"]);
    let puddle = run_in("puddle", &["--dynamics", "puddle"]);
    let parameters = |v: &serde_json::Value| v["runs"][0]["parameters"].clone();
    assert_eq!(parameters(&default)["gp_search"], "screened");
    assert!(parameters(&spec).get("gp_search").is_none());
    assert_eq!(parameters(&puddle)["gp_search"], "screened");
    // The experiment says which search was asked for, so the two files do not merge.
    assert!(
        default["experiment"]["options"]["gp"]
            .get("search")
            .is_none()
    );
    assert_eq!(spec["experiment"]["options"]["gp"]["search"], "spec");
    let returns = |v: &serde_json::Value| v["runs"][0]["steps"][0]["perf_disc_greedy_mean"].clone();
    assert!(returns(&default).is_number());
    assert_eq!(returns(&default), returns(&spec));
    let _ = std::fs::remove_dir_all(&base);
}

/// `--q-function joint` (the reference's one forest over state and action value) runs the
/// episodic baselines — their result files say so and differ from the per-action
/// forests' — and is refused with an active algorithm, which plans its own queries.
#[test]
fn the_joint_q_function_runs_the_baselines_and_refuses_active_algorithms() {
    let base = std::env::temp_dir().join(format!("awfqi-joint-{}", std::process::id()));
    let baselines = "fqi,iwfqi-ideal,rbt,sdt";
    let joint = base.join("joint");
    let per_action = base.join("per-action");
    run(&args_with(
        &joint,
        "1",
        baselines,
        &["--q-function", "joint"],
    ))
    .unwrap();
    run(&args(&per_action, "1", baselines)).unwrap();
    for name in ["fqi", "iwfqi-ideal", "rbt", "sdt"] {
        let file = format!("{name}.json");
        let j: serde_json::Value = serde_json::from_str(&read(&joint, &file)).unwrap();
        let p: serde_json::Value = serde_json::from_str(&read(&per_action, &file)).unwrap();
        assert_eq!(j["experiment"]["protocol"]["q_function"], "joint", "{name}");
        assert!(
            p["experiment"]["protocol"].get("q_function").is_none(),
            "{name}"
        );
        let returns =
            |v: &serde_json::Value| v["runs"][0]["steps"][1]["perf_disc_greedy_mean"].clone();
        assert!(returns(&j).as_f64().unwrap().is_finite(), "{name}");
        assert_ne!(j["runs"][0]["steps"], p["runs"][0]["steps"], "{name}");
    }
    let refused = run(&args_with(
        &base.join("active"),
        "1",
        "fqi,awfqi",
        &["--q-function", "joint"],
    ));
    assert!(format!("{:#}", refused.unwrap_err()).contains("--q-function joint"));
    let _ = std::fs::remove_dir_all(&base);
}

/// Each subcommand offers only the flags that apply to it: Puddle World's dynamics are not
/// in `dam --help` or `acrobot --help`; the core algorithms' options and the query budget
/// are in every command's.
#[test]
fn dam_and_acrobot_offer_no_puddle_world_flags() {
    let help = |command: &str| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_awfqi-harness"))
            .args([command, "--help"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{command} --help");
        String::from_utf8(out.stdout).unwrap()
    };
    let everywhere = [
        "--embedded-q",
        "--adaptive-q",
        "--adaptive-sweep-cells",
        "--queries-per-step",
        "--episode-length",
    ];
    let puddle = help("puddle");
    for flag in everywhere.iter().chain(&["--dynamics"]) {
        assert!(puddle.contains(flag), "puddle --help lacks {flag}");
    }
    for command in ["dam", "acrobot"] {
        let text = help(command);
        assert!(text.contains("--algorithms") && text.contains("--fixed-gp-variance"));
        assert!(
            !text.contains("--dynamics"),
            "{command} --help offers --dynamics"
        );
        for flag in everywhere {
            assert!(text.contains(flag), "{command} --help lacks {flag}");
        }
    }
}
