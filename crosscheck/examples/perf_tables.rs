//! Turns measurements into the markdown tables of `docs/performance.md`.
//!
//! Reads criterion's results (`target/criterion/**/new/{benchmark,estimates}.json`), the
//! callgrind counts written by `scripts/perf-tables` (`target/perf/callgrind.tsv`: operation,
//! repetitions, instructions) and the experiment times (`target/perf/experiments.tsv`:
//! experiment, algorithm, wall seconds, CPU seconds, command), and replaces each block between
//! `<!-- perf-tables:NAME -->` and `<!-- /perf-tables:NAME -->` in the files named on the
//! command line. Missing measurements show as `–`.
//!
//! ```text
//! cargo run --release -p awfqi-crosscheck --example perf_tables -- docs/performance.md
//! ```

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One criterion result: median time per iteration (ns).
#[derive(Debug, Clone, Copy)]
struct Timing {
    median_ns: f64,
}

/// Measurements keyed by `group/implementation/parameter`.
#[derive(Default)]
struct Data {
    times: BTreeMap<String, Timing>,
    /// Instructions of one iteration (callgrind total ÷ repetitions).
    instructions: BTreeMap<String, f64>,
    /// `(experiment, algorithm, wall seconds, CPU seconds, command)`.
    experiments: Vec<(String, String, f64, f64, String)>,
    /// CPU (user) seconds per repetition of the acceptance check, by operation.
    cpu: BTreeMap<String, f64>,
    /// Date, cores and load averages of the criterion run.
    conditions: BTreeMap<String, String>,
    /// Cortex-M4F instructions of one repetition, by operation (`scripts/m4-counts`).
    m4: BTreeMap<String, f64>,
    /// `(instructions, function)` over the six AWFQI steps on the Cortex-M4F, largest first.
    m4_profile: Vec<(f64, String)>,
    /// The adaptive kernel's Cortex-M4F instructions of one repetition, by operation.
    m4_adaptive: BTreeMap<String, f64>,
    /// `(instructions, function)` over its six steps, largest first.
    m4_adaptive_profile: Vec<(f64, String)>,
}

fn read_criterion(dir: &Path, data: &mut Data) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n == "new") {
                read_result(&path, data);
            } else {
                read_criterion(&path, data);
            }
        }
    }
}

fn read_result(dir: &Path, data: &mut Data) {
    let read = |name: &str| -> Option<serde_json::Value> {
        let text = std::fs::read_to_string(dir.join(name)).ok()?;
        serde_json::from_str(&text).ok()
    };
    let (Some(bench), Some(est)) = (read("benchmark.json"), read("estimates.json")) else {
        return;
    };
    let id = bench["full_id"].as_str().unwrap_or_default().to_string();
    let Some(median_ns) = est["median"]["point_estimate"].as_f64() else {
        return;
    };
    data.times.insert(id, Timing { median_ns });
}

fn read_tsv(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| l.split('\t').map(str::to_string).collect())
        .collect()
}

/// `3.14 µs`-style, three significant digits.
fn time(ns: f64) -> String {
    let (value, unit) = if ns < 1e3 {
        (ns, "ns")
    } else if ns < 1e6 {
        (ns / 1e3, "µs")
    } else if ns < 1e9 {
        (ns / 1e6, "ms")
    } else {
        (ns / 1e9, "s")
    };
    format!("{} {unit}", significant(value))
}

fn significant(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// `1 234 567`-style integer.
fn count(v: f64) -> String {
    let s = format!("{:.0}", v.round());
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push('\u{202f}');
        }
        out.push(c);
    }
    out
}

const DASH: &str = "–";

impl Data {
    /// Median time of one unit (iteration ÷ `per`).
    fn time(&self, id: &str, per: f64) -> Option<f64> {
        self.times.get(id).map(|t| t.median_ns / per)
    }

    fn instr(&self, id: &str, per: f64) -> Option<f64> {
        self.instructions.get(id).map(|i| i / per)
    }
}

fn opt(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map_or(DASH.to_string(), f)
}

/// Kernel-entry flops: per dimension a subtraction, a division, a square and a sum (4D),
/// then the halving, the exponential (counted as one) and the scaling by `c` (3).
fn kernel_flops(d: f64) -> f64 {
    4.0 * d + 3.0
}

/// The minimal flop counts of the GP operations (D = 3), the formulas stated in
/// `docs/performance.md`.
fn gp_flops(op: &str, n: f64) -> Option<f64> {
    let fk = kernel_flops(3.0);
    let fit = n * n * n / 3.0 + fk * n * (n - 1.0) / 2.0 + n * n;
    let predict = n * n + (fk + 4.0) * n;
    match op {
        "gp_fit" => Some(fit),
        "gp_predict" => Some(predict),
        "gp_fit_predict100" => Some(fit + 100.0 * predict),
        "gp_add_point" => Some(predict),
        "gp_add_point_drop_oldest" => Some(3.0 * (n - 1.0) * (n - 1.0) + n * n + predict),
        "gp_fit_search" => Some(551.0 * fit),
        _ => None,
    }
}

/// The GP operations: `(group, label, units per iteration, sizes)`.
const GP_OPS: [(&str, &str, f64, &[usize]); 6] = [
    ("gp_fit", "fit (fixed hyperparameters)", 1.0, &[16, 64, 128]),
    (
        "gp_predict",
        "predict, one point (mean + variance)",
        100.0,
        &[16, 64, 128],
    ),
    ("gp_fit_predict100", "fit + 100 predictions", 1.0, &[64]),
    (
        "gp_add_point",
        "add a point (reference: refit)",
        1.0,
        &[16, 64, 128],
    ),
    (
        "gp_add_point_drop_oldest",
        "add a point to a full GP, drop the oldest",
        1.0,
        &[16, 64, 128],
    ),
    (
        "gp_fit_search",
        "fit with the hyperparameter search",
        1.0,
        &[16, 64, 128],
    ),
];

const IMPLEMENTATIONS: [&str; 4] = ["kernel_f32", "kernel_f64", "reference_f64", "faithful_f64"];

fn ratio(a: Option<f64>, b: Option<f64>) -> String {
    match (a, b) {
        (Some(a), Some(b)) => format!("{:.2}", a / b),
        _ => DASH.into(),
    }
}

fn gp_table(d: &Data) -> String {
    let mut s = String::from(
        "| operation | N | kernel f32 | kernel f64 | reference f64 | faithful f64 \
         | reference ÷ kernel f64 | faithful ÷ kernel f64 |\n\
         |---|--:|--:|--:|--:|--:|--:|--:|\n",
    );
    for (group, label, per, sizes) in GP_OPS {
        for &n in sizes {
            let t = IMPLEMENTATIONS.map(|imp| d.time(&format!("{group}/{imp}/{n}"), per));
            let _ = writeln!(
                s,
                "| {label} | {n} | {} | {} | {} | {} | {} | {} |",
                opt(t[0], time),
                opt(t[1], time),
                opt(t[2], time),
                opt(t[3], time),
                ratio(t[2], t[1]),
                ratio(t[3], t[1]),
            );
        }
    }
    s
}

fn gp_instructions_table(d: &Data) -> String {
    let mut s = String::from(
        "| operation | N | flops | instructions kernel f32 | kernel f64 | reference f64 \
         | faithful f64 | instr./flop kernel f64 | reference | faithful |\n\
         |---|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n",
    );
    for (group, label, per, sizes) in GP_OPS {
        for &n in sizes {
            let i = IMPLEMENTATIONS.map(|imp| d.instr(&format!("{group}/{imp}/{n}"), per));
            let nf = n as f64;
            let flops = gp_flops(group, nf);
            // The reference's add-point is a refit: its flops are a fit's. The faithful
            // path's search is a different method (quasi-Newton with gradients).
            let ref_flops = if group == "gp_add_point" {
                gp_flops("gp_fit", nf)
            } else {
                flops
            };
            let faithful_flops = if group == "gp_fit_search" {
                None
            } else {
                flops
            };
            let per_flop = |i: Option<f64>, f: Option<f64>| match (i, f) {
                (Some(i), Some(f)) => format!("{:.2}", i / f),
                _ => DASH.into(),
            };
            let search = group == "gp_fit_search";
            let (bound, floor) = if search { ("≤ ", "≥ ") } else { ("", "") };
            let _ = writeln!(
                s,
                "| {label} | {n} | {bound}{} | {} | {} | {} | {} | {floor}{} | {} | {} |",
                opt(flops, count),
                opt(i[0], count),
                opt(i[1], count),
                opt(i[2], count),
                opt(i[3], count),
                per_flop(i[1], flops),
                per_flop(i[2], ref_flops),
                per_flop(i[3], faithful_flops),
            );
        }
    }
    s
}

fn other_table(d: &Data) -> String {
    let mut s = String::new();
    s.push_str(
        "| operation | unit | kernel f32 | kernel f64 | reference f64 | faithful f64 \
         | reference ÷ kernel f64 | instructions kernel f32 | kernel f64 | reference f64 \
         | faithful f64 |\n|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n",
    );
    struct Row {
        label: &'static str,
        unit: &'static str,
        group: &'static str,
        param: &'static str,
        per: f64,
    }
    let rows = [
        Row {
            label: "score table, realistic (3 reward GPs, N = 64)",
            unit: "row",
            group: "score_table",
            param: "realistic",
            per: 484.0,
        },
        Row {
            label: "score table, oracle (3 Puddle Worlds)",
            unit: "row",
            group: "score_table",
            param: "oracle",
            per: 484.0,
        },
        Row {
            label: "alias table build, 40 804 rows",
            unit: "table",
            group: "alias_build",
            param: "40804",
            per: 1.0,
        },
        Row {
            label: "alias draw, 40 804 rows",
            unit: "draw",
            group: "alias_draw",
            param: "40804",
            per: 1000.0,
        },
        Row {
            label: "weighted FQI, reward model (iteration 1), 41 × 41 × 4, 3 000 samples",
            unit: "fit",
            group: "fqi_fit",
            param: "1",
            per: 1.0,
        },
        Row {
            label: "weighted FQI, 60 iterations, 41 × 41 × 4, 3 000 samples",
            unit: "fit",
            group: "fqi_fit",
            param: "60",
            per: 1.0,
        },
        Row {
            label: "belief update, Grid World (4 candidates)",
            unit: "observation",
            group: "identify_belief_update",
            param: "grid4",
            per: 1.0,
        },
        Row {
            label: "uniform score, Grid World (400 pairs)",
            unit: "score",
            group: "identify_score_uniform",
            param: "grid4",
            per: 1.0,
        },
        Row {
            label: "variance score, Grid World (400 pairs)",
            unit: "score",
            group: "identify_score_variance",
            param: "grid4",
            per: 1.0,
        },
        Row {
            label: "mutual-information score, Grid World (400 pairs, 1 000 draws each)",
            unit: "score",
            group: "identify_score_mutual_information",
            param: "grid4",
            per: 1.0,
        },
        Row {
            label: "AWFQI kernel step (50 queries, GP search, 900 weights, FQI 60 × 11 × 11 × 4)",
            unit: "step",
            group: "awfqi_step",
            param: "puddle",
            per: 1.0,
        },
    ];
    let mut line = |label: &str, unit: &str, t: [Option<f64>; 4], i: [Option<f64>; 4]| {
        let _ = writeln!(
            s,
            "| {label} | {unit} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            opt(t[0], time),
            opt(t[1], time),
            opt(t[2], time),
            opt(t[3], time),
            ratio(t[2], t[1]),
            opt(i[0], count),
            opt(i[1], count),
            opt(i[2], count),
            opt(i[3], count),
        );
    };
    let imps = IMPLEMENTATIONS;
    for r in &rows {
        let id = |imp: &str| format!("{}/{imp}/{}", r.group, r.param);
        let t = imps.map(|imp| d.time(&id(imp), r.per));
        let i = imps.map(|imp| d.instr(&id(imp), r.per));
        line(r.label, r.unit, t, i);
        if r.group == "fqi_fit" && r.param == "60" {
            // One sweep: (t₆₀ − t₁)/59 for the kernel; t₂ − t₁ for the faithful path's
            // forests (measured with 1 and 2 iterations only).
            let sweep = |f: &dyn Fn(&str) -> Option<f64>, imp: &str| -> Option<f64> {
                let one = f(&format!("fqi_fit/{imp}/1"))?;
                match f(&format!("fqi_fit/{imp}/60")) {
                    Some(sixty) => Some((sixty - one) / 59.0),
                    None => Some(f(&format!("fqi_fit/{imp}/2"))? - one),
                }
            };
            let tf = |id: &str| d.time(id, 1.0);
            let inf = |id: &str| d.instr(id, 1.0);
            let t = imps.map(|imp| sweep(&tf, imp));
            let i = imps.map(|imp| sweep(&inf, imp));
            line(
                "weighted FQI, one sweep (iteration ≥ 2), 41 × 41 × 4, 3 000 samples",
                "sweep",
                t,
                i,
            );
        }
    }
    s
}

fn draws_line(d: &Data) -> String {
    let rate = |imp: &str| {
        d.time(&format!("alias_draw/{imp}/40804"), 1000.0)
            .map(|ns| format!("{:.0} million", 1e3 / ns))
    };
    format!(
        "Alias draws per second (one core): {} (f32), {} (f64).\n",
        rate("kernel_f32").unwrap_or(DASH.into()),
        rate("kernel_f64").unwrap_or(DASH.into())
    )
}

fn experiments_table(d: &Data) -> String {
    if d.experiments.is_empty() {
        return "No experiment times measured yet (`scripts/perf-experiments` found no \
                `puddle` command, or was skipped).\n"
            .into();
    }
    let mut s = String::from(
        "| experiment | algorithm | wall time | CPU time (user + sys) | command |\n\
         |---|---|--:|--:|---|\n",
    );
    for (experiment, algorithm, wall, cpu, command) in &d.experiments {
        let _ = writeln!(
            s,
            "| {experiment} | {algorithm} | {wall:.1} s | {cpu:.1} s | `{command}` |"
        );
    }
    s
}

/// Clock of the Cortex-M4F the instruction counts are converted at.
const M4_HZ: f64 = 168e6;
/// Assumed cycles per instruction (docs/performance.md: why), and a pessimistic one.
const M4_CPI: f64 = 1.25;
const M4_CPI_SLOW: f64 = 1.5;

fn m4_table(d: &Data) -> String {
    let at = |v: f64, cpi: f64| time(v * cpi / M4_HZ * 1e9);
    let mut s = format!(
        "| operation | instructions | at 168 MHz, CPI {M4_CPI} | at CPI {M4_CPI_SLOW} |\n|---|--:|--:|--:|\n"
    );
    let mut row = |what: &str, v: Option<f64>| {
        let _ = writeln!(
            s,
            "| {what} | {} | {} | {} |",
            opt(v, count),
            opt(v, |v| at(v, M4_CPI)),
            opt(v, |v| at(v, M4_CPI_SLOW))
        );
    };
    let get = |k: &str| d.m4.get(k).copied();
    row("GP fit at fixed hyperparameters, N = 24", get("gp_fit"));
    row(
        "GP prediction, one point (mean + variance), N = 24",
        get("gp_predict"),
    );
    row(
        "GP hyperparameter search (thesis: 550 evaluations, 10 restarts), N = 24",
        get("gp_search"),
    );
    row(
        "a step's target-GP training (`fit_gp`: reset, 24 of the 300 records, search)",
        get("target_gp_training"),
    );
    let (one, sixty) = (get("fqi_1_iteration"), get("fqi_60_iterations"));
    row(
        "FQI sweep (an iteration ≥ 2; 11 × 11 × 4 cells, 300 + 1 033 samples)",
        one.zip(sixty).map(|(a, b)| (b - a) / 59.0),
    );
    row("a step's FQI (60 iterations)", sixty);
    row("set-up (builder over the flash tables)", get("build"));
    let steps: Vec<f64> = (1..=6).filter_map(|k| get(&format!("step{k}"))).collect();
    for (k, v) in steps.iter().enumerate() {
        row(
            &format!("**AWFQI step {}** (50 queries, GP, weights, FQI)", k + 1),
            Some(*v),
        );
    }
    let largest = steps.iter().copied().fold(f64::NAN, f64::max);
    if largest.is_finite() {
        let total: f64 = d.m4_profile.iter().map(|(n, _)| n).sum();
        let _ = writeln!(
            s,
            "\nThe largest step takes {} at CPI {M4_CPI} ({} at CPI {M4_CPI_SLOW}); it stays \
             within 1 s at 168 MHz for any CPI up to {:.2}.",
            at(largest, M4_CPI),
            at(largest, M4_CPI_SLOW),
            M4_HZ / largest
        );
        if total > 0.0 {
            s.push_str(
                "\nWhere the six steps' instructions go (flat profile: each instruction counts \
                 for the function holding it, inlined code for the function it was inlined into):\n\n\
                 | function | instructions (6 steps) | share |\n|---|--:|--:|\n",
            );
            for (n, f) in d.m4_profile.iter().take(10) {
                let _ = writeln!(s, "| `{f}` | {} | {:.1} % |", count(*n), 100.0 * n / total);
            }
        }
    }
    s
}

/// The adaptive kernel's budget per step: 1 s at 168 MHz and CPI 1.25.
const M4_STEP_BUDGET: f64 = 134e6;

fn m4_adaptive_table(d: &Data) -> String {
    let at = |v: f64, cpi: f64| time(v * cpi / M4_HZ * 1e9);
    let mut s = format!(
        "| operation | instructions | at 168 MHz, CPI {M4_CPI} | at CPI {M4_CPI_SLOW} |\n|---|--:|--:|--:|\n"
    );
    let mut row = |what: &str, v: Option<f64>| {
        let _ = writeln!(
            s,
            "| {what} | {} | {} | {} |",
            opt(v, count),
            opt(v, |v| at(v, M4_CPI)),
            opt(v, |v| at(v, M4_CPI_SLOW))
        );
    };
    let get = |k: &str| d.m4_adaptive.get(k).copied();
    row(
        "set-up (one-time): the 3 sources' mean functions fitted on the device, the kernel built",
        get("setup"),
    );
    row(
        "set-up (one-time): the plan on the sources alone (`AdaptiveAwfqi::plan`)",
        get("plan"),
    );
    let steps: Vec<f64> = (1..=6).filter_map(|k| get(&format!("step{k}"))).collect();
    for (k, v) in steps.iter().enumerate() {
        row(
            &format!(
                "**step {}** (50 queries in 3 sub-batches: verification, scored draws, GP fits, weights, FQI)",
                k + 1
            ),
            Some(*v),
        );
    }
    let (one, sixty) = (get("fqi_1_iteration"), get("fqi_60_iterations"));
    row("parts: FQI, the model fit and one iteration", one);
    row("parts: FQI with 60 iterations", sixty);
    row(
        "parts: the target GP's training, thesis search",
        get("gp_thesis_search"),
    );
    row(
        "parts: the target GP's training, warm refit",
        get("gp_warm_refit"),
    );
    row(
        "parts: one GP prediction (mean + variance)",
        get("gp_predict"),
    );
    row(
        "parts: one source mean function's value",
        get("mean_function"),
    );
    let largest = steps.iter().copied().fold(f64::NAN, f64::max);
    if largest.is_finite() {
        let verdict = if largest <= M4_STEP_BUDGET {
            "within"
        } else {
            "over"
        };
        let _ = writeln!(
            s,
            "\nThe largest step executes {} instructions, {verdict} the budget of {} (1 s at \
             168 MHz and CPI {M4_CPI}): {} at CPI {M4_CPI}, {} at CPI {M4_CPI_SLOW}.",
            count(largest),
            count(M4_STEP_BUDGET),
            at(largest, M4_CPI),
            at(largest, M4_CPI_SLOW),
        );
        let total: f64 = d.m4_adaptive_profile.iter().map(|(n, _)| n).sum();
        if total > 0.0 {
            s.push_str(
                "\nWhere the six steps' instructions go (flat profile: each instruction counts \
                 for the function holding it, inlined code for the function it was inlined into):\n\n\
                 | function | instructions (6 steps) | share |\n|---|--:|--:|\n",
            );
            for (n, f) in d.m4_adaptive_profile.iter().take(10) {
                let _ = writeln!(s, "| `{f}` | {} | {:.1} % |", count(*n), 100.0 * n / total);
            }
        }
    }
    s
}

fn conditions(d: &Data) -> String {
    let get = |k: &str| d.conditions.get(k).map_or(DASH, String::as_str);
    format!(
        "Wall times measured on {} on {} cores; load average (1 min) {} before and {} after \
         the criterion run (above the core count means other work shared the machine, so \
         the wall times are slower than on an idle one; the instruction counts are not \
         affected).\n",
        get("date"),
        get("cores"),
        get("load_before"),
        get("load_after"),
    )
}

fn check(d: &Data) -> String {
    let per = |imp: &str| d.cpu.get(&format!("gp_fit_predict100/{imp}/64")).copied();
    let (k32, k64, r) = (per("kernel_f32"), per("kernel_f64"), per("reference_f64"));
    let us = |v: Option<f64>| opt(v, |s| time(s * 1e9));
    format!(
        "Fit + 100 predictions at N = 64, D = 3, in CPU time (user time of 3 000 repetitions, \
         best of 5 alternating rounds): kernel f64 {}, reference f64 {}, reference ÷ kernel \
         {} (kernel f32: {}). In instructions: reference ÷ kernel f64 = {}; kernel f64 {} \
         instructions per flop.\n",
        us(k64),
        us(r),
        ratio(r, k64),
        us(k32),
        ratio(
            d.instr("gp_fit_predict100/reference_f64/64", 1.0),
            d.instr("gp_fit_predict100/kernel_f64/64", 1.0)
        ),
        opt(
            d.instr("gp_fit_predict100/kernel_f64/64", 1.0)
                .zip(gp_flops("gp_fit_predict100", 64.0))
                .map(|(i, f)| i / f),
            |v| format!("{v:.2}")
        ),
    )
}

fn replace_block(text: &str, name: &str, body: &str) -> Option<String> {
    let open = format!("<!-- perf-tables:{name} -->");
    let close = format!("<!-- /perf-tables:{name} -->");
    let start = text.find(&open)? + open.len();
    let end = start + text[start..].find(&close)?;
    Some(format!("{}\n{}{}", &text[..start], body, &text[end..]))
}

fn main() {
    let mut args = std::env::args().skip(1);
    let mut criterion = PathBuf::from("target/criterion");
    let mut callgrind = PathBuf::from("target/perf/callgrind.tsv");
    let mut experiments = PathBuf::from("target/perf/experiments.tsv");
    let conditions_file = PathBuf::from("target/perf/conditions.tsv");
    let cpu_file = PathBuf::from("target/perf/cputime.tsv");
    let m4_file = PathBuf::from("target/perf/m4.tsv");
    let m4_profile_file = PathBuf::from("target/perf/m4-profile.tsv");
    let m4_adaptive_file = PathBuf::from("target/perf/m4-adaptive.tsv");
    let m4_adaptive_profile_file = PathBuf::from("target/perf/m4-adaptive-profile.tsv");
    let mut files = Vec::new();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--criterion" => criterion = args.next().map(PathBuf::from).unwrap_or(criterion),
            "--callgrind" => callgrind = args.next().map(PathBuf::from).unwrap_or(callgrind),
            "--experiments" => experiments = args.next().map(PathBuf::from).unwrap_or(experiments),
            _ => files.push(PathBuf::from(a)),
        }
    }
    let mut data = Data::default();
    read_criterion(&criterion, &mut data);
    for row in read_tsv(&callgrind) {
        if let [op, k, total, ..] = row.as_slice() {
            if let (Ok(k), Ok(total)) = (k.parse::<f64>(), total.parse::<f64>()) {
                data.instructions.insert(op.clone(), total / k);
            }
        }
    }
    for row in read_tsv(&experiments) {
        if let [experiment, algorithm, wall, cpu, command, ..] = row.as_slice() {
            if let (Ok(w), Ok(c)) = (wall.parse(), cpu.parse()) {
                data.experiments.push((
                    experiment.clone(),
                    algorithm.clone(),
                    w,
                    c,
                    command.clone(),
                ));
            }
        }
    }
    for row in read_tsv(&conditions_file) {
        if let [key, value, ..] = row.as_slice() {
            data.conditions.insert(key.clone(), value.clone());
        }
    }
    for row in read_tsv(&cpu_file) {
        if let [op, k, seconds, ..] = row.as_slice() {
            if let (Ok(k), Ok(s)) = (k.parse::<f64>(), seconds.parse::<f64>()) {
                data.cpu.insert(op.clone(), s / k);
            }
        }
    }
    for row in read_tsv(&m4_file) {
        if let [op, k, total, ..] = row.as_slice() {
            if let (Ok(k), Ok(total)) = (k.parse::<f64>(), total.parse::<f64>()) {
                data.m4.insert(op.clone(), total / k);
            }
        }
    }
    for row in read_tsv(&m4_profile_file) {
        if let [n, function, ..] = row.as_slice() {
            if let Ok(n) = n.parse::<f64>() {
                data.m4_profile.push((n, function.clone()));
            }
        }
    }
    for row in read_tsv(&m4_adaptive_file) {
        if let [op, k, total, ..] = row.as_slice() {
            if let (Ok(k), Ok(total)) = (k.parse::<f64>(), total.parse::<f64>()) {
                data.m4_adaptive.insert(op.clone(), total / k);
            }
        }
    }
    for row in read_tsv(&m4_adaptive_profile_file) {
        if let [n, function, ..] = row.as_slice() {
            if let Ok(n) = n.parse::<f64>() {
                data.m4_adaptive_profile.push((n, function.clone()));
            }
        }
    }
    // A block whose measurements are all missing (e.g. experiments skipped on a fresh
    // clone) keeps what the file already says.
    let (timed, counted) = (!data.times.is_empty(), !data.instructions.is_empty());
    let blocks: Vec<(&str, String)> = [
        ("conditions", !data.conditions.is_empty(), conditions(&data)),
        ("check", !data.cpu.is_empty() && counted, check(&data)),
        ("gp", timed, gp_table(&data)),
        ("gp-instructions", counted, gp_instructions_table(&data)),
        (
            "other",
            timed && counted,
            other_table(&data) + "\n" + &draws_line(&data),
        ),
        (
            "experiments",
            !data.experiments.is_empty(),
            experiments_table(&data),
        ),
        ("m4", !data.m4.is_empty(), m4_table(&data)),
        (
            "m4-adaptive",
            !data.m4_adaptive.is_empty(),
            m4_adaptive_table(&data),
        ),
    ]
    .into_iter()
    .filter(|(_, measured, _)| *measured)
    .map(|(name, _, body)| (name, body))
    .collect();
    if files.is_empty() {
        for (name, body) in &blocks {
            println!("<!-- {name} -->\n{body}");
        }
        return;
    }
    for file in files {
        let Ok(mut text) = std::fs::read_to_string(&file) else {
            eprintln!("cannot read {}", file.display());
            std::process::exit(1);
        };
        for (name, body) in &blocks {
            if let Some(t) = replace_block(&text, name, body) {
                text = t;
            }
        }
        if let Err(e) = std::fs::write(&file, text) {
            eprintln!("cannot write {}: {e}", file.display());
            std::process::exit(1);
        }
        println!("updated {}", file.display());
    }
}
