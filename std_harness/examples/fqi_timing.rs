//! Wall time of the faithful FQI path on one core (the target: one run of the puddle
//! reference configuration, 6 steps × 10 episodes, 60 iterations, 50 trees, evaluation
//! included, in at most 5 s).
//!
//! `cargo run --release -p awfqi-harness --example fqi_timing [-- SEED [SOURCES_DIR|- [run-only]]]`
//! (without a directory, or with `-`, the published sources embedded in the harness)
//!
//! With `run-only` only part (2) runs, so `perf stat` or `time` report its CPU time alone
//! (wall time on a shared machine includes waiting for the CPU).
//!
//! Prints (1) one FQI call (60 iterations, 50 trees) on an IWFQI-sized union of 500 target
//! records and the 1033 published shared-dynamics source records, and (2) one run of the
//! reference FQI configuration step by step: records, time of collection + FQI +
//! evaluation, and the greedy evaluation (mean of 5 discounted returns). This is a timing
//! harness, not the experiment command.

use std::time::Instant;

use awfqi::env::{Dynamics, PUDDLE_DISCOUNT, PUDDLE_HORIZON, PuddleWorld};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi_harness::forest_fqi::{Dataset, FqiOptions, fqi};
use awfqi_harness::transfer::sources::SourceSet;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// The shared-dynamics source records: the published ones (embedded in the harness), or
/// those of `dir` when one is given (empty or `-`: published).
fn read_sources(dir: &str) -> Dataset<2> {
    let set = if dir.is_empty() || dir == "-" {
        SourceSet::published(Dynamics::Shared)
    } else {
        SourceSet::read_dir(std::path::Path::new(dir), Dynamics::Shared)
    };
    set.unwrap_or_else(|e| panic!("{dir}: {e:#}")).union()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(0, |s| s.parse().unwrap());
    let sources = args.get(2).cloned().unwrap_or_default();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let target = PuddleWorld::<f64>::target(Dynamics::Shared);

    let mut uniform = UniformPolicy::new(4).unwrap();
    if args.get(3).map(String::as_str) != Some("run-only") {
        one_call(&target, &mut uniform, &sources, &mut rng);
    }

    // (2) One run of the reference FQI configuration.
    run(&target, &mut uniform, &mut rng);
}

/// (1) One FQI call on 500 uniform target records + 1033 source records.
fn one_call(
    target: &PuddleWorld<f64>,
    uniform: &mut UniformPolicy,
    sources: &str,
    rng: &mut ChaCha8Rng,
) {
    let mut union = Dataset::new();
    while union.len() < 500 {
        target
            .run_episode_with(uniform, PUDDLE_HORIZON, rng, |r| {
                if union.len() < 500 {
                    union.push(r.transition);
                }
                Ok(())
            })
            .unwrap();
    }
    union.extend_from(&read_sources(sources));
    let t = Instant::now();
    let out = fqi(&union, &FqiOptions::plain(), rng).unwrap();
    println!(
        "FQI 60 it x 50 trees on {} records (500 target + 1033 source): {:.3} s ({} nodes in Q)",
        union.len(),
        t.elapsed().as_secs_f64(),
        (0..4)
            .map(|a| out.q.forest(a).unwrap().n_nodes())
            .sum::<usize>()
    );
}

/// (2) One run of the reference FQI configuration.
fn run(target: &PuddleWorld<f64>, uniform: &mut UniformPolicy, rng: &mut ChaCha8Rng) {
    let run_start = Instant::now();
    let mut data = Dataset::new();
    let mut q = None;
    for step in 1..=6 {
        let t = Instant::now();
        for _ in 0..10 {
            let mut push = |r: awfqi::env::EpisodeRecord<f64>| {
                data.push(r.transition);
                Ok(())
            };
            match &q {
                None => target.run_episode_with(uniform, PUDDLE_HORIZON, rng, &mut push),
                Some(q) => {
                    let greedy =
                        |s: &[f64; 2]| Ok(awfqi_harness::trees::ActionForests::greedy_action(q, s));
                    let mut policy = EpsilonGreedyPolicy::new(greedy, 0.3, 4).unwrap();
                    target.run_episode_with(&mut policy, PUDDLE_HORIZON, rng, &mut push)
                }
            }
            .unwrap();
        }
        let t_collect = t.elapsed().as_secs_f64();
        let learned = fqi(&data, &FqiOptions::plain(), rng).unwrap().q;
        let t_fqi = t.elapsed().as_secs_f64() - t_collect;
        let mut greedy = |s: &[f64; 2]| Ok(learned.greedy_action(s));
        let returns: Vec<f64> = (0..5)
            .map(|_| {
                target
                    .rollout(&mut greedy, PUDDLE_HORIZON, PUDDLE_DISCOUNT, rng)
                    .unwrap()
                    .discounted_return
            })
            .collect();
        let t_total = t.elapsed().as_secs_f64();
        println!(
            "step {step}: {:5} records, collect {:.3} s, FQI {:.3} s, evaluate {:.3} s, greedy return {:8.2}",
            data.len(),
            t_collect,
            t_fqi,
            t_total - t_collect - t_fqi,
            returns.iter().sum::<f64>() / 5.0
        );
        q = Some(learned);
    }
    println!(
        "one run of the reference FQI configuration: {:.3} s",
        run_start.elapsed().as_secs_f64()
    );
}
