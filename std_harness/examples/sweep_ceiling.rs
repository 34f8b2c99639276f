//! What the adaptive AWFQI's approximator can reach on the Dam or Acrobot when data is not
//! the limit: the core's model sweep (`SweepFqi` with the domain's settings in
//! `awfqi-adaptive`: the Dam's rewards backfilled, 400 sweeps, γ = 0.999; Acrobot's pooled,
//! 50 sweeps, γ = 0.95; min mass 0, capped-nearest empty cells, the harness's box) fitted on
//! `N` target transitions, weight 1, no sources: states drawn uniformly in the box (the
//! Dam's day an integer in `1..=360`), every action at each, each answered once by the
//! `f32` target plant. Its greedy policy is scored as the harness scores the domain (Dam:
//! rollouts of a year from storage 200 on day 1; Acrobot: one rollout from each of the nine
//! evaluation angles, at rest), by the discounted return.
//!
//! With unweighted, uniform, exact target data the queries, the score and the importance
//! weights play no part: what is left is the approximator (grid resolution, the model's
//! interpolation). `--no-wrap` (Dam) draws days `1..=359` only, so no record carries the
//! year's wrap (day 360 → 1), whose day displacement of −359 the model averages into the
//! last cells' nodes.
//!
//! ```sh
//! cargo run --release -p awfqi-harness --example sweep_ceiling -- [--domain dam|acrobot] \
//!     [--cells 12,24,48] [--states 2000,20000] [--repeats 5] [--rollouts 100] [--sweeps N] \
//!     [--no-wrap] [--lookahead] [--anchors 256,1024 [--neighbours 4]]
//! ```
//!
//! `--anchors` fits the sweep on representative states placed from the records
//! (`AnchorFqi`, one line per node budget) instead of the grid.
//!
//! Each repeat `i` draws its data from `ChaCha8Rng::seed_from_u64(2000 + i)` and evaluates
//! with `seed_from_u64(3000 + i)` (a diagnostic, not the harness's streams). Prints one line
//! per (cells, states): the mean over repeats of the mean discounted return, and its s.e.

use std::f32::consts::PI;

use awfqi::env::{
    ACROBOT_ACTIONS, ACROBOT_DISCOUNT, ACROBOT_EVALUATION_ANGLES, ACROBOT_HORIZON,
    ACROBOT_MAX_VELOCITY_1, ACROBOT_MAX_VELOCITY_2, Acrobot, DAM_ACTIONS, DAM_DAYS, DAM_DISCOUNT,
    DAM_EVALUATION_STATE, DAM_HORIZON, DAM_MAX_STORAGE, Dam,
};
use awfqi::evaluation::{MultiStartProtocol, evaluate_greedy_multi_start};
use awfqi::prelude::{
    CellGrid, EmptyCells, FqiConfig, GenerativeModel, ModelSweep, RewardModel, SampleSet,
    SweepEntry, SweepFqi, SweepNode, Transition,
};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

struct Args {
    domain: String,
    cells: Vec<usize>,
    states: Vec<usize>,
    repeats: u64,
    rollouts: Option<usize>,
    wrap: bool,
    lookahead: bool,
    sweeps: Option<usize>,
    anchors: Vec<usize>,
    neighbours: usize,
}

fn list(v: &str) -> anyhow::Result<Vec<usize>> {
    v.split(',')
        .map(|x| x.trim().parse().map_err(anyhow::Error::from))
        .collect()
}

fn args() -> anyhow::Result<Args> {
    let mut a = Args {
        domain: "dam".into(),
        cells: vec![12, 24, 48],
        states: vec![2_000, 20_000],
        repeats: 5,
        rollouts: None,
        wrap: true,
        lookahead: false,
        sweeps: None,
        anchors: Vec::new(),
        neighbours: awfqi::fqi::ANCHOR_LINKS,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || {
            it.next()
                .ok_or_else(|| anyhow::anyhow!("{flag} needs a value"))
        };
        match flag.as_str() {
            "--domain" => a.domain = value()?,
            "--cells" => a.cells = list(&value()?)?,
            "--states" => a.states = list(&value()?)?,
            "--repeats" => a.repeats = value()?.parse()?,
            "--rollouts" => a.rollouts = Some(value()?.parse()?),
            "--sweeps" => a.sweeps = Some(value()?.parse()?),
            "--no-wrap" => a.wrap = false,
            "--lookahead" => a.lookahead = true,
            "--anchors" => a.anchors = list(&value()?)?,
            "--neighbours" => a.neighbours = value()?.parse()?,
            other => anyhow::bail!("unknown argument {other}"),
        }
    }
    Ok(a)
}

/// A uniform draw in `[0, 1)`.
fn unit(rng: &mut ChaCha8Rng) -> f32 {
    (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

/// One domain's plant, box, evaluation and model settings.
struct Setting<G, const D: usize> {
    target: G,
    lower: [f32; D],
    upper: [f32; D],
    actions: usize,
    rewards: RewardModel,
    discount: f32,
    sweeps: usize,
    starts: Vec<[f32; D]>,
    rollouts: usize,
    horizon: usize,
    draw: fn(&mut ChaCha8Rng, bool) -> [f32; D],
}

fn ceiling<G, const D: usize>(a: &Args, s: &Setting<G, D>) -> anyhow::Result<()>
where
    G: GenerativeModel<f32, State = [f32; D]>,
{
    let sweeps = a.sweeps.unwrap_or(s.sweeps);
    let rollouts = a.rollouts.unwrap_or(s.rollouts);
    let protocol = MultiStartProtocol {
        starts: &s.starts,
        rollouts,
        horizon: s.horizon,
        discount: s.discount,
    };
    let config = FqiConfig::new(s.discount, sweeps, EmptyCells::CappedNearest)?;
    println!(
        "{}: cells  states  records  mean return ({} repeats, {} rollouts from each of {} starts)  sweeps={sweeps} wrap={} lookahead={}",
        a.domain,
        a.repeats,
        rollouts,
        s.starts.len(),
        a.wrap,
        a.lookahead
    );
    if !a.anchors.is_empty() {
        return anchor_ceiling(a, s, &config, &protocol);
    }
    for &n in &a.states {
        for &c in &a.cells {
            let grid = CellGrid::new(s.lower, s.upper, [c; D])?;
            let sweep = ModelSweep::new(grid)?
                .with_rewards(s.rewards)
                .with_lookahead(a.lookahead);
            let needed = sweep
                .required_entries(s.actions)
                .ok_or_else(|| anyhow::anyhow!("grid too large"))?;
            let mut entries = vec![SweepEntry::EMPTY; needed];
            let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
            let mut returns = Vec::new();
            for i in 0..a.repeats {
                let mut rng = ChaCha8Rng::seed_from_u64(2000 + i);
                let mut records: Vec<Transition<[f32; D], f32>> = Vec::with_capacity(n * s.actions);
                for _ in 0..n {
                    let state = (s.draw)(&mut rng, a.wrap);
                    for action in 0..s.actions {
                        records.push(s.target.query(state, action, &mut rng)?);
                    }
                }
                let mut q = SweepFqi::new(sweep, s.actions, &mut entries, &mut nodes)?;
                q.fit(&[SampleSet::unweighted(&records)], &config)?;
                let mut eval_rng = ChaCha8Rng::seed_from_u64(3000 + i);
                let e = evaluate_greedy_multi_start(&s.target, &q, &protocol, &mut eval_rng)?;
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
            println!("{c:5}  {n:6}  {:7}  {m:9.2} ± {se:.2}", n * s.actions);
        }
    }
    Ok(())
}

/// The records of repeat `i`: `n` uniform states, every action at each.
fn draw<G, const D: usize>(
    a: &Args,
    s: &Setting<G, D>,
    n: usize,
    i: u64,
) -> anyhow::Result<Vec<Transition<[f32; D], f32>>>
where
    G: GenerativeModel<f32, State = [f32; D]>,
{
    let mut rng = ChaCha8Rng::seed_from_u64(2000 + i);
    let mut records = Vec::with_capacity(n * s.actions);
    for _ in 0..n {
        let state = (s.draw)(&mut rng, a.wrap);
        for action in 0..s.actions {
            records.push(s.target.query(state, action, &mut rng)?);
        }
    }
    Ok(records)
}

/// [`ceiling`] on anchors: one line per (node budget, states).
fn anchor_ceiling<G, const D: usize>(
    a: &Args,
    s: &Setting<G, D>,
    config: &FqiConfig<f32>,
    protocol: &MultiStartProtocol<'_, f32, D>,
) -> anyhow::Result<()>
where
    G: GenerativeModel<f32, State = [f32; D]>,
{
    for &n in &a.states {
        for &m in &a.anchors {
            let anchors = awfqi::fqi::AnchorSweep::new(s.lower, s.upper, m)?
                .with_neighbours(a.neighbours)?
                .with_rewards(s.rewards)
                .with_lookahead(a.lookahead);
            let mut entries = vec![awfqi::fqi::AnchorEntry::EMPTY; m * s.actions];
            let mut nodes = vec![SweepNode::EMPTY; m];
            let mut positions = vec![[0.0f32; D]; m];
            let mut landings = vec![[0.0f32; D]; m];
            let mut returns = Vec::new();
            for i in 0..a.repeats {
                let records = draw(a, s, n, i)?;
                let mut q = awfqi::fqi::AnchorFqi::new(
                    anchors,
                    s.actions,
                    awfqi::fqi::AnchorParts {
                        entries: &mut entries,
                        nodes: &mut nodes,
                        positions: &mut positions,
                        landings: &mut landings,
                    },
                )?;
                q.fit(&[SampleSet::unweighted(&records)], config)?;
                let mut eval_rng = ChaCha8Rng::seed_from_u64(3000 + i);
                let e = evaluate_greedy_multi_start(&s.target, &q, protocol, &mut eval_rng)?;
                returns.push(f64::from(e.mean_return));
            }
            let mean = returns.iter().sum::<f64>() / returns.len() as f64;
            let se = if returns.len() > 1 {
                let v = returns.iter().map(|x| (x - mean).powi(2)).sum::<f64>()
                    / (returns.len() - 1) as f64;
                (v / returns.len() as f64).sqrt()
            } else {
                f64::NAN
            };
            println!(
                "anchors {m:5} k {}  {n:6}  {:7}  {mean:9.2} ± {se:.2}",
                a.neighbours,
                n * s.actions
            );
        }
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let a = args()?;
    match a.domain.as_str() {
        "dam" => ceiling(
            &a,
            &Setting {
                target: Dam::<f32>::target(),
                lower: [0.0, 1.0],
                upper: [DAM_MAX_STORAGE as f32, DAM_DAYS as f32],
                actions: DAM_ACTIONS,
                rewards: RewardModel::Backfilled,
                discount: DAM_DISCOUNT as f32,
                sweeps: 400,
                starts: vec![DAM_EVALUATION_STATE.map(|x| x as f32)],
                rollouts: 100,
                horizon: DAM_HORIZON,
                draw: |rng, wrap| {
                    let days = if wrap { DAM_DAYS } else { DAM_DAYS - 1 } as u64;
                    let storage = unit(rng) * DAM_MAX_STORAGE as f32;
                    [storage, (1 + rng.next_u64() % days) as f32]
                },
            },
        ),
        "acrobot" => {
            let (w1, w2) = (ACROBOT_MAX_VELOCITY_1 as f32, ACROBOT_MAX_VELOCITY_2 as f32);
            ceiling(
                &a,
                &Setting {
                    target: Acrobot::<f32>::target(),
                    lower: [-PI, -PI, -w1, -w2],
                    upper: [PI, PI, w1, w2],
                    actions: ACROBOT_ACTIONS,
                    rewards: RewardModel::Pooled,
                    discount: ACROBOT_DISCOUNT as f32,
                    sweeps: 50,
                    starts: ACROBOT_EVALUATION_ANGLES
                        .iter()
                        .map(|&t| [t as f32, 0.0, 0.0, 0.0])
                        .collect(),
                    rollouts: 1,
                    horizon: ACROBOT_HORIZON,
                    draw: |rng, _| {
                        let (w1, w2) =
                            (ACROBOT_MAX_VELOCITY_1 as f32, ACROBOT_MAX_VELOCITY_2 as f32);
                        let mut u = || unit(rng) * 2.0 - 1.0;
                        [PI * u(), PI * u(), w1 * u(), w2 * u()]
                    },
                },
            )
        }
        other => anyhow::bail!("unknown domain {other} (dam or acrobot)"),
    }
}
