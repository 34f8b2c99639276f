//! `awfqi-harness demo`: the core in thirty seconds.
//!
//! Runs one Puddle World episode on the target task, then spends a small budget of
//! generative-model queries on the target, fits the core's fixed-capacity `f32` GP to the
//! observed rewards (hyperparameters searched by marginal likelihood inside spec §4.2's
//! box), and compares its posterior mean with the true mean reward on a grid. Writes
//! `episode.csv`, `gp_reward.csv`, `summary.json` and the figure `demo.{png,svg}` (the
//! episode and the queries over the box; the true and learned reward along y = 4, through
//! two puddles) under `--out`.

use std::fs;
use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use awfqi::env::{Dynamics, EpisodeRecord, PUDDLE_DISCOUNT, PUDDLE_HORIZON, PuddleWorld};
use awfqi::gp::{Gp, HyperparameterBounds, SearchOptions};
use awfqi::model::GenerativeModel;
use awfqi::policy::EpsilonGreedyPolicy;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use serde::Serialize;

use crate::plot::{Figure, LegendPosition, Panel, Series, SeriesStyle, XScale};

/// Capacity of the demo's GP: what a microcontroller could afford (≈ 17 KiB in `f32`).
const GP_CAPACITY: usize = 64;
/// Points per axis of the comparison grid over [0, 10]².
const GRID_POINTS: usize = 41;

/// Arguments of `awfqi-harness demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Seed of the run; the same seed writes the same files.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Generative-model queries spent on the target (at most the GP capacity, 64).
    #[arg(long, default_value_t = 64)]
    pub budget: usize,
    /// Output directory.
    #[arg(long, default_value = "results/demo")]
    pub out: PathBuf,
}

/// What the demo measured.
#[derive(Serialize, Debug)]
pub struct Summary {
    /// Seed of the run.
    pub seed: u64,
    /// Number of records of the episode.
    pub episode_steps: usize,
    /// Discounted return of the episode (γ = 0.99).
    pub episode_return: f64,
    /// Whether the episode reached the goal.
    pub episode_reached_goal: bool,
    /// Queries spent.
    pub queries: usize,
    /// Fitted signal variance c.
    pub signal_variance: f64,
    /// Fitted (isotropic) length scale.
    pub length_scale: f64,
    /// Fitted noise variance.
    pub noise_variance: f64,
    /// Log marginal likelihood at the fitted hyperparameters.
    pub log_marginal_likelihood: f64,
    /// Root-mean-square error of the GP mean against the true mean reward on the grid.
    pub rmse_gp: f64,
    /// The same error for the best constant predictor (the mean of the true rewards), for scale.
    pub rmse_constant: f64,
    /// Bytes of the GP's state (`size_of::<Gp<f32, 64, 3>>()`).
    pub gp_bytes: usize,
}

/// Runs the demo and prints its summary.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let summary = demo(args)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    println!("wrote {}", args.out.display());
    Ok(())
}

/// Runs the demo and returns what it measured (files are written under `args.out`).
pub fn demo(args: &Args) -> anyhow::Result<Summary> {
    anyhow::ensure!(
        (1..=GP_CAPACITY).contains(&args.budget),
        "--budget must be between 1 and {GP_CAPACITY}"
    );
    fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let target = PuddleWorld::<f32>::target(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(args.seed);

    // 1. One ε-greedy episode around a goal-seeking heuristic.
    let goal = target.goal();
    let heuristic = move |s: &[f32; 2]| -> awfqi::Result<usize> {
        let (dx, dy) = (goal[0] - s[0], goal[1] - s[1]);
        Ok(if dy.abs() >= dx.abs() {
            if dy > 0.0 { 2 } else { 3 }
        } else if dx > 0.0 {
            0
        } else {
            1
        })
    };
    let mut policy = EpsilonGreedyPolicy::new(heuristic, 0.3f32, 4)?;
    let mut records = [EpisodeRecord::<f32>::default(); PUDDLE_HORIZON];
    let steps = target.run_episode(&mut policy, PUDDLE_HORIZON, &mut records, &mut rng)?;
    let episode = records.get(..steps).unwrap_or_default();
    let mut file = fs::File::create(args.out.join("episode.csv"))?;
    writeln!(file, "t,s_x,s_y,a,r,next_s_x,next_s_y,absorbing")?;
    let mut episode_return = 0.0f64;
    for record in episode {
        let t = &record.transition;
        episode_return += PUDDLE_DISCOUNT.powi(record.t as i32) * f64::from(t.reward);
        writeln!(
            file,
            "{},{},{},{},{},{},{},{}",
            record.t,
            t.state[0],
            t.state[1],
            t.action,
            t.reward,
            t.next_state[0],
            t.next_state[1],
            u8::from(t.absorbing)
        )?;
    }
    let reached_goal = episode.last().is_some_and(|r| r.transition.absorbing);

    // 2. Active budget: uniform queries of the generative model, a reward GP on z = (x, y, a).
    let mut inputs = Vec::with_capacity(args.budget);
    let mut rewards = Vec::with_capacity(args.budget);
    for _ in 0..args.budget {
        let s = [
            awfqi::rng::uniform_in(&mut rng, 0.0f32, 10.0)?,
            awfqi::rng::uniform_in(&mut rng, 0.0f32, 10.0)?,
        ];
        let a = awfqi::rng::categorical(&mut rng, &[1.0f32; 4])?;
        let t = target.query(s, a, &mut rng)?;
        inputs.push([s[0], s[1], a as f32]);
        rewards.push(t.reward);
    }
    let mut gp = Box::new(Gp::<f32, GP_CAPACITY, 3>::empty());
    gp.fit(&inputs, &rewards)?;
    let options = SearchOptions {
        max_evaluations: 400,
        restarts: 3,
        isotropic: true,
    };
    let lml =
        gp.optimize_hyperparameters(&HyperparameterBounds::spec_default(), &options, &mut rng)?;

    // 3. Compare with the true mean reward on a grid (action 0; the reward ignores it).
    let mut file = fs::File::create(args.out.join("gp_reward.csv"))?;
    writeln!(file, "s_x,s_y,true_mean_reward,gp_mean,gp_latent_std")?;
    let (mut truths, mut errors) = (Vec::new(), Vec::new());
    for j in 0..GRID_POINTS {
        for i in 0..GRID_POINTS {
            let s = [
                10.0 * i as f32 / (GRID_POINTS - 1) as f32,
                10.0 * j as f32 / (GRID_POINTS - 1) as f32,
            ];
            let truth = target.mean_reward(s)?;
            let p = gp.predict(&[s[0], s[1], 0.0])?;
            writeln!(
                file,
                "{},{},{},{},{}",
                s[0],
                s[1],
                truth,
                p.mean,
                p.latent_variance.sqrt()
            )?;
            truths.push(f64::from(truth));
            errors.push(f64::from(p.mean - truth));
        }
    }
    let rms = |v: &[f64]| (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt();
    let mean_truth = truths.iter().sum::<f64>() / truths.len() as f64;
    let centred: Vec<f64> = truths.iter().map(|t| t - mean_truth).collect();
    let hyper = gp.hyperparameters();
    let summary = Summary {
        seed: args.seed,
        episode_steps: steps,
        episode_return,
        episode_reached_goal: reached_goal,
        queries: args.budget,
        signal_variance: f64::from(hyper.signal_variance),
        length_scale: f64::from(hyper.length_scales[0]),
        noise_variance: f64::from(hyper.noise_variance),
        log_marginal_likelihood: f64::from(lml),
        rmse_gp: rms(&errors),
        rmse_constant: rms(&centred),
        gp_bytes: std::mem::size_of::<Gp<f32, GP_CAPACITY, 3>>(),
    };
    fs::write(
        args.out.join("summary.json"),
        serde_json::to_string_pretty(&summary)?,
    )?;
    plot(&target, episode, &inputs, &gp, &args.out.join("demo"))?;
    Ok(summary)
}

/// Two panels: where the agent went and where it queried; the reward it learned along
/// y = 4 against the truth.
fn plot(
    target: &PuddleWorld<f32>,
    episode: &[EpisodeRecord<f32>],
    queries: &[[f32; 3]],
    gp: &Gp<f32, GP_CAPACITY, 3>,
    stem: &std::path::Path,
) -> anyhow::Result<()> {
    let mut path: Vec<(f64, f64)> = episode
        .iter()
        .map(|r| {
            (
                f64::from(r.transition.state[0]),
                f64::from(r.transition.state[1]),
            )
        })
        .collect();
    if let Some(last) = episode.last() {
        let s = last.transition.next_state;
        path.push((f64::from(s[0]), f64::from(s[1])));
    }
    let queried = queries
        .iter()
        .map(|z| (f64::from(z[0]), f64::from(z[1])))
        .collect();
    let space = Panel {
        title: "Target Puddle World: one episode and the queries".into(),
        x_label: "s_x".into(),
        y_label: "s_y".into(),
        x_scale: XScale::Linear,
        x_range: None,
        y_range: Some((0.0, 10.0)),
        series: vec![
            Series {
                label: "episode".into(),
                points: path,
                errors: None,
                style: SeriesStyle::LineWithMarkers,
                color: 0,
            },
            Series {
                label: "queries".into(),
                points: queried,
                errors: None,
                style: SeriesStyle::Points,
                color: 1,
            },
        ],
        references: vec![],
        legend: LegendPosition::LowerRight,
    };
    let (mut truth, mut mean, mut std) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..=100 {
        let x = i as f32 / 10.0;
        truth.push((f64::from(x), f64::from(target.mean_reward([x, 4.0])?)));
        let p = gp.predict(&[x, 4.0, 0.0])?;
        mean.push((f64::from(x), f64::from(p.mean)));
        std.push(f64::from(p.latent_variance.sqrt()));
    }
    let profile = Panel {
        title: "Mean reward along y = 4".into(),
        x_label: "s_x".into(),
        y_label: "reward".into(),
        x_scale: XScale::Linear,
        x_range: None,
        y_range: None,
        series: vec![
            Series {
                label: "true mean reward".into(),
                points: truth,
                errors: None,
                style: SeriesStyle::Line,
                color: 0,
            },
            Series {
                label: "GP mean ± latent std".into(),
                points: mean,
                errors: Some(std),
                style: SeriesStyle::Line,
                color: 1,
            },
        ],
        references: vec![],
        legend: LegendPosition::LowerRight,
    };
    Figure {
        panels: vec![space, profile],
        panel_width: 640,
        height: 480,
    }
    .save(stem)?;
    Ok(())
}
