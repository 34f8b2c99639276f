extern crate std;

use super::*;
use crate::env::EpisodeRecord;
use crate::model::GenerativeModel;
use crate::policy::{EpsilonGreedyPolicy, UniformPolicy};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::vec::Vec;

/// The golden points of spec §2.7.
const POINTS: [[f64; 2]; 8] = [
    [0.0, 0.0],
    [1.0, 4.0],
    [2.0, 2.0],
    [5.0, 5.0],
    [6.0, 6.0],
    [8.0, 2.0],
    [5.0, 9.0],
    [7.0, 9.0],
];

/// Spec §2.7: per instance (target, source 1, 2, 3), per point, (mean reward, α with κ = 5).
const GOLDEN: [[(f64, f64); 8]; 4] = [
    [
        (-1.000121, 0.999994),
        (-23.737327, 0.467975),
        (-1.639298, 0.969025),
        (-12.399788, 0.636947),
        (-22.527397, 0.481610),
        (-1.134113, 0.993339),
        (-0.039372, 0.998035),
        (-1.038409, 0.998083),
    ],
    [
        (-1.000000, 1.000000),
        (-1.000907, 0.999955),
        (-1.000074, 0.999996),
        (-12.399667, 0.636949),
        (-22.527397, 0.481610),
        (-1.134113, 0.993339),
        (-0.039372, 0.998035),
        (-1.038409, 0.998083),
    ],
    [
        (-1.134130, 0.993338),
        (-12.529551, 0.634326),
        (-22.527471, 0.481609),
        (-6.748596, 0.776741),
        (-3.061517, 0.906556),
        (-1.061376, 0.996941),
        (-0.039663, 0.998021),
        (-1.400652, 0.980361),
    ],
    [
        (-1.000000, 1.000000),
        (-1.000907, 0.999955),
        (-1.000074, 0.999996),
        (-12.399726, 0.636948),
        (-22.527412, 0.481610),
        (-23.870533, 0.466521),
        (-1.039372, 0.998035),
        (-0.038409, 0.998083),
    ],
];

fn instances<T: Real>(dynamics: Dynamics) -> [PuddleWorld<T>; 4] {
    let [s1, s2, s3] = PuddleWorld::sources(dynamics);
    [PuddleWorld::target(dynamics), s1, s2, s3]
}

fn pt<T: Real>(p: [f64; 2]) -> [T; 2] {
    p.map(T::from_f64)
}

/// The bivariate normal density written out with the full inverse covariance, as spec §1
/// states it (independent of the eigen-split used by the implementation).
fn direct_density(x: [f64; 2], mean: [f64; 2], v: f64, c: f64) -> f64 {
    let det = v * v - c * c;
    let inv = [[v / det, -c / det], [-c / det, v / det]];
    let d = [x[0] - mean[0], x[1] - mean[1]];
    let q =
        d[0] * (inv[0][0] * d[0] + inv[0][1] * d[1]) + d[1] * (inv[1][0] * d[0] + inv[1][1] * d[1]);
    (-0.5 * q).exp() / (2.0 * core::f64::consts::PI * det.sqrt())
}

#[test]
fn golden_mean_rewards_and_step_lengths_f64() {
    // The table has 6 decimals: rounding error ≤ 5e-7, so 1e-6 absolute is tight.
    for dynamics in [Dynamics::Shared, Dynamics::PuddleBased] {
        for (world, rows) in instances::<f64>(dynamics).iter().zip(GOLDEN) {
            for (p, (reward, alpha)) in POINTS.iter().zip(rows) {
                let r = world.mean_reward(*p).unwrap();
                assert!((r - reward).abs() < 1e-6, "{p:?}: {r} vs {reward}");
                let a = world.step_length(*p).unwrap();
                if dynamics == Dynamics::PuddleBased {
                    assert!((a - alpha).abs() < 1e-6, "{p:?}: α {a} vs {alpha}");
                } else {
                    assert_eq!(a, 1.0, "shared dynamics has unit steps");
                }
            }
        }
    }
}

#[test]
fn golden_mean_rewards_and_step_lengths_f32() {
    // f32 has relative precision 6e-8 and rewards reach −24 (ulp 1.9e-6), with W summing
    // up to 6 exps: the reward is compared to 5e-6 absolute (measured worst: 1.9e-6) and
    // α (≈ 1) to 2e-6 (measured worst: 4.5e-7, the table's own rounding).
    for (world, rows) in instances::<f32>(Dynamics::PuddleBased).iter().zip(GOLDEN) {
        for (p, (reward, alpha)) in POINTS.iter().zip(rows) {
            let r = world.mean_reward(pt(*p)).unwrap() as f64;
            assert!((r - reward).abs() < 5e-6, "{p:?}: {r} vs {reward}");
            let a = world.step_length(pt(*p)).unwrap() as f64;
            assert!((a - alpha).abs() < 2e-6, "{p:?}: α {a} vs {alpha}");
        }
    }
}

#[test]
fn puddle_weight_is_the_exact_bivariate_density_with_the_off_diagonal() {
    let world = PuddleWorld::<f64>::target(Dynamics::Shared);
    let c = PUDDLE_COVARIANCE_OFF_DIAGONAL;
    let puddles: Vec<Puddle<f64>> = world.puddles().collect();
    assert_eq!(puddles.len(), 5);
    for i in 0..=20 {
        for j in 0..=20 {
            let x = [i as f64 * 0.5, j as f64 * 0.5];
            let want: f64 = puddles
                .iter()
                .map(|p| direct_density(x, p.mean, p.variance, c))
                .sum();
            let got = world.puddle_weight(x).unwrap();
            assert!(
                (got - want).abs() <= 1e-13 * want.max(1e-300),
                "{x:?}: {got} vs {want}"
            );
        }
    }
    // The off-diagonal is visible: near the (6, 6) puddle, at (7, 7), dropping it changes W
    // by about 1.6e-5 relative, far more than rounding.
    let without: f64 = puddles
        .iter()
        .map(|p| direct_density([7.0, 7.0], p.mean, p.variance, 0.0))
        .sum();
    let with = world.puddle_weight([7.0, 7.0]).unwrap();
    assert!((with - without).abs() > 1e-5 * with);
}

#[test]
fn single_puddle_peak_and_far_field() {
    let world = PuddleWorld::new(
        [9.0, 9.0],
        &[Puddle::new([5.0, 5.0], 0.8)],
        Dynamics::Shared,
    )
    .unwrap();
    let peak = 1.0 / (2.0 * core::f64::consts::PI * (0.64f64 - 1e-10).sqrt());
    assert!((world.puddle_weight([5.0, 5.0]).unwrap() - peak).abs() < 1e-15);
    // "about 19.9" penalty for v = 0.8 (spec §2.2).
    assert!((100.0 * peak - 19.894).abs() < 1e-3);
    // A puddle far outside the box contributes exactly 0, never NaN.
    let far = PuddleWorld::new(
        [9.0, 9.0],
        &[Puddle::new([1e200, -1e200], 0.8)],
        Dynamics::PuddleBased,
    )
    .unwrap();
    assert_eq!(far.puddle_weight([0.0, 0.0]).unwrap(), 0.0);
    assert_eq!(far.mean_reward([0.0, 0.0]).unwrap(), -1.0);
    let far32 = PuddleWorld::new(
        [9.0f32, 9.0],
        &[Puddle::new([3e38, -3e38], 0.8)],
        Dynamics::PuddleBased,
    )
    .unwrap();
    assert_eq!(far32.puddle_weight([10.0, 10.0]).unwrap(), 0.0);
    // No puddles at all: W ≡ 0.
    let dry = PuddleWorld::<f32>::new([5.0, 10.0], &[], Dynamics::PuddleBased).unwrap();
    assert_eq!(dry.puddle_weight([3.0, 3.0]).unwrap(), 0.0);
    assert_eq!(dry.step_length([3.0, 3.0]).unwrap(), 1.0);
}

#[test]
fn goal_test_is_a_strict_inequality() {
    // sqrt(fl(x²)) = x exactly in binary floating point, so (1.41, 0) is at distance
    // exactly ρ from the origin and must be outside.
    let g64 = PuddleWorld::<f64>::new([0.0, 0.0], &[], Dynamics::Shared).unwrap();
    assert!(!g64.in_goal([1.41, 0.0]).unwrap());
    assert!(g64.in_goal([1.409_999_9, 0.0]).unwrap());
    assert!(!g64.in_goal([0.0, 1.41]).unwrap());
    assert!(g64.in_goal([0.0, 0.0]).unwrap());
    let g32 = PuddleWorld::<f32>::new([0.0, 0.0], &[], Dynamics::Shared).unwrap();
    assert!(!g32.in_goal([1.41, 0.0]).unwrap());
    assert!(g32.in_goal([1.409_99, 0.0]).unwrap());
    // Target goal (5, 10): (5, 9) is at distance 1, (6, 9) at √2 ≈ 1.4142 > 1.41.
    let t = PuddleWorld::<f64>::target(Dynamics::Shared);
    assert!(t.in_goal([5.0, 9.0]).unwrap());
    assert!(!t.in_goal([6.0, 9.0]).unwrap());
    assert!(!t.in_goal([0.0, 0.0]).unwrap());
    // Base reward: 0 in the goal, −1 outside (spec §2.4).
    let dry = PuddleWorld::<f64>::new([5.0, 10.0], &[], Dynamics::Shared).unwrap();
    assert_eq!(dry.mean_reward([5.0, 9.0]).unwrap(), 0.0);
    assert_eq!(dry.mean_reward([6.0, 9.0]).unwrap(), -1.0);
}

#[test]
fn mean_next_state_moves_by_alpha_and_clips() {
    let shared = PuddleWorld::<f64>::target(Dynamics::Shared);
    let s = [3.25, 4.5];
    assert_eq!(
        shared.mean_next_state(s, ACTION_RIGHT).unwrap(),
        [4.25, 4.5]
    );
    assert_eq!(shared.mean_next_state(s, ACTION_LEFT).unwrap(), [2.25, 4.5]);
    assert_eq!(shared.mean_next_state(s, ACTION_UP).unwrap(), [3.25, 5.5]);
    assert_eq!(shared.mean_next_state(s, ACTION_DOWN).unwrap(), [3.25, 3.5]);
    assert_eq!(shared.mean_next_state([0.5, 9.5], 1).unwrap(), [0.0, 9.5]);
    assert_eq!(shared.mean_next_state([0.5, 9.5], 2).unwrap(), [0.5, 10.0]);
    assert_eq!(shared.mean_next_state([10.0, 0.0], 0).unwrap(), [10.0, 0.0]);
    assert_eq!(shared.mean_next_state([10.0, 0.0], 3).unwrap(), [10.0, 0.0]);
    // Puddle-based: at (5, 5) the target's α is 0.636947 (spec §2.7).
    let slow = PuddleWorld::<f64>::target(Dynamics::PuddleBased);
    let [x, y] = slow.mean_next_state([5.0, 5.0], ACTION_UP).unwrap();
    assert_eq!(x, 5.0);
    assert!((y - 5.636947).abs() < 1e-6);
    let [x, _] = slow.mean_next_state([5.0, 5.0], ACTION_LEFT).unwrap();
    assert!((x - (5.0 - 0.636947)).abs() < 1e-6);
}

#[test]
fn step_equals_the_hand_composed_formula_with_draws_in_order() {
    for dynamics in [Dynamics::Shared, Dynamics::PuddleBased] {
        let world = PuddleWorld::<f64>::target(dynamics);
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        for k in 0..400 {
            let s = [(k % 21) as f64 * 0.5, (k / 21 % 21) as f64 * 0.5];
            let a = k % 4;
            let mut replay = rng.clone();
            let t = world.step(s, a, &mut rng).unwrap();
            let ex: f64 = rng::standard_normal(&mut replay);
            let ey: f64 = rng::standard_normal(&mut replay);
            let eta: f64 = rng::standard_normal(&mut replay);
            // The replayed stream is now exactly where the step left the real one.
            assert_eq!(replay.next_u64(), rng.clone().next_u64());

            let w: f64 = world
                .puddles()
                .map(|p| direct_density(s, p.mean, p.variance, 1e-5))
                .sum();
            let kappa = if dynamics == Dynamics::Shared {
                0.0
            } else {
                5.0
            };
            let alpha = 1.0 / (1.0 + kappa * w);
            let e = [[alpha, 0.0], [-alpha, 0.0], [0.0, alpha], [0.0, -alpha]][a];
            let want_next = [
                (s[0] + e[0] + 0.2 * ex).clamp(0.0, 10.0),
                (s[1] + e[1] + 0.2 * ey).clamp(0.0, 10.0),
            ];
            let dist = |p: [f64; 2]| ((p[0] - 5.0).powi(2) + (p[1] - 10.0).powi(2)).sqrt();
            let base = if dist(s) < 1.41 { 0.0 } else { -1.0 };
            let want_reward = base - 100.0 * w + 0.1 * eta;
            assert_eq!(t.state, s);
            assert_eq!(t.action, a);
            for (g, w) in t.next_state.iter().zip(want_next) {
                assert!(
                    (g - w).abs() < 1e-12,
                    "{s:?} {a}: {:?} vs {want_next:?}",
                    t.next_state
                );
            }
            assert!(
                (t.reward - want_reward).abs() < 1e-11,
                "{s:?}: {} vs {want_reward}",
                t.reward
            );
            assert_eq!(t.absorbing, dist(t.next_state) < 1.41);
        }
    }
}

/// Mean and population std of a slice.
fn moments(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

#[test]
fn sampled_steps_have_the_model_means_and_noise_stds() {
    let n = 20_000;
    for dynamics in [Dynamics::Shared, Dynamics::PuddleBased] {
        let world = PuddleWorld::<f64>::target(dynamics);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (s, a) in [([5.0, 5.0], ACTION_RIGHT), ([3.0, 6.5], ACTION_DOWN)] {
            let (mut xs, mut ys, mut rs) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..n {
                let t = world.query(s, a, &mut rng).unwrap();
                xs.push(t.next_state[0]);
                ys.push(t.next_state[1]);
                rs.push(t.reward);
            }
            let mean_next = world.mean_next_state(s, a).unwrap();
            let mean_reward = world.mean_reward(s).unwrap();
            let (mx, sx) = moments(&xs);
            let (my, sy) = moments(&ys);
            let (mr, sr) = moments(&rs);
            // 5 standard errors: mean SE σ/√n, std SE ≈ σ/√(2n).
            let nf = n as f64;
            assert!(
                (mx - mean_next[0]).abs() < 5.0 * 0.2 / nf.sqrt(),
                "x mean {mx}"
            );
            assert!(
                (my - mean_next[1]).abs() < 5.0 * 0.2 / nf.sqrt(),
                "y mean {my}"
            );
            assert!(
                (mr - mean_reward).abs() < 5.0 * 0.1 / nf.sqrt(),
                "r mean {mr}"
            );
            assert!(
                (sx - 0.2).abs() < 5.0 * 0.2 / (2.0 * nf).sqrt(),
                "x std {sx}"
            );
            assert!(
                (sy - 0.2).abs() < 5.0 * 0.2 / (2.0 * nf).sqrt(),
                "y std {sy}"
            );
            assert!(
                (sr - 0.1).abs() < 5.0 * 0.1 / (2.0 * nf).sqrt(),
                "r std {sr}"
            );
            // The three noises are independent: sample correlations near 0 (SE 1/√n).
            let corr = |u: &[f64], v: &[f64]| {
                let ((mu, su), (mv, sv)) = (moments(u), moments(v));
                u.iter()
                    .zip(v)
                    .map(|(a, b)| (a - mu) * (b - mv))
                    .sum::<f64>()
                    / (nf * su * sv)
            };
            for c in [corr(&xs, &ys), corr(&xs, &rs), corr(&ys, &rs)] {
                assert!(c.abs() < 5.0 / nf.sqrt(), "correlation {c}");
            }
        }
    }
}

#[test]
fn noise_is_added_before_clipping() {
    let world = PuddleWorld::<f64>::source_1(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let n = 10_000;
    // Moving up along the left wall: x = clip(0 + ε_x) is exactly 0 half of the time and
    // otherwise positive, never negative.
    let mut at_wall = 0;
    for _ in 0..n {
        let t = world.step([0.0, 5.0], ACTION_UP, &mut rng).unwrap();
        assert!(t.next_state[0] >= 0.0);
        if t.next_state[0] == 0.0 {
            at_wall += 1;
        }
        assert!(t.next_state[1] > 5.0 && t.next_state[1] < 7.0);
    }
    // Binomial(10000, 1/2): std 50, allow 5 std.
    assert!((at_wall as f64 - 5000.0).abs() < 250.0, "{at_wall}");
    // Pushing into the corner: clip(−1 + ε) = 0 unless ε > 1 (a 5σ event), in both coordinates
    // at the top-right corner likewise.
    for _ in 0..1000 {
        let t = world.step([0.0, 0.0], ACTION_LEFT, &mut rng).unwrap();
        assert_eq!(t.next_state[0], 0.0);
        assert!(t.next_state[1] >= 0.0);
        let t = world.step([10.0, 10.0], ACTION_RIGHT, &mut rng).unwrap();
        assert_eq!(t.next_state[0], 10.0);
        assert!(t.next_state[1] <= 10.0);
    }
}

#[test]
fn goal_reward_uses_the_current_state_and_absorption_the_next() {
    let world = PuddleWorld::<f64>::target(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    // From (5, 9), inside the goal, moving down to ≈ (5, 8), outside: base reward 0 and
    // (almost always) not absorbing.
    let n = 4000;
    let mut rewards = Vec::new();
    let mut absorbed = 0;
    for _ in 0..n {
        let t = world.query([5.0, 9.0], ACTION_DOWN, &mut rng).unwrap();
        rewards.push(t.reward);
        assert_eq!(t.absorbing, world.in_goal(t.next_state).unwrap());
        absorbed += usize::from(t.absorbing);
    }
    let (mr, _) = moments(&rewards);
    assert!(
        (mr - -0.039372).abs() < 5.0 * 0.1 / (n as f64).sqrt(),
        "{mr}"
    );
    // P(‖(ε_x, −1 + ε_y)‖ < 1.41) is about P(ε_y > 0.59) ≈ 0.2 %.
    assert!(absorbed < 40, "{absorbed}");
    // From outside the goal, (5, 7.8) moving up to ≈ (5, 8.8): reward base −1, mostly absorbing.
    let mut absorbed = 0;
    for _ in 0..n {
        let t = world.query([5.0, 7.8], ACTION_UP, &mut rng).unwrap();
        assert_eq!(t.absorbing, world.in_goal(t.next_state).unwrap());
        assert!(t.reward < -1.0 + 0.6, "base −1 outside the goal");
        absorbed += usize::from(t.absorbing);
    }
    assert!(absorbed > n * 3 / 4 && absorbed < n, "{absorbed}");
}

#[test]
fn boundary_states_are_accepted_and_everything_else_is_a_typed_error() {
    let world = PuddleWorld::<f64>::target(Dynamics::PuddleBased);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for s in [
        [0.0, 0.0],
        [10.0, 10.0],
        [0.0, 10.0],
        [10.0, 0.0],
        [-0.0, 3.0],
    ] {
        assert!(world.step(s, 3, &mut rng).is_ok(), "{s:?}");
        assert!(world.mean_reward(s).is_ok());
    }
    let non_finite = Err(Error::NonFinite { parameter: "state" });
    let out = Err(Error::OutOfRange { parameter: "state" });
    let bad_action = Error::OutOfRange {
        parameter: "action",
    };
    let cases = [
        ([f64::NAN, 1.0], non_finite),
        ([1.0, f64::INFINITY], non_finite),
        ([f64::NEG_INFINITY, f64::NAN], non_finite),
        ([-1e-9, 5.0], out),
        ([5.0, 10.000_000_001], out),
        ([11.0, -3.0], out),
    ];
    for (s, want) in cases {
        let before = rng.clone();
        assert_eq!(world.step(s, 0, &mut rng).map(|_| ()), want, "{s:?}");
        assert_eq!(world.query(s, 0, &mut rng).map(|_| ()), want);
        assert_eq!(world.puddle_weight(s).map(|_| ()), want);
        assert_eq!(world.step_length(s).map(|_| ()), want);
        assert_eq!(world.in_goal(s).map(|_| ()), want);
        assert_eq!(world.mean_reward(s).map(|_| ()), want);
        assert_eq!(world.mean_next_state(s, 0).map(|_| ()), want);
        assert_eq!(world.check_state(s), want);
        assert_eq!(rng, before, "nothing drawn on error");
    }
    let before = rng.clone();
    for a in [4, 5, usize::MAX] {
        assert_eq!(world.step([1.0, 1.0], a, &mut rng), Err(bad_action));
        assert_eq!(world.mean_next_state([1.0, 1.0], a), Err(bad_action));
    }
    assert_eq!(rng, before);
    // A bad state is reported before a bad action.
    assert_eq!(
        world.step([f64::NAN, 0.0], 9, &mut rng).map(|_| ()),
        non_finite
    );
    // f32 as well.
    let w32 = PuddleWorld::<f32>::source_2(Dynamics::Shared);
    assert_eq!(
        w32.step([10.5, 0.0], 0, &mut rng).map(|_| ()),
        Err(Error::OutOfRange { parameter: "state" })
    );
    assert_eq!(w32.num_actions(), 4);
}

#[test]
fn constructor_validates_and_reproduces_the_builtin_instances() {
    let target = PuddleWorld::<f64>::target(Dynamics::PuddleBased);
    let puddles = [
        Puddle::new([1.0, 4.0], 0.7),
        Puddle::new([1.0, 10.0], 0.8),
        Puddle::new([1.0, 8.0], 0.8),
        Puddle::new([6.0, 6.0], 0.8),
        Puddle::new([6.0, 4.0], 0.8),
    ];
    let custom = PuddleWorld::new([5.0, 10.0], &puddles, Dynamics::PuddleBased).unwrap();
    assert_eq!(custom, target);
    assert_eq!(target.goal(), [5.0, 10.0]);
    assert_eq!(target.num_puddles(), 5);
    assert_eq!(target.puddles().collect::<Vec<_>>(), puddles);
    assert_eq!(target.dynamics(), Dynamics::PuddleBased);
    assert_eq!(target.slow_down(), 5.0);
    assert_eq!(target.initial_state(), [0.0, 0.0]);
    assert_eq!(
        PuddleWorld::<f32>::target(Dynamics::Shared).slow_down(),
        0.0
    );
    // The sources differ as spec §2.6 says.
    let [s1, s2, s3] = PuddleWorld::<f64>::sources(Dynamics::Shared);
    assert_eq!(s1.puddles().collect::<Vec<_>>(), puddles[1..]);
    assert_eq!(s2.num_puddles(), 6);
    assert_eq!(s3.goal(), [7.0, 10.0]);
    assert_eq!(s3.puddles().next(), Some(Puddle::new([8.0, 2.0], 0.7)));
    assert_eq!(s1, PuddleWorld::source_1(Dynamics::Shared));
    assert_eq!(s2, PuddleWorld::source_2(Dynamics::Shared));
    assert_eq!(s3, PuddleWorld::source_3(Dynamics::Shared));

    // Capacity: exactly MAX_PUDDLES is fine, one more is not.
    let many = [Puddle::new([5.0, 5.0], 0.8); MAX_PUDDLES + 1];
    assert!(PuddleWorld::new([0.0, 0.0], &many[..MAX_PUDDLES], Dynamics::Shared).is_ok());
    assert_eq!(
        PuddleWorld::new([0.0, 0.0], &many, Dynamics::Shared),
        Err(Error::CapacityExceeded {
            capacity: MAX_PUDDLES
        })
    );
    let ok = Puddle::new([5.0, 5.0], 0.8f64);
    let cases = [
        ([f64::NAN, 0.0], ok, Error::NonFinite { parameter: "goal" }),
        (
            [0.0, 0.0],
            Puddle::new([f64::INFINITY, 0.0], 0.8),
            Error::NonFinite {
                parameter: "puddle mean",
            },
        ),
        (
            [0.0, 0.0],
            Puddle::new([1.0, 1.0], f64::NAN),
            Error::NonFinite {
                parameter: "puddle variance",
            },
        ),
        (
            [0.0, 0.0],
            Puddle::new([1.0, 1.0], 1e-5),
            Error::InvalidParameter {
                parameter: "puddle variance",
            },
        ),
        (
            [0.0, 0.0],
            Puddle::new([1.0, 1.0], 0.0),
            Error::InvalidParameter {
                parameter: "puddle variance",
            },
        ),
        (
            [0.0, 0.0],
            Puddle::new([1.0, 1.0], -0.8),
            Error::InvalidParameter {
                parameter: "puddle variance",
            },
        ),
    ];
    for (goal, bad, want) in cases {
        assert_eq!(
            PuddleWorld::new(goal, &[ok, bad], Dynamics::Shared),
            Err(want)
        );
    }
    // Just above the off-diagonal the covariance is positive definite (if very peaked).
    let sharp = PuddleWorld::new(
        [0.0, 0.0],
        &[Puddle::new([5.0, 5.0], 2e-5)],
        Dynamics::Shared,
    )
    .unwrap();
    let peak = sharp.puddle_weight([5.0, 5.0]).unwrap();
    let want = 1.0 / (2.0 * core::f64::consts::PI * (4e-10f64 - 1e-10).sqrt());
    assert!((peak - want).abs() < 1e-9 * want);
}

#[test]
fn dynamics_variants_expose_their_slow_down() {
    assert_eq!(Dynamics::Shared.slow_down(), 0.0);
    assert_eq!(Dynamics::PuddleBased.slow_down(), 5.0);
}

#[test]
fn f32_steps_track_f64_steps_from_the_same_seed() {
    let w32 = PuddleWorld::<f32>::target(Dynamics::PuddleBased);
    let w64 = PuddleWorld::<f64>::target(Dynamics::PuddleBased);
    for seed in 0..200u64 {
        let s = [
            (seed % 11) as f64 * 0.9 + 0.3,
            (seed / 11 % 11) as f64 * 0.9 + 0.2,
        ];
        let a = (seed % 4) as usize;
        let t32 = w32
            .step(pt::<f32>(s), a, &mut ChaCha8Rng::seed_from_u64(seed))
            .unwrap();
        let t64 = w64
            .step(s, a, &mut ChaCha8Rng::seed_from_u64(seed))
            .unwrap();
        for (a, b) in t32.next_state.iter().zip(t64.next_state) {
            assert!((*a as f64 - b).abs() < 1e-5, "seed {seed}");
        }
        assert!((t32.reward as f64 - t64.reward).abs() < 2e-5, "seed {seed}");
    }
}

// ----- episodes and rollouts -----

/// Up along x = 0… until y ≥ 9, then right: reaches the (5, 10) goal in about 15 steps.
fn up_then_right(s: &[f64; 2]) -> Result<usize> {
    Ok(if s[1] < 9.0 { ACTION_UP } else { ACTION_RIGHT })
}

fn check_episode(world: &PuddleWorld<f64>, records: &[EpisodeRecord<f64>], horizon: usize) {
    assert!(!records.is_empty() && records.len() <= horizon);
    assert_eq!(records[0].transition.state, [0.0, 0.0]);
    for (i, r) in records.iter().enumerate() {
        assert_eq!(r.t, i);
        assert!(!world.in_goal(r.transition.state).unwrap());
        assert_eq!(
            r.transition.absorbing,
            world.in_goal(r.transition.next_state).unwrap()
        );
        if i + 1 < records.len() {
            assert!(
                !r.transition.absorbing,
                "only the last record can be absorbing"
            );
            assert_eq!(records[i + 1].transition.state, r.transition.next_state);
        }
    }
    let last = records[records.len() - 1].transition;
    assert!(last.absorbing || records.len() == horizon);
}

#[test]
fn episodes_stop_at_the_goal_with_consistent_records() {
    let world = PuddleWorld::<f64>::target(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut records = [EpisodeRecord::default(); PUDDLE_HORIZON];
    let mut policy = up_then_right;
    for _ in 0..20 {
        let n = world
            .run_episode(&mut policy, PUDDLE_HORIZON, &mut records, &mut rng)
            .unwrap();
        check_episode(&world, &records[..n], PUDDLE_HORIZON);
        assert!(
            records[n - 1].transition.absorbing,
            "the path reaches the goal"
        );
        assert!((10..=25).contains(&n), "{n} steps");
    }
}

#[test]
fn episodes_stop_at_the_horizon_and_leave_spare_storage_untouched() {
    let world = PuddleWorld::<f64>::source_2(Dynamics::PuddleBased);
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    // Always left: the agent stays near the left wall at the bottom, far from the goal.
    let mut left = |_: &[f64; 2]| -> Result<usize> { Ok(ACTION_LEFT) };
    let marker = EpisodeRecord {
        t: 999,
        ..EpisodeRecord::default()
    };
    let mut records = [marker; 12];
    let n = world
        .run_episode(&mut left, 7, &mut records, &mut rng)
        .unwrap();
    assert_eq!(n, 7);
    check_episode(&world, &records[..7], 7);
    assert!(records[7..].iter().all(|r| *r == marker));
    // Uniform episodes are consistent too, whatever their length.
    let mut uniform = UniformPolicy::new(PUDDLE_ACTIONS).unwrap();
    let mut records = [EpisodeRecord::default(); PUDDLE_HORIZON];
    for _ in 0..50 {
        let n = world
            .run_episode(&mut uniform, PUDDLE_HORIZON, &mut records, &mut rng)
            .unwrap();
        check_episode(&world, &records[..n], PUDDLE_HORIZON);
    }
}

#[test]
fn episode_errors() {
    let world = PuddleWorld::<f64>::target(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let mut policy = up_then_right;
    let mut small = [EpisodeRecord::default(); 10];
    let before = rng.clone();
    assert_eq!(
        world.run_episode(&mut policy, 11, &mut small, &mut rng),
        Err(Error::CapacityExceeded { capacity: 10 })
    );
    assert_eq!(
        world.run_episode(&mut policy, 0, &mut small, &mut rng),
        Err(Error::InvalidParameter {
            parameter: "horizon"
        })
    );
    assert_eq!(
        world.rollout(&mut policy, 0, 0.99, &mut rng),
        Err(Error::InvalidParameter {
            parameter: "horizon"
        })
    );
    assert_eq!(
        world.rollout(&mut policy, 50, f64::NAN, &mut rng),
        Err(Error::NonFinite {
            parameter: "discount"
        })
    );
    assert_eq!(
        world.rollout(&mut policy, 50, 1.01, &mut rng),
        Err(Error::OutOfRange {
            parameter: "discount"
        })
    );
    assert_eq!(rng, before, "nothing drawn before validation passes");
    assert!(small.iter().all(|r| *r == EpisodeRecord::default()));
    // A policy that returns an invalid action fails at that step.
    let mut bad = |s: &[f64; 2]| -> Result<usize> { Ok(if s[1] > 1.5 { 4 } else { ACTION_UP }) };
    assert_eq!(
        world.run_episode(&mut bad, 10, &mut small, &mut rng),
        Err(Error::OutOfRange {
            parameter: "action"
        })
    );
    // A failing visitor stops the episode after its first record.
    let mut visits = 0;
    let r = world.run_episode_with(&mut policy, 50, &mut rng, |_| {
        visits += 1;
        Err(Error::EmptyData)
    });
    assert_eq!((r, visits), (Err(Error::EmptyData), 1));
}

#[test]
fn rollout_return_is_the_discounted_sum_of_the_episode_rewards() {
    let world = PuddleWorld::<f64>::target(Dynamics::PuddleBased);
    let mut uniform = UniformPolicy::new(PUDDLE_ACTIONS).unwrap();
    for seed in 0..20 {
        let mut records = [EpisodeRecord::default(); PUDDLE_HORIZON];
        let n = world
            .run_episode(
                &mut uniform,
                PUDDLE_HORIZON,
                &mut records,
                &mut ChaCha8Rng::seed_from_u64(seed),
            )
            .unwrap();
        let want: f64 = records[..n]
            .iter()
            .map(|r| 0.99f64.powi(r.t as i32) * r.transition.reward)
            .sum();
        let got = world
            .rollout(
                &mut uniform,
                PUDDLE_HORIZON,
                PUDDLE_DISCOUNT,
                &mut ChaCha8Rng::seed_from_u64(seed),
            )
            .unwrap();
        assert_eq!(got.steps, n);
        assert_eq!(got.absorbed, records[n - 1].transition.absorbing);
        assert!(
            (got.discounted_return - want).abs() < 1e-10,
            "{got:?} vs {want}"
        );
    }
    // Discount 1 sums the rewards; discount 0 keeps only the first.
    let mut policy = up_then_right;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut records = [EpisodeRecord::default(); PUDDLE_HORIZON];
    let n = world
        .run_episode(&mut policy, PUDDLE_HORIZON, &mut records, &mut rng.clone())
        .unwrap();
    let sum: f64 = records[..n].iter().map(|r| r.transition.reward).sum();
    let r1 = world
        .rollout(&mut policy, PUDDLE_HORIZON, 1.0, &mut rng.clone())
        .unwrap();
    assert!((r1.discounted_return - sum).abs() < 1e-10);
    let r0 = world
        .rollout(&mut policy, PUDDLE_HORIZON, 0.0, &mut rng)
        .unwrap();
    assert_eq!(r0.discounted_return, records[0].transition.reward);
}

#[test]
fn same_seed_same_episode_and_different_seed_different_episode() {
    let world = PuddleWorld::<f32>::source_3(Dynamics::PuddleBased);
    let run = |seed: u64| {
        let mut records = [EpisodeRecord::default(); PUDDLE_HORIZON];
        let mut policy =
            EpsilonGreedyPolicy::new(|_: &[f32; 2]| -> Result<usize> { Ok(ACTION_UP) }, 0.3f32, 4)
                .unwrap();
        let n = world
            .run_episode(
                &mut policy,
                PUDDLE_HORIZON,
                &mut records,
                &mut ChaCha8Rng::seed_from_u64(seed),
            )
            .unwrap();
        (n, records)
    };
    assert_eq!(run(77), run(77));
    assert_ne!(run(77), run(78));
}
