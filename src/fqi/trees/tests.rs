extern crate std;
use super::growth::{LANES, Sides, predict_lanes};
use super::*;
use crate::fqi::{EmptyCells, QFunction, QStorage};
use crate::model::Transition;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::vec;
use std::vec::Vec;

type S1 = Transition<[f64; 1], f64>;

fn at(x: f64, action: usize, reward: f64, next: f64, absorbing: bool) -> S1 {
    Transition {
        state: [x],
        action,
        reward,
        next_state: [next],
        absorbing,
    }
}

/// Storage for `records` records with 2 actions and `forests`.
fn storage(records: usize, forests: &ExtraTrees) -> (Vec<TreeRecord<f64, 1>>, Vec<TreeNode<f64>>) {
    (
        vec![TreeRecord::EMPTY; records],
        vec![TreeNode::EMPTY; forests.required_nodes(2).unwrap()],
    )
}

/// 30 records on `[0, 5)` of two actions: the samples (reward −1), the same samples
/// carrying the replacement rewards `−|x − 2|`, those rewards, and the generator after
/// drawing them.
fn replacement_case() -> (Vec<S1>, Vec<S1>, Vec<f64>, ChaCha8Rng) {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut samples = Vec::new();
    let mut rewards = Vec::new();
    for i in 0..30 {
        let x = crate::rng::uniform::<f64, _>(&mut rng) * 5.0;
        let next = crate::rng::uniform::<f64, _>(&mut rng) * 5.0;
        samples.push(at(x, i % 2, -1.0, next, i % 9 == 0));
        rewards.push(-(x - 2.0).abs());
    }
    let carried = samples
        .iter()
        .zip(&rewards)
        .map(|(s, &r)| Transition { reward: r, ..*s })
        .collect();
    (samples, carried, rewards, rng)
}

/// γ = 0.9, 10 iterations: the FQI of [`replacement_case`]'s tests.
fn replacement_config() -> FqiConfig<f64> {
    FqiConfig::new(0.9, 10, EmptyCells::Nearest).unwrap()
}

/// The values at 50 points of `forests` fitted on `sets` (seed 4).
fn fitted_values(forests: ExtraTrees, sets: &[SampleSet<'_, f64, 1>]) -> Vec<f64> {
    let (mut records, mut nodes) = storage(30, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    q.fit(
        sets,
        &replacement_config(),
        &mut ChaCha8Rng::seed_from_u64(4),
    )
    .unwrap();
    (0..50)
        .map(|i| q.value([i as f64 / 10.0], i % 2).unwrap())
        .collect()
}

/// One iteration: Q is the reward model.
fn one_iteration() -> FqiConfig<f64> {
    FqiConfig::new(0.9, 1, EmptyCells::Nearest).unwrap()
}

#[test]
fn one_tree_reproduces_an_obvious_split_and_its_weighted_leaf_means() {
    // Action 0: three records at x = 0 (rewards 1, 2, 3, reward weights 1, 2, 3) and two at
    // x = 1 (rewards 10, 20). The root's only feature ranges over [0, 1], so every threshold
    // τ ∈ [0, 1) separates the two groups; each group is constant in x (no candidate), so
    // it is a leaf: (1 + 4 + 9)/6 = 14/6 and 15.
    let samples = [
        at(0.0, 0, 1.0, 0.0, true),
        at(1.0, 0, 10.0, 0.0, true),
        at(0.0, 0, 2.0, 0.0, true),
        at(0.0, 0, 3.0, 0.0, true),
        at(1.0, 0, 20.0, 0.0, true),
    ];
    let wr = [1.0, 1.0, 2.0, 3.0, 1.0];
    let sets = [SampleSet::weighted(&samples, Some(&wr), None)];
    let forests = ExtraTrees::new(1, 15).unwrap();
    let (mut records, mut nodes) = storage(5, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        q.fit(&sets, &one_iteration(), &mut rng).unwrap();
        let tree = q.tree(0, 0).unwrap();
        let root = tree[0];
        assert_eq!(root.feature(), Some(0));
        assert!((0.0..1.0).contains(&root.value()));
        assert!(tree[1].is_leaf() && tree[2].is_leaf());
        assert!((tree[1].value() - 14.0 / 6.0).abs() < 1e-12);
        assert!((tree[2].value() - 15.0).abs() < 1e-12);
        // The rest of the budget is unused.
        assert!(tree[3..].iter().all(|n| *n == TreeNode::EMPTY));
        assert!((q.value([0.0], 0).unwrap() - 14.0 / 6.0).abs() < 1e-12);
        assert!((q.value([1.0], 0).unwrap() - 15.0).abs() < 1e-12);
        // Action 1 has no record: 0 (and wins the greedy choice only on value).
        assert_eq!(q.value([0.0], 1).unwrap(), 0.0);
        assert_eq!(q.greedy_action([1.0]).unwrap(), 0);
    }
}

#[test]
fn a_zero_weight_record_never_enters_a_leaf_value() {
    // A record of reward weight 0 and reward 100 at x = 2 beside the groups above: a child
    // holding only it has weight 0 and is never a valid split, so every leaf is a weighted
    // mean of positive-weight records: 14/6, 15 or (14 + 30)/8.
    let samples = [
        at(0.0, 0, 1.0, 0.0, true),
        at(0.0, 0, 2.0, 0.0, true),
        at(0.0, 0, 3.0, 0.0, true),
        at(1.0, 0, 10.0, 0.0, true),
        at(1.0, 0, 20.0, 0.0, true),
        at(2.0, 0, 100.0, 0.0, true),
    ];
    let wr = [1.0, 2.0, 3.0, 1.0, 1.0, 0.0];
    let sets = [SampleSet::weighted(&samples, Some(&wr), None)];
    let forests = ExtraTrees::new(1, 31).unwrap();
    let (mut records, mut nodes) = storage(6, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let allowed = [14.0 / 6.0, 15.0, 44.0 / 8.0];
    for seed in 0..50 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        q.fit(&sets, &one_iteration(), &mut rng).unwrap();
        for x in [0.0, 0.5, 1.0, 1.5, 2.0] {
            let v = q.value([x], 0).unwrap();
            assert!(allowed.iter().any(|a| (v - a).abs() < 1e-12), "{v} at {x}");
        }
    }
}

#[test]
fn the_minimum_weight_keeps_near_zero_weight_records_out_of_their_own_leaves() {
    // As above with weight 0.1 for the record at x = 2: without a minimum weight some of 50
    // trees give it a leaf of its own (Q(2) above 15); with 0.5 none can.
    let samples = [
        at(0.0, 0, 1.0, 0.0, true),
        at(1.0, 0, 10.0, 0.0, true),
        at(2.0, 0, 100.0, 0.0, true),
    ];
    let wr = [1.0, 1.0, 0.1];
    let sets = [SampleSet::weighted(&samples, Some(&wr), None)];
    let forests = ExtraTrees::new(50, 7).unwrap();
    let (mut records, mut nodes) = storage(3, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    q.fit(&sets, &one_iteration(), &mut rng).unwrap();
    assert!(q.value([2.0], 0).unwrap() > 15.0);
    let trusted = one_iteration().with_min_weight(0.5).unwrap();
    q.fit(&sets, &trusted, &mut rng).unwrap();
    // Each leaf holding x = 2 also holds x = 1 (and perhaps x = 0).
    let with_1 = (10.0 + 10.0) / 1.1;
    let with_both = (1.0 + 10.0 + 10.0) / 2.1;
    for t in 0..50 {
        let v = predict(q.tree(0, t).unwrap(), &[2.0]);
        assert!(
            (v - with_1).abs() < 1e-12 || (v - with_both).abs() < 1e-12,
            "{v}"
        );
    }
}

#[test]
fn a_constant_target_gives_a_constant_q_from_single_leaves() {
    // Reward −3 everywhere, absorbing: every tree is one leaf, Q ≡ −3 exactly; with
    // non-absorbing records and γ = 0.5, 3 iterations: −3(1 + 0.5 + 0.25).
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut samples = Vec::new();
    let mut wr = Vec::new();
    for i in 0..40 {
        let x = crate::rng::uniform::<f64, _>(&mut rng) * 10.0;
        samples.push(at(x, i % 2, -3.0, (x + 1.0) % 10.0, true));
        wr.push(0.1 + (i % 7) as f64);
    }
    let forests = ExtraTrees::new(4, 63).unwrap();
    let (mut records, mut nodes) = storage(40, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let sets = [SampleSet::weighted(&samples, Some(&wr), None)];
    q.fit(&sets, &one_iteration(), &mut rng).unwrap();
    for a in 0..2 {
        for t in 0..4 {
            assert!(q.tree(a, t).unwrap()[0].is_leaf());
        }
        for x in [0.0, 3.3, 9.9, -5.0] {
            assert_eq!(q.value([x], a).unwrap(), -3.0);
        }
    }
    for s in &mut samples {
        s.absorbing = false;
    }
    let config = FqiConfig::new(0.5, 3, EmptyCells::Nearest).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config, &mut rng)
        .unwrap();
    for x in [0.0, 3.3, 9.9] {
        assert_eq!(q.value([x], 1).unwrap(), -3.0 * 1.75);
    }
}

#[test]
fn fqi_on_a_chain_is_value_iteration_at_the_states() {
    // The 5-cell chain of the tiles' and kNN tests (states at c + 0.5; action 0 right,
    // absorbing on reaching cell 4; action 1 left; reward −1). Fully grown trees put records
    // of different targets in different leaves, so every record's value is its state's:
    // Q(c, right) = V*(c) = −(1 − γ^{4−c})/(1 − γ), Q(c, left) = −1 + γ V*(c − 1).
    let gamma = 0.9f64;
    let mut samples = Vec::new();
    for c in 0..4 {
        let x = c as f64 + 0.5;
        for _ in 0..2 {
            samples.push(at(x, 0, -1.0, x + 1.0, c + 1 == 4));
            samples.push(at(x, 1, -1.0, (x - 1.0).max(0.5), false));
        }
    }
    let forests = ExtraTrees::new(10, 15).unwrap();
    let (mut records, mut nodes) = storage(16, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let config = FqiConfig::new(gamma, 120, EmptyCells::Nearest).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    q.fit(&[SampleSet::unweighted(&samples)], &config, &mut rng)
        .unwrap();
    let v_star = |c: usize| -(1.0 - gamma.powi(4 - c as i32)) / (1.0 - gamma);
    for c in 0..4 {
        let s = [c as f64 + 0.5];
        assert!((q.value(s, 0).unwrap() - v_star(c)).abs() < 1e-9);
        let want_left = -1.0 + gamma * v_star(c.saturating_sub(1));
        assert!((q.value(s, 1).unwrap() - want_left).abs() < 1e-9);
        assert_eq!(q.greedy_action(s).unwrap(), 0);
        assert!((q.max_value(s).unwrap() - v_star(c)).abs() < 1e-9);
    }
    // R̂ = −1 at every record; the records are grouped by action.
    assert!(q.records().iter().all(|r| r.reward_model() == -1.0));
    assert!(
        q.records()
            .windows(2)
            .all(|w| w[0].action() <= w[1].action())
    );
}

#[test]
fn the_chain_in_f32() {
    let gamma = 0.9f32;
    let mut samples = Vec::new();
    for c in 0..4 {
        let x = c as f32 + 0.5;
        samples.push(Transition {
            state: [x],
            action: 0,
            reward: -1.0f32,
            next_state: [x + 1.0],
            absorbing: c + 1 == 4,
        });
        samples.push(Transition {
            state: [x],
            action: 1,
            reward: -1.0,
            next_state: [(x - 1.0).max(0.5)],
            absorbing: false,
        });
    }
    let forests = ExtraTrees::new(5, 15).unwrap();
    let mut records = vec![TreeRecord::<f32, 1>::EMPTY; 8];
    let mut nodes = vec![TreeNode::<f32>::EMPTY; forests.required_nodes(2).unwrap()];
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let config = FqiConfig::new(gamma, 120, EmptyCells::Nearest).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    q.fit(&[SampleSet::unweighted(&samples)], &config, &mut rng)
        .unwrap();
    for c in 0..4 {
        let v = -(1.0 - gamma.powi(4 - c)) / (1.0 - gamma);
        assert!((q.value([c as f32 + 0.5], 0).unwrap() - v).abs() < 1e-4);
    }
}

#[test]
fn the_node_budget_cuts_breadth_first() {
    // Records at x = 0, 1, 2, 3 with rewards 0, 1, 2, 3: a budget of 3 nodes is one split
    // and two leaves, each the mean of its side; a budget of 1 is the overall mean.
    let samples: Vec<S1> = (0..4)
        .map(|i| at(i as f64, 0, i as f64, 0.0, true))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let forests = ExtraTrees::new(1, 3).unwrap();
    let (mut records, mut nodes) = storage(4, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    for _ in 0..20 {
        q.fit(
            &[SampleSet::unweighted(&samples)],
            &one_iteration(),
            &mut rng,
        )
        .unwrap();
        let tree = q.tree(0, 0).unwrap();
        assert_eq!(tree.len(), 3);
        let tau = tree[0].value();
        assert!(tree[1].is_leaf() && tree[2].is_leaf());
        let left: Vec<f64> = (0..4).map(f64::from).filter(|&x| x <= tau).collect();
        let right: Vec<f64> = (0..4).map(f64::from).filter(|&x| x > tau).collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!((tree[1].value() - mean(&left)).abs() < 1e-12);
        assert!((tree[2].value() - mean(&right)).abs() < 1e-12);
    }
    let forests = ExtraTrees::new(1, 1).unwrap();
    let (mut records, mut nodes) = storage(4, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    q.fit(
        &[SampleSet::unweighted(&samples)],
        &one_iteration(),
        &mut rng,
    )
    .unwrap();
    assert_eq!(q.value([0.0], 0).unwrap(), 1.5);
}

#[test]
fn min_samples_leaf_keeps_three_records_per_leaf() {
    // Six records x = y = 0..5, min_samples_leaf 3: the only valid split is {0,1,2} |
    // {3,4,5}, so every prediction is 1, 4 or (no valid threshold drawn) 2.5.
    let samples: Vec<S1> = (0..6)
        .map(|i| at(i as f64, 0, i as f64, 0.0, true))
        .collect();
    let forests = ExtraTrees::new(1, 63)
        .unwrap()
        .with_min_samples(2, 3)
        .unwrap();
    let (mut records, mut nodes) = storage(6, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let mut seen_split = false;
    for seed in 0..40 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        q.fit(
            &[SampleSet::unweighted(&samples)],
            &one_iteration(),
            &mut rng,
        )
        .unwrap();
        for x in 0..6 {
            let v = q.value([f64::from(x)], 0).unwrap();
            assert!([1.0, 4.0, 2.5].contains(&v), "{v}");
            seen_split |= v != 2.5;
        }
    }
    assert!(seen_split);
}

#[test]
fn same_seed_same_q_and_replacement_rewards_as_carried_rewards() {
    let (samples, carried, rewards, _) = replacement_case();
    let forests = ExtraTrees::new(3, 31).unwrap();
    let config = replacement_config();
    let fit = |sets: &[SampleSet<'_, f64, 1>]| fitted_values(forests, sets);
    let replaced = fit(&[SampleSet::unweighted(&samples).with_rewards(Some(&rewards))]);
    assert_eq!(replaced, fit(&[SampleSet::unweighted(&carried)]));
    // Split across two sets: the same records, the same values.
    let (a, b) = carried.split_at(13);
    assert_eq!(
        replaced,
        fit(&[SampleSet::unweighted(a), SampleSet::unweighted(b)])
    );
    // Through the common Q-function type.
    let (mut records, mut nodes) = storage(30, &forests);
    let mut q = crate::fqi::Approximator::<f64, 1>::Trees(forests)
        .build(
            2,
            QStorage {
                tree_records: &mut records,
                nodes: &mut nodes,
                ..QStorage::default()
            },
        )
        .unwrap();
    assert!(matches!(q, QFunction::Trees(_)));
    q.fit(
        &[SampleSet::unweighted(&carried)],
        &config,
        &mut ChaCha8Rng::seed_from_u64(4),
    )
    .unwrap();
    let through: Vec<f64> = (0..50)
        .map(|i| q.value([i as f64 / 10.0], i % 2).unwrap())
        .collect();
    assert_eq!(replaced, through);
}

#[test]
fn bad_input_and_short_capacity_are_errors_that_leave_q_as_it_was() {
    let samples = [
        at(0.0, 0, 1.0, 1.0, false),
        at(1.0, 1, 2.0, 0.0, false),
        at(2.0, 0, 3.0, 1.0, true),
    ];
    let forests = ExtraTrees::new(2, 7).unwrap();
    let (mut records, mut nodes) = storage(3, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let config = FqiConfig::new(0.9, 5, EmptyCells::Nearest).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    q.fit(&[SampleSet::unweighted(&samples)], &config, &mut rng)
        .unwrap();
    let before: Vec<f64> = (0..6)
        .map(|i| q.value([i as f64 / 2.0], i % 2).unwrap())
        .collect();
    let kept_records = q.records().to_vec();
    let check = |q: &TreeFqi<'_, f64, 1>| {
        let now: Vec<f64> = (0..6)
            .map(|i| q.value([i as f64 / 2.0], i % 2).unwrap())
            .collect();
        assert_eq!(now, before);
        assert_eq!(q.records(), &kept_records[..]);
    };
    let four = [samples[0], samples[1], samples[2], samples[0]];
    assert_eq!(
        q.fit(&[SampleSet::unweighted(&four)], &config, &mut rng),
        Err(Error::CapacityExceeded { capacity: 3 })
    );
    check(&q);
    let mut bad = samples;
    bad[1].state = [f64::NAN];
    assert!(matches!(
        q.fit(&[SampleSet::unweighted(&bad)], &config, &mut rng),
        Err(Error::NonFinite { .. })
    ));
    check(&q);
    let mut bad = samples;
    bad[2].action = 2;
    assert_eq!(
        q.fit(&[SampleSet::unweighted(&bad)], &config, &mut rng),
        Err(Error::OutOfRange {
            parameter: "action"
        })
    );
    check(&q);
    let negative = [1.0, -1.0, 1.0];
    assert!(matches!(
        q.fit(
            &[SampleSet::weighted(&samples, Some(&negative), None)],
            &config,
            &mut rng
        ),
        Err(Error::InvalidParameter { .. })
    ));
    check(&q);
    let short = [1.0, 1.0];
    assert!(
        q.fit(
            &[SampleSet::unweighted(&samples).with_rewards(Some(&short))],
            &config,
            &mut rng
        )
        .is_err()
    );
    check(&q);
    assert_eq!(q.fit(&[], &config, &mut rng), Err(Error::EmptyData));
    check(&q);
    assert!(q.value([f64::INFINITY], 0).is_err());
    assert!(q.value([0.0], 2).is_err());
    assert!(q.greedy_action([f64::NAN]).is_err());
    assert!(q.max_value([f64::NAN]).is_err());

    // Construction.
    assert_eq!(
        ExtraTrees::new(0, 7),
        Err(Error::InvalidParameter { parameter: "trees" })
    );
    for bad in [0, 70_000] {
        assert_eq!(
            ExtraTrees::new(1, bad),
            Err(Error::InvalidParameter {
                parameter: "max_nodes"
            })
        );
    }
    assert!(forests.with_min_samples(1, 1).is_err());
    assert!(forests.with_min_samples(2, 0).is_err());
    let mut few = vec![TreeNode::EMPTY; 27];
    let mut slots = vec![TreeRecord::<f64, 1>::EMPTY; 3];
    assert_eq!(
        TreeFqi::new(forests, 2, &mut slots, &mut few).err(),
        Some(Error::CapacityExceeded { capacity: 27 })
    );
    let mut enough = vec![TreeNode::EMPTY; 28];
    assert!(TreeFqi::new(forests, 0, &mut slots, &mut enough).is_err());
    let mut many = vec![TreeRecord::<f64, 1>::EMPTY; 65_535];
    assert_eq!(
        TreeFqi::new(forests, 2, &mut many, &mut enough).err(),
        Some(Error::CapacityExceeded { capacity: 65_534 })
    );
}

#[test]
fn a_fresh_or_cleared_q_is_zero() {
    let forests = ExtraTrees::new(2, 7).unwrap();
    let (mut records, mut nodes) = storage(3, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    assert_eq!(q.value([1.0], 1).unwrap(), 0.0);
    let samples = [at(0.0, 0, 1.0, 1.0, true), at(1.0, 1, 2.0, 0.0, true)];
    q.fit(
        &[SampleSet::unweighted(&samples)],
        &one_iteration(),
        &mut ChaCha8Rng::seed_from_u64(0),
    )
    .unwrap();
    assert_eq!(q.value([1.0], 1).unwrap(), 2.0);
    q.clear();
    assert_eq!(q.value([1.0], 1).unwrap(), 0.0);
    assert!(q.records().is_empty());
}

/// Streamed forests: the same expectations as the stored ones.
#[test]
fn streamed_trees_on_the_chain_are_value_iteration_at_the_states() {
    let gamma = 0.9f64;
    let mut samples = Vec::new();
    for c in 0..4 {
        let x = c as f64 + 0.5;
        for _ in 0..2 {
            samples.push(at(x, 0, -1.0, x + 1.0, c + 1 == 4));
            samples.push(at(x, 1, -1.0, (x - 1.0).max(0.5), false));
        }
    }
    let forests = ExtraTrees::streamed(10, 15).unwrap();
    assert!(forests.is_streamed());
    assert_eq!(forests.required_nodes(2), Some(15));
    let (mut records, mut nodes) = storage(16, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let config = FqiConfig::new(gamma, 120, EmptyCells::Nearest).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    q.fit(&[SampleSet::unweighted(&samples)], &config, &mut rng)
        .unwrap();
    assert!(q.tree(0, 0).is_none());
    let v_star = |c: usize| -(1.0 - gamma.powi(4 - c as i32)) / (1.0 - gamma);
    for c in 0..4 {
        let s = [c as f64 + 0.5];
        assert!((q.value(s, 0).unwrap() - v_star(c)).abs() < 1e-9);
        let want_left = -1.0 + gamma * v_star(c.saturating_sub(1));
        assert!((q.value(s, 1).unwrap() - want_left).abs() < 1e-9);
        assert_eq!(q.greedy_action(s).unwrap(), 0);
        assert!((q.max_value(s).unwrap() - v_star(c)).abs() < 1e-9);
    }
    assert!(q.records().iter().all(|r| r.reward_model() == -1.0));
}

#[test]
fn streamed_trees_reproduce_the_obvious_split_and_ignore_zero_weights() {
    let samples = [
        at(0.0, 0, 1.0, 0.0, true),
        at(1.0, 0, 10.0, 0.0, true),
        at(0.0, 0, 2.0, 0.0, true),
        at(0.0, 0, 3.0, 0.0, true),
        at(1.0, 0, 20.0, 0.0, true),
        at(2.0, 0, 100.0, 0.0, true),
    ];
    let wr = [1.0, 1.0, 2.0, 3.0, 1.0, 0.0];
    let sets = [SampleSet::weighted(&samples, Some(&wr), None)];
    let forests = ExtraTrees::streamed(5, 1).unwrap();
    let (mut records, mut nodes) = storage(6, &forests);
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    let allowed = [14.0 / 6.0, 15.0, 44.0 / 8.0];
    for seed in 0..30 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        q.fit(&sets, &one_iteration(), &mut rng).unwrap();
        // Each tree's leaf at 0 is {x = 0} or everything of positive weight.
        for x in [0.0, 1.0, 2.0] {
            for t in 0..5 {
                let v = lazy_tree(q.records(), &[x], tree_seed(q.seed, 0, t), &q.growth);
                assert!(allowed.iter().any(|a| (v - a).abs() < 1e-12), "{v} at {x}");
            }
        }
        // With no zero-weight record beside them the groups always separate.
        q.fit(
            &[SampleSet::weighted(&samples[..5], Some(&wr[..5]), None)],
            &one_iteration(),
            &mut rng,
        )
        .unwrap();
        assert!((q.value([0.0], 0).unwrap() - 14.0 / 6.0).abs() < 1e-12);
        assert!((q.value([1.0], 0).unwrap() - 15.0).abs() < 1e-12);
        assert_eq!(q.value([0.0], 1).unwrap(), 0.0);
    }
}

#[test]
fn fully_grown_trees_interpolate_distinct_training_states() {
    // Distinct 2-D states with arbitrary rewards, one iteration: a fully grown tree's leaf
    // holding a record holds only records of its target (else it would split), so every
    // tree — stored or streamed — predicts each record's reward at its state.
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let samples: Vec<Transition<[f64; 2], f64>> = (0..60)
        .map(|i| Transition {
            state: [
                crate::rng::uniform::<f64, _>(&mut rng) * 10.0,
                crate::rng::uniform::<f64, _>(&mut rng) * 10.0,
            ],
            action: i % 3,
            reward: crate::rng::uniform::<f64, _>(&mut rng) * 20.0 - 10.0,
            next_state: [0.0, 0.0],
            absorbing: true,
        })
        .collect();
    for forests in [
        ExtraTrees::new(4, 127).unwrap(),
        ExtraTrees::streamed(4, 1).unwrap(),
    ] {
        let mut records = vec![TreeRecord::<f64, 2>::EMPTY; 60];
        let mut nodes = vec![TreeNode::EMPTY; forests.required_nodes(3).unwrap()];
        let mut q = TreeFqi::new(forests, 3, &mut records, &mut nodes).unwrap();
        q.fit(
            &[SampleSet::unweighted(&samples)],
            &one_iteration(),
            &mut rng,
        )
        .unwrap();
        for s in &samples {
            let v = q.value(s.state, s.action).unwrap();
            assert!((v - s.reward).abs() < 1e-9, "{v} {}", s.reward);
        }
    }
}

#[test]
fn streamed_fits_are_reproducible_and_honour_replacement_rewards() {
    let (samples, carried, rewards, mut rng) = replacement_case();
    let forests = ExtraTrees::streamed(3, 63).unwrap();
    let config = replacement_config();
    let fit = |sets: &[SampleSet<'_, f64, 1>]| fitted_values(forests, sets);
    let replaced = fit(&[SampleSet::unweighted(&samples).with_rewards(Some(&rewards))]);
    assert_eq!(replaced, fit(&[SampleSet::unweighted(&carried)]));
    // Values stay within the range of the discounted rewards.
    assert!(
        replaced
            .iter()
            .all(|v| v.is_finite() && *v <= 0.0 && *v >= -2.5 / 0.1)
    );
    let (mut records, mut nodes) = storage(30, &forests);
    let short = vec![TreeNode::EMPTY; 62];
    let mut few = short.clone();
    assert_eq!(
        TreeFqi::new(forests, 2, &mut records, &mut few).err(),
        Some(Error::CapacityExceeded { capacity: 62 })
    );
    let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
    q.fit(&[SampleSet::unweighted(&carried)], &config, &mut rng)
        .unwrap();
    let before: Vec<f64> = (0..10)
        .map(|i| q.value([i as f64 / 2.0], 0).unwrap())
        .collect();
    let mut bad = carried.clone();
    bad[3].next_state = [f64::NAN];
    assert!(
        q.fit(&[SampleSet::unweighted(&bad)], &config, &mut rng)
            .is_err()
    );
    let after: Vec<f64> = (0..10)
        .map(|i| q.value([i as f64 / 2.0], 0).unwrap())
        .collect();
    assert_eq!(before, after);
}

#[test]
fn streamed_and_stored_forests_of_many_trees_agree() {
    // The same data and rules, different random streams: with 60 trees per action the two
    // forests' means differ by Monte-Carlo noise only — as much as two stored forests of
    // different seeds do — after FQI on noisy 2-D data with 3 actions of uneven counts,
    // unweighted and with reward weights (a third of them near 0) and a minimum weight.
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let moves = [[0.5, 0.0], [-0.5, 0.0], [0.0, 0.5]];
    let samples: Vec<Transition<[f64; 2], f64>> = (0..150)
        .map(|i| {
            let s = [
                crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
                crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
            ];
            let action = [0, 0, 0, 1, 2][i % 5];
            let m = moves[action];
            let next = [(s[0] + m[0]).clamp(0.0, 4.0), (s[1] + m[1]).clamp(0.0, 4.0)];
            let noise = crate::rng::uniform::<f64, _>(&mut rng) - 0.5;
            Transition {
                state: s,
                action,
                reward: -((s[0] - 3.0).powi(2) + (s[1] - 1.0).powi(2)).sqrt() + noise,
                next_state: next,
                absorbing: i % 17 == 0,
            }
        })
        .collect();
    let w_r: Vec<f64> = (0..150)
        .map(|i| {
            if i % 3 == 0 {
                1e-4
            } else {
                0.3 + 0.7 * crate::rng::uniform::<f64, _>(&mut rng)
            }
        })
        .collect();
    let plain = FqiConfig::new(0.9, 8, EmptyCells::Nearest).unwrap();
    let weighted = plain.with_min_weight(0.5).unwrap();
    for (sets, config) in [
        ([SampleSet::unweighted(&samples)], plain),
        ([SampleSet::weighted(&samples, Some(&w_r), None)], weighted),
    ] {
        let values = |forests: ExtraTrees, seed: u64| {
            let mut records = vec![TreeRecord::<f64, 2>::EMPTY; 150];
            let mut nodes = vec![TreeNode::EMPTY; forests.required_nodes(3).unwrap()];
            let mut q = TreeFqi::new(forests, 3, &mut records, &mut nodes).unwrap();
            q.fit(&sets, &config, &mut ChaCha8Rng::seed_from_u64(seed))
                .unwrap();
            let mut out = Vec::new();
            for i in 0..8 {
                for j in 0..8 {
                    let s = [0.25 + 0.5 * i as f64, 0.25 + 0.5 * j as f64];
                    out.push(q.value(s, (i + j) % 3).unwrap());
                }
            }
            out
        };
        let stored = values(ExtraTrees::new(60, 255).unwrap(), 9);
        let mean_gap = |other: &[f64]| {
            stored
                .iter()
                .zip(other)
                .map(|(a, b)| (a - b).abs())
                .sum::<f64>()
                / 64.0
        };
        // The noise between two stored forests of other seeds, as the yardstick.
        let noise = mean_gap(&values(ExtraTrees::new(60, 255).unwrap(), 10));
        let streamed = mean_gap(&values(ExtraTrees::streamed(60, 255).unwrap(), 9));
        assert!(streamed < 1.5 * noise, "{streamed} against {noise}");
    }
}

#[test]
fn the_depth_limit_holds_for_stored_and_streamed_trees() {
    // x = y = 0..3: at depth limit 1 a tree is one split, so its value at x = 0 is the mean
    // of {0, …, k} for the k its threshold cuts at (0, 0.5 or 1); at limit 0 it is 1.5.
    let samples: Vec<S1> = (0..4)
        .map(|i| at(i as f64, 0, i as f64, 0.0, true))
        .collect();
    for base in [
        ExtraTrees::new(1, 15).unwrap(),
        ExtraTrees::streamed(1, 15).unwrap(),
    ] {
        assert_eq!(base.max_depth(), usize::MAX);
        for seed in 0..20 {
            let forests = base.with_max_depth(1);
            let (mut records, mut nodes) = storage(4, &forests);
            let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            q.fit(
                &[SampleSet::unweighted(&samples)],
                &one_iteration(),
                &mut rng,
            )
            .unwrap();
            let v = q.value([0.0], 0).unwrap();
            assert!([0.0, 0.5, 1.0].contains(&v), "{v}");
            let forests = base.with_max_depth(0);
            let (mut records, mut nodes) = storage(4, &forests);
            let mut q = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
            q.fit(
                &[SampleSet::unweighted(&samples)],
                &one_iteration(),
                &mut rng,
            )
            .unwrap();
            assert_eq!(q.value([0.0], 0).unwrap(), 1.5);
        }
    }
}

/// The lockstep walk gives `predict`'s value at every state: on grown trees, and on node
/// arrays no growth makes (a child before its parent, a child past the end, a feature past
/// `D`, no nodes at all).
#[test]
fn lockstep_prediction_equals_the_single_walk() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut records: Vec<TreeRecord<f64, 2>> = (0..200)
        .map(|i| {
            let x = [
                crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
                crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
            ];
            TreeRecord {
                state: x,
                target: (x[0] * 3.0).sin() + x[1] + f64::from(i % 3),
                weight: 1.0,
                reward: 1.0,
                ..TreeRecord::EMPTY
            }
        })
        .collect();
    let growth = Growth {
        first: false,
        min_weight: 0.0,
        min_leaf: 1,
        min_node: 2,
        max_depth: usize::MAX,
    };
    let mut grown = vec![TreeNode::EMPTY; 255];
    grow(&mut records, &mut grown, &growth, 200.0, &mut rng);
    assert!(!grown[0].is_leaf());
    let split = |feature: u16, value: f64, left: u16| TreeNode {
        value,
        left,
        feature,
    };
    let leaf = TreeNode::<f64>::leaf;
    let odd: [&[TreeNode<f64>]; 4] = [
        &[split(1, 2.0, 1), leaf(1.0), split(2, 2.0, 0), leaf(5.0)], // child before parent
        &[split(1, 2.0, 1), leaf(-1.0), split(1, 1.0, 7)],           // child past the end
        &[split(3, 2.0, 1), leaf(4.0), leaf(8.0)],                   // feature past D
        &[],
    ];
    for nodes in odd.into_iter().chain([grown.as_slice()]) {
        for _ in 0..8 {
            let states: [[f64; 2]; LANES] = core::array::from_fn(|_| {
                [
                    crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
                    crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
                ]
            });
            let lanes = predict_lanes(nodes, &states);
            for (state, value) in states.iter().zip(lanes) {
                assert_eq!(
                    value.to_bits(),
                    predict(nodes, state).to_bits(),
                    "{nodes:?}"
                );
            }
        }
    }
}

/// Both ways of summing a split's sides, and of adding a tree's next-state values, give the
/// same bits (the target picks one by [`RUNS_AHEAD`]): signed targets, zero weights
/// (whose `wy` is −0 for a negative target), absorbing records.
#[test]
fn branch_free_and_branching_sums_agree_to_the_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (mut branching, mut branch_free) = (Sides::<f32>::EMPTY, Sides::<f32>::EMPTY);
    for i in 0..500 {
        let w = if i % 7 == 0 {
            0.0
        } else {
            crate::rng::uniform::<f32, _>(&mut rng)
        };
        let wy = w * (crate::rng::uniform::<f32, _>(&mut rng) - 0.5) * 10.0;
        let left = crate::rng::uniform::<f32, _>(&mut rng) < 0.5;
        branching.add(left, w, wy);
        branch_free.add_both(left, w, wy);
    }
    for (a, b) in [
        (branching.wl, branch_free.wl),
        (branching.sl, branch_free.sl),
        (branching.wr, branch_free.wr),
        (branching.sr, branch_free.sr),
    ] {
        assert_eq!(a.to_bits(), b.to_bits());
    }
    assert_eq!(branching.nl, branch_free.nl);
    assert!(branching.nl > 200 && branching.nl < 300);

    let mut records: Vec<TreeRecord<f64, 2>> = (0..61)
        .map(|i| {
            let x = [
                crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
                crate::rng::uniform::<f64, _>(&mut rng) * 4.0,
            ];
            TreeRecord {
                state: x,
                next_state: [x[1], x[0]],
                target: x[0] - x[1] * x[1],
                weight: 1.0,
                absorbing: i % 5 == 0,
                ..TreeRecord::EMPTY
            }
        })
        .collect();
    let growth = Growth {
        first: false,
        min_weight: 0.0,
        min_leaf: 1,
        min_node: 2,
        max_depth: usize::MAX,
    };
    let mut tree = vec![TreeNode::EMPTY; 127];
    grow(&mut records, &mut tree, &growth, 61.0, &mut rng);
    let mut walked = records.clone();
    add_next_state_values(&tree, &mut records, true);
    add_next_state_values(&tree, &mut walked, false);
    for (a, b) in records.iter().zip(&walked) {
        assert_eq!(a.acc.to_bits(), b.acc.to_bits());
        assert_eq!(
            a.acc == 0.0,
            a.absorbing || predict(&tree, &a.next_state) == 0.0
        );
    }
}
