//! Where the core's adaptive AWFQI (`awfqi-adaptive`) loses against Extra-Trees FQI: the approximator, on the
//! same data. Runs the core's adaptive kernel (f32, the harness's configuration: 64-point
//! GPs, 12 × 12 tiles × 8 tilings, 6 steps of 50 queries on shared-dynamics Puddle World,
//! the published sources, grid rows of spacing 0.1), then fits the harness's weighted
//! Extra-Trees FQI (the std algorithm's: 50 trees, 60 iterations, γ = 0.99) on exactly the
//! kernel's final data — its 300 target records (weight 1) and the source records with the
//! kernel's final relabelled rewards (or reward weights without relabelling) — and evaluates both greedy policies with the same 50
//! rollouts from (0, 0) (f64 target). The difference isolates the FQI approximator: the
//! queries, the GPs, the weights and the scalar are the kernel's for both.
//!
//! ```sh
//! cargo run --release -p awfqi-harness --example adaptive_gap -- [RUNS]   # default 10
//! ```
//!
//! Each run's generator is `ChaCha8Rng::seed_from_u64(1000 + i)` (a diagnostic, not the
//! harness's streams).

use awfqi::env::{Dynamics, PUDDLE_ACTIONS, PuddleWorld};
use awfqi::evaluation::{EvaluationProtocol, evaluate};
use awfqi::prelude::{
    AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, FqiEntry, Gp, GpTraining, MeanFunction,
    Posterior, RowSet, SourceData, SubsetRule, Tilings, Transition,
};
use awfqi_harness::domains::puddle::domain;
use awfqi_harness::forest_fqi::{Dataset, FqiOptions, fqi};
use awfqi_harness::transfer::protocol::Protocol;
use awfqi_harness::transfer::sources::SourceSet;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

type Record32 = Transition<[f32; 2], f32>;

fn main() -> anyhow::Result<()> {
    let runs: u64 = std::env::args()
        .nth(1)
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(10);
    let sources = SourceSet::published(Dynamics::Shared)?;
    let domain = domain(Dynamics::Shared);
    let protocol = Protocol::published(&domain, 6, 1);
    let records: Vec<Vec<Record32>> = sources
        .sources
        .iter()
        .map(|s| {
            s.records
                .iter()
                .map(|r| Transition {
                    state: r.state.map(|x| x as f32),
                    action: r.action,
                    reward: r.reward as f32,
                    next_state: r.next_state.map(|x| x as f32),
                    absorbing: r.absorbing,
                })
                .collect()
        })
        .collect();
    let slices: Vec<&[Record32]> = records.iter().map(Vec::as_slice).collect();
    let posteriors: Vec<Posterior<f32>> = sources
        .sources
        .iter()
        .flat_map(|s| &s.reward)
        .map(|p| Posterior::new(p.mean as f32, p.std as f32))
        .collect();
    let mut gp = Box::new(Gp::<f32, 64, 3>::empty());
    let mut rng = ChaCha8Rng::seed_from_u64(999);
    let mut means = vec![MeanFunction::<f32, 64, 3>::EMPTY; slices.len()];
    for (m, s) in means.iter_mut().zip(&slices) {
        m.fit_rewards(
            &mut gp,
            s,
            &GpTraining::published(),
            SubsetRule::Spread,
            &mut rng,
        )?;
    }
    let rows = RowSet::grid(PuddleWorld::score_grid(0.1)?, PUDDLE_ACTIONS)?;
    let target32 = PuddleWorld::<f32>::target(Dynamics::Shared);
    let target64 = PuddleWorld::<f64>::target(Dynamics::Shared);
    let evaluation = EvaluationProtocol {
        start: [0.0, 0.0],
        rollouts: 50,
        horizon: 50,
        discount: 0.99,
    };
    let approximator = Tilings::cube(0.0f32, 10.0, 12, 8)?;
    let entries = awfqi::fqi::Approximator::from(approximator)
        .required_entries(PUDDLE_ACTIONS)
        .unwrap_or(0);
    let (mut tiles_sum, mut trees_sum) = (Vec::new(), Vec::new());
    println!("run  tiles (kernel)  trees (same data and weights)");
    for i in 0..runs {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + i);
        let config = AdaptiveConfig::recommended(50, [0.0, 0.0], 50, 0.3, [(0.0, 10.0); 2]);
        let mut samples = vec![Transition::EMPTY; 300];
        let mut weights = vec![0.0; posteriors.len()];
        let mut candidates = vec![awfqi::adaptive::candidates::Candidate::EMPTY; 4000];
        let mut fqi_entries = vec![FqiEntry::EMPTY; entries];
        let mut path = vec![[0.0; 2]; 50];
        let mut beliefs = vec![awfqi::adaptive::plausibility::SourceBelief::EMPTY; slices.len()];
        let mut kernel = AdaptiveAwfqi::new(
            config.validate()?,
            approximator,
            SourceData::new(&slices, &posteriors)?,
            &means,
            rows,
            target32,
            AdaptiveBuffers {
                gp: &mut gp,
                samples: &mut samples,
                weights: &mut weights,
                candidates: &mut candidates,
                fqi: (&mut fqi_entries[..]).into(),
                path: &mut path,
                beliefs: &mut beliefs,
            },
        )?;
        for _ in 0..6 {
            kernel.step(&mut rng)?;
        }
        // The kernel's data in f64: D₀ then the sources, with its weights.
        let mut data = Dataset::<2>::new();
        for r in kernel.target_samples() {
            data.push(Transition {
                state: r.state.map(f64::from),
                action: r.action,
                reward: f64::from(r.reward),
                next_state: r.next_state.map(f64::from),
                absorbing: r.absorbing,
            });
        }
        // Relabelling (the recommended configuration) replaces the sources' rewards and
        // keeps their weights at 1; without it the sources keep their rewards and weights.
        let relabelled = kernel.relabelled_rewards();
        for (j, r) in sources.sources.iter().flat_map(|s| &s.records).enumerate() {
            let reward = relabelled.get(j).map_or(r.reward, |&y| f64::from(y));
            data.push(Transition { reward, ..*r });
        }
        let mut wr = vec![1.0; kernel.target_samples().len()];
        if relabelled.is_empty() {
            wr.extend(kernel.reward_weights().iter().map(|&w| f64::from(w)));
        } else {
            wr.resize(data.len(), 1.0);
        }
        let ws = vec![1.0; wr.len()];
        let options = FqiOptions {
            iterations: protocol.iterations,
            n_trees: protocol.trees,
            tree: protocol.tree,
            gamma: domain.discount,
            num_actions: PUDDLE_ACTIONS,
            ..FqiOptions::iwfqi(&wr, &ws)
        };
        let trees = fqi(&data, &options, &mut rng)?.q;
        let q = kernel.q();
        let mut tiles_policy = |s: &[f64; 2]| q.greedy_action([s[0] as f32, s[1] as f32]);
        let mut eval_rng = ChaCha8Rng::seed_from_u64(5000 + i);
        let tiles = evaluate(&target64, &mut tiles_policy, &evaluation, &mut eval_rng)?;
        let mut trees_policy = |s: &[f64; 2]| Ok(trees.greedy_action(s));
        let mut eval_rng = ChaCha8Rng::seed_from_u64(5000 + i);
        let forest = evaluate(&target64, &mut trees_policy, &evaluation, &mut eval_rng)?;
        println!(
            "{i:>3}  {:>14.1}  {:>14.1}",
            tiles.mean_return, forest.mean_return
        );
        tiles_sum.push(tiles.mean_return);
        trees_sum.push(forest.mean_return);
    }
    let stats = |x: &[f64]| {
        let n = x.len() as f64;
        let m = x.iter().sum::<f64>() / n;
        let v = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, (v / n).sqrt())
    };
    let diff: Vec<f64> = trees_sum
        .iter()
        .zip(&tiles_sum)
        .map(|(a, b)| a - b)
        .collect();
    let (t, f, d) = (stats(&tiles_sum), stats(&trees_sum), stats(&diff));
    println!(
        "mean ± s.e.: tiles {:.1} ± {:.1}, trees {:.1} ± {:.1}, trees − tiles {:+.1} ± {:.1}",
        t.0, t.1, f.0, f.1, d.0, d.1
    );
    Ok(())
}
