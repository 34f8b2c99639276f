//! Finite-MDP identification: `Belief::uniform`/`from_weights`/`update`/`observe` and
//! `log_likelihood` with arbitrary likelihood inputs — candidate models whose transition
//! probabilities, reward means and variances come from the fuzzer (NaN, negative, zero and
//! huge included) next to the thesis Grid World candidates — then `compute_score` (uniform,
//! variance, mutual information) on the resulting belief and `draw_pair(s)` from the score.
//!
//! Invariants: no panic; after a success the belief is a distribution (log-probabilities
//! ≤ 0, not NaN, `probabilities` sum to 1, finite entropy ≥ 0, MAP in range); an update that
//! fails leaves the belief unchanged (documented); scores are finite and ≥ 0; a drawn pair
//! is in range; errors are only the documented kinds.
#![no_main]

use awfqi::env::GridWorld;
use awfqi::identify::{
    Belief, Criterion, MiConfig, RewardEntropy, compute_score, draw_pair, draw_pairs,
    log_likelihood,
};
use awfqi::model::{FiniteMdp, Transition};
use awfqi::{Error, Result, prelude::Real};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, trace};
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

const STATES: usize = 3;
const ACTIONS: usize = 2;

/// A 3-state, 2-action model whose numbers come straight from the fuzzer.
#[derive(Debug, Clone)]
struct Fuzzed {
    /// p(s′ | s, a) at `[s][a][s′]`.
    p: [[[f64; STATES]; ACTIONS]; STATES],
    mean: [[f64; ACTIONS]; STATES],
    variance: [[f64; ACTIONS]; STATES],
}

fn get<const N: usize>(row: &[f64; N], i: usize, name: &'static str) -> Result<f64> {
    row.get(i)
        .copied()
        .ok_or(Error::OutOfRange { parameter: name })
}

impl FiniteMdp<f64> for Fuzzed {
    fn num_states(&self) -> usize {
        STATES
    }
    fn num_actions(&self) -> usize {
        ACTIONS
    }
    fn initial_state(&self) -> usize {
        0
    }
    fn transition_probability(&self, s: usize, a: usize, next: usize) -> Result<f64> {
        let row = self
            .p
            .get(s)
            .and_then(|r| r.get(a))
            .ok_or(Error::OutOfRange { parameter: "state" })?;
        get(row, next, "next_state")
    }
    fn for_each_successor<F: FnMut(usize, f64)>(
        &self,
        s: usize,
        a: usize,
        mut visit: F,
    ) -> Result<()> {
        let row = self
            .p
            .get(s)
            .and_then(|r| r.get(a))
            .ok_or(Error::OutOfRange { parameter: "state" })?;
        for (n, &p) in row.iter().enumerate() {
            if p != 0.0 {
                visit(n, p);
            }
        }
        Ok(())
    }
    fn reward_mean(&self, s: usize, a: usize) -> Result<f64> {
        get(
            self.mean
                .get(s)
                .ok_or(Error::OutOfRange { parameter: "state" })?,
            a,
            "action",
        )
    }
    fn reward_variance(&self, s: usize, a: usize) -> Result<f64> {
        get(
            self.variance
                .get(s)
                .ok_or(Error::OutOfRange { parameter: "state" })?,
            a,
            "action",
        )
    }
}

fn fuzzed(b: &mut Bytes) -> Fuzzed {
    let mut m = Fuzzed {
        p: [[[0.0; STATES]; ACTIONS]; STATES],
        mean: [[0.0; ACTIONS]; STATES],
        variance: [[0.25; ACTIONS]; STATES],
    };
    let raw = b.bool();
    for s in 0..STATES {
        for a in 0..ACTIONS {
            if raw {
                for n in 0..STATES {
                    m.p[s][a][n] = b.num();
                }
            } else {
                m.p[s][a][b.index(STATES)] = 1.0;
            }
            m.mean[s][a] = b.num();
            m.variance[s][a] = if b.bool() { b.num() } else { 0.25 };
        }
    }
    m
}

/// The documented invariants of a belief.
fn check_belief<T: Real, const K: usize>(belief: &Belief<T, K>) {
    let n = belief.len();
    assert!(n >= 1 && n <= K);
    for &l in belief.log_probabilities() {
        let l = l.to_f64();
        assert!(!l.is_nan() && l <= 1e-4, "log-probability {l}");
    }
    let mut p = [T::ZERO; K];
    belief
        .probabilities(&mut p[..n])
        .expect("room for every candidate");
    let total: f64 = p[..n].iter().map(|x| x.to_f64()).sum();
    assert!((total - 1.0).abs() < 1e-3, "probabilities sum to {total}");
    assert!(belief.map() < n);
    let h = belief.entropy().to_f64();
    finite("entropy", "h", h);
    assert!(h >= -1e-4, "entropy {h}");
}

fn run(b: &mut Bytes) {
    let grid_candidates = b.bool();
    let mut belief = if b.bool() {
        let weights: Vec<f64> = (0..b.index(6)).map(|_| b.num()).collect();
        trace!("Belief::from_weights({weights:?})");
        match Belief::<f64, 4>::from_weights(&weights) {
            Ok(b) => b,
            Err(e) => {
                expect_kind(
                    "from_weights",
                    &e,
                    &[Kind::Empty, Kind::Capacity, Kind::NonFinite, Kind::Invalid],
                );
                return;
            }
        }
    } else {
        match Belief::<f64, 4>::uniform(b.index(6)) {
            Ok(b) => b,
            Err(e) => {
                expect_kind("uniform", &e, &[Kind::Empty, Kind::Capacity]);
                return;
            }
        }
    };
    check_belief(&belief);
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u8()));
    if grid_candidates {
        let candidates = GridWorld::<f64>::thesis_candidates(b.bool());
        let k = belief.len().min(4);
        let cands = &candidates[..if b.u8() == 0xff { (k + 1) % 5 } else { k }];
        for _ in 0..6 {
            let (s, a, n) = (b.index(110), b.index(5), b.index(110));
            let r = b.num();
            let before = belief;
            trace!("update(grid, {s}, {a}, {n}, {r})");
            match belief.update(cands, s, a, n, r) {
                Ok(()) => check_belief(&belief),
                Err(e) => {
                    expect_kind(
                        "update",
                        &e,
                        &[Kind::Invalid, Kind::OutOfRange, Kind::NonFinite],
                    );
                    assert!(belief == before, "a failed update changed the belief");
                }
            }
            let t = Transition {
                state: s,
                action: a,
                reward: r,
                next_state: n,
                absorbing: false,
            };
            let before = belief;
            if belief.observe(cands, &t).is_err() {
                assert!(belief == before);
            }
        }
        scores(b, cands, &belief, &mut rng, 100, 4);
    } else {
        let candidates: Vec<Fuzzed> = (0..belief.len()).map(|_| fuzzed(b)).collect();
        for c in &candidates {
            let (s, a, n) = (b.index(4), b.index(3), b.index(4));
            match log_likelihood(c, s, a, n, b.num()) {
                Ok(l) => assert!(!l.is_nan() && l != f64::INFINITY, "log-likelihood {l}"),
                Err(e) => expect_kind(
                    "log_likelihood",
                    &e,
                    &[Kind::OutOfRange, Kind::NonFinite, Kind::Invalid],
                ),
            }
        }
        for _ in 0..6 {
            let (s, a, n) = (b.index(4), b.index(3), b.index(4));
            let r = b.num();
            let before = belief;
            trace!("update({candidates:?}, {s}, {a}, {n}, {r})");
            match belief.update(&candidates, s, a, n, r) {
                Ok(()) => check_belief(&belief),
                Err(e) => {
                    expect_kind(
                        "update",
                        &e,
                        &[Kind::Invalid, Kind::OutOfRange, Kind::NonFinite],
                    );
                    assert!(belief == before, "a failed update changed the belief");
                }
            }
        }
        scores(b, &candidates, &belief, &mut rng, STATES, ACTIONS);
    }
    belief.reset();
    check_belief(&belief);
    assert_eq!(belief.observations(), 0);
}

fn scores<M: FiniteMdp<f64>>(
    b: &mut Bytes,
    candidates: &[M],
    belief: &Belief<f64, 4>,
    rng: &mut ChaCha8Rng,
    states: usize,
    actions: usize,
) {
    let criterion = match b.u8() % 3 {
        0 => Criterion::Uniform,
        1 => Criterion::Variance,
        _ => Criterion::MutualInformation(MiConfig {
            samples: b.index(20),
            bins: b.index(140),
            reward_entropy: if b.bool() {
                RewardEntropy::Differential
            } else {
                RewardEntropy::Literal
            },
            skip_identical_rewards: b.bool(),
        }),
    };
    let mut weights = [0.0; 4];
    let n = belief.len();
    belief.probabilities(&mut weights[..n]).expect("room");
    let mut out = vec![0.0; states * actions + if b.u8() == 0xff { 1 } else { 0 }];
    trace!("compute_score({criterion:?})");
    match compute_score(&criterion, candidates, &weights[..n], rng, &mut out) {
        Ok(()) => {
            for &s in &out {
                finite("compute_score", "score", s);
                assert!(s >= -1e-9, "negative score {s}");
            }
            match draw_pair(&out, actions, rng) {
                Ok(p) => assert!(p.state < states && p.action < actions),
                Err(e) => expect_kind(
                    "draw_pair",
                    &e,
                    &[Kind::Empty, Kind::Invalid, Kind::NonFinite],
                ),
            }
            let mut pairs = [awfqi::identify::StateAction {
                state: 0,
                action: 0,
            }; 4];
            if draw_pairs(&out, actions, rng, &mut pairs).is_ok() {
                assert!(pairs.iter().all(|p| p.state < states && p.action < actions));
            }
        }
        Err(e) => expect_kind(
            "compute_score",
            &e,
            &[
                Kind::Empty,
                Kind::Invalid,
                Kind::NonFinite,
                Kind::OutOfRange,
                Kind::Capacity,
            ],
        ),
    }
}

fuzz_target!(|data: &[u8]| {
    run(&mut Bytes::new(data));
});
