//! FQI tests against hand-derived values: a deterministic chain's Q*, and the effect of each
//! weight and reward option on a two-sample set.

use super::*;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

fn record(
    x: f64,
    action: usize,
    reward: f64,
    next: f64,
    absorbing: bool,
) -> Transition<[f64; 2], f64> {
    Transition {
        state: [x, 0.0],
        action,
        reward,
        next_state: [next, 0.0],
        absorbing,
    }
}

/// A deterministic chain on x ∈ {0, 1, 2, 3, 4}: action 0 moves right, action 1 left
/// (staying at 0), reward −1 per step, entering 4 is absorbing. Every (s, a) with s < 4 is
/// sampled once.
fn chain() -> Dataset<2> {
    let mut data = Dataset::new();
    for s in 0..4 {
        let x = s as f64;
        data.push(record(x, 0, -1.0, x + 1.0, s == 3));
        data.push(record(x, 1, -1.0, (x - 1.0).max(0.0), false));
    }
    data
}

#[test]
fn chain_converges_to_known_q_star() {
    let gamma: f64 = 0.99;
    // V*(s) = Q*(s, right) = −(1 − γ^d)/(1 − γ) with d = 4 − s steps to the goal;
    // Q*(s, left) = −1 + γ V*(max(s − 1, 0)).
    let v = |s: usize| -(1.0 - gamma.powi(4 - s as i32)) / (1.0 - gamma);
    let options = FqiOptions {
        iterations: 10,
        num_actions: 2,
        ..FqiOptions::plain()
    };
    let out = fqi(&chain(), &options, &mut rng(1)).unwrap();
    assert!(out.model_rewards.is_none());
    for s in 0..4 {
        let x = [s as f64, 0.0];
        let right = out.q.predict(&x, 0).unwrap();
        let left = out.q.predict(&x, 1).unwrap();
        assert!((right - v(s)).abs() < 1e-12, "Q({s}, right) = {right}");
        let expected_left = -1.0 + gamma * v(s.saturating_sub(1));
        assert!(
            (left - expected_left).abs() < 1e-12,
            "Q({s}, left) = {left}"
        );
        assert_eq!(out.q.greedy_action(&x), 0);
    }
}

#[test]
fn too_few_iterations_give_the_truncated_values() {
    // After k iterations the chain's values are those of the k-step horizon:
    // Q_k(s, right) = −(1 − γ^min(d, k))/(1 − γ).
    let gamma: f64 = 0.99;
    let options = FqiOptions {
        iterations: 2,
        num_actions: 2,
        ..FqiOptions::plain()
    };
    let out = fqi(&chain(), &options, &mut rng(2)).unwrap();
    for s in 0..4 {
        let d = 4 - s;
        let expected = -(1.0 - gamma.powi(d.min(2))) / (1.0 - gamma);
        assert!((out.q.predict(&[s as f64, 0.0], 0).unwrap() - expected).abs() < 1e-12);
    }
}

/// Two absorbing samples of action 0: a trusted one (x = 0, r = −1) and an outlier
/// (x = 1, r = −100).
fn outlier_pair() -> Dataset<2> {
    [
        record(0.0, 0, -1.0, 0.0, true),
        record(1.0, 0, -100.0, 1.0, true),
    ]
    .into_iter()
    .collect()
}

fn q_at_outlier(options: &FqiOptions<'_>) -> (f64, Option<Vec<f64>>) {
    let out = fqi(&outlier_pair(), options, &mut rng(3)).unwrap();
    (out.q.predict(&[1.0, 0.0], 0).unwrap(), out.model_rewards)
}

#[test]
fn reward_weights_act_in_iteration_one_and_through_the_reward_model() {
    let zero_outlier = [1.0, 0.0];
    let ones = [1.0, 1.0];
    let base = FqiOptions {
        iterations: 3,
        num_actions: 1,
        ..FqiOptions::plain()
    };
    // Plain: the outlier keeps its own reward.
    assert_eq!(q_at_outlier(&base).0, -100.0);
    // IWFQI: w_r = 0 merges the outlier into the trusted sample's leaf (impurity 0), so
    // R̂ = −1 at both records, and later iterations fit −1 everywhere.
    let (q, r_hat) = q_at_outlier(&FqiOptions {
        iterations: 3,
        num_actions: 1,
        ..FqiOptions::iwfqi(&zero_outlier, &ones)
    });
    assert_eq!(q, -1.0);
    assert_eq!(r_hat, Some(vec![-1.0, -1.0]));
    // Reward weights without the reward model: iterations ≥ 2 use the observed rewards with
    // the (unit) transition weights, so the outlier is back.
    let (q, _) = q_at_outlier(&FqiOptions {
        reward_weights: Some(&zero_outlier),
        ..base
    });
    assert_eq!(q, -100.0);
    // With one iteration only the reward weights matter.
    let (q, _) = q_at_outlier(&FqiOptions {
        iterations: 1,
        reward_weights: Some(&zero_outlier),
        transition_weights: Some(&ones),
        ..base
    });
    assert_eq!(q, -1.0);
}

#[test]
fn transition_weights_act_from_iteration_two() {
    let zero_outlier = [1.0, 0.0];
    let base = FqiOptions {
        num_actions: 1,
        transition_weights: Some(&zero_outlier),
        ..FqiOptions::plain()
    };
    // Iteration 1 is unweighted: the outlier is fitted.
    let (q, _) = q_at_outlier(&FqiOptions {
        iterations: 1,
        ..base
    });
    assert_eq!(q, -100.0);
    // Iteration 2 gives it weight 0: merged into the trusted sample's leaf.
    let (q, _) = q_at_outlier(&FqiOptions {
        iterations: 2,
        ..base
    });
    assert_eq!(q, -1.0);
}

#[test]
fn sdt_fits_the_reward_model_on_the_target_prefix() {
    // Target record first (x = 0, r = −1), then a source record (x = 5, r = −50).
    let data: Dataset<2> = [
        record(0.0, 0, -1.0, 0.0, true),
        record(5.0, 0, -50.0, 5.0, true),
    ]
    .into_iter()
    .collect();
    let options = FqiOptions {
        iterations: 4,
        num_actions: 1,
        ..FqiOptions::sdt(1)
    };
    let out = fqi(&data, &options, &mut rng(4)).unwrap();
    // R̂ was fitted on the target record only: −1 everywhere, the source reward discarded.
    assert_eq!(out.model_rewards, Some(vec![-1.0, -1.0]));
    assert_eq!(out.q.predict(&[5.0, 0.0], 0).unwrap(), -1.0);
    // A prefix longer than the dataset is refused.
    let too_long = FqiOptions {
        first_iteration_records: Some(3),
        ..options
    };
    assert_eq!(
        fqi(&data, &too_long, &mut rng(4)).err(),
        Some(Error::OutOfRange {
            parameter: "first_iteration_records"
        })
    );
}

#[test]
fn unit_weights_equal_no_weights_and_seed_fixes_the_result() {
    let data = random_data(300, 5);
    let ones = vec![1.0; data.len()];
    let opts = FqiOptions {
        iterations: 5,
        n_trees: 10,
        ..FqiOptions::plain()
    };
    let weighted = FqiOptions {
        reward_weights: Some(&ones),
        transition_weights: Some(&ones),
        ..opts
    };
    let a = fqi(&data, &opts, &mut rng(6)).unwrap();
    let b = fqi(&data, &weighted, &mut rng(6)).unwrap();
    let c = fqi(&data, &opts, &mut rng(7)).unwrap();
    let probe: Vec<[f64; 2]> = (0..50)
        .map(|i| [i as f64 * 0.2, 10.0 - i as f64 * 0.2])
        .collect();
    let mut differs = false;
    for s in &probe {
        for act in 0..4 {
            let qa = a.q.predict(s, act).unwrap();
            assert_eq!(qa, b.q.predict(s, act).unwrap());
            differs |= qa != c.q.predict(s, act).unwrap();
        }
    }
    assert!(differs);
}

/// Random puddle-like transitions (uniform states, actions, noisy moves, rewards near −1).
pub(crate) fn random_data(n: usize, seed: u64) -> Dataset<2> {
    let mut r = rng(seed);
    let mut u = move || awfqi::rng::uniform_f64(&mut r);
    (0..n)
        .map(|_| {
            let s = [10.0 * u(), 10.0 * u()];
            let a = (4.0 * u()) as usize;
            let step = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]][a];
            let next = [
                (s[0] + step[0] + 0.4 * (u() - 0.5)).clamp(0.0, 10.0),
                (s[1] + step[1] + 0.4 * (u() - 0.5)).clamp(0.0, 10.0),
            ];
            let absorbing = (next[0] - 5.0).hypot(next[1] - 10.0) < 1.41;
            Transition {
                state: s,
                action: a,
                reward: -1.0 - 0.2 * u(),
                next_state: next,
                absorbing,
            }
        })
        .collect()
}

#[test]
fn invalid_input_is_rejected() {
    let data = outlier_pair();
    let one = [1.0];
    let plain = FqiOptions {
        num_actions: 1,
        ..FqiOptions::plain()
    };
    let cases: [(FqiOptions<'_>, Error); 4] = [
        (
            FqiOptions {
                iterations: 0,
                ..plain
            },
            Error::InvalidParameter {
                parameter: "iterations",
            },
        ),
        (
            FqiOptions {
                gamma: 1.5,
                ..plain
            },
            Error::OutOfRange { parameter: "gamma" },
        ),
        (
            FqiOptions {
                reward_weights: Some(&one),
                ..plain
            },
            Error::InvalidParameter {
                parameter: "reward_weights",
            },
        ),
        (
            FqiOptions {
                num_actions: 0,
                ..plain
            },
            Error::OutOfRange {
                parameter: "actions",
            },
        ),
    ];
    for (options, expected) in cases {
        assert_eq!(fqi(&data, &options, &mut rng(8)).err(), Some(expected));
    }
    let mut bad = outlier_pair();
    bad.next_states[1][0] = f64::NAN;
    assert_eq!(
        fqi(&bad, &plain, &mut rng(8)).err(),
        Some(Error::NonFinite {
            parameter: "next_states"
        })
    );
}

#[test]
fn morton_key_interleaves_the_quantised_coordinates() {
    // x is quantised to 16 bits on its range [0, 10] and takes the even bits, y (range
    // [0, 20]) the odd ones.
    let pts = [[0.0, 0.0], [10.0, 20.0], [5.0, 7.0]];
    let b = bounding_box(pts.iter());
    assert_eq!(b, [(0.0, 10.0), (0.0, 20.0)]);
    assert_eq!(morton_key(&[0.0, 0.0], &b), 0);
    assert_eq!(morton_key(&[10.0, 0.0], &b), 0x5555_5555);
    assert_eq!(morton_key(&[0.0, 20.0], &b), 0xAAAA_AAAA);
    assert_eq!(morton_key(&[10.0, 20.0], &b), u32::MAX);
    // Values outside the box are clamped.
    assert_eq!(morton_key(&[-3.0, 24.0], &b), 0xAAAA_AAAA);
    // Quantised x = 1 (bit 0) and y = 1 (bit 1): range/65535 is exactly one step.
    let step = 10.0 / 65535.0;
    assert_eq!(morton_key(&[step, 0.0], &b), 1);
    assert_eq!(morton_key(&[0.0, 2.0 * step], &b), 2);
    assert_eq!(morton_key(&[step, 2.0 * step], &b), 3);
    // A degenerate box (one point, or none) gives key 0.
    let one = bounding_box([[4.0, 4.0]].iter());
    assert_eq!(morton_key(&[4.0, 4.0], &one), 0);
    assert_eq!(
        bounding_box(std::iter::empty::<&[f64; 2]>()),
        [(0.0, 0.0); 2]
    );
}

#[test]
fn frozen_trees_reach_the_chains_q_star_too() {
    // Fully grown trees only merge records of equal targets. From iteration 5 on, two
    // records of an action have equal targets exactly when their Q* is equal (before, the
    // horizon hides the goal from the farthest states: at iteration 4, left from states
    // 0, 1 and 2 still look alike), so trees frozen after iteration 5 are as fine as
    // regrown ones and the frozen iterations still converge to Q*.
    let gamma: f64 = 0.99;
    let v = |s: usize| -(1.0 - gamma.powi(4 - s as i32)) / (1.0 - gamma);
    let options = FqiOptions {
        iterations: 10,
        num_actions: 2,
        freeze_after: Some(5),
        ..FqiOptions::plain()
    };
    let out = fqi(&chain(), &options, &mut rng(1)).unwrap();
    for s in 0..4 {
        let x = [s as f64, 0.0];
        let right = out.q.predict(&x, 0).unwrap();
        assert!((right - v(s)).abs() < 1e-12, "Q({s}, right) = {right}");
        let left = out.q.predict(&x, 1).unwrap();
        let expected_left = -1.0 + gamma * v(s.saturating_sub(1));
        assert!((left - expected_left).abs() < 1e-12, "{left}");
    }
}

#[test]
fn freezing_at_or_after_the_last_iteration_changes_no_bit() {
    // A noisy 2-D problem where the trees average several records per leaf.
    let mut r = rng(11);
    let mut data = Dataset::new();
    for i in 0..300 {
        let x = [
            10.0 * awfqi::rng::uniform_f64(&mut r),
            10.0 * awfqi::rng::uniform_f64(&mut r),
        ];
        let next = [
            (x[0] + awfqi::rng::uniform_f64(&mut r)).min(10.0),
            x[1] * 0.9,
        ];
        data.push(Transition {
            state: x,
            action: i % 3,
            reward: -x[0] + awfqi::rng::uniform_f64(&mut r),
            next_state: next,
            absorbing: i % 17 == 0,
        });
    }
    let weights: Vec<f64> = (0..300).map(|i| 0.5 + (i % 5) as f64).collect();
    let base = FqiOptions {
        iterations: 6,
        n_trees: 7,
        num_actions: 3,
        tree: TreeParams {
            min_samples_split: 6,
            min_samples_leaf: 2,
        },
        ..FqiOptions::iwfqi(&weights, &weights)
    };
    let grid: Vec<[f64; 2]> = (0..50).map(|i| [i as f64 / 5.0, (i % 7) as f64]).collect();
    let values = |options: &FqiOptions<'_>| -> Vec<u64> {
        let q = fqi(&data, options, &mut rng(12)).unwrap().q;
        grid.iter()
            .flat_map(|x| (0..3).map(|a| q.predict(x, a).unwrap().to_bits()))
            .collect()
    };
    let faithful = values(&base);
    for k in [6, 9] {
        let frozen = FqiOptions {
            freeze_after: Some(k),
            ..base
        };
        assert_eq!(values(&frozen), faithful, "freeze_after {k}");
    }
    // Frozen earlier, the structure differs from iteration 3 on, and so do the values.
    let early = FqiOptions {
        freeze_after: Some(2),
        ..base
    };
    assert_ne!(values(&early), faithful);
    let bad = FqiOptions {
        freeze_after: Some(1),
        ..base
    };
    assert_eq!(
        fqi(&data, &bad, &mut rng(12)).map(|_| ()),
        Err(Error::InvalidParameter {
            parameter: "freeze_after"
        })
    );
}

#[test]
fn regrowing_freezes_at_k_then_every_r_but_never_at_the_last_iteration() {
    let options = FqiOptions {
        iterations: 60,
        freeze_after: Some(2),
        regrow_every: Some(10),
        ..FqiOptions::plain()
    };
    let at: Vec<usize> = (1..=60).filter(|&i| options.freezes_at(i)).collect();
    assert_eq!(at, [2, 12, 22, 32, 42, 52]);
    let once = FqiOptions {
        regrow_every: None,
        ..options
    };
    assert_eq!((1..=60).filter(|&i| once.freezes_at(i)).count(), 1);
    let ending = FqiOptions {
        iterations: 52,
        ..options
    };
    assert!(!ending.freezes_at(52));
    assert!(!FqiOptions::plain().freezes_at(2));
}

#[test]
fn regrown_trees_reach_the_chains_q_star() {
    // As in `frozen_trees_reach_the_chains_q_star_too`: trees grown from iteration 5 on are
    // as fine as the spec's, and four iterations on a fine structure forget any start.
    // Frozen at 2 and regrown every 3 (at 5 and 8), each regrowth starts from the frozen
    // structure's values and FQI still ends at Q*.
    let gamma: f64 = 0.99;
    let v = |s: usize| -(1.0 - gamma.powi(4 - s as i32)) / (1.0 - gamma);
    let regrown = FqiOptions {
        iterations: 10,
        num_actions: 2,
        freeze_after: Some(2),
        regrow_every: Some(3),
        ..FqiOptions::plain()
    };
    let error = |options: &FqiOptions<'_>| -> f64 {
        let q = fqi(&chain(), options, &mut rng(1)).unwrap().q;
        (0..4)
            .map(|s| {
                let x = [s as f64, 0.0];
                let right = q.predict(&x, 0).unwrap() - v(s);
                let left = q.predict(&x, 1).unwrap() - (-1.0 + gamma * v(s.saturating_sub(1)));
                right.abs().max(left.abs())
            })
            .fold(0.0, f64::max)
    };
    assert!(error(&regrown) < 1e-12, "{}", error(&regrown));
}

#[test]
fn regrowing_needs_a_freeze_and_a_positive_period() {
    let data = chain();
    for (freeze_after, regrow_every) in [(None, Some(3)), (Some(2), Some(0))] {
        let options = FqiOptions {
            iterations: 5,
            num_actions: 2,
            freeze_after,
            regrow_every,
            ..FqiOptions::plain()
        };
        assert_eq!(
            fqi(&data, &options, &mut rng(1)).map(|_| ()),
            Err(Error::InvalidParameter {
                parameter: "regrow_every"
            })
        );
    }
}
