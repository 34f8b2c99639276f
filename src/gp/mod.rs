//! Gaussian-process regression of fixed capacity (spec §4.2).
//!
//! [`Gp<T, N, D>`](Gp) holds up to `N` points of dimension `D` with an ARD
//! squared-exponential kernel plus noise, zero prior mean and targets used as given. It keeps
//! the lower Cholesky factor of the Gram matrix in place, predicts the mean, the latent
//! variance and the noisy variance, gives the log marginal likelihood, grows by one point in
//! O(N²), escalates the diagonal jitter when a factorisation fails, and searches its
//! hyperparameters inside box bounds with a fixed budget of evaluations
//! ([`Gp::optimize_hyperparameters`]).
//!
//! The numerical work lives in slice-based functions (`cholesky`, `covariance`), so the code is
//! generated once per scalar type and dimension, not once per capacity `N`.
//!
//! # Memory
//!
//! `size_of::<Gp<T, N, D>>()` is
//! `size_of::<T>() · (N² + N·(D + 2) + D + 4) + 2 · size_of::<usize>() + 1`, rounded up to
//! the alignment: the factor (`N²`), inputs (`N·D`), targets and `L⁻¹y` (`2N`),
//! hyperparameters (`D + 2`), the conditioning policy (two limits and a flag byte), the
//! number of points and the jitter level. For `D = 3` (spec §4.2's
//! `z = (s_x, s_y, a)`), in bytes:
//!
//! | `N` | `f32`, Cortex-M (`thumbv7em`) | `f32`, 64-bit host | `f64`, Cortex-M | `f64`, 64-bit host |
//! |----:|------:|------:|-------:|-------:|
//! |  16 |  1 384 |  1 392 |   2 760 |   2 768 |
//! |  64 | 17 704 | 17 712 |  35 400 |  35 408 |
//! | 128 | 68 136 | 68 144 | 136 264 | 136 272 |
//!
//! [`Gp::predict`] uses `N · size_of::<T>()` more bytes of stack, and
//! [`Gp::optimize_hyperparameters`] under 1 KiB (`f64`) for its simplex and box.
//!
//! # Numerics
//!
//! Every factorisation adds [`BASE_JITTER`] (`10⁻¹⁰`, the reference's) to the diagonal unless
//! the GP's [`Conditioning`] policy leaves it out. When a pivot is not finite, or not above
//! the rounding floor `10·n·ε·K_ii` (below it, rounding in the working precision dominates the
//! pivot and the factor would be silently wrong), it retries with up to
//! [`JITTER_ESCALATIONS`] larger jitters relative to the signal variance and the precision of
//! `T`, as far as the policy allows relative to the noise variance (default `√ε·σ²ₙ`); a fit
//! that needs more returns [`Error::JitterLimit`](crate::Error::JitterLimit) naming the
//! jitter it needed, one that never factorises
//! [`Error::NotPositiveDefinite`](crate::Error::NotPositiveDefinite). A factor whose
//! condition estimate [`Gp::condition_estimate`] exceeds what the precision can be trusted
//! with (`ε·κ̂ > 10⁻²`) is refused with
//! [`Error::IllConditioned`](crate::Error::IllConditioned). [`Gp::jitter`] reports the
//! jitter in use. Dot products are summed in the working precision (four interleaved
//! partial sums, no wider accumulator: a Cortex-M4F has no double-precision FPU). The latent
//! variance is clipped at 0, so it is never negative.
//!
//! ```
//! use awfqi::gp::{Gp, Hyperparameters, WhenFull};
//! # fn main() -> awfqi::Result<()> {
//! let mut gp = Gp::<f32, 16, 1>::new(Hyperparameters::isotropic(1.0, 0.5, 0.01))?;
//! gp.fit(&[[0.0], [1.0]], &[0.0, 1.0])?;
//! gp.add_point([2.0], 0.5, WhenFull::DropOldest)?;
//! let p = gp.predict(&[1.0])?;
//! assert!((p.mean - 1.0).abs() < 0.05 && p.latent_variance < 0.02);
//! # Ok(())
//! # }
//! ```

mod cholesky;
mod conditioning;
mod covariance;
mod regression;
mod search;

pub use conditioning::{BASE_JITTER, Conditioning};
pub use covariance::Hyperparameters;
pub(crate) use regression::Searched;
pub use regression::{Gp, JITTER_ESCALATIONS, Prediction, WhenFull};
pub use search::{HyperparameterBounds, MAX_SEARCH_PARAMETERS, SearchOptions};

#[cfg(test)]
mod tests;
