//! End-to-end: IWFQI on Acrobot (fixed-kernel target GPs, five of them, all noise-free)
//! with `--fixed-gp incremental` (the default) or `compact` gives the weights of
//! `--fixed-gp refit`, the reference's per-step reconditioning, on the same target data,
//! and says which it ran.
//!
//! Only step 1 sees the same target data on both routes: weights equal to ≈ 10⁻¹⁵ are
//! enough for Extra-Trees to pick another split on a near-tie, so the next episodes differ
//! (the appended route against refits on identical data is `transfer::gp`'s unit test).

use std::path::Path;

use awfqi_harness::commands::acrobot::Args;
use awfqi_harness::commands::acrobot::run;

mod common;

fn args(out: &Path, update: &str) -> Args {
    let run = [
        "acrobot",
        "--steps",
        "3",
        "--episodes-per-step",
        "1",
        "--runs",
        "1",
        "--algorithms",
        "iwfqi",
    ];
    let out = ["--fixed-gp", update, "--out", out.to_str().unwrap()];
    common::parse(&[&run[..], &common::QUICK, &out].concat())
}

fn steps(dir: &Path) -> (serde_json::Value, Vec<serde_json::Value>) {
    let text = std::fs::read_to_string(dir.join("iwfqi.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let steps = v["runs"][0]["steps"].as_array().unwrap().clone();
    (v["experiment"]["options"]["gp"].clone(), steps)
}

#[test]
fn incremental_fixed_gps_give_the_refit_weights() {
    let base = std::env::temp_dir().join(format!("awfqi-fixed-gp-{}", std::process::id()));
    let (incremental, compact, refit) = (
        base.join("incremental"),
        base.join("compact"),
        base.join("refit"),
    );
    run(&args(&incremental, "incremental")).unwrap();
    run(&args(&compact, "compact")).unwrap();
    run(&args(&refit, "refit")).unwrap();
    let (pi, si) = steps(&incremental);
    let (pc, sc) = steps(&compact);
    let (pr, sr) = steps(&refit);
    // The default is not written; the others are.
    assert!(pi.get("fixed_update").is_none(), "{pi}");
    assert_eq!(pc["fixed_update"], "compact", "{pc}");
    assert_eq!(pr["fixed_update"], "refit", "{pr}");
    assert_eq!((si.len(), sc.len(), sr.len()), (3, 3, 3));
    let b = &sr[0];
    for a in [&si[0], &sc[0]] {
        assert_eq!(a["n_target_samples"], b["n_target_samples"]);
        assert_eq!(a["reward_gp"], b["reward_gp"]);
        // Reward weights from one GP, transition weights the product of four.
        for key in ["wr_mean", "wr_eff", "ws_mean", "ws_eff"] {
            let (x, y) = (a[key].as_f64().unwrap(), b[key].as_f64().unwrap());
            assert!((x - y).abs() <= 1e-9 * y.abs(), "{key} {x} vs {y}");
        }
    }
    // Later steps: the GP keeps every target record so far on every route.
    for steps in [&si, &sc, &sr] {
        for s in steps.iter() {
            assert_eq!(s["reward_gp"]["points"], s["n_target_samples"]);
            assert!(s["wr_mean"].as_f64().unwrap().is_finite());
        }
    }
    let _ = std::fs::remove_dir_all(&base);
}
