//! The core's thesis AWFQI (`awfqi-embedded`) on the main job's protocol at other
//! capacities: target-GP points `N`, FQI cells per axis and score-grid spacing — what a
//! smaller RAM budget costs in return (the 32 KiB configuration).
//!
//! Same protocol, data and random streams as `awfqi-harness puddle --algorithms
//! awfqi-embedded --embedded-q tabular` (thesis setting 2 (b): shared dynamics, the published sources, grid rows,
//! 50 queries per step, 6 steps, seed 0, run `i` from the stream (seed, RUN, awfqi-embedded, i), the
//! realistic score table from (seed, SCORE_TABLE, 100), evaluation by the domain's 5 greedy
//! rollouts); with `64 11 0.1` it reproduces that path's result files' returns exactly.
//!
//! ```sh
//! cargo run --release -p awfqi-harness --example embedded_capacity -- N CELLS SPACING [RUNS | A..B]
//! ```
//!
//! `N` is one of 16, 24, 32, 48, 64. Prints the mean ± standard error of the greedy return
//! after every step, each run's step-6 return, and the RAM the configuration's
//! `AwfqiStorage` takes on a Cortex-M4F (thumbv7em: `usize` 4 bytes, so a record is 28 B).

use awfqi::env::{Dynamics, PUDDLE_ACTIONS, PuddleWorld};
use awfqi_harness::domains::puddle::domain;
use awfqi_harness::transfer::algorithms::Algorithm;
use awfqi_harness::transfer::algorithms::embedded::thesis::{EmbeddedLearner, EmbeddedMemory};
use awfqi_harness::transfer::algorithms::embedded::{EmbeddedConfig, EmbeddedQ, EmbeddedSetup};
use awfqi_harness::transfer::protocol::Learner;
use awfqi_harness::transfer::score_tables::Mode;
use awfqi_harness::transfer::sources::SourceSet;
use awfqi_harness::transfer::{RUN, SCORE_TABLE, stream};

const STEPS: usize = 6;
const BUDGET: usize = 50;

/// The harness's embedded path (`awfqi-embedded`'s set-up, memory and learner, which build
/// the core's AWFQI with its builder) at GP capacity `N`.
fn run<const N: usize>(
    cells: usize,
    spacing: f64,
    first: usize,
    runs: usize,
) -> anyhow::Result<()> {
    let seed = 0;
    let sources = SourceSet::published(Dynamics::Shared)?;
    let domain = domain(Dynamics::Shared);
    let config = EmbeddedConfig::new(Mode::Grid, spacing).with_q(EmbeddedQ::Tabular(cells));
    // The realistic score table, once (as the harness's embedded set-up does).
    let setup = EmbeddedSetup::<N>::new(&sources, config, &mut stream(seed, &[SCORE_TABLE, 100]))?;
    let slices = setup.source_slices();
    let rows = setup.score_rows();
    let records: usize = slices.iter().map(|s| s.len()).sum();

    let mut returns = vec![[0.0f64; STEPS]; runs];
    for (i, out) in returns.iter_mut().enumerate() {
        let mut rng = stream(
            seed,
            &[RUN, Algorithm::AwfqiEmbedded.id(), (first + i) as u64],
        );
        let mut memory = EmbeddedMemory::<N>::new(&setup, STEPS, BUDGET, PUDDLE_ACTIONS, false)?;
        let mut learner = EmbeddedLearner::new(
            &setup,
            &slices,
            &mut memory,
            BUDGET,
            PuddleWorld::target(Dynamics::Shared),
            None,
            &mut rng,
        )?;
        for (k, r) in out.iter_mut().enumerate() {
            learner.step(k, &mut rng)?;
            let greedy = |s: &[f64; 2]| learner.greedy_action(s);
            *r = domain.evaluate(&greedy, &mut rng)?.returns.mean_return;
        }
    }

    // RAM of the configuration's AwfqiStorage on thumbv7em (4-byte usize): the GP
    // (`4·(N² + N·(I + 2) + I + 2) + 8`), 28-byte records, 4-byte weights, 8-byte alias
    // entries, 20-byte FQI entries.
    let gp_bytes = 4 * (N * N + N * 5 + 5) + 8;
    let parts = [
        ("GP", gp_bytes),
        ("target records", STEPS * BUDGET * 28),
        ("weights", records * 4),
        ("alias", rows * 8),
        ("FQI", cells * cells * PUDDLE_ACTIONS * 20),
    ];
    let total: usize = parts.iter().map(|p| p.1).sum();
    println!(
        "N = {N}, {cells} x {cells} cells, spacing {spacing} ({} rows), runs {first}..{}",
        rows,
        first + runs
    );
    println!("AwfqiStorage on thumbv7em: {total} B ({parts:?})");
    for k in 0..STEPS {
        let v: Vec<f64> = returns.iter().map(|r| r[k]).collect();
        let mean = v.iter().sum::<f64>() / runs as f64;
        // Population variance over √runs: the harness's summary.csv convention.
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / runs as f64;
        println!(
            "step {}: {mean:.1} ± {:.1}",
            k + 1,
            (var / runs as f64).sqrt()
        );
    }
    let last: Vec<String> = returns
        .iter()
        .map(|r| format!("{:.2}", r[STEPS - 1]))
        .collect();
    println!("step {STEPS} per run: {}", last.join(" "));
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: embedded_capacity N CELLS SPACING [RUNS | A..B]";
    let n: usize = args
        .first()
        .ok_or_else(|| anyhow::anyhow!(usage))?
        .parse()?;
    let cells: usize = args.get(1).ok_or_else(|| anyhow::anyhow!(usage))?.parse()?;
    let spacing: f64 = args.get(2).ok_or_else(|| anyhow::anyhow!(usage))?.parse()?;
    // RUNS: a count from run 0, or a range `A..B` (runs A to B − 1).
    let (first, runs) = match args.get(3).map(|r| r.split_once("..")) {
        None => (0, 10),
        Some(None) => (0, args[3].parse()?),
        Some(Some((a, b))) => {
            let (a, b): (usize, usize) = (a.parse()?, b.parse()?);
            anyhow::ensure!(a < b, "{usage}");
            (a, b - a)
        }
    };
    match n {
        16 => run::<16>(cells, spacing, first, runs),
        24 => run::<24>(cells, spacing, first, runs),
        32 => run::<32>(cells, spacing, first, runs),
        48 => run::<48>(cells, spacing, first, runs),
        64 => run::<64>(cells, spacing, first, runs),
        _ => anyhow::bail!("N must be 16, 24, 32, 48 or 64"),
    }
}
