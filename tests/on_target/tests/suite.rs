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

/// State `c` of the 4-state chain of the FQI tests: the centre of cell `c` of [0, 5].
fn chain_state(c: usize) -> [f32; 1] {
    [c as f32 + 0.5]
}

/// The chain's 8 samples: from each state, action 0 steps right for reward −1 (the
/// step out of state 3 is absorbing), action 1 steps left (clipped at state 0).
fn chain_samples() -> [awfqi::model::Transition<[f32; 1], f32>; 8] {
    use awfqi::model::Transition;
    let mut samples = [Transition::<[f32; 1], f32>::EMPTY; 8];
    for c in 0..4 {
        samples[2 * c] = Transition {
            state: chain_state(c),
            action: 0,
            reward: -1.0,
            next_state: chain_state(c + 1),
            absorbing: c == 3,
        };
        samples[2 * c + 1] = Transition {
            state: chain_state(c),
            action: 1,
            reward: -1.0,
            next_state: chain_state(c.saturating_sub(1)),
            absorbing: false,
        };
    }
    samples
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

/// A 1-D plant for the transition-weight test: `x ∈ [0, 10]`, action 0 moves right by
/// `shift`, action 1 left (clipped), next-state noise of std 0.1; reward `−|x − 5|/5` from
/// the state alone, so sources differ from the target only in their dynamics.
#[derive(Clone, Copy)]
struct Shift(f32);

impl Shift {
    fn mean_next(&self, x: f32, action: usize) -> f32 {
        let step = if action == 0 { self.0 } else { -self.0 };
        (x + step).clamp(0.0, 10.0)
    }
}

impl awfqi::model::SourceModel<f32, 1> for Shift {
    fn predict(&self, s: [f32; 1], a: usize) -> awfqi::Result<awfqi::model::SourceMeans<f32, 1>> {
        Ok(awfqi::model::SourceMeans {
            reward: -libm::fabsf(s[0] - 5.0) / 5.0,
            next_state: [self.mean_next(s[0], a)],
        })
    }
}

impl awfqi::model::GenerativeModel<f32> for Shift {
    type State = [f32; 1];

    fn num_actions(&self) -> usize {
        2
    }

    fn query<R: rand_core::Rng + ?Sized>(
        &self,
        s: [f32; 1],
        a: usize,
        rng: &mut R,
    ) -> awfqi::Result<awfqi::model::Transition<[f32; 1], f32>> {
        let next = self.mean_next(s[0], a) + awfqi::rng::normal(rng, 0.0, 0.1)?;
        Ok(awfqi::model::Transition {
            state: s,
            action: a,
            reward: -libm::fabsf(s[0] - 5.0) / 5.0 + awfqi::rng::normal(rng, 0.0, 0.1)?,
            next_state: [next.clamp(0.0, 10.0)],
            absorbing: false,
        })
    }
}

#[defmt_test::tests]
mod tests {
    use super::{check_predictions, gp_hyper, gp_point, instance};
    use awfqi::Error;
    use awfqi::env::{Dynamics, EpisodeRecord, GridWorld, PuddleWorld};
    use awfqi::gp::{Gp, HyperparameterBounds, SearchOptions, WhenFull};
    use awfqi::model::{FiniteMdp, GenerativeModel};
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

    /// The IWFQI paper's Acrobot steps and Dam means in f32 against the published
    /// definitions evaluated on the host in f64.
    #[test]
    fn iwfqi_domains_match_host_f64() {
        use awfqi::env::{Acrobot, Dam};
        for (&(k, s, a), &(reward, next)) in golden::ACROBOT_CASES
            .iter()
            .zip(golden::ACROBOT_EXPECTED.iter())
        {
            let env = match k {
                0 => Acrobot::<f32>::target(),
                k => Acrobot::<f32>::sources()[k - 1],
            };
            let t = env.step(s.map(|x| x as f32), a).unwrap();
            assert!(close(t.reward as f64, reward, 1e-5, 1e-5), "r {}", t.reward);
            for (got, want) in t.next_state.iter().zip(next.iter()) {
                assert!(
                    close(*got as f64, *want, 1e-4, 1e-4),
                    "s′ {} vs {}",
                    got,
                    want
                );
            }
        }
        for (&(k, s, a), &(reward, mean)) in
            golden::DAM_CASES.iter().zip(golden::DAM_EXPECTED.iter())
        {
            let env = match k {
                0 => Dam::<f32>::target(),
                k => Dam::<f32>::sources()[k - 1],
            };
            let s = s.map(|x| x as f32);
            let r = env.mean_reward(s, a).unwrap();
            assert!(close(r as f64, reward, 1e-4, 1e-6), "r {}", r);
            let m = env.mean_next_state(s, a).unwrap();
            assert!(
                close(m[0] as f64, mean, 1e-3, 1e-6),
                "s′ {} vs {}",
                m[0],
                mean
            );
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
        assert!(rollout.absorbed == records[n - 1].transition.absorbing);

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

    /// The AWFQI loop for a small budget on the target (f32): 6 × 6 cells, a 16-point GP,
    /// 100 score rows, 2 steps of 20 queries, sources of 2 episodes. Checks the step report
    /// against the run's own sizes and that every output is finite and in range.
    #[test]
    fn awfqi_loop_small_budget() {
        use awfqi_on_target::workloads::{KernelRun, KernelStorage, awfqi_puddle};
        static mut STORAGE: KernelStorage<300, 100, 144, 40, 16> = KernelStorage::new();
        // SAFETY: the only reference.
        let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
        let run = KernelRun {
            cells: 6,
            spacing: 2.5,
            budget: 20,
            steps: 2,
            episodes: 2,
            search: (40, 1),
        };
        // Every drawn query lies on the score grid (spacing 2.5) with a valid action.
        let mut on_grid = false;
        let (report, evaluation) = awfqi_puddle(storage, run, 3, |samples| {
            on_grid = samples.len() == 40
                && samples.iter().all(|t| {
                    t.state
                        .iter()
                        .all(|&c| c % 2.5 == 0.0 && (0.0..=10.0).contains(&c))
                        && t.action < 4
                        && t.reward.is_finite()
                });
        })
        .unwrap();
        assert!(on_grid);
        assert!(
            report.step == 2 && report.n_target_samples == 40,
            "step {} samples {}",
            report.step,
            report.n_target_samples
        );
        assert!(report.n_source_samples > 0 && report.n_source_samples <= 300);
        assert!(report.gp_points == 16 && report.gp_log_likelihood.is_finite());
        assert!(report.wr_mean.is_finite() && report.wr_mean >= 0.0);
        let total = (report.n_target_samples + report.n_source_samples) as f32;
        assert!(
            report.wr_eff > 0.0 && report.wr_eff <= total * 1.0001,
            "ess {}",
            report.wr_eff
        );
        assert!(evaluation.mean_return.is_finite() && evaluation.mean_return <= 0.0);
        assert!(
            evaluation.mean_steps >= 1.0
                && evaluation.mean_steps <= 50.0
                && evaluation.absorbed <= 5
        );
    }

    /// The 32 KiB configuration's workload on the target: the builder over the flash
    /// tables (1033 published records, 324 score rows), 6 steps of 50 queries, a 24-point
    /// GP, and a finite, bounded evaluation.
    #[test]
    fn awfqi_puddle_32k_runs() {
        use awfqi_on_target::workloads::{Storage32k, awfqi_puddle_32k};
        static mut STORAGE: Storage32k = Storage32k::new();
        // SAFETY: the only reference.
        let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
        let (report, evaluation) = awfqi_puddle_32k(storage, 5).unwrap();
        assert!(report.step == 6 && report.n_target_samples == 300);
        assert!(report.n_source_samples == 1033 && report.gp_points == 24);
        assert!(report.wr_eff > 0.0 && report.wr_eff <= 1333.0 * 1.0001);
        assert!(evaluation.mean_return.is_finite() && evaluation.mean_return <= 0.0);
        assert!(evaluation.mean_steps >= 1.0 && evaluation.mean_steps <= 50.0);
    }

    /// Adaptive AWFQI on the target (f32) over the published sources in flash, small: a
    /// 16-point GP, 60 candidates, 6 × 6 tiles × 2 tilings, 2 steps of 12 queries, short
    /// searches, relabelling on. Checks the run's sizes, the verification rollouts (each sub-batch of 4
    /// starts with 3 verified queries from (0, 0)), the beliefs (a distribution), the
    /// relabelled source rewards and that every output is finite and in range.
    #[test]
    fn adaptive_awfqi_on_the_published_sources() {
        use awfqi_on_target::workloads::{AdaptiveQ, AdaptiveRun, adaptive_puddle};
        awfqi::adaptive_storage! {
            struct Memory {
                scalar: f32,
                state_dim: 2,
                actions: 4,
                gp_points: 16,
                steps: 2,
                budget: 12,
                sources: 3,
                source_records: 1033,
                source_posteriors: 0,
                candidates: 60,
                table_entries: 392,
            }
        }
        static mut MEMORY: Memory = Memory::new();
        // SAFETY: the only reference.
        let memory = unsafe { &mut *core::ptr::addr_of_mut!(MEMORY) };
        let run = AdaptiveRun {
            budget: 12,
            steps: 2,
            candidates: 60,
            q: AdaptiveQ::Tiles(6, 2),
            search: Some((40, 1)),
            relabel: true,
            refit: None,
        };
        let mut checked = false;
        let fqi = awfqi::fqi::QStorage::default();
        let (report, evaluation) = adaptive_puddle(memory, fqi, run, 4, |kernel| {
            let d0 = kernel.target_samples();
            // The schedule rule at 12 queries a step: one sub-batch (under 16 queries),
            // round(0.7 · 12) = 8 verified from the one start, so each step's 12 samples
            // begin at the start and the path holds 8 states.
            let starts = d0.chunks(12).all(|b| b[0].state == [0.0, 0.0]);
            let finite = d0.iter().all(|t| {
                t.reward.is_finite() && t.action < 4 && t.state.iter().all(|x| x.is_finite())
            });
            let total: f32 = kernel.beliefs().iter().map(|b| b.plausibility).sum();
            // Relabelling: no weights, one finite reward per source record.
            let relabelled = kernel.relabelled_rewards();
            let weights = kernel.reward_weights().is_empty()
                && relabelled.len() == 1033
                && relabelled.iter().all(|y| y.is_finite());
            checked = d0.len() == 24
                && starts
                && finite
                && (total - 1.0).abs() < 1e-5
                && weights
                && kernel.path().len() == 8;
        })
        .unwrap();
        assert!(checked);
        assert!(report.step == 2 && report.n_target_samples == 24);
        assert!(report.n_source_samples == 1033 && report.gp_points == 16);
        assert!(report.wr_eff > 0.0 && report.wr_eff <= 1057.0 * 1.0001);
        assert!(evaluation.mean_return.is_finite() && evaluation.mean_return <= 0.0);
        assert!(evaluation.mean_steps >= 1.0 && evaluation.mean_steps <= 50.0);
    }

    /// Adaptive AWFQI on the target with streamed Extra-Trees FQI (f32), small: as above
    /// with 4 streamed trees per action in a 511-node scratch tree (one record slot per
    /// target and source record), reward weights instead of relabelling. Checks the run's
    /// sizes, that every weight and the evaluation are finite, and that the greedy policy
    /// of the final trees (grown along each query's path) acts.
    #[test]
    fn adaptive_awfqi_with_streamed_trees() {
        use awfqi_on_target::workloads::{AdaptiveQ, AdaptiveRun, adaptive_puddle};
        awfqi::adaptive_storage! {
            struct Memory {
                scalar: f32,
                state_dim: 2,
                actions: 4,
                gp_points: 16,
                steps: 2,
                budget: 12,
                sources: 3,
                source_records: 1033,
                source_posteriors: 0,
                candidates: 60,
                table_entries: 0,
            }
        }
        static mut MEMORY: Memory = Memory::new();
        static mut TREES: awfqi::fqi::TreeStorage<f32, 2, 1057, 511> =
            awfqi::fqi::TreeStorage::new();
        // SAFETY: the only references.
        let memory = unsafe { &mut *core::ptr::addr_of_mut!(MEMORY) };
        let trees = unsafe { &mut *core::ptr::addr_of_mut!(TREES) };
        let run = AdaptiveRun {
            budget: 12,
            steps: 2,
            candidates: 60,
            q: AdaptiveQ::Trees(4, 511),
            search: Some((40, 1)),
            relabel: false,
            refit: None,
        };
        let mut checked = false;
        let (report, evaluation) = adaptive_puddle(memory, trees.storage(), run, 4, |kernel| {
            let weights = kernel.reward_weights();
            let action = kernel.q().greedy_action([0.0, 0.0]);
            checked = kernel.target_samples().len() == 24
                && weights.len() == 1033
                && weights.iter().all(|w| w.is_finite() && *w >= 0.0)
                && matches!(action, Ok(a) if a < 4)
                && kernel
                    .q()
                    .max_value([5.0, 5.0])
                    .is_ok_and(|v| v.is_finite());
        })
        .unwrap();
        assert!(checked);
        assert!(report.step == 2 && report.n_target_samples == 24);
        assert!(evaluation.mean_return.is_finite() && evaluation.mean_return <= 0.0);
        assert!(evaluation.mean_steps >= 1.0 && evaluation.mean_steps <= 50.0);
    }

    /// The 4-D loop on the target: the greedy policy is the closed-form optimum in more
    /// than half of the cells where that is known (110 of 132 measured).
    #[test]
    fn awfqi_4d_runs() {
        use awfqi_on_target::workloads::{Storage4d, awfqi_4d};
        static mut STORAGE: Storage4d = Storage4d::new();
        // SAFETY: the only reference.
        let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
        let (checked, optimal) = awfqi_4d(storage, 2026).unwrap();
        assert!(
            checked > 100 && 2 * optimal > checked,
            "{} of {}",
            optimal,
            checked
        );
    }

    /// Spec §7.3's golden weights (both estimators), the ESS example and §7.7's ideal weight,
    /// in f32.
    #[test]
    fn weights_match_spec_golden_values() {
        use awfqi::weights::{
            Estimator, Posterior, WeightParams, effective_sample_size, ideal_weight,
        };
        // y, μt, σt, μs, σs, v, mean, heuristic
        const TABLE: [[f64; 8]; 5] = [
            [
                -1.0,
                -1.2,
                0.1,
                -1.0,
                0.05,
                0.1,
                0.805079404153,
                0.804827777517,
            ],
            [
                -1.3,
                -1.0,
                0.2,
                -1.25,
                0.03,
                0.1,
                0.623422515078,
                0.623257005989,
            ],
            [
                -5.0,
                -1.0,
                0.05,
                -5.1,
                0.04,
                0.1,
                1.33061875955e-34,
                1.32832086981e-34,
            ],
            [
                2.3,
                2.0,
                0.1,
                2.2,
                0.02,
                0.2,
                0.808455457025,
                0.808372998447,
            ],
            [0.0, 0.0, 0.1, 0.0, 0.4, 0.1, 0.0, 1.53741222957],
        ];
        for row in TABLE.iter() {
            let f = |i: usize| row[i] as f32;
            let (t, s) = (Posterior::new(f(1), f(2)), Posterior::new(f(3), f(4)));
            for (estimator, expected) in [(Estimator::Mean, row[6]), (Estimator::Heuristic, row[7])]
            {
                let params = WeightParams::new(estimator, f(5), 1000.0).unwrap();
                let w = params.weight(f(0), t, s).unwrap() as f64;
                assert!(
                    close(w, expected, 0.0, 2e-4),
                    "weight {} vs {}",
                    w,
                    expected
                );
            }
        }
        let ess = effective_sample_size(&[1.0f32, 1.0, 0.5, 0.0, 2.0]).unwrap();
        assert!(close(ess as f64, 3.24, 0.0, 1e-6), "ess {}", ess);
        let w = ideal_weight(-1.05f32, -1.0, -1.2, 0.01).unwrap();
        assert!(
            close(w as f64, core::f64::consts::E, 0.0, 2e-5),
            "ideal {}",
            w
        );
    }

    /// Oracle score table over the three sources on the 3 × 3 puddle grid (spacing 5):
    /// `V_r` at (0, 0) and (5, 5) from spec §2.7's mean rewards, `V_x = V_y = 0` (shared
    /// dynamics), and draws whose frequencies follow `V_r / Σ V_r` (never a zero row).
    #[test]
    fn score_table_and_draws() {
        use awfqi::alias::AliasEntry;
        use awfqi::score::{RowSet, ScoreColumn, ScoreTable, Scores};
        let worlds = PuddleWorld::<f32>::sources(Dynamics::Shared);
        let rows = RowSet::grid(PuddleWorld::score_grid(5.0).unwrap(), 4).unwrap();
        assert!(rows.len() == 36);
        let mut storage = [Scores::<f32, 2>::ZERO; 36];
        let table = ScoreTable::compute(rows, &worlds, &mut storage).unwrap();
        let variance = |v: [f64; 3]| {
            let m = (v[0] + v[1] + v[2]) / 3.0;
            v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / 3.0
        };
        let expected_00 = variance([-1.000000, -1.134130, -1.000000]);
        let expected_55 = variance([-12.399667, -6.748596, -12.399726]);
        let mut sum = 0.0f64;
        for r in 0..36 {
            let row = table.row(r).unwrap();
            assert!(
                row.scores.get(ScoreColumn::NextState(0)) == Some(0.0)
                    && row.scores.get(ScoreColumn::NextState(1)) == Some(0.0)
            );
            let v = row.scores.reward as f64;
            if row.state == [0.0, 0.0] {
                assert!(
                    close(v, expected_00, 1e-5, 1e-3),
                    "V_r(0,0) {} vs {}",
                    v,
                    expected_00
                );
            }
            if row.state == [5.0, 5.0] {
                assert!(
                    close(v, expected_55, 1e-4, 1e-4),
                    "V_r(5,5) {} vs {}",
                    v,
                    expected_55
                );
            }
            sum += v;
        }
        let mut alias = [AliasEntry::<f32>::EMPTY; 36];
        let sampler = table.sampler(ScoreColumn::Reward, &mut alias).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut counts = [0u32; 36];
        const DRAWS: u32 = 4000;
        for _ in 0..DRAWS {
            let (r, state, action) = sampler.draw(&mut rng);
            assert!(table.rows().row(r) == Some((state, action)));
            counts[r] += 1;
        }
        for r in 0..36 {
            let p = table.row(r).unwrap().scores.reward as f64 / sum;
            let n = DRAWS as f64;
            let sd = libm::sqrt(n * p * (1.0 - p));
            let c = counts[r] as f64;
            assert!(
                (c - n * p).abs() <= 5.0 * sd + 1.0,
                "row {}: {} draws, expected {}",
                r,
                c,
                n * p
            );
            if p == 0.0 {
                assert!(counts[r] == 0);
            }
        }
    }

    /// Weighted FQI on a two-cell chain, hand-computed: target samples c0 → c1 (r = 0) and
    /// c1 absorbing (r = 1); a source sample c0 → c0 with r = −10, reward weight 0.25 and
    /// transition weight 0.5. Then R̂(c0) = (0 + 0.25·(−10))/1.25 = −2 and
    /// Q(c0) = −2 + 0.9·(1·Q(c1) + 0.5·Q(c0))/1.5, whose fixed point is −2; Q(c1) = 1.
    #[test]
    fn weighted_fqi_sweep_on_a_chain() {
        use awfqi::fqi::{CellGrid, EmptyCells, FqiConfig, FqiEntry, SampleSet, TabularFqi};
        use awfqi::model::Transition;
        let t = |s: [f32; 2], r: f32, n: [f32; 2], absorbing: bool| Transition {
            state: s,
            action: 0,
            reward: r,
            next_state: n,
            absorbing,
        };
        let target = [
            t([0.5, 0.5], 0.0, [1.5, 0.5], false),
            t([1.5, 0.5], 1.0, [1.5, 0.5], true),
        ];
        let source = [t([0.5, 0.5], -10.0, [0.5, 0.5], false)];
        let (rw, tw) = ([0.25f32], [0.5f32]);
        let grid = CellGrid::new([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
        let mut storage = [FqiEntry::<f32>::EMPTY; 2];
        let mut fqi = TabularFqi::new(grid, 1, &mut storage).unwrap();
        let config = FqiConfig::new(0.9f32, 40, EmptyCells::Value(0.0))
            .unwrap()
            .with_min_weight(0.0)
            .unwrap();
        let sets = [
            SampleSet::unweighted(&target),
            SampleSet::weighted(&source, Some(&rw), Some(&tw)),
        ];
        fqi.fit(&sets, &config).unwrap();
        let e = fqi.entries();
        assert!(
            close(e[0].reward_model() as f64, -2.0, 1e-6, 1e-6),
            "R̂(c0) {}",
            e[0].reward_model()
        );
        assert!(
            close(e[0].q() as f64, -2.0, 1e-5, 1e-6),
            "Q(c0) {}",
            e[0].q()
        );
        assert!(
            close(e[1].q() as f64, 1.0, 1e-6, 1e-6),
            "Q(c1) {}",
            e[1].q()
        );
        assert!(close(e[0].transition_weight() as f64, 1.5, 1e-6, 0.0));
        assert!(fqi.value([0.2, 0.9], 0) == Ok(e[0].q()) && fqi.greedy_action([1.9, 0.1]) == Ok(0));
        // Bad input leaves the table unchanged.
        let before = [e[0], e[1]];
        let bad = [t([0.5, 0.5], f32::NAN, [1.5, 0.5], false)];
        assert!(matches!(
            fqi.fit(&[SampleSet::unweighted(&bad)], &config),
            Err(Error::NonFinite { .. })
        ));
        assert!(fqi.entries() == &before[..]);
        assert!(fqi.fit(&[], &config) == Err(Error::EmptyData));
    }

    /// Belief updates by hand: from a uniform prior over the four thesis candidates, one
    /// observation at the goal of candidate 0 (reward 1 at state 99, whose mean is 1 under
    /// candidate 0 and 0 under the others, variance 0.25) multiplies candidate 0's odds by
    /// exp((1 − 0)²/(2·0.25)) = e² against each other one. Then the identification workload
    /// (50 adaptive queries) finds the true candidate.
    #[test]
    fn belief_update_and_identification() {
        use awfqi::identify::Belief;
        let candidates = awfqi::env::GridWorld::<f32>::thesis_candidates(false);
        let mut belief = Belief::<f32, 4>::uniform(4).unwrap();
        belief.update(&candidates, 99, 1, 98, 1.0).unwrap();
        let p = belief.probability_array();
        let e2 = libm::exp(2.0);
        let expected0 = e2 / (e2 + 3.0);
        assert!(
            close(p[0] as f64, expected0, 1e-6, 1e-5),
            "p0 {} vs {}",
            p[0],
            expected0
        );
        for &q in &p[1..] {
            assert!(close(q as f64, 1.0 / (e2 + 3.0), 1e-6, 1e-5), "p {}", q);
        }
        assert!(belief.map() == 0 && belief.observations() == 1);
        let before = belief;
        assert!(belief.update(&candidates, 100, 0, 0, 1.0).is_err() && belief == before);
        assert!(belief.update(&candidates, 0, 0, 1, f32::NAN).is_err() && belief == before);

        use awfqi_on_target::workloads::{IdentificationStorage, grid_identification};
        use core::mem::MaybeUninit;
        static mut STORAGE: MaybeUninit<IdentificationStorage> = MaybeUninit::zeroed();
        // SAFETY: the only reference; all-zero bits are valid.
        let storage = unsafe { (*core::ptr::addr_of_mut!(STORAGE)).assume_init_mut() };
        let found = grid_identification(storage, 2, 50, 200, 5).unwrap();
        assert!(
            found.map == 2 && found.map_probability > 0.99,
            "map {} p {}",
            found.map,
            found.map_probability
        );
        // Candidate 2's goal is (0, 9): from state 0 the optimal first move is up (action 2),
        // and the value is γ⁹/(1 − γ) (9 steps up, then reward 1 every step: moving up at the top
        // border stays put).
        let v = libm::pow(0.9, 9.0) / 0.1;
        assert!(
            found.initial_action == 2 && close(found.initial_value as f64, v, 1e-3, 1e-4),
            "v {} vs {}",
            found.initial_value,
            v
        );
    }
    /// Tile coding on a deterministic chain (5 unit cells, right −1 per move, the last move
    /// absorbing; left clipped at 0): two tilings shifted by half a tile hold one chain
    /// state per tile, so Q is the closed-form Q* at the states and, halfway between two
    /// states, the mean of their values.
    #[test]
    fn tile_coding_on_a_chain() {
        use awfqi::prelude::{EmptyCells, FqiConfig, FqiEntry, SampleSet, TileFqi, Tilings};
        let at = super::chain_state;
        let samples = super::chain_samples();
        let tilings = Tilings::<f32, 1>::cube(0.0, 5.0, 5, 2).unwrap();
        let mut storage = [FqiEntry::<f32>::EMPTY; 24];
        let mut fqi = TileFqi::new(tilings, 2, &mut storage).unwrap();
        let config = FqiConfig::new(0.9f32, 80, EmptyCells::Nearest).unwrap();
        fqi.fit(&[SampleSet::unweighted(&samples)], &config)
            .unwrap();
        let v = |c: usize| -(1.0 - libm::pow(0.9, (4 - c) as f64)) / 0.1;
        for c in 0..4 {
            let right = fqi.value(at(c), 0).unwrap();
            assert!(
                close(right as f64, v(c), 1e-5, 1e-5),
                "Q({}, right) {}",
                c,
                right
            );
            assert!(fqi.greedy_action(at(c)) == Ok(0));
        }
        for c in 0..3 {
            let mid = fqi.value([c as f32 + 1.0], 0).unwrap() as f64;
            assert!(close(mid, (v(c) + v(c + 1)) / 2.0, 1e-5, 1e-5), "mid {}", c);
        }
        assert!(fqi.value([f32::NAN], 0).is_err());
    }

    /// Kernel averaging (`KnnFqi`, f32) on the same chain: with one neighbour, every next
    /// state's nearest record of each action is the record at that very state, so FQI is
    /// value iteration and Q is the closed-form Q* at the states and 0.3 past them; a
    /// reach of 0.1 of the range caps an action tried only far away (hand-computed).
    #[test]
    fn knn_q_on_a_chain() {
        use awfqi::prelude::{
            EmptyCells, FqiConfig, Kernel, KnnFqi, KnnRecord, Neighbours, SampleSet, Transition,
        };
        let at = super::chain_state;
        let samples = super::chain_samples();
        let nb = Neighbours::<f32, 1>::cube(1, 0.0, 5.0, Kernel::Uniform).unwrap();
        let mut records = [KnnRecord::<f32, 1>::EMPTY; 8];
        let mut links = [0u16; 16];
        let mut fqi = KnnFqi::new(nb, 2, &mut records, &mut links).unwrap();
        let config = FqiConfig::new(0.9f32, 80, EmptyCells::Nearest).unwrap();
        fqi.fit(&[SampleSet::unweighted(&samples)], &config)
            .unwrap();
        let v = |c: usize| -(1.0 - libm::pow(0.9, (4 - c) as f64)) / 0.1;
        for c in 0..4 {
            let right = fqi.value(at(c), 0).unwrap() as f64;
            assert!(close(right, v(c), 1e-5, 1e-5), "Q({}, right) {}", c, right);
            let past = fqi.value([c as f32 + 0.8], 0).unwrap() as f64;
            assert!(close(past, v(c), 1e-5, 1e-5), "past {}", c);
            let left = fqi.value(at(c), 1).unwrap() as f64;
            assert!(close(left, -1.0 + 0.9 * v(c.saturating_sub(1)), 1e-5, 1e-5));
            assert!(fqi.greedy_action(at(c)) == Ok(0));
        }
        assert!(fqi.value([f32::NAN], 0).is_err());
        // Action 1 tried only at 4.5 (reward +10): copied to 0.5 without a reach, capped at
        // action 0's −1 with reach 0.1 (0.5 units).
        let far = [
            Transition {
                state: [0.5],
                action: 0,
                reward: -1.0,
                next_state: [0.5],
                absorbing: true,
            },
            Transition {
                state: [4.5],
                action: 1,
                reward: 10.0,
                next_state: [4.5],
                absorbing: true,
            },
        ];
        let mut records = [KnnRecord::<f32, 1>::EMPTY; 2];
        let mut links = [0u16; 4];
        let capped = nb.with_reach(0.1).unwrap();
        let mut fqi = KnnFqi::new(capped, 2, &mut records, &mut links).unwrap();
        fqi.fit(&[SampleSet::unweighted(&far)], &config).unwrap();
        assert!(fqi.value([0.5], 1) == Ok(-1.0));
        assert!(fqi.greedy_action([0.5]) == Ok(0));
        assert!(fqi.value([4.5], 1) == Ok(10.0));
    }

    /// Extra-Trees Q on the target (f32), stored and streamed: on the 5-cell chain fully
    /// grown trees put each state's records in leaves of their own value, so FQI is value
    /// iteration and Q is the closed-form Q* at the states.
    #[test]
    fn trees_q_on_a_chain() {
        use awfqi::prelude::{
            EmptyCells, ExtraTrees, FqiConfig, SampleSet, TreeFqi, TreeNode, TreeRecord,
        };
        use rand_chacha::ChaCha8Rng;
        use rand_core::SeedableRng;
        let at = super::chain_state;
        let samples = super::chain_samples();
        let config = FqiConfig::new(0.9f32, 80, EmptyCells::Nearest).unwrap();
        let v = |c: usize| -(1.0 - libm::pow(0.9, (4 - c) as f64)) / 0.1;
        for forests in [
            ExtraTrees::new(5, 15).unwrap(),
            ExtraTrees::streamed(5, 15).unwrap(),
        ] {
            let mut records = [TreeRecord::<f32, 1>::EMPTY; 8];
            let mut nodes = [TreeNode::<f32>::EMPTY; 2 * 5 * 15];
            let mut fqi = TreeFqi::new(forests, 2, &mut records, &mut nodes).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            fqi.fit(&[SampleSet::unweighted(&samples)], &config, &mut rng)
                .unwrap();
            for c in 0..4 {
                let right = fqi.value(at(c), 0).unwrap() as f64;
                assert!(close(right, v(c), 1e-5, 1e-5), "Q({}, right) {}", c, right);
                let left = fqi.value(at(c), 1).unwrap() as f64;
                assert!(close(left, -1.0 + 0.9 * v(c.saturating_sub(1)), 1e-5, 1e-5));
                assert!(fqi.greedy_action(at(c)) == Ok(0));
            }
            assert!(fqi.value([f32::NAN], 0).is_err());
        }
    }

    /// A model sweep on the target (f32): on the 5-state chain the records lie on the nodes,
    /// so the sweep is value iteration and Q is the closed-form Q* at the states, and the
    /// greedy action between two states is the interpolated one.
    #[test]
    fn sweep_q_on_a_chain() {
        use awfqi::prelude::{
            EmptyCells, FqiConfig, ModelSweep, RewardModel, SampleSet, SweepEntry, SweepFqi,
            SweepNode,
        };
        let at = super::chain_state;
        let samples = super::chain_samples();
        let config = FqiConfig::new(0.9f32, 80, EmptyCells::Nearest).unwrap();
        let v = |c: usize| -(1.0 - libm::pow(0.9, (4 - c) as f64)) / 0.1;
        for rewards in [RewardModel::PerAction, RewardModel::Pooled] {
            let sweep = ModelSweep::cube(0.5f32, 4.5, 4)
                .unwrap()
                .with_rewards(rewards);
            let mut entries = [SweepEntry::<f32, 1>::EMPTY; 5 * 2];
            let mut nodes = [SweepNode::<f32>::EMPTY; 5];
            let mut fqi = SweepFqi::new(sweep, 2, &mut entries, &mut nodes).unwrap();
            fqi.fit(&[SampleSet::unweighted(&samples)], &config)
                .unwrap();
            for c in 0..4 {
                let right = fqi.value(at(c), 0).unwrap() as f64;
                assert!(close(right, v(c), 1e-5, 1e-5), "Q({}, right) {}", c, right);
                let left = fqi.value(at(c), 1).unwrap() as f64;
                assert!(close(left, -1.0 + 0.9 * v(c.saturating_sub(1)), 1e-5, 1e-5));
                assert!(fqi.greedy_action(at(c)) == Ok(0));
            }
            let middle = fqi.value([1.0], 0).unwrap() as f64;
            assert!(close(middle, (v(0) + v(1)) / 2.0, 1e-5, 1e-5));
            assert!(fqi.value([f32::NAN], 0).is_err());
        }
    }

    /// A model sweep on anchors (f32): on a 5-state chain whose last state is absorbing,
    /// with one neighbour, every record state is a node and nothing else, so the sweep is
    /// value iteration on them and Q is the closed-form Q* at the states; a state between
    /// two nodes reads the nearer one.
    #[test]
    fn anchor_sweep_q_on_a_chain() {
        use awfqi::prelude::{
            AnchorEntry, AnchorFqi, AnchorParts, AnchorSweep, EmptyCells, FqiConfig, SampleSet,
            SweepNode, Transition,
        };
        let mut samples = [Transition::<[f32; 1], f32>::EMPTY; 10];
        for c in 0..5 {
            let right = (c + 1).min(4);
            samples[2 * c] = Transition {
                state: [c as f32],
                action: 0,
                reward: -1.0,
                next_state: [right as f32],
                absorbing: right == 4,
            };
            samples[2 * c + 1] = Transition {
                state: [c as f32],
                action: 1,
                reward: -1.0,
                next_state: [c.saturating_sub(1) as f32],
                absorbing: false,
            };
        }
        let config = FqiConfig::new(0.9f32, 60, EmptyCells::Nearest).unwrap();
        let v = |c: usize| -(1.0 - libm::pow(0.9, (4 - c) as f64)) / 0.1;
        let anchors = AnchorSweep::new([0.0f32], [4.0], 8)
            .unwrap()
            .with_neighbours(1)
            .unwrap();
        let mut entries = [AnchorEntry::<f32>::EMPTY; 8 * 2];
        let mut nodes = [SweepNode::<f32>::EMPTY; 8];
        let mut positions = [[0.0f32; 1]; 8];
        let mut landings = [[0.0f32; 1]; 8];
        let parts = AnchorParts {
            entries: &mut entries,
            nodes: &mut nodes,
            positions: &mut positions,
            landings: &mut landings,
        };
        let mut fqi = AnchorFqi::new(anchors, 2, parts).unwrap();
        fqi.fit(&[SampleSet::unweighted(&samples)], &config)
            .unwrap();
        assert!(fqi.placed() == 5);
        for c in 0..4 {
            let right = fqi.value([c as f32], 0).unwrap() as f64;
            assert!(close(right, v(c), 1e-5, 1e-5), "Q({}, right) {}", c, right);
            assert!(fqi.greedy_action([c as f32]) == Ok(0));
        }
        assert!(fqi.value([1.4], 0) == fqi.value([1.0], 0));
        assert!(fqi.value([f32::NAN], 0).is_err());
    }

    /// Adaptive AWFQI on the target with FQI by a model sweep (f32), small: as
    /// `adaptive_awfqi_with_streamed_trees` with a 6 × 6-cell sweep of pooled rewards and
    /// warm refits. Checks the run's sizes, the weights, and that the greedy policy acts.
    #[test]
    fn adaptive_awfqi_with_a_model_sweep() {
        use awfqi_on_target::workloads::{AdaptiveQ, AdaptiveRun, adaptive_puddle};
        awfqi::adaptive_storage! {
            struct Memory {
                scalar: f32,
                state_dim: 2,
                actions: 4,
                gp_points: 16,
                steps: 2,
                budget: 12,
                sources: 3,
                source_records: 1033,
                source_posteriors: 0,
                candidates: 60,
                table_entries: 0,
            }
        }
        static mut MEMORY: Memory = Memory::new();
        static mut SWEEP: awfqi::fqi::SweepStorage<f32, 2, { 49 * 4 }, 49> =
            awfqi::fqi::SweepStorage::new();
        // SAFETY: the only references.
        let memory = unsafe { &mut *core::ptr::addr_of_mut!(MEMORY) };
        let sweep = unsafe { &mut *core::ptr::addr_of_mut!(SWEEP) };
        let run = AdaptiveRun {
            budget: 12,
            steps: 2,
            candidates: 60,
            q: AdaptiveQ::Sweep(6, awfqi::fqi::RewardModel::Pooled, 0.0),
            search: Some((40, 1)),
            relabel: false,
            refit: Some((10, 0)),
        };
        let mut checked = false;
        let (report, evaluation) = adaptive_puddle(memory, sweep.storage(), run, 4, |kernel| {
            let weights = kernel.reward_weights();
            let action = kernel.q().greedy_action([0.0, 0.0]);
            checked = kernel.target_samples().len() == 24
                && weights.len() == 1033
                && weights.iter().all(|w| w.is_finite() && *w >= 0.0)
                && matches!(action, Ok(a) if a < 4)
                && kernel
                    .q()
                    .max_value([5.0, 5.0])
                    .is_ok_and(|v| v.is_finite() && v <= 0.0);
        })
        .unwrap();
        assert!(checked);
        assert!(report.step == 2 && report.n_target_samples == 24);
        assert!(evaluation.mean_return.is_finite() && evaluation.mean_return <= 0.0);
        assert!(evaluation.mean_steps >= 1.0 && evaluation.mean_steps <= 50.0);
    }

    /// Transition weights in the loop, on a 1-D plant whose two sources share the target's
    /// reward: the twin (same dynamics) keeps far more weight than the source whose moves
    /// are 2.5 instead of 1, the report's `ws_mean` is theirs, and FQI used them (an
    /// independent fit with the same weights gives the same table).
    #[test]
    fn transition_weights_in_the_loop() {
        use crate::Shift;
        use awfqi::prelude::{
            Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, FqiEntry, GenerativeModel, PointGrid,
            Posterior, RowSet, SampleSet, Scores, SourceModel, TabularFqi, Transition,
            WeightParams,
        };
        use rand_chacha::ChaCha8Rng;
        use rand_core::{Rng, SeedableRng};
        const PER: usize = 24;
        static mut STORAGE: AwfqiStorage<f32, 1, 2, 24, 24, 48, 20, 20> = AwfqiStorage::new();
        // SAFETY: the only reference.
        let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let models = [Shift(1.0), Shift(2.5)];
        let mut data = [[Transition::<[f32; 1], f32>::EMPTY; PER]; 2];
        let mut reward = [Posterior::<f32>::default(); 2 * PER];
        let mut transition = [Posterior::<f32>::default(); 2 * PER];
        for (j, m) in models.iter().enumerate() {
            for i in 0..PER {
                let x = (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32 * 10.0;
                let r = m.query([x], i % 2, &mut rng).unwrap();
                let mean = m.predict(r.state, r.action).unwrap();
                reward[j * PER + i] = Posterior::new(mean.reward, 0.0);
                transition[j * PER + i] = Posterior::new(mean.next_state[0], 0.0);
                data[j][i] = r;
            }
        }
        let slices: [&[Transition<[f32; 1], f32>]; 2] = [&data[0], &data[1]];
        let mut config = AwfqiConfig::thesis(24);
        config.gp_training.search.max_evaluations = 80;
        config.gp_training.search.restarts = 1;
        let config = config.validate().unwrap();
        let lattice = PointGrid::new([0.25f32], [0.5], [10]).unwrap();
        let mut scores = [Scores::<f32, 1>::ZERO; 20];
        let mut ws = [0.0f32; 2 * PER];
        let grid = CellGrid::cube(0.0f32, 10.0, 10).unwrap();
        let mut kernel = Awfqi::builder(config, grid, &slices, RowSet::grid(lattice, 2).unwrap())
            .stored_posteriors(&reward)
            .scores_from(&models, &mut scores)
            .unwrap()
            .transition_weights(WeightParams::reference_transition(), &transition, &mut ws)
            .build(Shift(1.0), storage, &mut rng)
            .unwrap();
        let report = kernel.step(&mut rng).unwrap();
        let w = kernel.transition_weights();
        let twin: f32 = w[..PER].iter().sum();
        let other: f32 = w[PER..].iter().sum();
        assert!(twin > 5.0 * other, "twin {} other {}", twin, other);
        let mean = (24.0 + twin + other) / (24 + 2 * PER) as f32;
        assert!(
            close(report.ws_mean as f64, mean as f64, 1e-4, 1e-6),
            "ws_mean {}",
            report.ws_mean
        );
        let wr = kernel.reward_weights();
        let sets = [
            SampleSet::unweighted(kernel.target_samples()),
            SampleSet::weighted(&data[0], Some(&wr[..PER]), Some(&w[..PER])),
            SampleSet::weighted(&data[1], Some(&wr[PER..]), Some(&w[PER..])),
        ];
        let mut entries = [FqiEntry::<f32>::EMPTY; 20];
        let mut table = TabularFqi::new(grid, 2, &mut entries).unwrap();
        table.fit(&sets, &config.fqi).unwrap();
        assert!(kernel.q().entries() == table.entries());
    }
}
