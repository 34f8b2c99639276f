//! Tests of frozen trees against the forest they were taken from and against leaf means
//! computed by hand.

use super::*;
use crate::trees::TreeParams;
use crate::trees::tests::random_set;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::collections::HashMap;

fn fitted(n: usize, seed: u64) -> (Forest<2>, Vec<[f64; 2]>, Vec<f64>, Vec<f64>) {
    let (xs, ys, ws) = random_set(n, seed);
    let mut forest = Forest::empty();
    let params = TreeParams {
        min_samples_split: 5,
        min_samples_leaf: 1,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 1);
    forest
        .refit_with(&xs, &ys, &ws, 12, &params, &mut rng)
        .unwrap();
    (forest, xs, ys, ws)
}

#[test]
fn frozen_forest_predicts_bit_for_bit_like_its_forest() {
    let (forest, xs, _, ws) = fitted(400, 1);
    let (queries, _, _) = random_set(333, 2);
    let frozen = FrozenForest::new(&forest, &xs, &ws, &queries).unwrap();
    assert_eq!(frozen.n_queries(), 333);
    let mut want = vec![0.0; 333];
    forest.predict_into(&queries, &mut want).unwrap();
    let mut got = vec![1.0; 333];
    frozen.predict_into(&forest, &mut got).unwrap();
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.to_bits(), w.to_bits());
    }
}

#[test]
fn refit_gives_each_leaf_the_weighted_mean_of_the_new_targets() {
    let (mut forest, xs, ys, ws) = fitted(400, 3);
    let (queries, _, _) = random_set(50, 4);
    let mut frozen = FrozenForest::new(&forest, &xs, &ws, &queries).unwrap();
    let splits_before: Vec<bool> = (0..forest.n_nodes()).map(|i| forest.is_leaf(i)).collect();
    // New targets: a different function of the inputs.
    let new: Vec<f64> = xs.iter().map(|x| (x[0] - 2.0 * x[1]).sin() * 7.0).collect();
    frozen.refit(&mut forest, &new).unwrap();
    let leaves_after: Vec<bool> = (0..forest.n_nodes()).map(|i| forest.is_leaf(i)).collect();
    assert_eq!(splits_before, leaves_after, "the structure is unchanged");
    let mut checked = 0;
    for t in 0..forest.n_trees() {
        let mut by_leaf: HashMap<usize, (f64, f64)> = HashMap::new();
        for (i, x) in xs.iter().enumerate() {
            let e = by_leaf.entry(forest.leaf_id(t, x).unwrap()).or_default();
            e.0 += ws[i] * new[i];
            e.1 += ws[i];
        }
        for (&leaf, &(s, w)) in &by_leaf {
            let x = xs
                .iter()
                .find(|x| forest.leaf_id(t, x).unwrap() == leaf)
                .unwrap();
            let got = forest.tree_prediction(t, x).unwrap();
            assert!(w > 0.0);
            assert!(
                (got - s / w).abs() <= 1e-12 * (1.0 + got.abs()),
                "{got} {}",
                s / w
            );
            checked += 1;
        }
    }
    assert!(checked > 12 * 20, "{checked}");
    // Refitting the original targets restores the grown values (to rounding).
    let (grown, _, _, _) = fitted(400, 3);
    frozen.refit(&mut forest, &ys).unwrap();
    let (mut a, mut b) = (vec![0.0; 50], vec![0.0; 50]);
    grown.predict_into(&queries, &mut a).unwrap();
    frozen.predict_into(&forest, &mut b).unwrap();
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 1e-12 * (1.0 + x.abs()), "{x} {y}");
    }
}

#[test]
fn bad_input_is_refused_and_leaves_the_forest_unchanged() {
    let (mut forest, xs, ys, ws) = fitted(200, 5);
    let (other, _, _, _) = fitted(150, 6);
    let mut frozen = FrozenForest::new(&forest, &xs, &ws, &xs[..10]).unwrap();
    let mut out = vec![0.0; 10];
    assert_eq!(
        frozen.predict_into(&other, &mut out),
        Err(Error::InvalidParameter {
            parameter: "forest"
        })
    );
    assert_eq!(
        frozen.predict_into(&forest, &mut out[..9]),
        Err(Error::InvalidParameter { parameter: "out" })
    );
    let before: Vec<f64> = xs.iter().map(|x| forest.predict(x)).collect();
    let mut bad = ys.clone();
    bad[7] = f64::NAN;
    assert_eq!(
        frozen.refit(&mut forest, &bad),
        Err(Error::NonFinite {
            parameter: "targets"
        })
    );
    assert_eq!(
        frozen.refit(&mut forest, &ys[1..]),
        Err(Error::InvalidParameter {
            parameter: "targets"
        })
    );
    let after: Vec<f64> = xs.iter().map(|x| forest.predict(x)).collect();
    assert_eq!(before, after);
    // Weights under which some leaf holds no weight: not this forest's training data.
    let zero = vec![0.0; xs.len()];
    assert_eq!(
        FrozenForest::new(&forest, &xs, &zero, &xs).map(|_| ()),
        Err(Error::InvalidParameter {
            parameter: "weights"
        })
    );
    assert!(FrozenForest::new(&forest, &xs, &ws[1..], &xs).is_err());
    let mut negative = ws.clone();
    negative[3] = -1.0;
    assert!(FrozenForest::new(&forest, &xs, &negative, &xs).is_err());
}

#[test]
fn frozen_action_forests_match_the_action_forests() {
    let (xs, ys, ws) = random_set(600, 7);
    let actions: Vec<usize> = (0..600).map(|i| (i * 7 / 3) % 3).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let mut q = ActionForests::zero_with(
        3,
        TreeParams {
            min_samples_split: 4,
            min_samples_leaf: 2,
        },
    );
    q.refit(&xs, &actions, &ys, &ws, 9, &mut rng).unwrap();
    let (queries, _, _) = random_set(101, 9);
    let mut frozen = FrozenActionForests::new(&q, &xs, &actions, &ws, &queries).unwrap();
    let (mut want, mut got) = (vec![0.0; 101], vec![0.0; 101]);
    let mut scratch = vec![0.0; 101];
    q.max_over_actions_into(&queries, &mut want, &mut scratch)
        .unwrap();
    frozen
        .max_over_actions_into(&q, &mut got, &mut scratch)
        .unwrap();
    assert_eq!(
        got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        want.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    // A refit of constant targets c makes every prediction c (each leaf's weighted mean).
    frozen.refit(&mut q, &vec![2.5; 600]).unwrap();
    for x in &queries {
        for a in 0..3 {
            assert!((q.predict(x, a).unwrap() - 2.5).abs() < 1e-12);
        }
    }
    assert!(frozen.refit(&mut q, &[1.0; 5]).is_err());
}
