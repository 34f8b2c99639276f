//! End-to-end: IWFQI on the Dam with `--fixed-gp-variance explicit-inverse` (scikit-learn's
//! predictive variance, the reference's arithmetic) against the default stable form, on
//! the same step-1 target data (step 1 is uniform, so both runs collect the same episode).
//!
//! The reward GP is noise-free over nearby storages, so its explicit-inverse variance
//! carries rounding error and the reward weights move a little. The storage GP has noise
//! variance 4, is well conditioned, and its weights must agree to rounding. The option is
//! written to the result file only when it is not the default.

use std::path::Path;

use awfqi_harness::commands::dam::Args;
use awfqi_harness::commands::dam::run;

mod common;

fn args(out: &Path, variance: &str) -> Args {
    let run = [
        "dam",
        "--steps",
        "1",
        "--runs",
        "1",
        "--algorithms",
        "iwfqi",
        "--q-function",
        "joint",
    ];
    let out = [
        "--fixed-gp-variance",
        variance,
        "--out",
        out.to_str().unwrap(),
    ];
    common::parse(&[&run[..], &common::QUICK, &out].concat())
}

fn first_step(dir: &Path) -> (serde_json::Value, serde_json::Value) {
    let text = std::fs::read_to_string(dir.join("iwfqi.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    (
        v["experiment"]["options"]["gp"].clone(),
        v["runs"][0]["steps"][0].clone(),
    )
}

#[test]
fn explicit_inverse_variance_moves_the_reward_weights_only() {
    let base = std::env::temp_dir().join(format!("awfqi-fixed-var-{}", std::process::id()));
    let (stable, explicit) = (base.join("stable"), base.join("explicit"));
    run(&args(&stable, "stable")).unwrap();
    run(&args(&explicit, "explicit-inverse")).unwrap();
    let (gs, s) = first_step(&stable);
    let (ge, e) = first_step(&explicit);
    assert!(gs.get("fixed_variance").is_none(), "{gs}");
    assert_eq!(ge["fixed_variance"], "explicit-inverse", "{ge}");
    assert_eq!(s["n_target_samples"], e["n_target_samples"]);
    let value = |x: &serde_json::Value, key: &str| x[key].as_f64().unwrap();
    for key in ["ws_mean", "ws_eff"] {
        let (a, b) = (value(&s, key), value(&e, key));
        assert!((a - b).abs() <= 1e-6 * a.abs(), "{key} {a} vs {b}");
    }
    for key in ["wr_mean", "wr_eff"] {
        let (a, b) = (value(&s, key), value(&e, key));
        let relative = (a - b).abs() / a.abs();
        assert!(relative > 0.0 && relative < 0.05, "{key} {a} vs {b}");
    }
    let _ = std::fs::remove_dir_all(&base);
}
