//! The IWFQI paper's Dam and Acrobot against golden values computed independently from the
//! published definitions (`scripts/golden/iwfqi_domains.py`, whose output is
//! `tests/data/iwfqi_domains_golden.rs`), fixed-policy episodes, and bad input.

#![allow(clippy::needless_range_loop)]

use awfqi::Error;
use awfqi::env::{
    ACROBOT_DISCOUNT, ACROBOT_HORIZON, Acrobot, AcrobotTask, DAM_ACTIONS, DAM_DISCOUNT,
    DAM_HORIZON, DAM_INFLOW_STD, Dam, InflowProfile,
};
use awfqi::model::GenerativeModel;
use awfqi::rng::standard_normal;
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

#[allow(dead_code, clippy::type_complexity, clippy::approx_constant)]
#[allow(clippy::excessive_precision, clippy::unreadable_literal)]
mod golden {
    include!("data/iwfqi_domains_golden.rs");
}

fn dam(k: usize) -> Dam<f64> {
    if k == 0 {
        Dam::target()
    } else {
        Dam::sources()[k - 1]
    }
}

fn acrobot<T: awfqi::float::Real>(k: usize) -> Acrobot<T> {
    if k == 0 {
        Acrobot::target()
    } else {
        Acrobot::sources()[k - 1]
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

#[test]
fn inflow_profiles_match_the_published_curves() {
    for &(profile, day, want) in golden::INFLOW {
        let got = InflowProfile::new(profile).unwrap().mean(day);
        assert!(
            close(got, want, 1e-13),
            "profile {profile} day {day}: {got} vs {want}"
        );
    }
    // Through an instance and in f32.
    let target = Dam::<f32>::target();
    let mu = target.inflow_mean([100.0, 60.0]).unwrap();
    assert!((f64::from(mu) - 15.998085596255814).abs() < 1e-5);
}

#[test]
fn dam_means_and_steps_match_the_golden_values() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for &(k, state, action, reward, noise_free, next_day, mean_next) in golden::DAM {
        let env = dam(k);
        assert!(close(
            env.mean_reward(state, action).unwrap(),
            reward,
            1e-13
        ));
        let mean = env.mean_next_state(state, action).unwrap();
        assert!(
            close(mean[0], mean_next, 1e-12),
            "{k} {state:?}: {mean:?} vs {mean_next}"
        );
        assert_eq!(mean[1], next_day);
        // A sampled step: the inflow noise is the generator's next standard normal, times 2.
        let mut copy = rng.clone();
        let eps: f64 = standard_normal(&mut copy);
        let t = env.step(state, action, &mut rng).unwrap();
        assert_eq!(rng.next_u64(), copy.next_u64(), "one normal drawn");
        assert_eq!((t.state, t.action, t.absorbing), (state, action, false));
        assert!(close(t.reward, reward, 1e-13));
        let want = (noise_free + DAM_INFLOW_STD * eps).max(0.0);
        assert!(
            close(t.next_state[0], want, 1e-12),
            "{} vs {want}",
            t.next_state[0]
        );
        assert_eq!(t.next_state[1], next_day);
        // The generative model is the step.
        let mut a = ChaCha8Rng::seed_from_u64(9);
        let mut b = a.clone();
        assert_eq!(
            env.query(state, action, &mut a),
            env.step(state, action, &mut b)
        );
    }
}

#[test]
fn dam_release_bounds_and_clipping() {
    let env = Dam::<f64>::target();
    // Above 500 the release is at least s − 500; below 50 + release it is at most s − 50.
    assert_eq!(env.release([520.0, 5.0], 0).unwrap(), 20.0);
    assert_eq!(env.release([520.0, 5.0], 7).unwrap(), 30.0);
    assert_eq!(env.release([60.0, 5.0], 7).unwrap(), 10.0);
    assert_eq!(env.release([20.0, 5.0], 4).unwrap(), 0.0);
    // Near an empty reservoir the mean next storage exceeds max(m, 0) = 0 (clipped noise):
    // m = 0 + μ − 0, and E max(m + 2ε, 0) > m.
    let m = env.inflow_mean([0.0, 200.0]).unwrap();
    let mean = env.mean_next_state([0.0, 200.0], 0).unwrap()[0];
    assert!(mean > m && mean < m + 0.1, "{mean} vs {m}");
    // Day 360 wraps to 1.
    assert_eq!(env.mean_next_state([100.0, 360.0], 0).unwrap()[1], 1.0);
}

#[test]
fn dam_mean_dynamics_year_matches() {
    let (ret, average, last) = golden::DAM_EPISODE;
    let env = Dam::<f64>::target();
    let (mut s, mut total, mut discounted, mut discount) = ([200.0, 1.0], 0.0, 0.0, 1.0);
    for _ in 0..DAM_HORIZON {
        let r = env.mean_reward(s, 4).unwrap();
        discounted += discount * r;
        total += r;
        discount *= DAM_DISCOUNT;
        s = env.mean_next_state(s, 4).unwrap();
    }
    assert!(close(discounted, ret, 1e-10), "{discounted} vs {ret}");
    assert!(close(total / DAM_HORIZON as f64, average, 1e-10));
    assert!(close(s[0], last[0], 1e-10) && s[1] == last[1]);
}

#[test]
fn dam_episode_starts_follow_the_reference() {
    let env = Dam::<f64>::target();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut days = [0usize; 3];
    for _ in 0..3000 {
        let [storage, day] = env.initial_state(&mut rng);
        assert!((50.0..500.0).contains(&storage));
        let i = [1.0, 120.0, 240.0].iter().position(|&d| d == day).unwrap();
        days[i] += 1;
    }
    // Each start day has probability 1/3: 1000 ± 26 (s.d.), so ± 130 is 5 s.d.
    assert!(days.iter().all(|&n| n.abs_diff(1000) < 130), "{days:?}");
}

#[test]
fn acrobot_steps_match_the_golden_values() {
    for &(k, state, action, reward, next, absorbing) in golden::ACROBOT {
        let env = acrobot::<f64>(k);
        let t = env.step(state, action).unwrap();
        assert!(close(t.reward, reward, 1e-13));
        for d in 0..4 {
            assert!(
                close(t.next_state[d], next[d], 1e-11),
                "{k} {state:?} dim {d}: {:?} vs {next:?}",
                t.next_state
            );
        }
        assert_eq!(t.absorbing, absorbing);
        assert_eq!(env.mean_reward(state).unwrap(), t.reward);
        assert_eq!(env.mean_next_state(state, action).unwrap(), t.next_state);
        // f32 follows f64 to single precision.
        let env32 = acrobot::<f32>(k);
        let t32 = env32.step(state.map(|x| x as f32), action).unwrap();
        for d in 0..4 {
            let (a, b) = (f64::from(t32.next_state[d]), next[d]);
            // A wrapped angle may land on the other side of ±π.
            let d = (a - b).abs();
            let diff = d.min((d - 2.0 * std::f64::consts::PI).abs());
            assert!(diff < 2e-4 * b.abs().max(1.0), "f32 dim {d}: {a} vs {b}");
        }
        // The generative model draws nothing.
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let before = rng.clone();
        assert_eq!(env.query(state, action, &mut rng).unwrap(), t);
        assert_eq!(rng, before);
    }
}

#[test]
fn acrobot_fixed_policy_episode_matches() {
    let (steps, ret, last) = golden::ACROBOT_EPISODE;
    let env = Acrobot::<f64>::target();
    let (mut s, mut discounted, mut discount, mut n) = ([-1.0, 0.0, 0.0, 0.0], 0.0, 1.0, 0);
    for _ in 0..ACROBOT_HORIZON {
        let t = env.step(s, usize::from(s[3] >= 0.0)).unwrap();
        discounted += discount * t.reward;
        discount *= ACROBOT_DISCOUNT;
        n += 1;
        s = t.next_state;
        if t.absorbing {
            break;
        }
    }
    assert_eq!(n, steps);
    assert!(env.in_goal(s).unwrap());
    assert!(close(discounted, ret, 1e-9), "{discounted} vs {ret}");
    for d in 0..4 {
        assert!(close(s[d], last[d], 1e-8), "{s:?} vs {last:?}");
    }
}

#[test]
fn acrobot_tasks_and_parameters() {
    let [s1, s2] = Acrobot::<f64>::sources();
    assert_eq!(
        (s1.task(), s2.task()),
        (AcrobotTask::SwingUp, AcrobotTask::Rotate)
    );
    assert_eq!(s1.masses(), [0.9, 0.6]);
    assert_eq!(s1.lengths(), [1.1, 0.7]);
    // The rotate task is never absorbing, even with the tip up; its reward is −|θ̇₁ − π|.
    let up = [std::f64::consts::PI, 0.0, std::f64::consts::PI, 0.0];
    assert!(!s2.in_goal(up).unwrap());
    assert_eq!(s2.mean_reward(up).unwrap(), 0.0);
    assert!(Acrobot::<f64>::target().in_goal(up).unwrap());
    // The second link's length does not enter the dynamics.
    let a = Acrobot::new([1.0, 1.0], [1.0, 0.3], AcrobotTask::SwingUp).unwrap();
    let s = [0.3, -0.2, 1.0, 2.0];
    assert_eq!(
        a.step(s, 1).unwrap(),
        Acrobot::<f64>::target().step(s, 1).unwrap()
    );
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for _ in 0..100 {
        let s0 = a.initial_state(&mut rng);
        assert!((-2.0..2.0).contains(&s0[0]) && s0[1..] == [0.0; 3]);
    }
}

#[test]
fn bad_input_is_a_typed_error_and_draws_nothing() {
    let env = Dam::<f64>::target();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let before = rng.clone();
    let state_err = |p| Err(Error::OutOfRange { parameter: p });
    for bad in [[-1.0, 5.0], [100.0, 0.0], [100.0, 361.0], [100.0, 1.5]] {
        assert_eq!(
            env.step(bad, 0, &mut rng).map(|_| ()),
            state_err("state"),
            "{bad:?}"
        );
        assert_eq!(env.mean_reward(bad, 0).map(|_| ()), state_err("state"));
        assert_eq!(env.mean_next_state(bad, 0).map(|_| ()), state_err("state"));
    }
    for bad in [[f64::NAN, 5.0], [100.0, f64::INFINITY]] {
        assert_eq!(
            env.query(bad, 0, &mut rng).map(|_| ()),
            Err(Error::NonFinite { parameter: "state" })
        );
    }
    assert_eq!(
        env.step([100.0, 5.0], DAM_ACTIONS, &mut rng).map(|_| ()),
        state_err("action")
    );
    assert_eq!(rng, before, "nothing drawn on error");
    assert!(InflowProfile::new(0).is_err() && InflowProfile::new(8).is_err());
    let p = InflowProfile::new(3).unwrap();
    assert_eq!(
        Dam::new(p, f64::NAN, 0.5),
        Err(Error::NonFinite { parameter: "alpha" })
    );
    assert_eq!(
        Dam::new(p, -0.1, 1.1),
        Err(Error::InvalidParameter { parameter: "alpha" })
    );
    assert_eq!(
        Dam::new(p, 0.3, 0.6),
        Err(Error::InvalidParameter { parameter: "beta" })
    );
    assert!(Dam::new(p, 0.35f32, 0.65).is_ok());

    let acro = Acrobot::<f64>::target();
    for bad in [
        [3.2, 0.0, 0.0, 0.0],
        [0.0, -3.2, 0.0, 0.0],
        [0.0, 0.0, 12.6, 0.0],
        [0.0, 0.0, 0.0, -28.3],
    ] {
        assert_eq!(acro.step(bad, 0).map(|_| ()), state_err("state"), "{bad:?}");
    }
    assert_eq!(
        acro.query([0.0, f64::NAN, 0.0, 0.0], 0, &mut rng)
            .map(|_| ()),
        Err(Error::NonFinite { parameter: "state" })
    );
    assert_eq!(acro.step([0.0; 4], 2).map(|_| ()), state_err("action"));
    assert_eq!(
        Acrobot::new([1.0, 0.0], [1.0, 1.0], AcrobotTask::Rotate),
        Err(Error::InvalidParameter {
            parameter: "masses"
        })
    );
    assert_eq!(
        Acrobot::new([1.0, 1.0], [f64::INFINITY, 1.0], AcrobotTask::Rotate),
        Err(Error::NonFinite {
            parameter: "lengths"
        })
    );
    // Extreme parameters that overflow the integration are an error, not a wrong number.
    let heavy = Acrobot::new([1e300, 1e300], [1e300, 1.0], AcrobotTask::SwingUp).unwrap();
    assert_eq!(
        heavy.step([0.5, 0.5, 1.0, 1.0], 1).map(|_| ()),
        Err(Error::NonFinite {
            parameter: "next state"
        })
    );
}

/// Values worked out by hand from the published equations (module docs of `awfqi::env::dam`),
/// independent of the Python golden script.
#[test]
fn dam_hand_computed_values() {
    let env = Dam::<f64>::target(); // α = 0.3, β = 0.7, profile 1
    // s = 350, release 5: flooding −(350 − 300)/4 = −12.5, demand −(10 − 5)² = −25,
    // r = 0.3·(−12.5) + 0.7·(−25) = −21.25.
    assert!((env.mean_reward([350.0, 10.0], 2).unwrap() + 21.25).abs() < 1e-12);
    // s = 100 (no flood), release 10 meets the demand: r = 0.
    assert_eq!(env.mean_reward([100.0, 10.0], 4).unwrap(), 0.0);
    // s = 60 can release at most 60 − 50 = 10: asking 30 releases 10, r = 0.
    assert_eq!(env.mean_reward([60.0, 10.0], 7).unwrap(), 0.0);
    // s = 40 releases nothing whatever is asked: r = 0.7·(−100) = −70.
    assert!((env.mean_reward([40.0, 10.0], 7).unwrap() + 70.0).abs() < 1e-12);
    // Profile 1 on day 1 (x = 0): (sin 0 + 0.5)·8 + 4 = 8; from s = 100 releasing 3 the
    // mean next storage is 100 + 8 − 3 = 105 (far from 0, the clip at 0 does not bite:
    // P(𝒩(105, 4) < 0) is below 10⁻³⁰⁰).
    let next = env.mean_next_state([100.0, 1.0], 1).unwrap();
    assert!(
        (next[0] - 105.0).abs() < 1e-12 && next[1] == 2.0,
        "{next:?}"
    );
    // Day 121 (x = 120) of profile 1: (sin(120·3π/359)/2 + 0.5)·8 + 4.
    let x = 120.0 * 3.0 * std::f64::consts::PI / 359.0;
    let want = (x.sin() / 2.0 + 0.5) * 8.0 + 4.0;
    assert!((env.inflow_mean([100.0, 121.0]).unwrap() - want).abs() < 1e-12);
}

/// The Acrobot's equations are symmetric under the mirror `s ↦ −s` with the torque
/// reversed (action `a ↦ 1 − a`): the step of the mirrored state is the mirrored step,
/// and the swing-up reward (`−cos θ₁ − cos(θ₁ + θ₂) − 2`, even) is unchanged. A closed-form
/// property of the published dynamics, checked on every task and on states away from the
/// ±π wrap.
#[test]
fn acrobot_steps_are_mirror_symmetric() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let mut checked = 0;
    for k in 0..3 {
        let env = acrobot::<f64>(k);
        for _ in 0..200 {
            let u =
                |rng: &mut ChaCha8Rng, h: f64| (2.0 * awfqi::rng::uniform::<f64, _>(rng) - 1.0) * h;
            let s = [
                u(&mut rng, 2.0),
                u(&mut rng, 2.0),
                u(&mut rng, 4.0),
                u(&mut rng, 8.0),
            ];
            let mirrored = s.map(|x| -x);
            for a in 0..2 {
                let t = env.step(s, a).unwrap();
                let m = env.step(mirrored, 1 - a).unwrap();
                if t.next_state[..2].iter().any(|x| x.abs() > 3.0) {
                    continue; // near the wrap, ±π may land on either side
                }
                for d in 0..4 {
                    assert!(
                        (m.next_state[d] + t.next_state[d]).abs() < 1e-9,
                        "task {k} {s:?} a {a} dim {d}: {:?} vs {:?}",
                        t.next_state,
                        m.next_state
                    );
                }
                checked += 1;
                if k < 2 {
                    assert!((m.reward - t.reward).abs() < 1e-12);
                    assert_eq!(m.absorbing, t.absorbing);
                }
            }
        }
    }
    assert!(
        checked > 900,
        "only {checked} of 1200 pairs away from the wrap"
    );
    // Hanging at rest: reward −1 − 1 − 2 = −4; upright: 1 + 1 − 2 = 0 (and in the goal).
    let target = Acrobot::<f64>::target();
    assert_eq!(target.mean_reward([0.0; 4]).unwrap(), -4.0);
    assert!(
        target
            .mean_reward([std::f64::consts::PI, 0.0, 0.0, 0.0])
            .unwrap()
            .abs()
            < 1e-15
    );
}

#[test]
fn mean_functions_reject_bad_actions_and_states() {
    let dam = Dam::<f64>::target();
    let action_err: awfqi::Result<()> = Err(Error::OutOfRange {
        parameter: "action",
    });
    assert_eq!(
        dam.mean_reward([100.0, 5.0], DAM_ACTIONS).map(|_| ()),
        action_err
    );
    assert_eq!(
        dam.mean_next_state([100.0, 5.0], DAM_ACTIONS).map(|_| ()),
        action_err
    );
    assert_eq!(
        dam.release([100.0, 5.0], DAM_ACTIONS).map(|_| ()),
        action_err
    );
    assert_eq!(
        dam.inflow_mean([f64::NAN, 5.0]),
        Err(Error::NonFinite { parameter: "state" })
    );
    let acro = Acrobot::<f64>::target();
    assert_eq!(acro.mean_next_state([0.0; 4], 2).map(|_| ()), action_err);
    let nan = Err(Error::NonFinite { parameter: "state" });
    assert_eq!(acro.mean_reward([f64::NAN, 0.0, 0.0, 0.0]), nan);
    assert_eq!(
        acro.in_goal([0.0, 0.0, f64::INFINITY, 0.0]),
        nan.map(|_: f64| false)
    );
    assert_eq!(
        acro.mean_next_state([0.0, 0.0, 0.0, f64::NEG_INFINITY], 0)
            .map(|_| ()),
        Err(Error::NonFinite { parameter: "state" })
    );
}
