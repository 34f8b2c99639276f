//! A step report's warnings as a `heapless::Vec` (feature `heapless`).
//!
//! [`StepReport::warnings`] is an iterator; firmware that keeps the warnings past the
//! report, queues them for a logger task or serialises them wants a bounded vector of
//! its own capacity. At most six warnings exist per step (one per kind and weights), so
//! `N = 6` always suffices; a smaller `N` is refused with a typed error when the step
//! has more warnings than fit, never cut short.
//!
//! ```
//! # use awfqi::thesis::{StepReport, Warning};
//! # fn keep(report: &StepReport<f32, 3>) -> awfqi::Result<()> {
//! let kept: heapless::Vec<Warning<f32>, 5> = awfqi::interop::heapless::warnings(report)?;
//! # Ok(()) }
//! ```

use ::heapless::Vec;

use crate::error::{Error, Result};
use crate::float::Real;
use crate::thesis::{StepReport, Warning};

/// The warnings of `report`, in [`StepReport::warnings`]'s order.
///
/// Errors: more warnings than `N` ([`Error::CapacityExceeded`] with `capacity: N`); the
/// report is unchanged and its warnings can be read again with a larger `N`.
pub fn warnings<T: Real, const I: usize, const N: usize>(
    report: &StepReport<T, I>,
) -> Result<Vec<Warning<T>, N>> {
    let mut kept = Vec::new();
    for warning in report.warnings() {
        kept.push(warning)
            .map_err(|_| Error::CapacityExceeded { capacity: N })?;
    }
    Ok(kept)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::gp::Hyperparameters;

    /// A report with every warning raised (700 source records worth 15, 100 discarded,
    /// one refused GP optimum): five warnings.
    fn all_warnings() -> StepReport<f32, 3> {
        StepReport {
            step: 2,
            queries: 50,
            n_target_samples: 100,
            n_source_samples: 700,
            gp_points: 64,
            gp_log_likelihood: -12.0,
            gp_hyperparameters: Hyperparameters::isotropic(1.0, 1.0, 0.1),
            gp_jitter: 1e-6,
            gp_condition: 10.0,
            gp_refused_fits: 1,
            wr_mean: 0.5,
            wr_eff: 100.0,
            wr_source_eff: 15.0,
            wr_discarded: 100,
            wr_capped: 0,
            ws_mean: 0.5,
            ws_eff: 100.0,
            ws_source_eff: 15.0,
            ws_discarded: 100,
            ws_capped: 0,
            plan_shortfall: 0.0,
            reward_std: 0.0,
        }
    }

    #[test]
    fn the_vector_holds_the_iterators_warnings_in_order() {
        let report = all_warnings();
        let kept: Vec<Warning<f32>, 5> = warnings(&report).unwrap();
        let iterated: std::vec::Vec<_> = report.warnings().collect();
        assert_eq!(iterated.len(), 5);
        assert_eq!(kept.as_slice(), iterated.as_slice());
        let mut healthy = report;
        healthy.wr_source_eff = 700.0;
        healthy.ws_source_eff = 700.0;
        healthy.wr_discarded = 0;
        healthy.ws_discarded = 0;
        healthy.gp_refused_fits = 0;
        assert!(warnings::<f32, 3, 0>(&healthy).unwrap().is_empty());
    }

    #[test]
    fn a_vector_too_small_is_refused_and_nothing_is_lost() {
        let report = all_warnings();
        assert_eq!(
            warnings::<f32, 3, 4>(&report),
            Err(Error::CapacityExceeded { capacity: 4 })
        );
        // The report still gives all five to a vector large enough.
        assert_eq!(warnings::<f32, 3, 8>(&report).unwrap().len(), 5);
    }
}
