//! The core on an emulated Cortex-M4F (QEMU `mps2-an386`), in `f32`, the microcontroller's
//! precision: every module against golden values computed on the host in `f64`
//! (`src/golden.rs`, proven by the core's host test `tests/on_target_golden.rs`), spec
//! tables, hand-computed values and invariants.
//!
//! Run with `scripts/test-on-target`. A failed assertion logs its message and exits
//! QEMU with status 1, a hard fault with status 3; the runner prints `N passed, M failed`.
#![no_std]
#![no_main]

use cortex_m as _;
use cortex_m_rt as _;
use defmt_semihosting as _;

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("{}", defmt::Display2Format(info));
    semihosting::process::exit(1)
}

#[defmt::panic_handler]
fn defmt_panic() -> ! {
    semihosting::process::exit(1)
}

#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!("hard fault");
    semihosting::process::exit(3)
}

use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::gp::{Gp, Hyperparameters};
use awfqi_on_target::{close, golden};

// Helpers live outside the `#[defmt_test::tests]` module, which admits only tests.
fn instance(i: usize, dynamics: Dynamics) -> PuddleWorld<f32> {
    match i {
        0 => PuddleWorld::target(dynamics),
        1 => PuddleWorld::source_1(dynamics),
        2 => PuddleWorld::source_2(dynamics),
        _ => PuddleWorld::source_3(dynamics),
    }
}

fn gp_hyper() -> Hyperparameters<f32, 3> {
    let l = golden::GP_LENGTH_SCALES;
    Hyperparameters {
        signal_variance: golden::GP_SIGNAL_VARIANCE as f32,
        length_scales: [l[0] as f32, l[1] as f32, l[2] as f32],
        noise_variance: golden::GP_NOISE_VARIANCE as f32,
    }
}

fn gp_point(p: &[f64; 3]) -> [f32; 3] {
    [p[0] as f32, p[1] as f32, p[2] as f32]
}

fn check_predictions(gp: &Gp<f32, 16, 3>, expected: &[(f64, f64); 3]) {
    for (x, &(mean, variance)) in golden::GP_TEST.iter().zip(expected.iter()) {
        let p = gp.predict(&gp_point(x)).unwrap();
        assert!(
            close(p.mean as f64, mean, 2e-4, 1e-4),
            "mean {} vs {}",
            p.mean,
            mean
        );
        assert!(
            close(p.latent_variance as f64, variance, 2e-4, 1e-4),
            "variance {} vs {}",
            p.latent_variance,
            variance
        );
        assert!(p.noisy_variance == p.latent_variance + gp_hyper().noise_variance);
    }
}

#[defmt_test::tests]
mod tests {
    use super::{check_predictions, gp_hyper, gp_point, instance};
    use awfqi::Error;
    use awfqi::env::{Dynamics, EpisodeRecord, FiniteMdp, GenerativeModel, GridWorld, PuddleWorld};
    use awfqi::gp::{Gp, HyperparameterBounds, SearchOptions, WhenFull};
    use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
    use awfqi_on_target::{close, golden};
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    /// Spec §2.7: mean reward r̄ and step length α (κ = 5) of the four instances at eight
    /// points, to f32 precision (the table has 6 decimals).
    #[test]
    fn puddle_world_mean_reward_and_step_length_match_spec_table() {
        const POINTS: [[f32; 2]; 8] = [
            [0.0, 0.0],
            [1.0, 4.0],
            [2.0, 2.0],
            [5.0, 5.0],
            [6.0, 6.0],
            [8.0, 2.0],
            [5.0, 9.0],
            [7.0, 9.0],
        ];
        // [point][instance] = (r̄, α)
        const TABLE: [[(f64, f64); 4]; 8] = [
            [
                (-1.000121, 0.999994),
                (-1.000000, 1.000000),
                (-1.134130, 0.993338),
                (-1.000000, 1.000000),
            ],
            [
                (-23.737327, 0.467975),
                (-1.000907, 0.999955),
                (-12.529551, 0.634326),
                (-1.000907, 0.999955),
            ],
            [
                (-1.639298, 0.969025),
                (-1.000074, 0.999996),
                (-22.527471, 0.481609),
                (-1.000074, 0.999996),
            ],
            [
                (-12.399788, 0.636947),
                (-12.399667, 0.636949),
                (-6.748596, 0.776741),
                (-12.399726, 0.636948),
            ],
            [
                (-22.527397, 0.481610),
                (-22.527397, 0.481610),
                (-3.061517, 0.906556),
                (-22.527412, 0.481610),
            ],
            [
                (-1.134113, 0.993339),
                (-1.134113, 0.993339),
                (-1.061376, 0.996941),
                (-23.870533, 0.466521),
            ],
            [
                (-0.039372, 0.998035),
                (-0.039372, 0.998035),
                (-0.039663, 0.998021),
                (-1.039372, 0.998035),
            ],
            [
                (-1.038409, 0.998083),
                (-1.038409, 0.998083),
                (-1.400652, 0.980361),
                (-0.038409, 0.998083),
            ],
        ];
        for (point, row) in POINTS.iter().zip(TABLE.iter()) {
            for (i, &(reward, alpha)) in row.iter().enumerate() {
                let world = instance(i, Dynamics::PuddleBased);
                let r = world.mean_reward(*point).unwrap() as f64;
                let a = world.step_length(*point).unwrap() as f64;
                assert!(
                    close(r, reward, 2e-6, 4e-6),
                    "r̄ instance {} at {:?}: {} vs {}",
                    i,
                    point,
                    r,
                    reward
                );
                assert!(
                    close(a, alpha, 2e-6, 2e-6),
                    "α instance {} at {:?}: {} vs {}",
                    i,
                    point,
                    a,
                    alpha
                );
                let shared = instance(i, Dynamics::Shared);
                assert!(shared.step_length(*point).unwrap() == 1.0);
            }
        }
    }

    /// Sampled steps (κ = 5) from fixed seeds against spec §2.3 evaluated on the host in f64
    /// with the same noise draws.
    #[test]
    fn puddle_world_steps_match_host_f64() {
        for (&(i, s, a, seed), &(next, reward, absorbing)) in
            golden::STEP_CASES.iter().zip(golden::STEP_EXPECTED.iter())
        {
            let world = instance(i, Dynamics::PuddleBased);
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let state = [s[0] as f32, s[1] as f32];
            let t = world.query(state, a, &mut rng).unwrap();
            for (got, want) in t.next_state.iter().zip(next.iter()) {
                assert!(
                    close(*got as f64, *want, 1e-5, 1e-6),
                    "s′ {} vs {}",
                    got,
                    want
                );
            }
            assert!(
                close(t.reward as f64, reward, 1e-5, 2e-6),
                "r {} vs {}",
                t.reward,
                reward
            );
            assert!(t.absorbing == absorbing && t.state == state && t.action == a);
        }
    }

    /// Episodes: records chain (each next state is the following record's state), only the
    /// last can be absorbing, and the rollout's discounted return is the sum over the same
    /// episode (same seed) computed here; bad arguments are typed errors.
    #[test]
    fn puddle_world_episodes_chain_and_rollouts_sum() {
        let world = PuddleWorld::<f32>::target(Dynamics::Shared);
        let greedy_up = |_: &[f32; 2]| -> awfqi::Result<usize> { Ok(2) };
        let mut policy = EpsilonGreedyPolicy::new(greedy_up, 0.3f32, 4).unwrap();
        let mut records = [EpisodeRecord::<f32>::default(); 50];
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n = world
            .run_episode(&mut policy, 50, &mut records, &mut rng)
            .unwrap();
        assert!((1..=50).contains(&n));
        assert!(records[0].transition.state == [0.0, 0.0]);
        for (t, pair) in records[..n].windows(2).enumerate() {
            assert!(pair[0].t == t && pair[1].t == t + 1);
            assert!(pair[0].transition.next_state == pair[1].transition.state);
            assert!(!pair[0].transition.absorbing);
        }
        let mut expected = 0.0f32;
        let mut weight = 1.0f32;
        for r in &records[..n] {
            expected += weight * r.transition.reward;
            weight *= 0.99;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let rollout = world.rollout(&mut policy, 50, 0.99, &mut rng).unwrap();
        assert!(rollout.steps == n && rollout.discounted_return == expected);
        assert!(rollout.reached_goal == records[n - 1].transition.absorbing);

        let mut small = [EpisodeRecord::<f32>::default(); 10];
        assert!(
            world.run_episode(&mut policy, 50, &mut small, &mut rng)
                == Err(Error::CapacityExceeded { capacity: 10 })
        );
        let mut uniform = UniformPolicy::new(4).unwrap();
        assert!(world.rollout(&mut uniform, 0, 0.99, &mut rng).is_err());
        assert!(world.rollout(&mut uniform, 50, f32::NAN, &mut rng).is_err());
        assert!(
            world.query([f32::NAN, 1.0], 0, &mut rng)
                == Err(Error::NonFinite { parameter: "state" })
        );
        assert!(
            world.query([10.5, 1.0], 0, &mut rng) == Err(Error::OutOfRange { parameter: "state" })
        );
        assert!(
            world.query([1.0, 1.0], 4, &mut rng)
                == Err(Error::OutOfRange {
                    parameter: "action"
                })
        );
    }

    /// Grid World: hand-computed moves (walls keep the state), exact probabilities, reward
    /// means, and a sampled reward that is the mean plus √0.25 times the seeded normal draw.
    #[test]
    fn grid_world_moves_probabilities_and_rewards() {
        let grid = GridWorld::<f32>::thesis(0, false).unwrap(); // goal (9, 9) = state 99
        let moves = [
            (0, 0, 1),
            (0, 1, 0),
            (0, 2, 10),
            (0, 3, 0),
            (99, 0, 99),
            (99, 2, 99),
            (55, 1, 54),
            (55, 3, 45),
        ];
        for &(s, a, next) in &moves {
            assert!(grid.next_state(s, a) == Ok(next));
            assert!(grid.transition_probability(s, a, next) == Ok(1.0));
            let other = if next == 0 { 1 } else { 0 };
            assert!(grid.transition_probability(s, a, other) == Ok(0.0));
        }
        assert!(grid.reward_mean(99, 1) == Ok(1.0) && grid.reward_mean(98, 0) == Ok(0.0));
        assert!(grid.reward_variance(3, 3) == Ok(0.25));
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let t = grid.query(99, 1, &mut rng).unwrap();
        let mut same = ChaCha8Rng::seed_from_u64(21);
        let z: f32 = awfqi::rng::standard_normal(&mut same);
        assert!(t.next_state == 98 && close(t.reward as f64, (1.0 + 0.5 * z) as f64, 1e-6, 1e-6));
        assert!(grid.query(100, 0, &mut rng).is_err() && grid.query(0, 4, &mut rng).is_err());
        let absorbing = GridWorld::<f32>::thesis(3, true).unwrap(); // goal (5, 5) = 55
        assert!(absorbing.next_state(55, 0) == Ok(55));
        assert!(absorbing.query(54, 0, &mut rng).unwrap().absorbing);
    }

    /// GP in f32 on the target: fit 7 points, predict, add an 8th, predict again; every
    /// value against the harness's f64 reference GP on the host.
    #[test]
    fn gp_fit_predict_add_point_match_host_f64_reference() {
        let mut gp = Gp::<f32, 16, 3>::new(gp_hyper()).unwrap();
        let mut x = [[0.0f32; 3]; 7];
        let mut y = [0.0f32; 7];
        for ((xi, yi), (p, v)) in x
            .iter_mut()
            .zip(y.iter_mut())
            .zip(golden::GP_X.iter().zip(golden::GP_Y.iter()))
        {
            *xi = gp_point(p);
            *yi = *v as f32;
        }
        gp.fit(&x, &y).unwrap();
        assert!(gp.jitter() == 1e-10);
        check_predictions(&gp, &golden::GP_PRED_7);
        let lml = gp.log_marginal_likelihood().unwrap() as f64;
        assert!(
            close(lml, golden::GP_LML[0], 1e-3, 1e-5),
            "lml {} vs {}",
            lml,
            golden::GP_LML[0]
        );

        gp.add_point(
            gp_point(&golden::GP_X[7]),
            golden::GP_Y[7] as f32,
            WhenFull::Refuse,
        )
        .unwrap();
        assert!(gp.len() == 8);
        check_predictions(&gp, &golden::GP_PRED_8);
        let lml = gp.log_marginal_likelihood().unwrap() as f64;
        assert!(
            close(lml, golden::GP_LML[1], 1e-3, 1e-5),
            "lml {} vs {}",
            lml,
            golden::GP_LML[1]
        );
    }

    /// The bounded search never ends below its own starting point (spec §4.2's initial
    /// hyperparameters), stays in the box, and bad input leaves the GP unchanged.
    #[test]
    fn gp_search_improves_and_bad_input_is_a_typed_error() {
        let mut x = [[0.0f32; 3]; 8];
        let mut y = [0.0f32; 8];
        for ((xi, yi), (p, v)) in x
            .iter_mut()
            .zip(y.iter_mut())
            .zip(golden::GP_X.iter().zip(golden::GP_Y.iter()))
        {
            *xi = gp_point(p);
            *yi = *v as f32;
        }
        let mut gp = Gp::<f32, 8, 3>::empty();
        gp.fit(&x, &y).unwrap();
        let start = gp.log_marginal_likelihood().unwrap();
        let bounds = HyperparameterBounds::spec_default();
        let options = SearchOptions {
            max_evaluations: 60,
            restarts: 1,
            isotropic: true,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let best = gp
            .optimize_hyperparameters(&bounds, &options, &mut rng)
            .unwrap();
        assert!(
            best >= start - 1e-3 && best.is_finite(),
            "search {} < start {}",
            best,
            start
        );
        assert!(bounds.contains(gp.hyperparameters()));

        let before = *gp.hyperparameters();
        assert!(
            gp.add_point([1.0, 2.0, 3.0], 0.0, WhenFull::Refuse)
                == Err(Error::CapacityExceeded { capacity: 8 })
        );
        assert!(
            gp.add_point([f32::NAN, 2.0, 3.0], 0.0, WhenFull::DropOldest)
                == Err(Error::NonFinite { parameter: "x" })
        );
        assert!(gp.fit(&x[..0], &y[..0]) == Err(Error::EmptyData));
        let mut bad = before;
        bad.length_scales[1] = 0.0;
        assert!(
            gp.set_hyperparameters(bad)
                == Err(Error::InvalidParameter {
                    parameter: "length_scales"
                })
        );
        assert!(*gp.hyperparameters() == before && gp.len() == 8 && gp.inputs() == &x[..]);
        assert!(gp.predict(&[0.0, f32::INFINITY, 0.0]) == Err(Error::NonFinite { parameter: "x" }));
    }

    /// Draws from the caller's generator: categorical never picks a zero weight, uniform_in
    /// stays in its interval, and invalid parameters are typed errors.
    #[test]
    fn random_draws_respect_their_supports() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let weights = [0.0f32, 3.0, 0.0, 1.0];
        let mut counts = [0u32; 4];
        for _ in 0..400 {
            counts[awfqi::rng::categorical(&mut rng, &weights).unwrap()] += 1;
        }
        assert!(counts[0] == 0 && counts[2] == 0 && counts[1] > counts[3] && counts[3] > 0);
        for _ in 0..100 {
            let u = awfqi::rng::uniform_in(&mut rng, -2.0f32, 3.0).unwrap();
            assert!((-2.0..3.0).contains(&u));
        }
        assert!(awfqi::rng::categorical::<f32, _>(&mut rng, &[]) == Err(Error::EmptyData));
        assert!(awfqi::rng::normal(&mut rng, 0.0f32, -1.0).is_err());
        assert!(
            EpsilonGreedyPolicy::new(|_: &[f32; 2]| awfqi::Result::Ok(0usize), 1.5f32, 4).is_err()
        );
    }

    /// The footprint images' GP workload runs to completion on the target (a footprint of
    /// code that fails would mean nothing) and gives a finite result.
    #[test]
    fn footprint_gp_workload_runs() {
        let mut gp = Gp::<f32, 16, 3>::empty();
        let total = awfqi_on_target::workloads::gp_reward_model(&mut gp, 7).unwrap();
        assert!(total.is_finite() && gp.len() == 16, "total {}", total);
    }
}
