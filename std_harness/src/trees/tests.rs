//! Tests of the Extra-Trees rules of spec §4.1, each against a hand-derived expectation.

use super::*;
use awfqi::Error;
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};
use std::collections::HashMap;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Random points in [0, 10]² with targets and weights, some weights exactly 0.
pub(crate) fn random_set(n: usize, seed: u64) -> (Vec<[f64; 2]>, Vec<f64>, Vec<f64>) {
    let mut r = rng(seed);
    let mut u = || awfqi::rng::uniform_f64(&mut r);
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    let mut ws = Vec::new();
    for i in 0..n {
        xs.push([10.0 * u(), 10.0 * u()]);
        ys.push(-5.0 + 10.0 * u());
        ws.push(if i % 3 == 0 { 0.0 } else { 0.1 + 2.0 * u() });
    }
    (xs, ys, ws)
}

/// Training samples grouped by the leaf they fall in, for one tree.
fn leaves_of(forest: &Forest<2>, tree: usize, xs: &[[f64; 2]]) -> HashMap<usize, Vec<usize>> {
    let mut map: HashMap<usize, Vec<usize>> = HashMap::new();
    for (i, x) in xs.iter().enumerate() {
        map.entry(forest.leaf_id(tree, x).unwrap())
            .or_default()
            .push(i);
    }
    map
}

#[test]
fn zero_weight_sample_never_forms_its_own_leaf() {
    let (xs, ys, ws) = random_set(300, 1);
    let forest = Forest::fit(&xs, &ys, &ws, 20, &mut rng(2)).unwrap();
    assert_eq!(forest.n_trees(), 20);
    for t in 0..forest.n_trees() {
        for members in leaves_of(&forest, t, &xs).values() {
            let w: f64 = members.iter().map(|&i| ws[i]).sum();
            assert!(w > 0.0, "tree {t}: a leaf holds only zero-weight samples");
        }
    }
}

#[test]
fn leaf_predicts_weighted_mean_of_its_samples() {
    let (xs, ys, ws) = random_set(300, 3);
    let forest = Forest::fit(&xs, &ys, &ws, 10, &mut rng(4)).unwrap();
    let mut merged = 0;
    for t in 0..forest.n_trees() {
        for members in leaves_of(&forest, t, &xs).values() {
            let w: f64 = members.iter().map(|&i| ws[i]).sum();
            let wy: f64 = members.iter().map(|&i| ws[i] * ys[i]).sum();
            let value = forest.tree_prediction(t, &xs[members[0]]).unwrap();
            assert!((value - wy / w).abs() <= 1e-12 * (1.0 + value.abs()));
            merged += usize::from(members.len() > 1);
        }
    }
    // Zero-weight samples are merged into positive-weight leaves, so multi-sample leaves exist.
    assert!(merged > 0);
}

#[test]
fn split_with_a_zero_weight_child_is_never_chosen() {
    // x₀ = 0, 1, 2 (x₁ constant, so skipped); weights 1, 1, 0; targets 0, 10, 5.
    // Root impurity 25. τ ∈ [0, 1) gives {0} | {1, 2}: valid; then {1, 2} has impurity 0
    // (only the sample at 1 has weight) and is a leaf of value 10. τ ∈ [1, 2) gives
    // {0, 1} | {2} with W_R = 0: invalid, so the root is a leaf of value (0 + 10)/2 = 5.
    let xs = [[0.0, 7.0], [1.0, 7.0], [2.0, 7.0]];
    let ys = [0.0, 10.0, 5.0];
    let ws = [1.0, 1.0, 0.0];
    let forest = Forest::fit(&xs, &ys, &ws, 50, &mut rng(5)).unwrap();
    let (mut splits, mut leaves) = (0, 0);
    for t in 0..50 {
        let p = |x: f64| forest.tree_prediction(t, &[x, 7.0]).unwrap();
        if p(0.0) == 5.0 {
            leaves += 1;
            assert_eq!((p(1.0), p(2.0), p(1.5)), (5.0, 5.0, 5.0));
        } else {
            splits += 1;
            assert_eq!((p(0.0), p(1.0), p(2.0)), (0.0, 10.0, 10.0));
        }
    }
    // Each case has probability 1/2 per tree.
    assert!(splits > 0 && leaves > 0, "{splits} splits, {leaves} leaves");
}

#[test]
fn subnormal_weights_never_make_a_zero_weight_leaf() {
    // With a subnormal weight, w·y·y/w and (w·y/w)² round differently and the impurity of
    // {subnormal, zero} can exceed 10⁻⁷; the zero-weight sample must still not get a leaf.
    let xs = [[0.0, 0.0], [1.0, 1.0]];
    let ys = [-1.3, 5.0];
    let ws = [4.4e-323, 0.0];
    let forest = Forest::fit(&xs, &ys, &ws, 10, &mut rng(30)).unwrap();
    let value = forest.predict(&xs[0]);
    assert!(value.is_finite());
    assert_eq!(forest.predict(&xs[1]), value);
    assert_eq!(forest.n_nodes(), 10);
    // Many subnormal and zero weights: every leaf has positive weight, every value finite.
    let (xs, ys, mut ws) = random_set(200, 31);
    for (i, w) in ws.iter_mut().enumerate() {
        *w = if i % 2 == 0 {
            0.0
        } else {
            f64::from_bits(1 + (i as u64 % 17))
        };
    }
    let forest = Forest::fit(&xs, &ys, &ws, 10, &mut rng(32)).unwrap();
    for t in 0..forest.n_trees() {
        for members in leaves_of(&forest, t, &xs).values() {
            assert!(members.iter().any(|&i| ws[i] > 0.0));
            assert!(
                forest
                    .tree_prediction(t, &xs[members[0]])
                    .unwrap()
                    .is_finite()
            );
        }
    }
}

#[test]
fn best_candidate_is_chosen() {
    // y = 10·x₀ on the corners of the unit square. Any threshold on x₀ separates perfectly
    // (score 0²/2 + 20²/2 = 200), any threshold on x₁ mixes (score 10²/2 + 10²/2 = 100): every
    // tree splits once on x₀ into two pure leaves, 3 nodes per tree.
    let xs = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]];
    let ys = [0.0, 0.0, 10.0, 10.0];
    let ws = [1.0; 4];
    let forest = Forest::fit(&xs, &ys, &ws, 50, &mut rng(6)).unwrap();
    assert_eq!(forest.n_nodes(), 3 * 50);
    for t in 0..50 {
        for x1 in [0.0, 0.3, 1.0] {
            assert_eq!(forest.tree_prediction(t, &[0.0, x1]), Some(0.0));
            assert_eq!(forest.tree_prediction(t, &[1.0, x1]), Some(10.0));
        }
    }
}

#[test]
fn impurity_stop_at_1e_minus_7() {
    let xs = [[0.0, 0.0], [1.0, 2.0], [2.0, 1.0]];
    // Targets 1 ± 1e-4: weighted variance (2·10⁻⁸)/3 ≈ 6.7·10⁻⁹ ≤ 10⁻⁷, a single leaf.
    let ys = [1.0, 1.0 + 1e-4, 1.0 - 1e-4];
    let ws = [1.0, 2.0, 1.0];
    let mean = (1.0 + 2.0 * (1.0 + 1e-4) + (1.0 - 1e-4)) / 4.0;
    let forest = Forest::fit(&xs, &ys, &ws, 10, &mut rng(7)).unwrap();
    assert_eq!(forest.n_nodes(), 10);
    for x in &xs {
        assert!((forest.predict(x) - mean).abs() < 1e-15);
    }
    // Targets 1 ± 10⁻³: variance ≈ 6·10⁻⁷ > 10⁻⁷, fully grown: each point keeps its target.
    let ys = [1.0, 1.0 + 1e-3, 1.0 - 1e-3];
    let forest = Forest::fit(&xs, &ys, &ws, 10, &mut rng(7)).unwrap();
    assert_eq!(forest.n_nodes(), 10 * 5);
    for (x, y) in xs.iter().zip(&ys) {
        // Leaf value w·y/w and the mean of 10 equal trees: exact up to rounding.
        assert!((forest.predict(x) - y).abs() < 1e-15);
    }
}

#[test]
fn constant_feature_is_skipped() {
    // x₀ constant: every split is on x₁, and the forest still reproduces the targets.
    let xs = [[3.0, 0.0], [3.0, 1.0], [3.0, 2.0], [3.0, 5.0]];
    let ys = [1.0, -2.0, 4.0, 0.5];
    let ws = [1.0; 4];
    let forest = Forest::fit(&xs, &ys, &ws, 20, &mut rng(8)).unwrap();
    for (x, y) in xs.iter().zip(&ys) {
        let p = forest.predict(x);
        assert!((p - y).abs() < 1e-15);
        // Moving along the constant feature never changes the leaf.
        assert_eq!(forest.predict(&[-100.0, x[1]]), p);
        assert_eq!(forest.predict(&[100.0, x[1]]), p);
    }
    // Both features within 10⁻⁷ of constant: no candidate, the root is a leaf (weighted mean)
    // although the impurity is large.
    let xs = [[3.0, 1.0], [3.0 + 5e-8, 1.0 - 5e-8]];
    let ys = [0.0, 10.0];
    let ws = [1.0, 3.0];
    let forest = Forest::fit(&xs, &ys, &ws, 5, &mut rng(9)).unwrap();
    assert_eq!(forest.n_nodes(), 5);
    assert_eq!(forest.predict(&xs[0]), 7.5);
    // Just above the tolerance (2·10⁻⁷ apart) the feature is split again.
    let xs = [[3.0, 1.0], [3.0 + 2e-7, 1.0]];
    let forest = Forest::fit(&xs, &ys, &ws, 5, &mut rng(9)).unwrap();
    assert_eq!(forest.predict(&xs[0]), 0.0);
    assert_eq!(forest.predict(&xs[1]), 10.0);
}

#[test]
fn total_weight_zero_predicts_zero() {
    let xs = [[0.0, 0.0], [1.0, 1.0]];
    let forest = Forest::fit(&xs, &[5.0, 6.0], &[0.0, 0.0], 50, &mut rng(10)).unwrap();
    assert_eq!(forest.n_trees(), 0);
    assert_eq!(forest.predict(&[0.0, 0.0]), 0.0);
    let empty = Forest::<2>::fit(&[], &[], &[], 50, &mut rng(10)).unwrap();
    assert_eq!(empty.predict(&[3.0, 3.0]), 0.0);
    let mut out = [1.0; 2];
    empty.predict_into(&xs, &mut out).unwrap();
    assert_eq!(out, [0.0, 0.0]);
    // No seed is drawn for a degenerate forest.
    let mut a = rng(11);
    Forest::fit(&xs, &[5.0, 6.0], &[0.0, 0.0], 50, &mut a).unwrap();
    assert_eq!(a.next_u64(), rng(11).next_u64());
}

#[test]
fn fully_grown_forest_reproduces_training_targets() {
    let (xs, mut ys, _) = random_set(500, 12);
    // Distinct targets at least 10⁻³ apart, so no pair merges under the impurity stop.
    for (i, y) in ys.iter_mut().enumerate() {
        *y = (i as f64 * 0.618_033_988_75).fract() * 10.0 + i as f64 * 1e-3;
    }
    let ws = vec![1.0; xs.len()];
    let forest = Forest::fit(&xs, &ys, &ws, 50, &mut rng(13)).unwrap();
    for (x, y) in xs.iter().zip(&ys) {
        assert!((forest.predict(x) - y).abs() <= 1e-12 * (1.0 + y.abs()));
    }
}

#[test]
fn same_seed_same_forest_other_seed_other_forest() {
    let (xs, ys, ws) = random_set(200, 14);
    let a = Forest::fit(&xs, &ys, &ws, 50, &mut rng(15)).unwrap();
    let b = Forest::fit(&xs, &ys, &ws, 50, &mut rng(15)).unwrap();
    let c = Forest::fit(&xs, &ys, &ws, 50, &mut rng(16)).unwrap();
    let grid: Vec<[f64; 2]> = (0..400)
        .map(|i| [(i % 20) as f64 * 0.5 + 0.13, (i / 20) as f64 * 0.5 + 0.07])
        .collect();
    let mut pa = vec![0.0; grid.len()];
    let mut pb = pa.clone();
    let mut pc = pa.clone();
    a.predict_into(&grid, &mut pa).unwrap();
    b.predict_into(&grid, &mut pb).unwrap();
    c.predict_into(&grid, &mut pc).unwrap();
    assert_eq!(pa, pb);
    assert_ne!(pa, pc);
}

#[test]
fn batch_prediction_equals_pointwise() {
    let (xs, ys, ws) = random_set(333, 17);
    let forest = Forest::fit(&xs, &ys, &ws, 7, &mut rng(18)).unwrap();
    let queries: Vec<[f64; 2]> = (0..103)
        .map(|i| [(i as f64 * 0.37) % 10.0, (i as f64 * 0.91) % 10.0])
        .collect();
    let mut out = vec![0.0; queries.len()];
    forest.predict_into(&queries, &mut out).unwrap();
    for (q, o) in queries.iter().zip(&out) {
        assert_eq!(forest.predict(q), *o);
        let mean: f64 = (0..7)
            .map(|t| forest.tree_prediction(t, q).unwrap())
            .sum::<f64>()
            / 7.0;
        assert_eq!(mean, *o);
    }
    assert!(forest.predict_into(&queries, &mut out[1..]).is_err());
}

#[test]
fn refit_reuses_buffers_with_identical_results() {
    let (xs, ys, ws) = random_set(120, 19);
    let fresh = Forest::fit(&xs, &ys, &ws, 10, &mut rng(20)).unwrap();
    let (xs2, ys2, ws2) = random_set(300, 21);
    let mut reused = Forest::fit(&xs2, &ys2, &ws2, 10, &mut rng(22)).unwrap();
    reused.refit(&xs, &ys, &ws, 10, &mut rng(20)).unwrap();
    for x in &xs2 {
        assert_eq!(fresh.predict(x), reused.predict(x));
    }
}

#[test]
fn invalid_input_is_rejected_and_forest_kept() {
    let xs = [[0.0, 0.0], [1.0, 1.0]];
    let mut forest = Forest::fit(&xs, &[1.0, 2.0], &[1.0, 1.0], 3, &mut rng(23)).unwrap();
    let before = forest.predict(&[1.0, 1.0]);
    let mut r = rng(24);
    assert_eq!(
        forest.refit(&xs, &[1.0, 2.0], &[1.0, -1.0], 3, &mut r),
        Err(Error::InvalidParameter {
            parameter: "weights"
        })
    );
    assert_eq!(
        forest.refit(&xs, &[1.0, f64::NAN], &[1.0, 1.0], 3, &mut r),
        Err(Error::NonFinite {
            parameter: "targets"
        })
    );
    assert_eq!(
        forest.refit(&[[0.0, f64::INFINITY]], &[1.0], &[1.0], 3, &mut r),
        Err(Error::NonFinite {
            parameter: "states"
        })
    );
    assert_eq!(
        forest.refit(&xs, &[1.0], &[1.0, 1.0], 3, &mut r),
        Err(Error::InvalidParameter {
            parameter: "targets"
        })
    );
    assert_eq!(
        forest.refit(&xs, &[1.0, 2.0], &[1.0, 1.0], 0, &mut r),
        Err(Error::InvalidParameter {
            parameter: "n_trees"
        })
    );
    assert_eq!(forest.predict(&[1.0, 1.0]), before);
}

#[test]
fn action_forests_fit_each_action_on_its_own_samples() {
    // Action 0 sees y = 1, action 1 sees y = 3, action 2 none, action 3 sees y = 3.
    let xs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [5.0, 5.0]];
    let actions = [0, 1, 0, 1, 3];
    let ys = [1.0, 3.0, 1.0, 3.0, 3.0];
    let ws = [1.0; 5];
    let q = ActionForests::fit(4, &xs, &actions, &ys, &ws, 5, &mut rng(25)).unwrap();
    assert_eq!(q.num_actions(), 4);
    let s = [0.5, 0.5];
    assert_eq!(q.predict(&s, 0), Ok(1.0));
    assert_eq!(q.predict(&s, 1), Ok(3.0));
    assert_eq!(q.predict(&s, 2), Ok(0.0));
    assert_eq!(q.predict(&s, 3), Ok(3.0));
    assert!(q.predict(&s, 4).is_err());
    // Tie between actions 1 and 3: the smaller index wins.
    assert_eq!(q.greedy_action(&s), 1);
    assert_eq!(q.max_over_actions(&s), 3.0);
    // Q ≡ 0: every action ties, action 0 is greedy.
    let zero = ActionForests::<2>::zero(4);
    assert_eq!(zero.greedy_action(&s), 0);
    assert_eq!(zero.max_over_actions(&s), 0.0);
    assert_eq!(
        ActionForests::fit(4, &xs, &[0, 1, 0, 4, 3], &ys, &ws, 5, &mut rng(25)).err(),
        Some(Error::OutOfRange {
            parameter: "actions"
        })
    );
}

#[test]
fn action_forest_batches_equal_pointwise() {
    let (xs, ys, ws) = random_set(400, 26);
    let actions: Vec<usize> = (0..xs.len()).map(|i| (i * 7 + i / 3) % 4).collect();
    let q = ActionForests::fit(4, &xs, &actions, &ys, &ws, 8, &mut rng(27)).unwrap();
    let queries: Vec<[f64; 2]> = (0..101)
        .map(|i| [(i as f64 * 0.53) % 10.0, (i as f64 * 0.29) % 10.0])
        .collect();
    let mut out = vec![0.0; queries.len()];
    let mut scratch = out.clone();
    q.max_over_actions_into(&queries, &mut out, &mut scratch)
        .unwrap();
    for (s, &o) in queries.iter().zip(&out) {
        assert_eq!(q.max_over_actions(s), o);
        let g = q.greedy_action(s);
        assert_eq!(q.predict(s, g), Ok(o));
    }
    let acts: Vec<usize> = (0..queries.len()).map(|i| i % 4).collect();
    q.predict_actions_into(&queries, &acts, &mut out).unwrap();
    for ((s, &a), &o) in queries.iter().zip(&acts).zip(&out) {
        assert_eq!(q.predict(s, a), Ok(o));
    }
}

#[test]
fn a_pair_with_a_zero_and_a_subnormal_weight_is_a_leaf_not_a_nan() {
    // Two samples, weights 0 and 1.73·10⁻³²² (subnormal: w·y keeps only a few bits, so the
    // computed impurity of the pair need not be 0). The zero-weight sample must not get a
    // leaf of its own (its value would be 0/0): the pair is one leaf predicting about the
    // positive-weight sample's target.
    let xs = [[1.0, 1.0], [2.0, 3.0]];
    let ys = [-0.97, -37.3];
    let ws = [0.0, 1.73e-322];
    for seed in 0..50 {
        let forest = Forest::fit(&xs, &ys, &ws, 5, &mut rng(seed)).unwrap();
        for x in &xs {
            let v = forest.predict(x);
            assert!(v.is_finite(), "seed {seed}: prediction {v}");
            assert!((v + 37.3).abs() < 37.3 * 0.1, "seed {seed}: prediction {v}");
        }
    }
}

#[test]
fn growth_limits_bound_node_and_leaf_sizes() {
    let (xs, ys, _) = random_set(400, 7);
    let ones = vec![1.0; xs.len()];
    for params in [
        TreeParams {
            min_samples_split: 20,
            min_samples_leaf: 1,
        },
        TreeParams {
            min_samples_split: 5,
            min_samples_leaf: 2,
        },
        TreeParams {
            min_samples_split: 2,
            min_samples_leaf: 7,
        },
    ] {
        let mut forest = Forest::empty();
        forest
            .refit_with(&xs, &ys, &ones, 10, &params, &mut rng(8))
            .unwrap();
        for tree in 0..10 {
            let leaves = leaves_of(&forest, tree, &xs);
            // Every leaf keeps at least min_samples_leaf samples; a leaf of fewer than
            // min_samples_split samples came from a split of a node of at least that many,
            // so there are fewer leaves than n / min_samples_leaf and at least one small one
            // only if splits happened. The leaf value is the mean of its samples.
            for members in leaves.values() {
                assert!(members.len() >= params.min_samples_leaf, "{params:?}");
                let mean = members.iter().map(|&i| ys[i]).sum::<f64>() / members.len() as f64;
                let x = xs[members[0]];
                assert!((forest.tree_prediction(tree, &x).unwrap() - mean).abs() < 1e-9);
            }
            // Route the samples through the tree: every split node held at least
            // max(min_samples_split, 2·min_samples_leaf) samples.
            let min_node = params.min_samples_split.max(2 * params.min_samples_leaf);
            let mut counts: HashMap<usize, usize> = HashMap::new();
            for x in &xs {
                let mut i = forest.roots[tree] as usize;
                loop {
                    *counts.entry(i).or_default() += 1;
                    let next = forest.nodes[i].step(x);
                    if next == i {
                        break;
                    }
                    i = next;
                }
            }
            for (&i, &n) in &counts {
                if forest.nodes[i].left as usize != i {
                    assert!(n >= min_node, "split node of {n} samples, {params:?}");
                }
            }
            assert!(leaves.len() > 1, "the root was split");
        }
    }
    // Fewer samples than min_samples_split: every tree is a single leaf, the mean.
    let params = TreeParams {
        min_samples_split: 20,
        min_samples_leaf: 1,
    };
    let mut forest = Forest::empty();
    forest
        .refit_with(&xs[..19], &ys[..19], &ones[..19], 3, &params, &mut rng(9))
        .unwrap();
    let mean = ys[..19].iter().sum::<f64>() / 19.0;
    assert!((forest.predict(&[3.0, 3.0]) - mean).abs() < 1e-12);
    assert_eq!(forest.n_nodes(), 3);
    // The defaults are the fully grown trees of `refit`, bit for bit.
    let mut a = Forest::empty();
    a.refit(&xs, &ys, &ones, 5, &mut rng(3)).unwrap();
    let mut b = Forest::empty();
    b.refit_with(&xs, &ys, &ones, 5, &TreeParams::default(), &mut rng(3))
        .unwrap();
    for x in &xs {
        assert_eq!(a.predict(x).to_bits(), b.predict(x).to_bits());
    }
    // Invalid limits are errors.
    let bad = TreeParams {
        min_samples_split: 1,
        min_samples_leaf: 1,
    };
    assert!(b.refit_with(&xs, &ys, &ones, 5, &bad, &mut rng(3)).is_err());
}

#[test]
fn fine_growth_splits_pure_nodes_down_to_the_size_limit() {
    // Constant targets: every node is pure, so the spec's trees are single leaves, while
    // the fine ones split until min_samples_split stops them; both predict the constant.
    let (xs, _, _) = random_set(200, 21);
    let (ys, ws) = (vec![3.5; xs.len()], vec![1.0; xs.len()]);
    let params = TreeParams {
        min_samples_split: 10,
        min_samples_leaf: 1,
    };
    let mut spec = Forest::empty();
    spec.refit_with(&xs, &ys, &ws, 5, &params, &mut rng(22))
        .unwrap();
    assert_eq!(spec.n_nodes(), 5);
    let mut fine = Forest::empty();
    fine.refit_fine(&xs, &ys, &ws, 5, &params, &mut rng(22))
        .unwrap();
    assert!(fine.n_nodes() > 5 * 20, "{}", fine.n_nodes());
    for t in 0..5 {
        for members in leaves_of(&fine, t, &xs).values() {
            // A leaf of the fine tree is below the size limit or holds equal inputs.
            let distinct = members.iter().any(|&i| xs[i] != xs[members[0]]);
            assert!(members.len() < 10 || !distinct, "{}", members.len());
        }
    }
    for x in &xs {
        assert!((fine.predict(x) - 3.5).abs() < 1e-12);
        assert_eq!(spec.predict(x), 3.5);
    }
}
