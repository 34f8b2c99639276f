//! End-to-end tests of `awfqi-harness gp`: the binary on a JSON file, core and reference.

use std::path::PathBuf;
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

use serde_json::{Value, json};

fn binary() -> Command {
    Command::new(env!("CARGO_BIN_EXE_awfqi-harness"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("awfqi-gp-command-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Runs `gp --cases FILE extra…` and parses standard output; asserts it succeeded.
fn run(cases: &Value, extra: &[&str]) -> Value {
    let (ok, stderr, output) = run_status(cases, extra);
    assert!(ok, "gp {extra:?} failed: {stderr}");
    output
}

/// Runs `gp --cases FILE extra…` where the cases `failed` fail: the command writes every
/// case's output, then exits non-zero naming each failed case.
fn run_failing(cases: &Value, extra: &[&str], failed: &[&str]) -> Value {
    let (ok, stderr, output) = run_status(cases, extra);
    assert!(!ok, "gp {extra:?} succeeded with failed cases");
    let total = cases["cases"].as_array().unwrap().len();
    let count = format!("{} of {total} case(s) failed", failed.len());
    assert!(stderr.contains(&count), "{stderr}");
    for name in failed {
        assert!(stderr.contains(name), "{name} not named: {stderr}");
    }
    output
}

/// Runs `gp --cases FILE extra…`: (exit success, stderr, parsed standard output).
fn run_status(cases: &Value, extra: &[&str]) -> (bool, String, Value) {
    static RUNS: AtomicUsize = AtomicUsize::new(0);
    let file = scratch(&format!(
        "cases-{}.json",
        RUNS.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::write(&file, cases.to_string()).unwrap();
    let output = binary()
        .args(["gp", "--cases"])
        .arg(&file)
        .args(extra)
        .output()
        .unwrap();
    (
        output.status.success(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
        serde_json::from_slice(&output.stdout).unwrap(),
    )
}

/// A case of `n` points in `d` dimensions on a deterministic lattice-like pattern.
fn grid_case(name: &str, n: usize, d: usize) -> Value {
    let x: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..d)
                .map(|k| ((i * (k + 3) + k) % 17) as f64 * 0.37 + i as f64 * 0.01)
                .collect()
        })
        .collect();
    let y: Vec<f64> = x.iter().map(|p| p.iter().sum::<f64>().sin()).collect();
    json!({
        "name": name, "x": x, "y": y, "signal_variance": 1.3,
        "length_scales": vec![1.1; d], "noise_variance": 0.05,
        "x_test": [vec![0.5; d], x[0].clone(), vec![30.0; d]],
    })
}

fn one_point_case() -> Value {
    json!({"name": "one point", "x": [[0.3]], "y": [1.5], "signal_variance": 2.0,
           "length_scales": [0.8], "noise_variance": 0.5, "x_test": [[1.3], [0.3]]})
}

fn cases() -> Value {
    let too_many: Vec<Vec<f64>> = (0..257).map(|i| vec![i as f64]).collect();
    json!({"cases": [
        one_point_case(),
        grid_case("capacity 256, D = 8", 200, 8),
        {"name": "too many points", "x": too_many, "y": vec![0.0; 257], "signal_variance": 1.0,
         "length_scales": [1.0], "noise_variance": 0.1, "x_test": [[0.0]]},
        {"name": "wrong dimension", "x": [[0.0, 1.0]], "y": [1.0], "signal_variance": 1.0,
         "length_scales": [1.0], "noise_variance": 0.1, "x_test": [[0.0]]},
        {"name": "no points", "x": [], "y": [], "signal_variance": 1.0,
         "length_scales": [1.0], "noise_variance": 0.1, "x_test": [[0.0]]},
        {"name": "zero signal variance", "x": [[0.0]], "y": [1.0], "signal_variance": 0.0,
         "length_scales": [1.0], "noise_variance": 0.1, "x_test": [[0.0]]},
        grid_case("capacity 32, D = 3", 20, 3),
    ]})
}

fn entry<'a>(output: &'a Value, name: &str) -> &'a Value {
    output["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == name)
        .unwrap_or_else(|| panic!("no case {name} in {output}"))
}

fn numbers(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol * b.abs().max(1.0),
        "{what}: {a} vs {b}"
    );
}

/// The one-point case solved by hand: K = c + s2 + j, with j the jitter the output reports.
#[test]
fn one_point_case_matches_the_closed_form() {
    let (c, s2, y0, l) = (2.0f64, 0.5f64, 1.5f64, 0.8f64);
    let input = json!({"cases": [one_point_case()]});
    for (extra, tol) in [
        (&[][..], 1e-13),
        (&["--reference"][..], 1e-14),
        (&["--reference", "--jitter", "0.25"][..], 1e-14),
        (&["--precision", "f32"][..], 1e-6),
    ] {
        let output = run(&input, extra);
        let case = entry(&output, "one point");
        let j = case["jitter"].as_f64().unwrap();
        let expected_jitter = match extra {
            [] | ["--precision", _] => awfqi::gp::BASE_JITTER,
            ["--reference"] => 0.0,
            _ => 0.25,
        };
        assert_close(j, expected_jitter, 1e-7, &format!("{extra:?} jitter"));
        let diagonal = c + s2 + j;
        let k = c * (-0.5 / (l * l)).exp();
        let mean = [k * y0 / diagonal, c * y0 / diagonal];
        let std = [(c - k * k / diagonal).sqrt(), (c - c * c / diagonal).sqrt()];
        let lml = -0.5 * y0 * y0 / diagonal
            - 0.5 * diagonal.ln()
            - 0.5 * (2.0 * std::f64::consts::PI).ln();
        let means = numbers(&case["mean"]);
        let stds = numbers(&case["std"]);
        for i in 0..2 {
            assert_close(means[i], mean[i], tol, &format!("{extra:?} mean[{i}]"));
            assert_close(stds[i], std[i], tol, &format!("{extra:?} std[{i}]"));
        }
        assert_close(
            case["log_marginal_likelihood"].as_f64().unwrap(),
            lml,
            tol,
            "lml",
        );
    }
}

/// Good cases are computed, bad ones give an `error` and do not stop the others; the
/// 256-capacity case in 8 dimensions runs in a debug build (stack).
#[test]
fn every_case_runs_and_bad_ones_report_an_error() {
    let input = cases();
    let bad = [
        "too many points",
        "wrong dimension",
        "no points",
        "zero signal variance",
    ];
    let core = run_failing(&input, &[], &bad);
    // The reference with the core's base jitter on the diagonal: the same model.
    let base_jitter = awfqi::gp::BASE_JITTER.to_string();
    let reference = run_failing(
        &input,
        &["--reference", "--jitter", &base_jitter],
        &bad[1..],
    );
    let f32_core = run_failing(&input, &["--precision", "f32"], &bad);
    assert_eq!(core["cases"].as_array().unwrap().len(), 7);

    for (name, needle) in [
        ("too many points", "257"),
        ("wrong dimension", "x[0]"),
        ("no points", "empty"),
        ("zero signal variance", "signal_variance"),
    ] {
        let error = entry(&core, name)["error"]
            .as_str()
            .unwrap_or_else(|| panic!("{name} did not fail: {core}"));
        assert!(error.contains(needle), "{name}: {error}");
        assert!(entry(&f32_core, name)["error"].is_string(), "{name} in f32");
        // The reference has no capacity: only the core refuses 257 points.
        if name != "too many points" {
            assert!(
                entry(&reference, name)["error"].is_string(),
                "{name} in the reference"
            );
        }
    }
    assert!(entry(&reference, "too many points")["mean"].is_array());

    for name in ["capacity 256, D = 8", "capacity 32, D = 3"] {
        let (a, b) = (entry(&core, name), entry(&reference, name));
        assert!(a["error"].is_null(), "{name}: {a}");
        for field in ["mean", "std"] {
            for (x, y) in numbers(&a[field]).iter().zip(numbers(&b[field])) {
                assert_close(*x, y, 1e-9, &format!("{name} {field}"));
            }
        }
        // Far from the data the GP reverts to the prior: mean 0, std √c.
        assert!(numbers(&a["mean"])[2].abs() < 1e-12);
        assert_close(numbers(&a["std"])[2], 1.3f64.sqrt(), 1e-12, "prior std");
        assert_close(
            a["log_marginal_likelihood"].as_f64().unwrap(),
            b["log_marginal_likelihood"].as_f64().unwrap(),
            1e-9,
            "lml",
        );
        let f = entry(&f32_core, name);
        for (x, y) in numbers(&f["mean"]).iter().zip(numbers(&b["mean"])) {
            assert_close(*x, y, 1e-3, &format!("{name} f32 mean"));
        }
    }
}

/// `--out` writes the same document to a file; a non-finite value in f32 is the core's error.
#[test]
fn out_file_and_f32_overflow() {
    let input = json!({"cases": [
        one_point_case(),
        {"name": "overflows f32", "x": [[0.0]], "y": [1e39], "signal_variance": 1.0,
         "length_scales": [1.0], "noise_variance": 0.1, "x_test": [[0.0]]},
    ]});
    let file = scratch("overflow.json");
    std::fs::write(&file, input.to_string()).unwrap();
    let out = scratch("overflow-out.json");
    let result = binary()
        .args(["gp", "--precision", "f32", "--cases"])
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success());
    assert!(
        stderr.contains("1 of 2 case(s) failed: overflows f32"),
        "{stderr}"
    );
    let output: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let error = entry(&output, "overflows f32")["error"].as_str().unwrap();
    assert!(error.contains("non-finite"), "{error}");
    assert!(entry(&output, "one point")["mean"].is_array());
    // The same value is fine in f64.
    let output = run(&input, &[]);
    assert!(entry(&output, "overflows f32")["mean"].is_array());
}

/// A document that is not `{"cases":[…]}` is an error of the whole command.
#[test]
fn malformed_document_fails() {
    let file = scratch("not-cases.json");
    std::fs::write(&file, "[1, 2, 3]").unwrap();
    let output = binary()
        .args(["gp", "--cases"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(!output.status.success());
}

/// Targets too large for the precision are each case's error, naming the targets, and the
/// command fails: never a `null` likelihood as a success, never "not positive definite".
#[test]
fn overflowing_targets_fail_by_name_in_the_core_and_the_reference() {
    let case = |name: &str, y: [f64; 3]| {
        json!({"name": name, "x": [[0.0], [0.5], [1.0]], "y": y, "signal_variance": 1.0,
               "length_scales": [1.0], "noise_variance": 0.01, "x_test": [[0.25]]})
    };
    let input = json!({"cases": [
        one_point_case(),
        case("all at 1e200", [1e200; 3]),
        case("one at 1e308", [0.0, 1e308, 0.0]),
    ]});
    let failed = ["all at 1e200", "one at 1e308"];
    for extra in [&[][..], &["--reference"]] {
        let output = run_failing(&input, extra, &failed);
        for name in failed {
            let e = entry(&output, name);
            let error = e["error"]
                .as_str()
                .unwrap_or_else(|| panic!("{name} {extra:?}: {e}"));
            assert!(
                error.contains("`y` is too large"),
                "{name} {extra:?}: {error}"
            );
            assert!(e.get("log_marginal_likelihood").is_none(), "{e}");
        }
        assert!(entry(&output, "one point")["mean"].is_array());
    }
}
