//! Transition records as Gaussian-process regression data (spec §4.2, §6, §7.2).
//!
//! Every GP of the method regresses one output of a record — the reward, or one next-state
//! coordinate — on the state-action vector `z = (s, a)`: the `D` state coordinates followed
//! by the action index as a plain real coordinate (§1; Puddle World's `z = (s_x, s_y, a)`).
//! So a GP over records with `D`-dimensional states has input dimension `I = D + 1`; stable
//! Rust cannot write `D + 1` in a type, so the functions here take both and check
//! `I == D + 1` at compile time. A GP of fixed capacity `N` holds at most `N` records, so a
//! [`SubsetRule`] picks which ones when a dataset is larger: the reference keeps the **last**
//! `max_gp` records; with the small capacities of a microcontroller, **spread** (every
//! `len/N`-th record) keeps every part of the dataset represented instead.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::gp::{
    Conditioning, Gp, HyperparameterBounds, Hyperparameters, SearchOptions, Searched, WhenFull,
};
use crate::model::Transition;
use crate::weights::{NoiseSubtraction, Posterior, StdTransform};
use rand_core::Rng;

/// A state dimension `D` paired with a GP input dimension `I`: it implements
/// [`StatePlusAction`] exactly when `I = D + 1`, so an entry point bounded by
/// `Dims<D, I>: StatePlusAction` refuses a wrong pair at `cargo check` (error E0277), before
/// anything is built.
///
/// ```compile_fail,E0277
/// // A 2-D plant's GP input is (s₀, s₁, a): I = 3, not 4.
/// type Wrong = awfqi::thesis::AwfqiStorage<f32, 2, 4, 16, 20, 40, 42, 20>;
/// let storage = Wrong::new();
/// ```
///
/// ```
/// type Right = awfqi::thesis::AwfqiStorage<f32, 2, 3, 16, 20, 40, 42, 20>;
/// let storage = Right::new();
/// ```
///
/// The free functions that pair records with GP inputs carry the same bound:
///
/// ```compile_fail,E0277
/// let z: [f32; 4] = awfqi::record_gp::input([0.5, 0.5], 1);
/// ```
///
/// ```
/// let z: [f32; 3] = awfqi::record_gp::input([0.5, 0.5], 1);
/// assert_eq!(z, [0.5, 0.5, 1.0]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dims<const D: usize, const I: usize>;

mod sealed {
    pub trait Sealed {}
}

/// Implemented by [`Dims<D, I>`](Dims) for `I = D + 1`, `1 ≤ D ≤ 32`: the GP input is the
/// `D` state coordinates followed by the action. Sealed.
#[diagnostic::on_unimplemented(
    message = "the GP input dimension I must be the state dimension D plus one (the action): \
               `{Self}` is not `Dims<D, D + 1>`",
    label = "I ≠ D + 1 here",
    note = "a plant with states `[T; D]` uses GP inputs `[T; D + 1]`: e.g. D = 2, I = 3"
)]
pub trait StatePlusAction: sealed::Sealed {}

macro_rules! state_plus_action {
    ($($d:literal => $i:literal),* $(,)?) => {$(
        impl sealed::Sealed for Dims<$d, $i> {}
        impl StatePlusAction for Dims<$d, $i> {}
    )*};
}

state_plus_action!(
    1 => 2, 2 => 3, 3 => 4, 4 => 5, 5 => 6, 6 => 7, 7 => 8, 8 => 9, 9 => 10, 10 => 11,
    11 => 12, 12 => 13, 13 => 14, 14 => 15, 15 => 16, 16 => 17, 17 => 18, 18 => 19,
    19 => 20, 20 => 21, 21 => 22, 22 => 23, 23 => 24, 24 => 25, 25 => 26, 26 => 27,
    27 => 28, 28 => 29, 29 => 30, 30 => 31, 31 => 32, 32 => 33,
);

/// Fails to compile unless `I == D + 1` (the GP input is the state followed by the action).
/// Referenced from every function that pairs `D`-dimensional records with `I`-dimensional
/// GP inputs, so a wrong pair of parameters is a compile error, never a runtime one.
pub(crate) struct InputDim<const D: usize, const I: usize>;

impl<const D: usize, const I: usize> InputDim<D, I> {
    pub(crate) const CHECK: () = assert!(
        D > 0 && I == D + 1,
        "the GP input dimension I must be the state dimension D plus one (the action)"
    );
}

/// The GP input `z = (s₀, …, s_{D−1}, a)` of a state-action pair (`I = D + 1`, checked at
/// compile time).
pub fn input<T: Real, const D: usize, const I: usize>(state: [T; D], action: usize) -> [T; I]
where
    Dims<D, I>: StatePlusAction,
{
    let () = InputDim::<D, I>::CHECK;
    let mut z = [T::from_usize(action); I];
    for (zi, &si) in z.iter_mut().zip(&state) {
        *zi = si;
    }
    z
}

/// Which output of a record a GP regresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Output {
    /// The observed reward `r`.
    Reward,
    /// Coordinate `k` of the observed next state, `s′_k` (Puddle World: 0 is `x`, 1 is `y`).
    NextState(usize),
}

impl Output {
    /// This output of `record`.
    ///
    /// Errors: [`Output::NextState`] with `k ≥ D` ([`Error::OutOfRange`] `output`).
    pub fn of<T: Real, const D: usize>(self, record: &Transition<[T; D], T>) -> Result<T> {
        match self {
            Output::Reward => Ok(record.reward),
            Output::NextState(k) => record.next_state.get(k).copied().ok_or(Error::OutOfRange {
                parameter: "output",
            }),
        }
    }
}

/// Which records a GP of capacity `N` is fitted on when a dataset has more than `N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SubsetRule {
    /// The last `N` records (the reference's `max_gp` rule, §4.2): in AWFQI, the most
    /// recent queries.
    Last,
    /// `N` records evenly spread over the dataset: record `⌊i·len/N⌋` for `i < N`, so every
    /// step's queries (or every episode of a source) stay represented. Deterministic.
    Spread,
}

impl SubsetRule {
    /// The indices of the records kept from a dataset of `len` records for capacity
    /// `capacity`, in increasing order (all of them when `len ≤ capacity`).
    pub fn indices(self, len: usize, capacity: usize) -> impl Iterator<Item = usize> + Clone {
        let kept = len.min(capacity);
        (0..kept).map(move |i| match self {
            SubsetRule::Last => len - kept + i,
            // i·len/kept < len, computed in u128 so it cannot overflow.
            SubsetRule::Spread => (i as u128 * len as u128)
                .checked_div(kept as u128)
                .unwrap_or(0) as usize,
        })
    }
}

/// How a GP with `I`-dimensional inputs is trained (§4.2): the starting hyperparameters, the
/// search box, the search budget and the conditioning policy. Size: about `2I + 8` `T`, 3
/// `usize` and a byte.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GpTraining<T, const I: usize> {
    /// Hyperparameters the GP is reset to before the data are loaded and the search starts.
    pub initial: Hyperparameters<T, I>,
    /// Box of the hyperparameter search.
    pub bounds: HyperparameterBounds<T, I>,
    /// Budget and restarts of the search.
    pub search: SearchOptions,
    /// The GP's conditioning policy during this training ([`Conditioning::DEFAULT`]: the
    /// jitter bound and condition limit of the precision). A plant whose outputs carry no
    /// noise (the Dam's reward) may need a looser jitter bound; the caller says so here.
    pub conditioning: Conditioning<T>,
}

impl<T: Real, const I: usize> GpTraining<T, I> {
    /// Spec §4.2: start from `c = ℓ = σ²_n = 1`, its bounds, an isotropic search with 10
    /// restarts (the reference's protocol).
    pub fn published() -> Self {
        Self {
            initial: Hyperparameters::SPEC_INITIAL,
            bounds: HyperparameterBounds::spec_default(),
            search: SearchOptions::default(),
            conditioning: Conditioning::DEFAULT,
        }
    }

    /// Checks the initial hyperparameters, the bounds and the search options.
    ///
    /// Errors: those of [`Hyperparameters::validate`], [`HyperparameterBounds::validate`]
    /// and [`SearchOptions::validate`].
    pub fn validate(&self) -> Result<()> {
        self.initial.validate()?;
        self.bounds.validate()?;
        self.search.validate()
    }
}

/// Fits `gp` from scratch on `output` of the records of `records` chosen by `subset`: resets
/// it to `training.initial`, loads the records (O(n²) each) and searches the
/// hyperparameters. Returns the log marginal likelihood reached.
///
/// Errors: no records ([`Error::EmptyData`]); an `output` the records do not have
/// ([`Error::OutOfRange`] `output`), checked before the GP changes; those of
/// [`Gp::set_hyperparameters`], [`Gp::add_point`] (a non-finite record) and
/// [`Gp::optimize_hyperparameters`]. On error the GP may hold part of the subset; refit it
/// before use.
pub fn fit_gp<T: Real, R: Rng + ?Sized, const N: usize, const D: usize, const I: usize>(
    gp: &mut Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    output: Output,
    subset: SubsetRule,
    training: &GpTraining<T, I>,
    rng: &mut R,
) -> Result<T>
where
    Dims<D, I>: StatePlusAction,
{
    let () = InputDim::<D, I>::CHECK;
    let Some(first) = records.first() else {
        return Err(Error::EmptyData);
    };
    output.of(first)?;
    fit_gp_on(gp, records, |r| output.of(r), subset, training, rng)
}

/// [`fit_gp`] on any target of a record, `target(record)` (e.g. a reward minus a prior
/// mean): resets `gp` to `training.initial`, loads the records `subset` keeps with their
/// targets and searches the hyperparameters. Returns the log marginal likelihood reached.
///
/// Errors: no records ([`Error::EmptyData`]); those of `target`, of
/// [`Gp::set_hyperparameters`], [`Gp::add_point`] and [`Gp::optimize_hyperparameters`]. On
/// error the GP may hold part of the subset; refit it before use.
pub fn fit_gp_on<T, R, F, const N: usize, const D: usize, const I: usize>(
    gp: &mut Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    target: F,
    subset: SubsetRule,
    training: &GpTraining<T, I>,
    rng: &mut R,
) -> Result<T>
where
    T: Real,
    R: Rng + ?Sized,
    F: FnMut(&Transition<[T; D], T>) -> Result<T>,
    Dims<D, I>: StatePlusAction,
{
    fit_gp_searched(gp, records, target, subset, training, rng).map(|s| s.lml)
}

/// [`fit_gp_on`], also saying whether the search's optimum was refused by the GP's
/// conditioning policy (a step report counts those fits).
pub(crate) fn fit_gp_searched<T, R, F, const N: usize, const D: usize, const I: usize>(
    gp: &mut Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    mut target: F,
    subset: SubsetRule,
    training: &GpTraining<T, I>,
    rng: &mut R,
) -> Result<Searched<T>>
where
    T: Real,
    R: Rng + ?Sized,
    F: FnMut(&Transition<[T; D], T>) -> Result<T>,
    Dims<D, I>: StatePlusAction,
{
    let () = InputDim::<D, I>::CHECK;
    if records.is_empty() {
        return Err(Error::EmptyData);
    }
    training.search.validate()?;
    training.bounds.validate()?;
    gp.clear();
    gp.set_conditioning(training.conditioning)?;
    gp.set_hyperparameters(training.initial)?;
    for i in subset.indices(records.len(), N) {
        if let Some(r) = records.get(i) {
            gp.add_point(input(r.state, r.action), target(r)?, WhenFull::Refuse)?;
        }
    }
    gp.search(&training.bounds, &training.search, rng)
}

/// Predicts `gp` at every record's `z` and writes the posterior of the mean function into
/// `out`, the predictive variances turned into standard deviations by `noise` with the
/// records as one batch (§6 step 3, §7.2 step 2).
///
/// Two passes over the records when `noise` is [`NoiseSubtraction::Reference`] (the
/// smallest variance first), one otherwise; O(n·N²) in all. Errors: `out` of another length
/// than `records` ([`Error::InvalidParameter`] naming `out`), no records
/// ([`Error::EmptyData`]), those of [`Gp::predict`].
pub fn predict_posteriors<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    noise: NoiseSubtraction,
    out: &mut [Posterior<T>],
) -> Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    if out.len() != records.len() {
        return Err(Error::InvalidParameter { parameter: "out" });
    }
    let mut out = out.iter_mut();
    visit_posteriors(gp, records, noise, |_, posterior| {
        if let Some(o) = out.next() {
            *o = posterior;
        }
        Ok(())
    })
}

/// Calls `visit` with every record and the posterior of the mean function at its `z`, the
/// predictive variances turned into standard deviations by `noise` with the records as one
/// batch (§6 step 3, §7.2 step 2), in the records' order: the one place the stored source
/// posteriors ([`predict_posteriors`]) and the target posteriors of the weights come from.
/// Nothing is stored; `visit`'s first error stops the pass.
///
/// Errors: no records ([`Error::EmptyData`]), those of [`Gp::predict`] and of `visit`.
pub fn visit_posteriors<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    noise: NoiseSubtraction,
    mut visit: impl FnMut(&Transition<[T; D], T>, Posterior<T>) -> Result<()>,
) -> Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    let transform = batch_transform(gp, records, noise)?;
    for r in records {
        let p = gp.predict(&input(r.state, r.action))?;
        visit(r, Posterior::new(p.mean, transform.apply(p.noisy_variance)))?;
    }
    Ok(())
}

/// Writes `f(i, record, posterior)` into `out[i]` for every record, the posteriors as
/// [`visit_posteriors`] gives them but with one prediction per record: for
/// [`NoiseSubtraction::Reference`] the batch pass keeps each record's predictive variance in
/// `out[i]`, and the second pass computes only the mean, `Σⱼ k(z, xⱼ) αⱼ` from the GP's
/// mean weights, the same value up to rounding at `O(N·I)` instead of `O(N²)`. For
/// `f32` and `N = 32` that halves the cost of a batch.
///
/// Errors: `out` of another length than `records` ([`Error::InvalidParameter`] naming
/// `out`), no records ([`Error::EmptyData`]), those of [`Gp::predict`], of
/// [`Gp::mean_weights`] and of `f`; `out` may hold variances then.
pub fn map_posteriors<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    noise: NoiseSubtraction,
    out: &mut [T],
    mut f: impl FnMut(usize, &Transition<[T; D], T>, Posterior<T>) -> Result<T>,
) -> Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    if out.len() != records.len() {
        return Err(Error::InvalidParameter { parameter: "out" });
    }
    if records.is_empty() {
        return Err(Error::EmptyData);
    }
    if noise != NoiseSubtraction::Reference {
        let transform = StdTransform::new(noise, gp.hyperparameters().noise_variance, T::ZERO)?;
        for (i, (r, o)) in records.iter().zip(out.iter_mut()).enumerate() {
            let p = gp.predict(&input(r.state, r.action))?;
            *o = f(
                i,
                r,
                Posterior::new(p.mean, transform.apply(p.noisy_variance)),
            )?;
        }
        return Ok(());
    }
    let mut smallest = T::INFINITY;
    for (r, o) in records.iter().zip(out.iter_mut()) {
        let p = gp.predict(&input(r.state, r.action))?;
        smallest = smallest.min(p.noisy_variance);
        *o = p.noisy_variance;
    }
    let hyper = gp.hyperparameters();
    let transform = StdTransform::new(noise, hyper.noise_variance, smallest)?;
    let mut alpha = [T::ZERO; N];
    let n = gp.mean_weights(&mut alpha)?;
    let (points, alpha) = (gp.inputs(), alpha.get(..n).unwrap_or(&[]));
    for (i, (r, o)) in records.iter().zip(out.iter_mut()).enumerate() {
        let z = input(r.state, r.action);
        let mut mean = T::ZERO;
        for (x, &a) in points.iter().zip(alpha) {
            mean += hyper.covariance(&z, x) * a;
        }
        crate::error::ensure_finite(mean, "mean")?;
        *o = f(i, r, Posterior::new(mean, transform.apply(*o)))?;
    }
    Ok(())
}

/// The [`StdTransform`] of `gp`'s predictions at the records' inputs as one batch (a pass of
/// predictions for [`NoiseSubtraction::Reference`], none otherwise).
///
/// Errors: no records ([`Error::EmptyData`]), those of [`Gp::predict`].
pub fn batch_transform<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    noise: NoiseSubtraction,
) -> Result<StdTransform<T>>
where
    Dims<D, I>: StatePlusAction,
{
    if records.is_empty() {
        return Err(Error::EmptyData);
    }
    let mut smallest = T::INFINITY;
    if noise == NoiseSubtraction::Reference {
        for r in records {
            let p = gp.predict(&input(r.state, r.action))?;
            smallest = smallest.min(p.noisy_variance);
        }
    } else {
        smallest = T::ZERO;
    }
    StdTransform::new(noise, gp.hyperparameters().noise_variance, smallest)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::weights::predictive_stds;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn inputs_are_the_state_then_the_action_and_outputs_name_a_coordinate() {
        assert_eq!(input::<f64, 2, 3>([1.5, -2.0], 3), [1.5, -2.0, 3.0]);
        assert_eq!(
            input::<f32, 4, 5>([1.0, 2.0, 3.0, 4.0], 1),
            [1.0, 2.0, 3.0, 4.0, 1.0]
        );
        let r = Transition {
            state: [0.0f64; 4],
            action: 0,
            reward: -1.0,
            next_state: [1.0, 2.0, 3.0, 4.0],
            absorbing: false,
        };
        assert_eq!(Output::Reward.of(&r), Ok(-1.0));
        assert_eq!(Output::NextState(3).of(&r), Ok(4.0));
        assert_eq!(
            Output::NextState(4).of(&r),
            Err(Error::OutOfRange {
                parameter: "output"
            })
        );
        // fit_gp refuses such an output before it touches the GP.
        let mut gp = Gp::<f64, 4, 5>::new(Hyperparameters::isotropic(2.0, 1.0, 0.1)).unwrap();
        gp.fit(&[[0.0; 5]], &[1.0]).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let e = fit_gp(
            &mut gp,
            &[r],
            Output::NextState(4),
            SubsetRule::Last,
            &GpTraining::published(),
            &mut rng,
        );
        assert_eq!(
            e,
            Err(Error::OutOfRange {
                parameter: "output"
            })
        );
        assert_eq!(gp.len(), 1);
    }

    #[test]
    fn subset_rules_pick_the_documented_records() {
        let last: Vec<_> = SubsetRule::Last.indices(10, 4).collect();
        assert_eq!(last, vec![6, 7, 8, 9]);
        let spread: Vec<_> = SubsetRule::Spread.indices(10, 4).collect();
        // ⌊i·10/4⌋ = 0, 2, 5, 7.
        assert_eq!(spread, vec![0, 2, 5, 7]);
        let all: Vec<_> = SubsetRule::Spread.indices(3, 4).collect();
        assert_eq!(all, vec![0, 1, 2]);
        assert_eq!(SubsetRule::Last.indices(0, 4).count(), 0);
        let big: Vec<_> = SubsetRule::Spread.indices(usize::MAX, 2).collect();
        assert_eq!(big, vec![0, usize::MAX / 2]);
    }

    fn records(n: usize) -> Vec<Transition<[f64; 2], f64>> {
        (0..n)
            .map(|i| {
                let x = i as f64 * 0.37 % 10.0;
                let y = i as f64 * 0.71 % 10.0;
                Transition {
                    state: [x, y],
                    action: i % 4,
                    reward: -1.0 - 0.1 * x,
                    next_state: [x + 1.0, y],
                    absorbing: false,
                }
            })
            .collect()
    }

    #[test]
    fn fit_gp_loads_the_subset_and_learns_the_trend() {
        let data = records(40);
        let mut gp = Gp::<f64, 16, 3>::empty();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let training = GpTraining {
            search: SearchOptions {
                max_evaluations: 200,
                restarts: 3,
                isotropic: true,
            },
            ..GpTraining::published()
        };
        fit_gp(
            &mut gp,
            &data,
            Output::Reward,
            SubsetRule::Spread,
            &training,
            &mut rng,
        )
        .unwrap();
        assert_eq!(gp.len(), 16);
        let want: Vec<[f64; 3]> = SubsetRule::Spread
            .indices(40, 16)
            .map(|i| input(data[i].state, data[i].action))
            .collect();
        assert_eq!(gp.inputs(), &want[..]);
        // r = −1 − 0.1x is smooth: a held-out record is predicted within 0.2.
        let held_out = &data[1];
        let p = gp.predict(&input(held_out.state, held_out.action)).unwrap();
        assert!((p.mean - held_out.reward).abs() < 0.2, "{}", p.mean);

        fit_gp(
            &mut gp,
            &data,
            Output::NextState(0),
            SubsetRule::Last,
            &training,
            &mut rng,
        )
        .unwrap();
        assert_eq!(gp.targets()[15], data[39].next_state[0]);
        assert_eq!(
            fit_gp(
                &mut gp,
                &[] as &[Transition<[f64; 2], f64>],
                Output::NextState(0),
                SubsetRule::Last,
                &training,
                &mut rng
            ),
            Err(Error::EmptyData)
        );
    }

    #[test]
    fn posteriors_apply_noise_subtraction_over_the_batch() {
        let data = records(12);
        let mut gp = Gp::<f64, 16, 3>::new(Hyperparameters::isotropic(2.0, 1.5, 0.05)).unwrap();
        let xs: Vec<[f64; 3]> = data.iter().map(|r| input(r.state, r.action)).collect();
        let ys: Vec<f64> = data.iter().map(|r| r.reward).collect();
        gp.fit(&xs, &ys).unwrap();
        let batch = &data[3..9];
        for mode in [
            NoiseSubtraction::Reference,
            NoiseSubtraction::Principled,
            NoiseSubtraction::Off,
        ] {
            let mut out = vec![Posterior::default(); batch.len()];
            predict_posteriors(&gp, batch, mode, &mut out).unwrap();
            // Independent route: collect the variances, then the slice rule of `weights`.
            let mut stds: Vec<f64> = batch
                .iter()
                .map(|r| {
                    gp.predict(&input(r.state, r.action))
                        .unwrap()
                        .noisy_variance
                })
                .collect();
            predictive_stds(mode, 0.05, &mut stds).unwrap();
            for ((o, s), r) in out.iter().zip(&stds).zip(batch) {
                assert!((o.std - s).abs() < 1e-12);
                let mean = gp.predict(&input(r.state, r.action)).unwrap().mean;
                assert_eq!(o.mean, mean);
            }
        }
        let mut short = vec![Posterior::default(); 2];
        assert!(predict_posteriors(&gp, batch, NoiseSubtraction::Off, &mut short).is_err());
    }

    #[test]
    fn mapped_posteriors_are_the_visited_ones_with_one_prediction_each() {
        let data = records(12);
        let mut gp = Gp::<f64, 16, 3>::new(Hyperparameters::isotropic(2.0, 1.5, 0.05)).unwrap();
        let xs: Vec<[f64; 3]> = data.iter().map(|r| input(r.state, r.action)).collect();
        let ys: Vec<f64> = data.iter().map(|r| r.reward).collect();
        gp.fit(&xs, &ys).unwrap();
        let batch = &data[2..10];
        for mode in [
            NoiseSubtraction::Reference,
            NoiseSubtraction::Principled,
            NoiseSubtraction::Off,
        ] {
            let mut expected = vec![Posterior::default(); batch.len()];
            predict_posteriors(&gp, batch, mode, &mut expected).unwrap();
            let mut seen = Vec::new();
            let mut out = vec![0.0; batch.len()];
            map_posteriors(&gp, batch, mode, &mut out, |i, r, p| {
                seen.push((i, r.reward, p));
                Ok(p.mean + 10.0 * p.std)
            })
            .unwrap();
            for (i, (e, r)) in expected.iter().zip(batch).enumerate() {
                let (j, reward, p) = seen[i];
                assert_eq!((j, reward), (i, r.reward));
                assert!((p.mean - e.mean).abs() < 1e-10 * (1.0 + e.mean.abs()));
                assert_eq!(p.std, e.std);
                assert_eq!(out[i], p.mean + 10.0 * p.std);
            }
        }
        let mut short = vec![0.0; 2];
        let ok = |_: usize, _: &Transition<[f64; 2], f64>, _| Ok(0.0);
        assert_eq!(
            map_posteriors(&gp, batch, NoiseSubtraction::Off, &mut short, ok),
            Err(Error::InvalidParameter { parameter: "out" })
        );
        assert_eq!(
            map_posteriors(&gp, &[], NoiseSubtraction::Off, &mut [], ok),
            Err(Error::EmptyData)
        );
        let fail = |_: usize, _: &Transition<[f64; 2], f64>, _| Err(Error::EmptyData);
        let mut out = vec![0.0; batch.len()];
        assert_eq!(
            map_posteriors(&gp, batch, NoiseSubtraction::Reference, &mut out, fail),
            Err(Error::EmptyData)
        );
    }
}
