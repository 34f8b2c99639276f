//! The zones example's controller (`examples/zones/src/zones.rs`) on the host, over a range
//! of seeds: the same code and `f32` arithmetic as on the Cortex-M4F (the device's seed
//! gives the returns the QEMU run prints). Prints each seed's three returns and, with
//! `--out DIR`, writes them as the harness's result files (`awfqi.json`, `fqi.json`,
//! `thermostat.json`: one step per run) for `scripts/paired-tests`.
//!
//! ```sh
//! cargo run --release --example zones_host -- 0 20 --out /tmp/zones-eval
//! scripts/paired-tests /tmp/zones-eval/awfqi.json /tmp/zones-eval/fqi.json /tmp/zones-eval/thermostat.json
//! ```

#[path = "zones/src/zones.rs"]
mod zones;

use std::fmt::Write as _;

fn main() -> awfqi::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let number =
        |i: usize, default: u64| args.get(i).and_then(|a| a.parse().ok()).unwrap_or(default);
    let (first, end) = (number(0, 100), number(1, 120));
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1));
    // Host-only variations (ablations and budget schedules): `--schedule STEPSxBUDGET`,
    // `--all-starts` (verify from every start state), `--sub-batches S` and `--verify V`
    // (instead of the schedule rule's), `--safeguard`.
    let flag = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
    };
    let mut variant = zones::RECOMMENDED;
    if let Some((steps, budget)) = flag("--schedule").and_then(|s| s.split_once('x')) {
        variant.steps = steps.parse().unwrap_or(variant.steps);
        variant.budget = budget.parse().unwrap_or(variant.budget);
    }
    variant.all_starts = args.iter().any(|a| a == "--all-starts");
    let sub_batches: Option<usize> = flag("--sub-batches").and_then(|s| s.parse().ok());
    let verify: Option<f32> = flag("--verify").and_then(|s| s.parse().ok());
    // `--k K`: the reward weights' noise variance K·ν_r instead of the scaled rule's.
    let k: Option<f32> = flag("--k").and_then(|s| s.parse().ok());
    let safeguard = args.iter().any(|a| a == "--safeguard");
    // `--fading KAPPA` (with `--fading-cells C`, default 10): fading source weights.
    let fading: Option<f32> = flag("--fading").and_then(|s| s.parse().ok());
    let fading_cells: usize = flag("--fading-cells")
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let mut table = vec![awfqi::adaptive::FadeCell::EMPTY; fading_cells.pow(3) * zones::ACTIONS];
    let default = variant == zones::RECOMMENDED
        && sub_batches.is_none()
        && verify.is_none()
        && k.is_none()
        && fading.is_none()
        && !safeguard;
    let mut memory = Box::new(zones::Memory::new());
    let mut rows: Vec<(u64, [f32; 3])> = Vec::new();
    for seed in first..end {
        let mut warnings = 0;
        let verbose = std::env::var_os("ZONES_VERBOSE").is_some();
        let configure = |c: &mut awfqi::prelude::AdaptiveConfig<f32, 3, 4>| {
            if let Some(s) = sub_batches {
                c.sub_batches = s;
            }
            if let Some(v) = verify {
                c.verify = v;
            }
            if let Some(k) = k {
                let w = c.awfqi.weights;
                let v = w.noise_variance() * k / awfqi::thesis::NOISE_MULTIPLIER as f32;
                if let Ok(p) = awfqi::prelude::WeightParams::new(w.estimator(), v, w.max_weight()) {
                    c.awfqi.weights = p;
                }
            }
            c.safeguard = safeguard;
        };
        let on_step = |report: &awfqi::prelude::StepReport<f32, 4>| {
            if verbose {
                eprintln!(
                    "seed {seed}, step {}: source ESS {:.1}, discarded {}, capped {}, GP {:?}, jitter {:.2e}, condition {:.2e}",
                    report.step,
                    report.wr_source_eff,
                    report.wr_discarded,
                    report.wr_capped,
                    report.gp_hyperparameters,
                    report.gp_jitter,
                    report.gp_condition
                );
            }
            for w in report.warnings() {
                eprintln!("seed {seed}, step {}: warning: {w}", report.step);
                warnings += 1;
            }
            eprintln!(
                "seed {seed}, step {}: shortfall {:.4}, reward std {:.4}",
                report.step, report.plan_shortfall, report.reward_std
            );
        };
        let outcome = if default {
            zones::learn_and_compare(&mut memory, seed, on_step)?
        } else {
            let fade = fading.map(|kappa| {
                let f = awfqi::adaptive::Fading {
                    pseudo_records: kappa,
                    cells: fading_cells,
                };
                (f, &mut table[..])
            });
            zones::learn_and_compare_with(&mut memory, seed, variant, configure, fade, on_step)?
        };
        // The uniform random policy over the same protocol (from its own stream).
        let random = {
            use awfqi::rand_core::SeedableRng;
            let plant = awfqi::env::Zones::<f32>::target();
            let protocol = awfqi::prelude::MultiStartProtocol {
                starts: &zones::STARTS,
                rollouts: zones::ROLLOUTS,
                horizon: zones::HORIZON,
                discount: zones::DISCOUNT,
            };
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut policy = awfqi::prelude::UniformPolicy::new(zones::ACTIONS)?;
            awfqi::prelude::evaluate_multi_start(&plant, &mut policy, &protocol, &mut rng)?
                .mean_return
        };
        println!("seed {seed}: random {random:.2}");
        let r = [
            outcome.awfqi.mean_return,
            outcome.fqi.mean_return,
            outcome.thermostat.mean_return,
        ];
        println!(
            "seed {seed}: awfqi {:.2}, fqi {:.2}, thermostat {:.2}",
            r[0], r[1], r[2]
        );
        rows.push((seed, r));
        if std::env::var_os("ZONES_VERBOSE").is_some() {
            let logs: [&[_]; 2] = [&memory.sources[0], &memory.sources[1]];
            let scales = awfqi::thesis::SourceScales::measure(&logs)?;
            eprintln!(
                "seed {seed}: reward mean {:.3}, variance {:.4}, local noise {:.5}, v_r {:.5}",
                scales.reward_mean,
                scales.reward_variance,
                scales.reward_noise,
                scales.reward_weights()?.noise_variance()
            );
        }
    }
    let n = rows.len() as f64;
    for (k, name) in ["awfqi", "fqi", "thermostat"].iter().enumerate() {
        let mean = rows.iter().map(|(_, r)| f64::from(r[k])).sum::<f64>() / n;
        println!("{name}: mean {mean:.2} over {n} seeds");
    }
    if let Some(dir) = out {
        std::fs::create_dir_all(dir)
            .map_err(|_| awfqi::Error::InvalidParameter { parameter: "--out" })?;
        for (k, name) in ["awfqi", "fqi", "thermostat"].iter().enumerate() {
            let mut json = format!(
                "{{\"experiment\": \"zones\", \"algorithm\": \"{name}\", \"n_runs\": {}, \"runs\": [",
                rows.len()
            );
            for (i, (seed, r)) in rows.iter().enumerate() {
                let sep = if i == 0 { "" } else { ", " };
                let _ = write!(
                    json,
                    "{sep}{{\"run\": {seed}, \"steps\": [{{\"step\": 1, \"perf_disc_greedy_mean\": {}}}]}}",
                    r[k]
                );
            }
            json.push_str("]}\n");
            let path = std::path::Path::new(dir).join(format!("{name}.json"));
            std::fs::write(&path, json)
                .map_err(|_| awfqi::Error::InvalidParameter { parameter: "--out" })?;
        }
    }
    Ok(())
}
