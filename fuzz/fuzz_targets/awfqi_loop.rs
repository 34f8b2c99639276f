//! The AWFQI set-up and loop through the public builder, at state dimension 2 (Puddle World,
//! its sources as oracle models) and 4 (a toy plant), in f32 and f64: `AwfqiConfig`
//! (budget, GP search, subset rule, noise subtraction, FQI settings, sampling column) and
//! its `validate`, source records and posteriors from the fuzzer (NaN, ±∞ and huge values
//! included), candidate rows (grid, pairs or source rows), every posterior and score stage
//! (stored, fitted, oracle, realistic), buffers of every size (one short of what is needed
//! too), then steps and `reset`; with bits 2–3 of the first byte, tile coding instead of
//! the table and transition weights (stored next-state posteriors from the fuzzer).
//!
//! Invariants: no panic; errors only of the documented kinds; a built kernel's step reports
//! finite diagnostics, its Q-values stay finite, and a failed step leaves the step count
//! and the Q-function as they were.
#![no_main]

use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::{
    Error,
    prelude::{
        AliasEntry, Approximator, Awfqi, AwfqiBuffers, AwfqiConfig, CellGrid, EmptyCells,
        FqiConfig, FqiEntry, GenerativeModel, Gp, NoiseSubtraction, PointGrid, Posterior, Real,
        RowSet, ScoreColumn, Scores, SourceMeans, SourceModel, SubsetRule, Tilings, Transition,
        WeightParams,
    },
};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, kind, trace};
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// Capacity of the GP.
const N: usize = 8;

/// Every kind: the builder and a step document all of them (a fit can fail to factorise).
const ANY: &[Kind] = &[
    Kind::Empty,
    Kind::Capacity,
    Kind::NonFinite,
    Kind::OutOfRange,
    Kind::Invalid,
    Kind::Overflow,
    Kind::NotPd,
    Kind::Conditioning,
];

fn real<T: Real>(b: &mut Bytes) -> T {
    T::from_f64(b.num())
}

/// A 4-D plant: action 0 moves every coordinate by −0.5, action 1 by +0.5 in [−1, 1]⁴;
/// reward −(Σ s′ − c)²/4.
#[derive(Debug, Clone, Copy)]
struct Toy<T> {
    c: T,
}

impl<T: Real> SourceModel<T, 4> for Toy<T> {
    fn predict(&self, state: [T; 4], action: usize) -> awfqi::Result<SourceMeans<T, 4>> {
        if action > 1 {
            return Err(Error::OutOfRange {
                parameter: "action",
            });
        }
        let mut sum = T::ZERO;
        for &x in &state {
            if !x.is_finite() {
                return Err(Error::NonFinite { parameter: "state" });
            }
            if x.abs() > T::ONE {
                return Err(Error::OutOfRange { parameter: "state" });
            }
        }
        let step = T::from_f64(if action == 0 { -0.5 } else { 0.5 });
        let next_state = state.map(|x| (x + step).clamp_to(-T::ONE, T::ONE));
        for &x in &next_state {
            sum += x;
        }
        Ok(SourceMeans {
            reward: -(sum - self.c).squared() / T::from_f64(4.0),
            next_state,
        })
    }
}

impl<T: Real> GenerativeModel<T> for Toy<T> {
    type State = [T; 4];

    fn num_actions(&self) -> usize {
        2
    }

    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; 4],
        action: usize,
        rng: &mut R,
    ) -> awfqi::Result<Transition<[T; 4], T>> {
        let mean = self.predict(state, action)?;
        Ok(Transition {
            state,
            action,
            reward: awfqi::rng::normal(rng, mean.reward, T::from_f64(0.05))?,
            next_state: mean.next_state,
            absorbing: false,
        })
    }
}

/// The plant and its sources at one dimension: the box `[low, high]^D` they accept.
struct Plant<G, const D: usize> {
    target: G,
    sources: [G; 3],
    low: f64,
    high: f64,
}

/// Sizes: `needed` or, when the fuzzer says so, one less (an error the builder must catch
/// before anything is fitted) or a few more.
fn size(b: &mut Bytes, needed: usize) -> usize {
    match b.u8() % 8 {
        0 => needed.saturating_sub(1),
        1 => needed + 3,
        _ => needed,
    }
}

/// Options chosen by bits 2–3 of the first byte (so the seeds written before them, whose
/// first byte is below 4, keep their meaning): tile coding instead of the table, and
/// transition weights.
#[derive(Debug, Clone, Copy)]
struct Options {
    tiles: bool,
    transitions: bool,
}

fn run<T: Real, G, const D: usize, const I: usize>(
    b: &mut Bytes,
    plant: Plant<G, D>,
    options: Options,
) where
    G: GenerativeModel<T, State = [T; D]> + SourceModel<T, D> + Copy + core::fmt::Debug,
    awfqi::record_gp::Dims<D, I>: awfqi::record_gp::StatePlusAction,
{
    // Configuration.
    let mut config = AwfqiConfig::<T, I>::thesis(b.index(9));
    config.gp_training.search.max_evaluations = b.index(25);
    config.gp_training.search.restarts = b.index(3);
    if b.bool() {
        config.gp_training.initial.noise_variance = real(b);
    }
    config.subset = if b.bool() {
        SubsetRule::Spread
    } else {
        SubsetRule::Last
    };
    config.noise_subtraction = match b.u8() % 3 {
        0 => NoiseSubtraction::Reference,
        1 => NoiseSubtraction::Principled,
        _ => NoiseSubtraction::Off,
    };
    let empty = match b.u8() % 3 {
        0 => EmptyCells::Nearest,
        1 => EmptyCells::CappedNearest,
        _ => EmptyCells::Value(real(b)),
    };
    let discount = real::<T>(b);
    let iterations = 1 + b.index(8);
    match FqiConfig::new(discount, iterations, empty)
        .and_then(|c| c.with_min_weight(T::from_f64(0.5)))
    {
        Ok(c) => config.fqi = c,
        Err(e) => {
            expect_kind(
                "FqiConfig::new",
                &e,
                &[Kind::NonFinite, Kind::OutOfRange, Kind::Invalid],
            );
            // The published settings (γ = 0.99, capped nearest, minimum weight 0.5) with the
            // fuzzed iteration count instead of their 60: the same loop body, run at most 8
            // times (the 60 iterations of `FqiConfig::published` took most of the target's
            // time on every input whose fuzzed FQI settings were refused).
            config.fqi = FqiConfig::new(T::from_f64(0.99), iterations, EmptyCells::CappedNearest)
                .and_then(|c| c.with_min_weight(T::from_f64(0.5)))
                .expect("the published FQI settings");
        }
    }
    config.sampling = match b.u8() % 3 {
        0 => ScoreColumn::Reward,
        1 => ScoreColumn::Total,
        _ => ScoreColumn::NextState(b.index(D + 2)),
    };
    trace!("{config:?}");
    let config = match config.validate() {
        Ok(c) => c,
        Err(e) => {
            expect_kind(
                "AwfqiConfig::validate",
                &e,
                &[Kind::Invalid, Kind::NonFinite, Kind::OutOfRange],
            );
            return;
        }
    };

    // Source records: near-valid states with fuzzed rewards (and sometimes anything at all).
    let (low, high) = (plant.low, plant.high);
    let state = |b: &mut Bytes| -> [T; D] {
        core::array::from_fn(|_| match b.u8() {
            0xff => real(b),
            v => T::from_f64(low + (high - low) * f64::from(v) / 254.0),
        })
    };
    let sources: Vec<Vec<Transition<[T; D], T>>> = (0..b.index(4))
        .map(|_| {
            (0..b.index(7))
                .map(|_| Transition {
                    state: state(b),
                    action: b.index(3),
                    reward: real(b),
                    next_state: state(b),
                    absorbing: b.bool(),
                })
                .collect()
        })
        .collect();
    let slices: Vec<&[Transition<[T; D], T>]> = sources.iter().map(Vec::as_slice).collect();
    let total: usize = slices.iter().map(|s| s.len()).sum();
    let actions = plant.target.num_actions();

    // Candidates.
    let pairs: Vec<([T; D], usize)> = (0..1 + b.index(4))
        .map(|_| (state(b), b.index(actions + 1)))
        .collect();
    let spacing = T::from_f64((high - low) / f64::from(1 + b.u8() % 4));
    let grid = PointGrid::spanning([T::from_f64(low); D], [T::from_f64(high); D], spacing);
    let rows = match (b.u8() % 3, grid) {
        (0, Ok(g)) => RowSet::grid(g, actions),
        (1, _) => RowSet::pairs(&pairs),
        _ => RowSet::source_data(&slices),
    };
    let rows = match rows {
        Ok(r) => r,
        Err(e) => {
            expect_kind(
                "RowSet",
                &e,
                &[Kind::Empty, Kind::NonFinite, Kind::Capacity],
            );
            return;
        }
    };
    let cells =
        CellGrid::cube(T::from_f64(low), T::from_f64(high), 1 + b.index(3)).expect("a valid cube");

    // Set-up memory and stages.
    let stored: Vec<Posterior<T>> = (0..size(b, total))
        .map(|_| Posterior::new(real(b), real(b)))
        .collect();
    let mut fitted = vec![Posterior::default(); size(b, total)];
    let stored_scores: Vec<Scores<T, D>> = (0..size(b, rows.len()))
        .map(|_| Scores {
            reward: real(b),
            next_state: core::array::from_fn(|_| T::ZERO),
        })
        .collect();
    let mut computed = vec![Scores::<T, D>::ZERO; size(b, rows.len())];
    let approximator: Approximator<T, D> = if options.tiles {
        match Tilings::cube(T::from_f64(low), T::from_f64(high), b.index(4), b.index(5)) {
            Ok(t) => t.into(),
            Err(e) => {
                expect_kind("Tilings::cube", &e, &[Kind::Invalid]);
                return;
            }
        }
    } else {
        cells.into()
    };
    let transition_posteriors: Vec<Posterior<T>> = if options.transitions {
        (0..size(b, total * D))
            .map(|_| Posterior::new(real(b), real(b)))
            .collect()
    } else {
        Vec::new()
    };
    let mut transition_weights = vec![
        T::ZERO;
        if options.transitions {
            size(b, total)
        } else {
            0
        }
    ];
    let builder = Awfqi::builder(config, approximator, &slices, rows);
    let builder = if options.transitions {
        builder.transition_weights(
            WeightParams::reference_transition(),
            &transition_posteriors,
            &mut transition_weights,
        )
    } else {
        builder
    };
    let builder = match b.u8() % 3 {
        0 => builder.stored_posteriors(&stored),
        1 => builder.fit_posteriors(&mut fitted),
        _ => builder,
    };
    let builder = match b.u8() % 3 {
        0 => Ok(builder.stored_scores(&stored_scores)),
        1 => builder.scores_from(&plant.sources[..b.index(4)], &mut computed),
        _ => Ok(builder.realistic_scores(&mut computed)),
    };
    let builder = match builder {
        Ok(builder) => builder,
        Err(e) => {
            expect_kind(
                "scores_from",
                &e,
                &[
                    Kind::Empty,
                    Kind::Capacity,
                    Kind::NonFinite,
                    Kind::OutOfRange,
                    Kind::Invalid,
                ],
            );
            return;
        }
    };

    // The kernel's memory.
    let steps = 1 + b.index(3);
    let mut gp = Box::new(Gp::<T, N, I>::empty());
    let mut samples = vec![Transition::EMPTY; size(b, steps * config.budget)];
    let mut weights = vec![T::ZERO; size(b, total)];
    let mut alias = vec![AliasEntry::EMPTY; size(b, rows.len())];
    let needed = approximator
        .required_entries(actions)
        .unwrap_or(usize::MAX)
        .min(1 << 16);
    let mut fqi = vec![FqiEntry::EMPTY; size(b, needed)];
    let buffers = AwfqiBuffers {
        gp: &mut gp,
        samples: &mut samples,
        weights: &mut weights,
        alias: &mut alias,
        fqi: &mut fqi,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u8()));
    let mut kernel = match builder.build(plant.target, buffers, &mut rng) {
        Ok(k) => k,
        Err(e) => {
            expect_kind("build", &e, ANY);
            return;
        }
    };
    trace!(
        "built: {} rows, {} source records",
        kernel.sampler().rows().len(),
        total
    );
    for round in 0..2 {
        for _ in 0..steps + 1 {
            let before: Vec<FqiEntry<T>> = kernel.q().entries().to_vec();
            let done = kernel.steps();
            match kernel.step(&mut rng) {
                Ok(report) => {
                    trace!("step {}: {report:?}", report.step);
                    assert_eq!(report.step, done + 1);
                    assert_eq!(report.n_target_samples, kernel.target_samples().len());
                    finite("step", "wr_mean", report.wr_mean.to_f64());
                    finite("step", "wr_eff", report.wr_eff.to_f64());
                    assert!(report.wr_mean >= T::ZERO && report.wr_eff >= T::ZERO);
                    for e in kernel.q().entries() {
                        finite("step", "q", e.q().to_f64());
                    }
                    for &w in kernel.reward_weights() {
                        finite("step", "weight", w.to_f64());
                    }
                }
                Err(e) => {
                    trace!("step error {e:?}");
                    expect_kind("step", &e, ANY);
                    assert_eq!(kernel.steps(), done, "a failed step advanced the count");
                    assert!(
                        kernel.q().entries() == &before[..],
                        "a failed step changed Q ({:?})",
                        kind(&e)
                    );
                }
            }
        }
        if round == 0 {
            kernel.reset();
            assert_eq!(kernel.steps(), 0);
            assert!(kernel.target_samples().is_empty());
        }
    }
}

fn puddle<T: Real>(b: &mut Bytes, options: Options) {
    let dynamics = if b.bool() {
        Dynamics::PuddleBased
    } else {
        Dynamics::Shared
    };
    let plant = Plant {
        target: PuddleWorld::<T>::target(dynamics),
        sources: PuddleWorld::sources(dynamics),
        low: 0.0,
        high: 10.0,
    };
    run::<T, _, 2, 3>(b, plant, options);
}

fn toy<T: Real>(b: &mut Bytes, options: Options) {
    let plant = Plant {
        target: Toy { c: T::ZERO },
        sources: [0.0, 1.0, -1.0].map(|c| Toy { c: T::from_f64(c) }),
        low: -1.0,
        high: 1.0,
    };
    run::<T, _, 4, 5>(b, plant, options);
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let first = b.u8();
    let options = Options {
        tiles: first & 4 != 0,
        transitions: first & 8 != 0,
    };
    match first % 4 {
        0 => puddle::<f32>(&mut b, options),
        1 => puddle::<f64>(&mut b, options),
        2 => toy::<f32>(&mut b, options),
        _ => toy::<f64>(&mut b, options),
    }
});
