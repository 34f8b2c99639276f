//! What the adaptive AWFQI's approximator can reach on the Dam when data is not the limit:
//! the core's model sweep (`SweepFqi`, the Dam's settings in `awfqi-adaptive`: rewards
//! backfilled, min mass 0, capped-nearest empty cells, γ = 0.999, 400 sweeps) fitted on
//! `N` target transitions, weight 1, no sources: states drawn uniformly (storage in
//! `[0, 500]`, day an integer in `1..=360`), every one of the eight releases at each, each
//! answered once by the `f32` target plant. Its greedy policy is scored as the harness
//! scores the Dam (rollouts of a year from storage 200 on day 1, discounted return).
//!
//! With unweighted, uniform, exact target data the queries, the score and the importance
//! weights play no part: what is left is the approximator (grid resolution, the model's
//! interpolation). `--no-wrap` draws days `1..=359` only, so no record carries the year's
//! wrap (day 360 → 1), whose day displacement of −359 the model averages into the last
//! cells' nodes.
//!
//! ```sh
//! cargo run --release -p awfqi-harness --example dam_sweep_ceiling -- \
//!     [--cells 12,24,48] [--states 2000,20000] [--repeats 5] [--rollouts 100] [--no-wrap] [--lookahead]
//! ```
//!
//! Each repeat `i` draws its data from `ChaCha8Rng::seed_from_u64(2000 + i)` and evaluates
//! with `seed_from_u64(3000 + i)` (a diagnostic, not the harness's streams). Prints one line
//! per (cells, states): the mean over repeats of the mean discounted return, and its s.e.

use awfqi::env::{DAM_ACTIONS, DAM_DAYS, DAM_DISCOUNT, DAM_EVALUATION_STATE, DAM_HORIZON, Dam};
use awfqi::evaluation::{EvaluationProtocol, evaluate_greedy};
use awfqi::{
    CellGrid, EmptyCells, FqiConfig, GenerativeModel, ModelSweep, RewardModel, SampleSet,
    SweepEntry, SweepFqi, SweepNode, Transition,
};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

struct Args {
    cells: Vec<usize>,
    states: Vec<usize>,
    repeats: u64,
    rollouts: usize,
    wrap: bool,
    lookahead: bool,
    sweeps: usize,
}

fn list(v: &str) -> anyhow::Result<Vec<usize>> {
    v.split(',')
        .map(|x| x.trim().parse().map_err(anyhow::Error::from))
        .collect()
}

fn args() -> anyhow::Result<Args> {
    let mut a = Args {
        cells: vec![12, 24, 48],
        states: vec![2_000, 20_000],
        repeats: 5,
        rollouts: 100,
        wrap: true,
        lookahead: false,
        sweeps: 400,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || {
            it.next()
                .ok_or_else(|| anyhow::anyhow!("{flag} needs a value"))
        };
        match flag.as_str() {
            "--cells" => a.cells = list(&value()?)?,
            "--states" => a.states = list(&value()?)?,
            "--repeats" => a.repeats = value()?.parse()?,
            "--rollouts" => a.rollouts = value()?.parse()?,
            "--sweeps" => a.sweeps = value()?.parse()?,
            "--no-wrap" => a.wrap = false,
            "--lookahead" => a.lookahead = true,
            other => anyhow::bail!("unknown argument {other}"),
        }
    }
    Ok(a)
}

/// `n` uniform states × every release, one target transition each.
fn data(
    target: &Dam<f32>,
    n: usize,
    wrap: bool,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<Vec<Transition<[f32; 2], f32>>> {
    let days = if wrap { DAM_DAYS } else { DAM_DAYS - 1 } as u64;
    let mut out = Vec::with_capacity(n * DAM_ACTIONS);
    for _ in 0..n {
        let storage = (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32 * 500.0;
        let day = (1 + rng.next_u64() % days) as f32;
        for a in 0..DAM_ACTIONS {
            out.push(target.query([storage, day], a, rng)?);
        }
    }
    Ok(out)
}

fn main() -> anyhow::Result<()> {
    let a = args()?;
    let target = Dam::<f32>::target();
    let protocol = EvaluationProtocol {
        start: DAM_EVALUATION_STATE.map(|x| x as f32),
        rollouts: a.rollouts,
        horizon: DAM_HORIZON,
        discount: DAM_DISCOUNT as f32,
    };
    let config = FqiConfig::new(DAM_DISCOUNT as f32, a.sweeps, EmptyCells::CappedNearest)?;
    println!(
        "cells  states  records  mean return ({} repeats, {} rollouts each)  wrap={} lookahead={}",
        a.repeats, a.rollouts, a.wrap, a.lookahead
    );
    for &n in &a.states {
        for &c in &a.cells {
            let grid = CellGrid::new([0.0f32, 1.0], [500.0, DAM_DAYS as f32], [c, c])?;
            let sweep = ModelSweep::new(grid)?
                .with_rewards(RewardModel::Backfilled)
                .with_lookahead(a.lookahead);
            let needed = sweep
                .required_entries(DAM_ACTIONS)
                .ok_or_else(|| anyhow::anyhow!("grid too large"))?;
            let mut entries = vec![SweepEntry::EMPTY; needed];
            let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
            let mut returns = Vec::new();
            for i in 0..a.repeats {
                let mut rng = ChaCha8Rng::seed_from_u64(2000 + i);
                let records = data(&target, n, a.wrap, &mut rng)?;
                let mut q = SweepFqi::new(sweep, DAM_ACTIONS, &mut entries, &mut nodes)?;
                q.fit(&[SampleSet::unweighted(&records)], &config)?;
                let mut eval_rng = ChaCha8Rng::seed_from_u64(3000 + i);
                let e = evaluate_greedy(&target, &q, &protocol, &mut eval_rng)?;
                returns.push(f64::from(e.mean_return));
            }
            let m = returns.iter().sum::<f64>() / returns.len() as f64;
            let se = if returns.len() > 1 {
                let v = returns.iter().map(|x| (x - m).powi(2)).sum::<f64>()
                    / (returns.len() - 1) as f64;
                (v / returns.len() as f64).sqrt()
            } else {
                f64::NAN
            };
            println!("{c:5}  {n:6}  {:7}  {m:9.1} ± {se:.1}", n * DAM_ACTIONS);
        }
    }
    Ok(())
}
