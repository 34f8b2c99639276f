//! Q-values, states and plants as `nalgebra::SVector`s (feature `nalgebra`).
//!
//! The core's states are arrays `[T; D]`; a controller built on `nalgebra` holds
//! `SVector<T, D>`. These functions take and give its types, with no allocation (an
//! `SVector` lives inline) and typed errors:
//!
//! ```
//! use awfqi::fqi::{Approximator, CellGrid, FqiEntry};
//! use awfqi::interop::nalgebra::{greedy_action, q_values};
//! use nalgebra::{SVector, Vector2};
//!
//! let mut entries = [FqiEntry::<f64>::EMPTY; 4 * 4 * 3]; // 4 × 4 cells, 3 actions
//! let q = Approximator::Table(CellGrid::cube(0.0, 1.0, 4)?).build(3, &mut entries)?;
//! // (a learner's `q()` is such a Q-function, fitted)
//! let state = Vector2::new(0.3, 0.7);
//! let all: SVector<f64, 3> = q_values(&q, &state)?; // Q(state, 0), Q(state, 1), Q(state, 2)
//! let best = greedy_action(&q, &state)?;
//! assert_eq!(all[best], all.max());
//! // A vector whose length is not the number of actions is refused:
//! assert!(q_values::<f64, 2, 4>(&q, &state).is_err());
//! # Ok::<(), awfqi::Error>(())
//! ```

use ::nalgebra::SVector;
use rand_core::Rng;

use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::QFunction;
use crate::model::{GenerativeModel, Transition};

/// The core's state `[T; D]` of a vector.
pub fn to_array<T: Real, const D: usize>(state: &SVector<T, D>) -> [T; D] {
    let [column] = state.data.0;
    column
}

/// The vector of a core state `[T; D]`.
pub fn to_vector<T: Real, const D: usize>(state: [T; D]) -> SVector<T, D> {
    SVector::from(state)
}

/// All Q-values of `state`, one per action: entry `a` is `Q(state, a)`, as
/// [`QFunction::value`] gives it.
///
/// Errors: `A` is not the Q-function's number of actions ([`Error::InvalidParameter`]
/// naming `A`), a non-finite state ([`Error::NonFinite`]).
pub fn q_values<T: Real, const D: usize, const A: usize>(
    q: &QFunction<'_, T, D>,
    state: &SVector<T, D>,
) -> Result<SVector<T, A>> {
    if A != q.actions() {
        return Err(Error::InvalidParameter {
            parameter: "A (the vector's length, which must be the Q-function's actions)",
        });
    }
    let state = to_array(state);
    let mut values = [T::ZERO; A];
    for (action, value) in values.iter_mut().enumerate() {
        *value = q.value(state, action)?;
    }
    Ok(SVector::from(values))
}

/// [`QFunction::greedy_action`] of a vector state.
///
/// Errors: a non-finite state.
pub fn greedy_action<T: Real, const D: usize>(
    q: &QFunction<'_, T, D>,
    state: &SVector<T, D>,
) -> Result<usize> {
    q.greedy_action(to_array(state))
}

/// [`QFunction::value`] of a vector state.
///
/// Errors: a non-finite state, an action `≥ actions`.
pub fn value<T: Real, const D: usize>(
    q: &QFunction<'_, T, D>,
    state: &SVector<T, D>,
    action: usize,
) -> Result<T> {
    q.value(to_array(state), action)
}

/// A plant whose states are `SVector<T, D>` as the plant on `[T; D]` the learners take:
/// each query converts the state in and the next state out, and leaves the rest (reward,
/// absorption, errors, draws from the generator) to the wrapped plant.
///
/// ```
/// use awfqi::interop::nalgebra::VectorPlant;
/// use awfqi::model::{GenerativeModel, Transition};
/// use nalgebra::Vector2;
///
/// /// A point that moves by a fixed step per action.
/// struct Mover;
/// impl GenerativeModel<f32> for Mover {
///     type State = Vector2<f32>;
///     fn num_actions(&self) -> usize { 2 }
///     fn query<R: awfqi::rand_core::Rng + ?Sized>(
///         &self, state: Vector2<f32>, action: usize, _rng: &mut R,
///     ) -> awfqi::Result<Transition<Vector2<f32>, f32>> {
///         let step = if action == 0 { Vector2::new(0.1, 0.0) } else { Vector2::new(0.0, 0.1) };
///         Ok(Transition { state, action, reward: -1.0, next_state: state + step, absorbing: false })
///     }
/// }
///
/// let plant = VectorPlant(Mover); // a `GenerativeModel<f32, State = [f32; 2]>`
/// # use awfqi::rand_core::SeedableRng;
/// # let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
/// let t = plant.query([0.5, 0.5], 1, &mut rng)?;
/// assert_eq!(t.next_state, [0.5, 0.6]);
/// # Ok::<(), awfqi::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct VectorPlant<G>(pub G);

impl<T, G, const D: usize> GenerativeModel<T> for VectorPlant<G>
where
    T: Real,
    G: GenerativeModel<T, State = SVector<T, D>>,
{
    type State = [T; D];

    fn num_actions(&self) -> usize {
        self.0.num_actions()
    }

    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; D],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; D], T>> {
        let t = self.0.query(to_vector(state), action, rng)?;
        Ok(Transition {
            state: to_array(&t.state),
            action: t.action,
            reward: t.reward,
            next_state: to_array(&t.next_state),
            absorbing: t.absorbing,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fqi::{Approximator, CellGrid, FqiConfig, FqiEntry, SampleSet};
    use ::nalgebra::Vector2;

    /// A 4 × 4 table with 3 actions fitted on records whose reward is the action's index
    /// in the cell's left half and minus it in the right half.
    fn fitted(entries: &mut [FqiEntry<f64>; 48]) -> QFunction<'_, f64, 2> {
        let mut records = [Transition::<[f64; 2], f64>::EMPTY; 48];
        for (i, r) in records.iter_mut().enumerate() {
            let (cell, action) = (i / 3, i % 3);
            let state = [
                (cell % 4) as f64 * 0.25 + 0.1,
                (cell / 4) as f64 * 0.25 + 0.1,
            ];
            let sign = if state[0] < 0.5 { 1.0 } else { -1.0 };
            *r = Transition {
                state,
                action,
                reward: sign * action as f64,
                next_state: state,
                absorbing: true,
            };
        }
        let mut q = Approximator::Table(CellGrid::cube(0.0, 1.0, 4).unwrap())
            .build(3, entries)
            .unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        q.fit(
            &[SampleSet::unweighted(&records)],
            &FqiConfig::published(),
            &mut rng,
        )
        .unwrap();
        q
    }

    use rand_core::SeedableRng;

    #[test]
    fn q_values_are_the_per_action_values() {
        let mut entries = [FqiEntry::EMPTY; 48];
        let q = fitted(&mut entries);
        for state in [[0.1, 0.1], [0.35, 0.85], [0.6, 0.4], [0.9, 0.9]] {
            let v: SVector<f64, 3> = q_values(&q, &Vector2::from(state)).unwrap();
            for a in 0..3 {
                assert_eq!(
                    v[a],
                    q.value(state, a).unwrap(),
                    "state {state:?} action {a}"
                );
            }
            let sign = if state[0] < 0.5 { 1.0 } else { -1.0 };
            assert!((v[2] - v[0] - sign * 2.0).abs() < 1e-12, "{v}");
            assert_eq!(
                greedy_action(&q, &Vector2::from(state)).unwrap(),
                q.greedy_action(state).unwrap()
            );
            assert_eq!(value(&q, &Vector2::from(state), 1).unwrap(), v[1]);
        }
        assert_eq!(greedy_action(&q, &Vector2::new(0.1, 0.1)).unwrap(), 2);
        assert_eq!(greedy_action(&q, &Vector2::new(0.9, 0.1)).unwrap(), 0);
    }

    #[test]
    fn a_vector_of_another_length_or_a_bad_state_is_refused() {
        let mut entries = [FqiEntry::EMPTY; 48];
        let q = fitted(&mut entries);
        let state = Vector2::new(0.3, 0.3);
        assert!(matches!(
            q_values::<f64, 2, 2>(&q, &state),
            Err(Error::InvalidParameter { .. })
        ));
        assert!(matches!(
            q_values::<f64, 2, 4>(&q, &state),
            Err(Error::InvalidParameter { .. })
        ));
        assert!(matches!(
            q_values::<f64, 2, 3>(&q, &Vector2::new(f64::NAN, 0.3)),
            Err(Error::NonFinite { .. })
        ));
        assert!(value(&q, &state, 3).is_err());
    }

    #[test]
    fn conversions_round_trip() {
        let a = [1.5f32, -2.0, 3.25];
        assert_eq!(to_array(&to_vector(a)), a);
        assert_eq!(to_vector(a), ::nalgebra::Vector3::new(1.5, -2.0, 3.25));
    }

    /// A plant on vectors: next state = state + (action + 1) · (1, -1), reward = the
    /// first coordinate, absorbing past 1; refuses action ≥ 2.
    struct Drift;
    impl GenerativeModel<f64> for Drift {
        type State = Vector2<f64>;
        fn num_actions(&self) -> usize {
            2
        }
        fn query<R: Rng + ?Sized>(
            &self,
            state: Vector2<f64>,
            action: usize,
            rng: &mut R,
        ) -> Result<Transition<Vector2<f64>, f64>> {
            if action >= 2 {
                return Err(Error::OutOfRange {
                    parameter: "action",
                });
            }
            let noise = crate::rng::uniform_f64(rng);
            let next_state = state + Vector2::new(1.0, -1.0) * (action as f64 + 1.0);
            Ok(Transition {
                state,
                action,
                reward: state[0] + noise,
                next_state,
                absorbing: next_state[0] > 1.0,
            })
        }
    }

    #[test]
    fn the_plant_adapter_forwards_states_rewards_draws_and_errors() {
        let plant = VectorPlant(Drift);
        assert_eq!(plant.num_actions(), 2);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut same = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let t = plant.query([0.25, 0.5], 1, &mut rng).unwrap();
        let expected_noise = crate::rng::uniform_f64(&mut same);
        assert_eq!(t.state, [0.25, 0.5]);
        assert_eq!(t.action, 1);
        assert_eq!(t.next_state, [2.25, -1.5]);
        assert!((t.reward - (0.25 + expected_noise)).abs() < 1e-15);
        assert!(t.absorbing);
        assert_eq!(
            plant.query([0.0, 0.0], 2, &mut rng),
            Err(Error::OutOfRange {
                parameter: "action"
            })
        );
    }
}
