extern crate std;
use super::*;
use crate::fqi::EmptyCells;
use crate::model::Transition;
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

/// Storage for `records` records with 2 actions and `k` neighbours.
fn storage(records: usize, k: usize) -> (Vec<KnnRecord<f64, 1>>, Vec<u16>) {
    (
        vec![KnnRecord::EMPTY; records],
        vec![NO_LINK; records * 2 * k],
    )
}

#[test]
fn one_neighbour_on_a_chain_gives_q_star_at_the_states() {
    // The 5-cell chain of the tiles' test (states at c + 0.5; action 0 right, absorbing on
    // reaching cell 4; action 1 left; reward −1): with k = 1 every next state's nearest
    // record of each action is the record at that very state, so FQI is exact value
    // iteration: Q(c, right) = V*(c) = −(1 − γ^{4−c})/(1 − γ), Q(c, left) = −1 + γ V*(c−1).
    let gamma = 0.9f64;
    let mut samples = Vec::new();
    for c in 0..4 {
        let x = c as f64 + 0.5;
        samples.push(at(x, 0, -1.0, x + 1.0, c + 1 == 4));
        samples.push(at(x, 1, -1.0, (x - 1.0).max(0.5), false));
    }
    let (mut records, mut links) = storage(8, 1);
    let nb = Neighbours::cube(1, 0.0, 5.0, Kernel::Uniform).unwrap();
    let mut q = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
    let config = FqiConfig::new(gamma, 80, EmptyCells::Nearest).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    let v_star = |c: usize| -(1.0 - gamma.powi(4 - c as i32)) / (1.0 - gamma);
    for c in 0..4 {
        let s = [c as f64 + 0.5];
        assert!((q.value(s, 0).unwrap() - v_star(c)).abs() < 1e-9);
        let want_left = -1.0 + gamma * v_star(c.saturating_sub(1));
        assert!((q.value(s, 1).unwrap() - want_left).abs() < 1e-9);
        assert_eq!(q.greedy_action(s).unwrap(), 0);
        assert!((q.max_value(s).unwrap() - v_star(c)).abs() < 1e-9);
        // Off the states the nearest record decides: 0.3 past a state is still its value.
        assert!((q.value([c as f64 + 0.8], 0).unwrap() - v_star(c)).abs() < 1e-9);
    }
}

#[test]
fn the_reward_model_averages_the_k_nearest_by_hand() {
    // Records of action 0 at x = 0, 1, 3 with rewards 1, 2, 4 (one iteration: Q = the
    // kernel mean of R̂). k = 2, unit range: R̂(0) = R̂(1) = (1 + 2)/2 = 1.5 (radius 1);
    // R̂(3): radius 2 (records 3 and 1) → (4 + 2)/2 = 3. Q(0.2) = (R̂(0) + R̂(1))/2 = 1.5,
    // Q(2.6) = (R̂(3) + R̂(1))/2 = 2.25. Action 1 has no record: Q = 0, and greedy prefers
    // action 0 at equal value.
    let samples = [
        at(0.0, 0, 1.0, 0.0, true),
        at(1.0, 0, 2.0, 0.0, true),
        at(3.0, 0, 4.0, 0.0, true),
    ];
    let (mut records, mut links) = storage(3, 2);
    let nb = Neighbours::cube(2, 0.0, 1.0, Kernel::Uniform).unwrap();
    let mut q = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
    let config = FqiConfig::new(0.9, 1, EmptyCells::Nearest).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    let fitted: Vec<f64> = q.records().iter().map(KnnRecord::reward_model).collect();
    assert_eq!(fitted, [1.5, 1.5, 3.0]);
    assert!((q.value([0.2], 0).unwrap() - 1.5).abs() < 1e-12);
    assert!((q.value([2.6], 0).unwrap() - 2.25).abs() < 1e-12);
    assert_eq!(q.value([2.6], 1).unwrap(), 0.0);
    assert_eq!(q.greedy_action([2.6]).unwrap(), 0);
    // Negative rewards: action 1 (no data, 0) wins on value.
    let negative = samples.map(|mut s| {
        s.reward = -s.reward;
        s
    });
    q.fit(&[SampleSet::unweighted(&negative)], &config).unwrap();
    assert_eq!(q.greedy_action([2.6]).unwrap(), 1);
}

#[test]
fn a_discarded_record_does_not_count_towards_k() {
    // A source record at 0 that the weights all but discard (w_r = 10⁻⁶, reward −1) next to
    // target records at 0.5 and 2 (w_r = 1, reward −10). k = 1, min weight 0.5: the trusted
    // radius at 0 is 0.5 (the record at 0.5), so R̂(0) = (10⁻⁶·(−1) + 1·(−10))/(1 + 10⁻⁶);
    // without the minimum weight the record is trusted itself and R̂(0) = −1.
    let samples = [
        at(0.0, 0, -1.0, 0.0, true),
        at(0.5, 0, -10.0, 0.0, true),
        at(2.0, 0, -10.0, 0.0, true),
    ];
    let wr = [1e-6, 1.0, 1.0];
    let sets = [SampleSet::weighted(&samples, Some(&wr), None)];
    let (mut records, mut links) = storage(3, 1);
    let nb = Neighbours::cube(1, 0.0, 1.0, Kernel::Uniform).unwrap();
    let mut q = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
    let base = FqiConfig::new(0.9, 1, EmptyCells::Nearest).unwrap();
    q.fit(&sets, &base.with_min_weight(0.5).unwrap()).unwrap();
    let want = (-1e-6 - 10.0) / (1.0 + 1e-6);
    assert!((q.value([0.0], 0).unwrap() - want).abs() < 1e-12);
    q.fit(&sets, &base).unwrap();
    assert!((q.value([0.0], 0).unwrap() + 1.0).abs() < 1e-12);
}

#[test]
fn the_gaussian_kernel_weighs_by_distance() {
    // Two records at 0 and 1 (rewards 0 and 1), k = 2, h = 1, unit range. R̂(0) =
    // e^{−1/2}/(1 + e^{−1/2}), R̂(1) = 1/(1 + e^{−1/2}) (each its own nearest, the other
    // at d² = 1); Q(0.25): d² = 1/16 and 9/16, weights 1 and e^{−1/4}.
    let samples = [at(0.0, 0, 0.0, 0.0, true), at(1.0, 0, 1.0, 0.0, true)];
    let (mut records, mut links) = storage(2, 2);
    let nb = Neighbours::cube(2, 0.0, 1.0, Kernel::Gaussian(1.0)).unwrap();
    let mut q = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
    let config = FqiConfig::new(0.9, 1, EmptyCells::Nearest).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    let e = (-0.5f64).exp();
    let (r0, r1) = (e / (1.0 + e), 1.0 / (1.0 + e));
    let w = (-0.25f64).exp();
    let want = (r0 + w * r1) / (1.0 + w);
    assert!((q.value([0.25], 0).unwrap() - want).abs() < 1e-12);
}

#[test]
fn a_discounted_two_state_loop_matches_its_closed_form() {
    // Two states 0 and 1, one action that swaps them; reward 1 in state 0, 0 in state 1,
    // k = 1: V(0) = 1/(1 − γ²), V(1) = γ/(1 − γ²); after N iterations the error is
    // γ^N-small.
    let gamma = 0.5;
    let samples = [at(0.0, 0, 1.0, 1.0, false), at(1.0, 0, 0.0, 0.0, false)];
    let (mut records, mut links) = storage(2, 1);
    let nb = Neighbours::cube(1, 0.0, 1.0, Kernel::Uniform).unwrap();
    let mut q = KnnFqi::new(nb, 1, &mut records, &mut links).unwrap();
    let config = FqiConfig::new(gamma, 60, EmptyCells::Nearest).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    let v0 = 1.0 / (1.0 - gamma * gamma);
    assert!((q.value([0.1], 0).unwrap() - v0).abs() < 1e-12);
    assert!((q.value([0.9], 0).unwrap() - gamma * v0).abs() < 1e-12);
}

#[test]
fn bad_input_is_refused_and_leaves_the_fit_intact() {
    let k0 = Neighbours::<f32, 2>::cube(0, 0.0, 1.0, Kernel::Uniform);
    assert_eq!(
        k0,
        Err(Error::InvalidParameter {
            parameter: "neighbours"
        })
    );
    assert!(Neighbours::<f32, 2>::cube(MAX_NEIGHBOURS + 1, 0.0, 1.0, Kernel::Uniform).is_err());
    assert!(Neighbours::<f32, 2>::cube(1, 1.0, 1.0, Kernel::Uniform).is_err());
    assert!(Neighbours::<f32, 2>::cube(1, f32::NAN, 1.0, Kernel::Uniform).is_err());
    assert!(Neighbours::<f32, 2>::cube(1, -f32::MAX, f32::MAX, Kernel::Uniform).is_err());
    for h in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e-30] {
        assert!(Neighbours::<f32, 2>::cube(1, 0.0, 1.0, Kernel::Gaussian(h)).is_err());
    }
    let nb = Neighbours::cube(2, 0.0, 1.0, Kernel::Uniform).unwrap();
    let (mut records, mut links) = storage(3, 2);
    assert_eq!(
        KnnFqi::new(nb, 2, &mut records, &mut links[..11]).err(),
        Some(Error::CapacityExceeded { capacity: 11 })
    );
    assert_eq!(
        KnnFqi::new(nb, 0, &mut records, &mut links).err(),
        Some(Error::InvalidParameter {
            parameter: "actions"
        })
    );
    let mut q = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
    let config = FqiConfig::published();
    let mut samples = vec![
        at(0.0, 0, 1.0, 0.5, false),
        at(0.5, 1, 2.0, 1.0, false),
        at(1.0, 0, 3.0, 1.0, true),
    ];
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    let before = q.records().to_vec();
    let value = q.value([0.3], 0).unwrap();
    let four = [samples.clone(), vec![samples[0]]].concat();
    assert_eq!(
        q.fit(&[SampleSet::unweighted(&four)], &config),
        Err(Error::CapacityExceeded { capacity: 3 })
    );
    samples[1].reward = f64::NAN;
    assert_eq!(
        q.fit(&[SampleSet::unweighted(&samples)], &config),
        Err(Error::NonFinite {
            parameter: "reward"
        })
    );
    samples[1].reward = 0.0;
    samples[2].action = 2;
    assert_eq!(
        q.fit(&[SampleSet::unweighted(&samples)], &config),
        Err(Error::OutOfRange {
            parameter: "action"
        })
    );
    samples[2].action = 0;
    samples[0].reward = 1e307;
    assert!(q.fit(&[SampleSet::unweighted(&samples)], &config).is_err());
    assert_eq!(q.fit(&[], &config), Err(Error::EmptyData));
    assert_eq!(q.records(), &before[..]);
    assert_eq!(q.value([0.3], 0).unwrap(), value);
    assert!(q.value([f64::NAN], 0).is_err());
    assert!(q.value([0.0], 2).is_err());
    assert!(q.greedy_action([f64::INFINITY]).is_err());
    assert!(q.max_value([f64::NAN]).is_err());
    q.clear();
    assert_eq!(q.value([0.3], 0).unwrap(), 0.0);
}

#[test]
fn the_reach_caps_an_action_without_nearby_records() {
    // Action 0 tried at 0 (reward −1), action 1 only at 5 (reward +10), k = 1, unit
    // range. Without a reach, Q(0, 1) = 10 is copied from 5 units away and wins; with reach
    // 1 it is capped at the tried action's −1, and the tie goes to the smaller index. At 5
    // the roles swap: action 0's −1 is below the cap 10 and stays.
    let samples = [at(0.0, 0, -1.0, 0.0, true), at(5.0, 1, 10.0, 0.0, true)];
    let (mut records, mut links) = storage(2, 1);
    let nb = Neighbours::cube(1, 0.0, 1.0, Kernel::Uniform).unwrap();
    let config = FqiConfig::new(0.9, 3, EmptyCells::Nearest).unwrap();
    let mut q = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    assert_eq!(q.greedy_action([0.0]).unwrap(), 1);
    assert_eq!(q.value([0.0], 1).unwrap(), 10.0);
    let (mut records, mut links) = storage(2, 1);
    let mut q = KnnFqi::new(nb.with_reach(1.0).unwrap(), 2, &mut records, &mut links).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    assert_eq!(q.value([0.0], 1).unwrap(), -1.0);
    assert_eq!(q.greedy_action([0.0]).unwrap(), 0);
    assert_eq!(q.max_value([0.0]).unwrap(), -1.0);
    assert_eq!(q.value([5.0], 0).unwrap(), -1.0);
    assert_eq!(q.greedy_action([5.0]).unwrap(), 1);
    // Nobody within reach: no cap.
    assert_eq!(q.value([2.5], 1).unwrap(), 10.0);
    for r in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e200] {
        assert!(nb.with_reach(r).is_err());
    }
}

#[test]
fn the_hybrid_is_the_mean_of_its_two_fits() {
    // The chain of the first test with a Gaussian kNN and two tilings: the hybrid's value is
    // the mean of a separately fitted tile Q and kNN Q on the same data, its greedy action
    // the argmax of that mean, and a refused fit (records too few) leaves both parts as
    // they were.
    use crate::fqi::{Approximator, FqiEntry, QStorage, TileFqi, Tilings};
    let gamma = 0.9f64;
    let mut samples = Vec::new();
    for c in 0..4 {
        let x = c as f64 + 0.5;
        samples.push(at(x, 0, -1.0, x + 1.0, c + 1 == 4));
        samples.push(at(x, 1, -1.0, (x - 1.0).max(0.5), false));
    }
    let sets = [SampleSet::unweighted(&samples)];
    let config = FqiConfig::new(gamma, 30, EmptyCells::Nearest).unwrap();
    let tilings = Tilings::<f64, 1>::cube(0.0, 5.0, 3, 2).unwrap();
    let nb = Neighbours::cube(2, 0.0, 5.0, Kernel::Gaussian(0.1)).unwrap();
    let (mut e1, mut e2) = (vec![FqiEntry::EMPTY; 16], vec![FqiEntry::EMPTY; 16]);
    let (mut r1, mut l1) = storage(8, 2);
    let (mut r2, mut l2) = storage(8, 2);
    let mut hybrid = Approximator::Hybrid(tilings, nb)
        .build(
            2,
            QStorage {
                entries: &mut e1,
                records: &mut r1,
                links: &mut l1,
                ..QStorage::default()
            },
        )
        .unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::from_seed([0; 32]);
    hybrid.fit(&sets, &config, &mut rng).unwrap();
    let mut tiles = TileFqi::new(tilings, 2, &mut e2).unwrap();
    tiles.fit(&sets, &config).unwrap();
    let mut knn = KnnFqi::new(nb, 2, &mut r2, &mut l2).unwrap();
    knn.fit(&sets, &config).unwrap();
    for x in [0.1, 0.5, 1.7, 2.5, 3.9, 4.9] {
        let mut best = (0, f64::NEG_INFINITY);
        for a in 0..2 {
            let want = (tiles.value([x], a).unwrap() + knn.value([x], a).unwrap()) / 2.0;
            let got = hybrid.value([x], a).unwrap();
            assert!((got - want).abs() < 1e-12, "{x} {a}: {got} {want}");
            if want > best.1 {
                best = (a, want);
            }
        }
        assert_eq!(hybrid.greedy_action([x]).unwrap(), best.0);
        assert!((hybrid.max_value([x]).unwrap() - best.1).abs() < 1e-12);
    }
    let before = hybrid.value([1.7], 0).unwrap();
    let nine = [samples.clone(), vec![samples[0]]].concat();
    assert_eq!(
        hybrid.fit(&[SampleSet::unweighted(&nine)], &config, &mut rng),
        Err(Error::CapacityExceeded { capacity: 8 })
    );
    assert_eq!(hybrid.value([1.7], 0).unwrap(), before);
}

#[test]
fn the_common_ball_bounds_every_action_by_the_same_radius() {
    // Action 0 at 0 and 0.1 (reward −1) and at 3 (reward −9); action 1 at 0.05 (−2); k = 2,
    // one iteration. R̂: −1 at 0 and 0.1, (−9 − 1)/2 = −5 at 3 (radius 2.9 holds 3 and
    // 0.1), −2 at 0.05. At 2: action 0's two nearest are 3 and 0.1 → Q = (−5 − 1)/2 = −3;
    // action 1's is 0.05 → −2, which wins without the common ball. With it, the ball of
    // the 2 nearest of any action has radius 1.9 (3 and 0.1): action 1's record (1.95
    // away) is outside, so its value is capped at −3, and the tie goes to action 0.
    let samples = [
        at(0.0, 0, -1.0, 0.0, true),
        at(0.1, 0, -1.0, 0.0, true),
        at(3.0, 0, -9.0, 0.0, true),
        at(0.05, 1, -2.0, 0.0, true),
    ];
    let config = FqiConfig::new(0.9, 1, EmptyCells::Nearest).unwrap();
    let nb = Neighbours::cube(2, 0.0, 1.0, Kernel::Uniform).unwrap();
    let (mut records, mut links) = storage(4, 2);
    let mut q = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    let fitted: Vec<f64> = q.records().iter().map(KnnRecord::reward_model).collect();
    assert_eq!(fitted, [-1.0, -1.0, -5.0, -2.0]);
    assert_eq!(q.value([2.0], 0).unwrap(), -3.0);
    assert_eq!(q.value([2.0], 1).unwrap(), -2.0);
    assert_eq!(q.greedy_action([2.0]).unwrap(), 1);
    let (mut records, mut links) = storage(4, 2);
    let common = nb.with_common_ball();
    assert!(common.common_ball());
    let mut q = KnnFqi::new(common, 2, &mut records, &mut links).unwrap();
    q.fit(&[SampleSet::unweighted(&samples)], &config).unwrap();
    assert_eq!(q.value([2.0], 0).unwrap(), -3.0);
    assert_eq!(q.value([2.0], 1).unwrap(), -3.0);
    assert_eq!(q.greedy_action([2.0]).unwrap(), 0);
    // Near 0 both actions have records inside the ball (0 and 0.05): no cap, and the
    // ball (radius 0.05 at 0.02: records 0 and 0.05) leaves action 0 only its record at 0.
    assert_eq!(q.value([0.02], 1).unwrap(), -2.0);
    assert_eq!(q.value([0.02], 0).unwrap(), -1.0);
}
