//! End-to-end: every active algorithm (`awfqi`, `awfqi-oracle`, `awfqi-embedded`,
//! `awfqi-adaptive`) runs on the Dam and on Acrobot with a query budget per step
//! (`--queries-per-step`), and FQI with episodes cut to the same number of samples
//! (`--episode-length`). Tiny sources (the first records of each published source) keep a
//! debug build fast.

use std::path::{Path, PathBuf};

use awfqi_harness::commands::{acrobot, dam};
use awfqi_harness::transfer::domain_data::DomainData;

mod common;

/// The first `n` records of every published source of `data`, written in the published
/// layout to `dir`.
fn tiny_sources<const D: usize>(data: &DomainData<D>, n: usize, dir: &Path) {
    let mut set = (data.published)().unwrap();
    for s in &mut set.sources {
        s.records.truncate(n);
        s.times.truncate(n);
        s.reward.truncate(n);
        for dim in &mut s.next_state {
            dim.truncate(n);
        }
    }
    set.write_dir(dir, &data.layout).unwrap();
}

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("awfqi-active-{name}-{}", std::process::id()))
}

fn read(dir: &Path, name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join(format!("{name}.json"))).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// The command line of a tiny run: 2 steps of 6 queries, FQI's one episode per step cut
/// to as many steps, 1 run.
fn words<'a>(command: &'a str, sources: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let fixed = [
        command,
        "--sources",
        sources,
        "--algorithms",
        "fqi,awfqi,awfqi-oracle,awfqi-embedded,awfqi-adaptive",
        "--steps",
        "2",
        "--runs",
        "1",
        "--queries-per-step",
        "6",
        "--episode-length",
        "6",
        "--episodes-per-step",
        "1",
        "--max-gp",
        "40",
        "--adaptive-candidates",
        "20",
        "--adaptive-gp-points",
        "16",
        "--out",
        out,
    ];
    [&fixed[..], &common::QUICK[..], extra].concat()
}

/// What every tiny run must show: each algorithm collected exactly its budget per step
/// (FQI: one episode of 6 steps at most), recorded the budget, and has finite returns.
fn check(out: &Path) {
    for name in [
        "fqi",
        "awfqi",
        "awfqi-oracle",
        "awfqi-embedded",
        "awfqi-adaptive",
    ] {
        let v = read(out, name);
        let protocol = &v["experiment"]["protocol"];
        assert_eq!(protocol["queries_per_step"], 6, "{name}");
        assert_eq!(protocol["episode_length"], 6, "{name}");
        let steps = v["runs"][0]["steps"].as_array().unwrap();
        assert_eq!(steps.len(), 2, "{name}");
        for (k, s) in steps.iter().enumerate() {
            let n = s["n_target_samples"].as_u64().unwrap();
            if name == "fqi" {
                assert!(n >= 1 && n <= 6 * (k as u64 + 1), "{name} step {k}: {n}");
            } else {
                assert_eq!(n, 6 * (k as u64 + 1), "{name} step {k}");
            }
            assert!(s["perf_disc_greedy_mean"].as_f64().unwrap().is_finite());
        }
        if name != "fqi" {
            assert_eq!(v["runs"][0]["parameters"]["budget_per_step"], 6, "{name}");
        }
    }
    for name in ["awfqi-embedded", "awfqi-adaptive"] {
        let e = &read(out, name)["runs"][0]["parameters"]["embedded"];
        assert_eq!(e["settings"], "scaled from the source records", "{name}");
    }
}

#[test]
fn every_active_algorithm_runs_on_the_dam_with_a_query_budget() {
    let base = temp("dam");
    let sources = base.join("sources");
    tiny_sources(
        &awfqi_harness::transfer::domain_data::dam::data(),
        40,
        &sources,
    );
    let out = base.join("out");
    let w = words(
        "dam",
        sources.to_str().unwrap(),
        out.to_str().unwrap(),
        &["--setting", "source", "--adaptive-sweep-cells", "3"],
    );
    dam::run(&common::parse(&w)).unwrap();
    check(&out);
    let e = &read(&out, "awfqi-adaptive")["runs"][0]["parameters"]["embedded"];
    assert_eq!(e["fqi_sweep_rewards"], "Backfilled");
    assert_eq!(e["fqi_discount"].as_f64().unwrap(), f64::from(0.999f32));
    assert_eq!(e["fqi_sweep_iterations"], 400, "the Dam's default sweeps");
    // One sweep plans only the next day's cost: the same streams decide otherwise.
    let myopic = base.join("myopic");
    let mut w = words(
        "dam",
        sources.to_str().unwrap(),
        myopic.to_str().unwrap(),
        &[
            "--setting",
            "source",
            "--adaptive-sweep-cells",
            "3",
            "--adaptive-sweeps",
            "1",
        ],
    );
    w[4] = "awfqi-adaptive";
    dam::run(&common::parse(&w)).unwrap();
    let one = &read(&myopic, "awfqi-adaptive")["runs"][0];
    assert_eq!(one["parameters"]["embedded"]["fqi_sweep_iterations"], 1);
    let returns = |run: &serde_json::Value| -> Vec<f64> {
        run["steps"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["perf_disc_greedy_mean"].as_f64().unwrap())
            .collect()
    };
    let default = returns(&read(&out, "awfqi-adaptive")["runs"][0]);
    assert_ne!(returns(one), default, "--adaptive-sweeps reaches the sweep");
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn every_active_algorithm_runs_on_acrobot_with_a_query_budget() {
    let base = temp("acrobot");
    let sources = base.join("sources");
    tiny_sources(
        &awfqi_harness::transfer::domain_data::acrobot::data(),
        40,
        &sources,
    );
    let out = base.join("out");
    let w = words(
        "acrobot",
        sources.to_str().unwrap(),
        out.to_str().unwrap(),
        &[
            "--spacing",
            "6.283185307179586",
            "--adaptive-sweep-cells",
            "2",
            "--embedded-resolution",
            "2",
        ],
    );
    acrobot::run(&common::parse(&w)).unwrap();
    check(&out);
    let e = &read(&out, "awfqi-adaptive")["runs"][0]["parameters"]["embedded"];
    assert_eq!(e["fqi_sweep_rewards"], "Pooled");
    assert_eq!(e["fqi_sweep_cells"], 2);
    assert!(
        e.get("fqi_sweep_iterations").is_none(),
        "Acrobot's sweep runs FQI's iterations, recorded as those"
    );
    let e = &read(&out, "awfqi-embedded")["runs"][0]["parameters"]["embedded"];
    assert_eq!(e["fqi_tiles"], serde_json::json!([2, 2, 2, 2]));
    let _ = std::fs::remove_dir_all(&base);
}
