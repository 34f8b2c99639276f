//! Property tests (proptest) of the core's invariants, on arbitrary inputs:
//!
//! * importance weights lie in `[0, w_max]` (both estimators, any finite posteriors);
//! * identification scores (uniform, variance, mutual information) sum to 1;
//! * the belief over candidate MDPs stays normalised after any sequence of observations;
//! * weighted FQI values are bounded by `R_max / (1 − γ)`;
//! * the same seed gives the same bytes (GP hyperparameter search, mutual-information
//!   score).

use awfqi::env::GridWorld;
use awfqi::fqi::{CellGrid, EmptyCells, FqiConfig, FqiEntry, SampleSet, TabularFqi};
use awfqi::gp::{Gp, HyperparameterBounds, Hyperparameters, SearchOptions};
use awfqi::identify::{Belief, Criterion, MiConfig, compute_score};
use awfqi::model::FiniteMdp;
use awfqi::model::Transition;
use awfqi::weights::{Estimator, Posterior, WeightParams};
use proptest::prelude::*;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;

fn posterior() -> impl Strategy<Value = Posterior<f64>> {
    (-1e3f64..1e3, 0.0f64..10.0).prop_map(|(m, s)| Posterior::new(m, s))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn weights_lie_in_zero_to_w_max(
        heuristic in any::<bool>(),
        noise in 1e-3f64..10.0,
        w_max in 1.0f64..1e4,
        rows in prop::collection::vec((-1e3f64..1e3, posterior(), posterior()), 1..40),
    ) {
        let estimator = if heuristic { Estimator::Heuristic } else { Estimator::Mean };
        let params = WeightParams::new(estimator, noise, w_max).unwrap();
        let ys: Vec<f64> = rows.iter().map(|r| r.0).collect();
        let targets: Vec<_> = rows.iter().map(|r| r.1).collect();
        let sources: Vec<_> = rows.iter().map(|r| r.2).collect();
        let mut out = vec![f64::NAN; rows.len()];
        params.weights_into(&ys, &targets, &sources, &mut out).unwrap();
        for w in out {
            prop_assert!((0.0..=w_max).contains(&w), "weight {w} outside [0, {w_max}]");
        }
    }

}

proptest! {
    // The mutual-information score samples rewards: fewer, costlier cases.
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn scores_sum_to_one_and_beliefs_stay_normalised(
        absorbing in any::<bool>(),
        prior in prop::collection::vec(0.01f64..1.0, 4),
        observations in prop::collection::vec((0usize..1000, 0usize..4, 0usize..1000, -2.0f64..2.0), 0..12),
        criterion in 0usize..3,
        seed in any::<u64>(),
    ) {
        let candidates = GridWorld::<f64>::thesis_candidates(absorbing);
        let states = candidates[0].num_states();
        let actions = candidates[0].num_actions();
        let mut belief = Belief::<f64, 4>::from_weights(&prior).unwrap();
        for (s, a, n, r) in observations {
            // An impossible observation is an error that leaves the belief as it was.
            let _ = belief.update(&candidates, s % states, a % actions, n % states, r);
            let mut p = [0.0; 4];
            belief.probabilities(&mut p).unwrap();
            let total: f64 = p.iter().sum();
            prop_assert!((total - 1.0).abs() < 1e-12, "belief sums to {total}");
            prop_assert!(p.iter().all(|&x| (0.0..=1.0).contains(&x)));
        }
        let mut b = [0.0; 4];
        belief.probabilities(&mut b).unwrap();
        let criterion = match criterion {
            0 => Criterion::Uniform,
            1 => Criterion::Variance,
            _ => Criterion::MutualInformation(MiConfig::default()),
        };
        let mut scores = vec![0.0; states * actions];
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        compute_score(&criterion, &candidates, &b, &mut rng, &mut scores).unwrap();
        let total: f64 = scores.iter().sum();
        prop_assert!((total - 1.0).abs() < 1e-9, "scores sum to {total}");
        prop_assert!(scores.iter().all(|&x| x >= 0.0));
    }

}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]
    #[test]
    fn fqi_values_are_bounded_by_r_max_over_one_minus_gamma(
        gamma in 0.0f64..0.99,
        samples in prop::collection::vec(
            (0.0f64..5.0, 0.0f64..1.0, 0usize..3, -10.0f64..10.0, 0.0f64..5.0, 0.0f64..1.0, any::<bool>(), 0.0f64..1e3),
            1..60,
        ),
        nearest in any::<bool>(),
    ) {
        let records: Vec<Transition<[f64; 2], f64>> = samples
            .iter()
            .map(|&(x, y, a, r, nx, ny, done, _)| Transition {
                state: [x, y],
                action: a,
                reward: r,
                next_state: [nx, ny],
                absorbing: done,
            })
            .collect();
        let weights: Vec<f64> = samples.iter().map(|s| s.7).collect();
        let r_max = records.iter().fold(0.0f64, |m, t| m.max(t.reward.abs()));
        let grid = CellGrid::new([0.0, 0.0], [5.0, 1.0], [5, 2]).unwrap();
        let mut storage = vec![FqiEntry::default(); 5 * 2 * 3];
        let mut fqi = TabularFqi::new(grid, 3, &mut storage).unwrap();
        let empty = if nearest { EmptyCells::Nearest } else { EmptyCells::Value(0.0) };
        let config = FqiConfig::new(gamma, 40, empty).unwrap();
        let set = SampleSet::weighted(&records, Some(&weights), Some(&weights));
        // All-zero weights in a cell are a documented error; anything else must fit.
        if fqi.fit(&[set], &config).is_ok() {
            let bound = r_max / (1.0 - gamma) * (1.0 + 1e-9) + 1e-12;
            for cx in 0..5 {
                for cy in 0..2 {
                    for a in 0..3 {
                        let v = fqi.value([cx as f64 + 0.5, cy as f64 * 0.5 + 0.25], a).unwrap();
                        prop_assert!(v.abs() <= bound, "|Q| = {} > {bound}", v.abs());
                    }
                }
            }
        }
    }

}

proptest! {
    // Each case runs two hyperparameter searches and two mutual-information scores.
    #![proptest_config(ProptestConfig::with_cases(12))]
    #[test]
    fn the_same_seed_gives_the_same_bytes(
        seed in any::<u64>(),
        points in prop::collection::vec((0.0f64..5.0, -1.0f64..1.0), 2..12),
    ) {
        let xs: Vec<[f64; 1]> = points.iter().map(|p| [p.0]).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
        let search = || {
            let mut gp = Gp::<f64, 16, 1>::new(Hyperparameters::SPEC_INITIAL).unwrap();
            gp.fit(&xs, &ys).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let options = SearchOptions { max_evaluations: 60, restarts: 2, isotropic: true };
            let lml = gp.optimize_hyperparameters(&HyperparameterBounds::spec_default(), &options, &mut rng);
            let h = *gp.hyperparameters();
            let p = gp.predict(&[2.5]).ok();
            format!("{lml:?} {h:?} {p:?}").into_bytes()
        };
        prop_assert_eq!(search(), search());
        let candidates = GridWorld::<f64>::thesis_candidates(true);
        let score = || {
            let mut out = vec![0.0; candidates[0].num_states() * candidates[0].num_actions()];
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            compute_score(
                &Criterion::MutualInformation(MiConfig::default()),
                &candidates,
                &[0.25; 4],
                &mut rng,
                &mut out,
            )
            .unwrap();
            out.iter().flat_map(|v| v.to_bits().to_le_bytes()).collect::<Vec<u8>>()
        };
        prop_assert_eq!(score(), score());
    }
}
