use crate::error::{Error, Result};
use crate::float::Real;
use crate::gp::covariance::Hyperparameters;
use crate::rng::uniform;
use rand_core::Rng;

/// The most hyperparameters the search can tune at once: `D + 2` with one length scale per
/// dimension (so ARD search supports `D ≤ 6`), 3 when the length scales are tied.
pub const MAX_SEARCH_PARAMETERS: usize = 8;

/// Box bounds `(low, high)` of each hyperparameter for the search; every bound must be
/// finite and `0 < low ≤ high` (the search works with logarithms). `low == high` fixes the
/// parameter. Memory: `2 · (D + 2) · size_of::<T>()` bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HyperparameterBounds<T, const D: usize> {
    /// Bounds of the signal variance `c`.
    pub signal_variance: (T, T),
    /// Bounds of each dimension's length scale `ℓ_d`.
    pub length_scales: [(T, T); D],
    /// Bounds of the noise variance `σ²ₙ` (the low bound must be > 0).
    pub noise_variance: (T, T),
}

impl<T: Real, const D: usize> HyperparameterBounds<T, D> {
    /// Spec §4.2's bounds: `c ∈ [10⁻⁵, 10⁵]`, `ℓ ∈ [10⁻², 10³]`, `σ²ₙ ∈ [10⁻², 1]`.
    pub fn spec_default() -> Self {
        Self {
            signal_variance: (T::from_f64(1e-5), T::from_f64(1e5)),
            length_scales: [(T::from_f64(1e-2), T::from_f64(1e3)); D],
            noise_variance: (T::from_f64(1e-2), T::ONE),
        }
    }

    /// Checks every bound: finite ([`Error::NonFinite`]), and `0 < low ≤ high`
    /// ([`Error::InvalidParameter`]), naming the field.
    pub fn validate(&self) -> Result<()> {
        check_pair(self.signal_variance, "signal_variance")?;
        for &pair in &self.length_scales {
            check_pair(pair, "length_scales")?;
        }
        check_pair(self.noise_variance, "noise_variance")
    }

    /// `true` when every hyperparameter of `hyper` lies inside its bounds.
    pub fn contains(&self, hyper: &Hyperparameters<T, D>) -> bool {
        let inside = |(lo, hi): (T, T), v: T| lo <= v && v <= hi;
        inside(self.signal_variance, hyper.signal_variance)
            && inside(self.noise_variance, hyper.noise_variance)
            && self
                .length_scales
                .iter()
                .zip(&hyper.length_scales)
                .all(|(&b, &l)| inside(b, l))
    }
}

fn check_pair<T: Real>((lo, hi): (T, T), parameter: &'static str) -> Result<()> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(Error::NonFinite { parameter });
    }
    if !(lo > T::ZERO && lo <= hi) {
        return Err(Error::InvalidParameter { parameter });
    }
    Ok(())
}

/// Bounded, allocation-free search for the hyperparameters that maximise the log marginal
/// likelihood (spec §4.2).
///
/// Spec §4.2's reference uses L-BFGS-B with the analytic gradient. The gradient needs `K⁻¹`,
/// a second `N × N` matrix, so this core uses a gradient-free Nelder–Mead simplex instead, in
/// the natural-log space of the hyperparameters, with every trial point clamped into the box
/// (projection). The search starts from spec §4.2's initial values (clipped into the box),
/// then from `restarts` points drawn uniformly in the log box from the caller's generator,
/// and keeps the best point seen. The evaluation budget is fixed: each start receives an
/// equal share of what is left, and a start that converges early passes its unused
/// evaluations on to the next one.
///
/// Settings of the hyperparameter search.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SearchOptions {
    /// Total number of likelihood evaluations (each one a Cholesky factorisation, O(n³/6)),
    /// shared by all starts; must be at least `restarts + 1`. The final refit at the best
    /// point is not counted.
    pub max_evaluations: usize,
    /// Number of random starts after the first one (spec §4.2: 10).
    pub restarts: usize,
    /// Tie all length scales to one value, as spec §4.2's isotropic kernel does. The tied
    /// length scale is bounded by the intersection of the per-dimension bounds.
    pub isotropic: bool,
}

impl Default for SearchOptions {
    /// Spec §4.2's protocol: isotropic, 10 restarts, and 50 evaluations per start.
    fn default() -> Self {
        Self {
            max_evaluations: 550,
            restarts: 10,
            isotropic: true,
        }
    }
}

impl SearchOptions {
    /// Checks that the budget gives every start at least one evaluation
    /// ([`Error::InvalidParameter`] naming `max_evaluations`, or `restarts` if `restarts + 1`
    /// overflows).
    pub fn validate(&self) -> Result<()> {
        let starts = self
            .restarts
            .checked_add(1)
            .ok_or(Error::InvalidParameter {
                parameter: "restarts",
            })?;
        if self.max_evaluations < starts {
            return Err(Error::InvalidParameter {
                parameter: "max_evaluations",
            });
        }
        Ok(())
    }
}

/// A point of the log-parameter space: `[ln c, ln ℓ₁ (, …, ln ℓ_D), ln σ²ₙ]`, padded with
/// zeros to [`MAX_SEARCH_PARAMETERS`].
pub(crate) type Theta<T> = [T; MAX_SEARCH_PARAMETERS];

/// The search box in log space, and the map from a log point to hyperparameters.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LogBox<T> {
    /// Number of coordinates in use.
    dim: usize,
    isotropic: bool,
    low: Theta<T>,
    high: Theta<T>,
    /// The same bounds before taking logarithms (results are clamped to them exactly).
    low_linear: Theta<T>,
    high_linear: Theta<T>,
}

impl<T: Real> LogBox<T> {
    /// Validates the bounds and options and builds the box.
    ///
    /// Errors: those of [`HyperparameterBounds::validate`]; an empty intersection of the
    /// length-scale bounds in isotropic mode ([`Error::InvalidParameter`]); `D + 2` above
    /// [`MAX_SEARCH_PARAMETERS`] without isotropy ([`Error::CapacityExceeded`]).
    pub(crate) fn new<const D: usize>(
        bounds: &HyperparameterBounds<T, D>,
        isotropic: bool,
    ) -> Result<Self> {
        bounds.validate()?;
        let mut pairs = [(T::ONE, T::ONE); MAX_SEARCH_PARAMETERS];
        let dim = if isotropic {
            let mut tied = (T::ZERO, T::INFINITY);
            for &(lo, hi) in &bounds.length_scales {
                tied = (tied.0.max(lo), tied.1.min(hi));
            }
            if D == 0 {
                tied = (T::ONE, T::ONE);
            }
            if tied.0 > tied.1 {
                return Err(Error::InvalidParameter {
                    parameter: "length_scales",
                });
            }
            let [c, l, s, ..] = &mut pairs;
            (*c, *l, *s) = (bounds.signal_variance, tied, bounds.noise_variance);
            3
        } else {
            let dim = D + 2;
            let (first, rest) = pairs.split_first_mut().ok_or(Error::CapacityExceeded {
                capacity: MAX_SEARCH_PARAMETERS,
            })?;
            let Some(lengths) = rest.get_mut(..=D) else {
                return Err(Error::CapacityExceeded {
                    capacity: MAX_SEARCH_PARAMETERS,
                });
            };
            *first = bounds.signal_variance;
            for (slot, &pair) in lengths.iter_mut().zip(&bounds.length_scales) {
                *slot = pair;
            }
            if let Some(last) = lengths.last_mut() {
                *last = bounds.noise_variance;
            }
            dim
        };
        let mut space = Self {
            dim,
            isotropic,
            low: [T::ZERO; MAX_SEARCH_PARAMETERS],
            high: [T::ZERO; MAX_SEARCH_PARAMETERS],
            low_linear: [T::ONE; MAX_SEARCH_PARAMETERS],
            high_linear: [T::ONE; MAX_SEARCH_PARAMETERS],
        };
        for (i, &(lo, hi)) in pairs.iter().enumerate().take(dim) {
            if let (Some(a), Some(b), Some(c), Some(d)) = (
                space.low.get_mut(i),
                space.high.get_mut(i),
                space.low_linear.get_mut(i),
                space.high_linear.get_mut(i),
            ) {
                (*a, *b, *c, *d) = (lo.ln(), hi.ln(), lo, hi);
            }
        }
        Ok(space)
    }

    /// Spec §4.2's initial point (`c = ℓ = σ²ₙ = 1`, so θ = 0) clamped into the box.
    pub(crate) fn initial(&self) -> Theta<T> {
        let mut theta = [T::ZERO; MAX_SEARCH_PARAMETERS];
        self.clamp(&mut theta);
        theta
    }

    /// A point drawn uniformly in the log box; consumes one `u64` per coordinate in use.
    pub(crate) fn random<R: Rng + ?Sized>(&self, rng: &mut R) -> Theta<T> {
        let mut theta = [T::ZERO; MAX_SEARCH_PARAMETERS];
        for ((t, &lo), &hi) in theta
            .iter_mut()
            .zip(&self.low)
            .zip(&self.high)
            .take(self.dim)
        {
            let u: T = uniform(rng);
            *t = (lo + (hi - lo) * u).clamp_to(lo, hi);
        }
        theta
    }

    /// Projects a point into the box (coordinates beyond `dim` are set to 0).
    pub(crate) fn clamp(&self, theta: &mut Theta<T>) {
        for (i, ((t, &lo), &hi)) in theta.iter_mut().zip(&self.low).zip(&self.high).enumerate() {
            *t = if i < self.dim {
                t.clamp_to(lo, hi)
            } else {
                T::ZERO
            };
        }
    }

    /// The hyperparameters at a log point, each clamped into its (linear) bounds so rounding
    /// in `exp(ln x)` cannot leave the box.
    pub(crate) fn hyperparameters<const D: usize>(
        &self,
        theta: &Theta<T>,
    ) -> Hyperparameters<T, D> {
        let value = |i: usize| -> T {
            match (
                theta.get(i),
                self.low_linear.get(i),
                self.high_linear.get(i),
            ) {
                (Some(&t), Some(&lo), Some(&hi)) => t.exp().clamp_to(lo, hi),
                _ => T::ONE,
            }
        };
        let last = self.dim.saturating_sub(1);
        let mut length_scales = [T::ONE; D];
        for (d, l) in length_scales.iter_mut().enumerate() {
            *l = value(if self.isotropic { 1 } else { 1 + d });
        }
        Hyperparameters {
            signal_variance: value(0),
            length_scales,
            noise_variance: value(last),
        }
    }

    /// Number of coordinates in use.
    #[cfg(test)]
    pub(crate) fn dim(&self) -> usize {
        self.dim
    }
}

/// A simplex vertex: a point and the value to minimise there (`−LML`, `+∞` for a failure).
#[derive(Debug, Clone, Copy)]
struct Vertex<T> {
    value: T,
    theta: Theta<T>,
}

/// Counts evaluations and remembers the best point seen.
struct Evaluator<'f, T, F> {
    objective: &'f mut F,
    left: usize,
    best: Vertex<T>,
}

impl<T: Real, F: FnMut(&Theta<T>) -> T> Evaluator<'_, T, F> {
    /// `−objective(θ)` (NaN counts as `+∞`), or `None` when the budget is spent.
    fn eval(&mut self, theta: &Theta<T>) -> Option<T> {
        self.left = self.left.checked_sub(1)?;
        let lml = (self.objective)(theta);
        let value = if lml.is_nan() { T::INFINITY } else { -lml };
        if value < self.best.value {
            self.best = Vertex {
                value,
                theta: *theta,
            };
        }
        Some(value)
    }
}

/// Maximises `objective` (a log marginal likelihood, `−∞` for a failed factorisation) over
/// the box with a fixed budget of evaluations. Returns the best point and its value
/// (`−∞` when no evaluation succeeded).
pub(crate) fn maximize<T, R, F>(
    space: &LogBox<T>,
    options: &SearchOptions,
    rng: &mut R,
    objective: &mut F,
) -> (Theta<T>, T)
where
    T: Real,
    R: Rng + ?Sized,
    F: FnMut(&Theta<T>) -> T,
{
    let starts = options.restarts.saturating_add(1);
    let mut pool = options.max_evaluations;
    let mut ev = Evaluator {
        objective,
        left: 0,
        best: Vertex {
            value: T::INFINITY,
            theta: space.initial(),
        },
    };
    for s in 0..starts {
        let start = if s == 0 {
            space.initial()
        } else {
            space.random(rng)
        };
        let share = pool / (starts - s);
        ev.left = share;
        nelder_mead(space, start, &mut ev);
        pool -= share - ev.left;
    }
    (ev.best.theta, -ev.best.value)
}

/// Reflection, expansion, contraction and shrink coefficients (the standard ones).
const REFLECT: f64 = 1.0;
const EXPAND: f64 = 2.0;
const CONTRACT: f64 = 0.5;
const SHRINK: f64 = 0.5;
/// Initial simplex edge as a fraction of each coordinate's log-box width.
const INITIAL_STEP: f64 = 0.1;
/// Convergence: simplex extent in log space (0.1 % relative change in a parameter).
const X_TOLERANCE: f64 = 1e-3;

/// `a + t (b − a)` per coordinate, clamped into the box.
fn along<T: Real>(space: &LogBox<T>, a: &Theta<T>, b: &Theta<T>, t: T) -> Theta<T> {
    let mut out = *a;
    for ((o, &p), &q) in out.iter_mut().zip(a).zip(b) {
        *o = p + t * (q - p);
    }
    space.clamp(&mut out);
    out
}

/// Sorts vertices by value, best first (insertion sort; at most 9 vertices).
fn sort<T: Real>(vertices: &mut [Vertex<T>]) {
    for i in 1..vertices.len() {
        let mut j = i;
        while j > 0 {
            match vertices.get_mut(j - 1..=j) {
                Some([a, b]) if b.value < a.value => core::mem::swap(a, b),
                _ => break,
            }
            j -= 1;
        }
    }
}

/// One Nelder–Mead run from `start` until the evaluator's budget is spent or the simplex
/// has converged.
fn nelder_mead<T, F>(space: &LogBox<T>, start: Theta<T>, ev: &mut Evaluator<'_, T, F>)
where
    T: Real,
    F: FnMut(&Theta<T>) -> T,
{
    let Some(value) = ev.eval(&start) else {
        return;
    };
    let mut simplex = [Vertex {
        value,
        theta: start,
    }; MAX_SEARCH_PARAMETERS + 1];
    let Some(vertices) = simplex.get_mut(..=space.dim) else {
        return;
    };
    // Initial simplex: one step along each coordinate, towards the inside of the box.
    for (i, vertex) in vertices.iter_mut().enumerate().skip(1) {
        let mut theta = start;
        if let (Some(t), Some(&lo), Some(&hi)) = (
            theta.get_mut(i - 1),
            space.low.get(i - 1),
            space.high.get(i - 1),
        ) {
            let step = T::from_f64(INITIAL_STEP) * (hi - lo);
            *t = if *t + step <= hi {
                *t + step
            } else {
                *t - step
            };
        }
        space.clamp(&mut theta);
        let Some(value) = ev.eval(&theta) else {
            return;
        };
        *vertex = Vertex { value, theta };
    }
    let f_tolerance = T::EPSILON.sqrt();
    let (reflect, expand) = (T::from_f64(REFLECT), T::from_f64(EXPAND));
    let (contract, shrink) = (T::from_f64(CONTRACT), T::from_f64(SHRINK));
    loop {
        sort(vertices);
        let Some((worst, rest)) = vertices.split_last_mut() else {
            return;
        };
        let (Some(best), Some(second_worst)) = (rest.first().copied(), rest.last().copied()) else {
            return;
        };
        // Converged when the simplex is small and its values are flat.
        let extent = rest
            .iter()
            .chain(core::iter::once(&*worst))
            .flat_map(|v| v.theta.iter().zip(&best.theta))
            .fold(T::ZERO, |m, (&a, &b)| m.max((a - b).abs()));
        let spread = worst.value - best.value;
        if extent <= T::from_f64(X_TOLERANCE) && spread <= f_tolerance * (T::ONE + best.value.abs())
        {
            return;
        }
        // Centroid of all vertices but the worst.
        let mut centroid = [T::ZERO; MAX_SEARCH_PARAMETERS];
        let count = T::from_usize(rest.len());
        for v in rest.iter() {
            for (c, &t) in centroid.iter_mut().zip(&v.theta) {
                *c += t / count;
            }
        }
        let reflected = along(space, &centroid, &worst.theta, -reflect);
        let Some(fr) = ev.eval(&reflected) else {
            return;
        };
        if fr < best.value {
            let expanded = along(space, &centroid, &reflected, expand);
            let Some(fe) = ev.eval(&expanded) else {
                return;
            };
            *worst = if fe < fr {
                Vertex {
                    value: fe,
                    theta: expanded,
                }
            } else {
                Vertex {
                    value: fr,
                    theta: reflected,
                }
            };
            continue;
        }
        if fr < second_worst.value {
            *worst = Vertex {
                value: fr,
                theta: reflected,
            };
            continue;
        }
        // Contract: outside (towards the reflected point) when it beat the worst, else inside.
        let (target, bar) = if fr < worst.value {
            (reflected, fr)
        } else {
            (worst.theta, worst.value)
        };
        let contracted = along(space, &centroid, &target, contract);
        let Some(fc) = ev.eval(&contracted) else {
            return;
        };
        if fc < bar {
            *worst = Vertex {
                value: fc,
                theta: contracted,
            };
            continue;
        }
        // Shrink every vertex towards the best one.
        for v in vertices.iter_mut().skip(1) {
            let theta = along(space, &best.theta, &v.theta, shrink);
            let Some(value) = ev.eval(&theta) else {
                return;
            };
            *v = Vertex { value, theta };
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;
    use std::vec::Vec;

    #[test]
    fn spec_default_bounds_and_options() {
        let b = HyperparameterBounds::<f64, 3>::spec_default();
        assert_eq!(b.signal_variance, (1e-5, 1e5));
        assert_eq!(b.length_scales, [(1e-2, 1e3); 3]);
        assert_eq!(b.noise_variance, (1e-2, 1.0));
        assert_eq!(b.validate(), Ok(()));
        let o = SearchOptions::default();
        assert_eq!((o.restarts, o.isotropic), (10, true));
        assert_eq!(o.validate(), Ok(()));
    }

    #[test]
    fn bad_bounds_and_options_are_named() {
        let good = HyperparameterBounds::<f32, 2>::spec_default();
        let mut b = good;
        b.signal_variance.1 = f32::INFINITY;
        assert_eq!(
            b.validate(),
            Err(Error::NonFinite {
                parameter: "signal_variance"
            })
        );
        let mut b = good;
        b.length_scales[1] = (2.0, 1.0);
        assert_eq!(
            b.validate(),
            Err(Error::InvalidParameter {
                parameter: "length_scales"
            })
        );
        let mut b = good;
        b.noise_variance.0 = 0.0;
        assert_eq!(
            b.validate(),
            Err(Error::InvalidParameter {
                parameter: "noise_variance"
            })
        );
        // Disjoint per-dimension bounds cannot be tied.
        let mut b = good;
        b.length_scales = [(1.0, 2.0), (3.0, 4.0)];
        assert!(LogBox::new(&b, false).is_ok());
        assert_eq!(
            LogBox::new(&b, true).err(),
            Some(Error::InvalidParameter {
                parameter: "length_scales"
            })
        );
        // D + 2 = 9 parameters do not fit the search without tying.
        let wide = HyperparameterBounds::<f64, 7>::spec_default();
        assert_eq!(
            LogBox::new(&wide, false).err(),
            Some(Error::CapacityExceeded {
                capacity: MAX_SEARCH_PARAMETERS
            })
        );
        assert_eq!(LogBox::new(&wide, true).map(|s| s.dim()), Ok(3));
        let o = SearchOptions {
            max_evaluations: 3,
            restarts: 3,
            isotropic: true,
        };
        assert_eq!(
            o.validate(),
            Err(Error::InvalidParameter {
                parameter: "max_evaluations"
            })
        );
        let o = SearchOptions {
            max_evaluations: usize::MAX,
            restarts: usize::MAX,
            isotropic: true,
        };
        assert_eq!(
            o.validate(),
            Err(Error::InvalidParameter {
                parameter: "restarts"
            })
        );
    }

    #[test]
    fn maps_log_points_to_clamped_hyperparameters() {
        let mut b = HyperparameterBounds::<f64, 2>::spec_default();
        b.length_scales = [(0.5, 4.0), (0.1, 2.0)];
        let iso = LogBox::new(&b, true).unwrap();
        // Initial point: c = 1, ℓ = 1 (inside [0.5, 2]), σ² = 1.
        let h = iso.hyperparameters::<2>(&iso.initial());
        assert_eq!(h, Hyperparameters::isotropic(1.0, 1.0, 1.0));
        // A point far outside is clamped to the tied bounds [0.5, 2].
        let mut theta = [0.0; MAX_SEARCH_PARAMETERS];
        theta[1] = 10.0;
        iso.clamp(&mut theta);
        let h = iso.hyperparameters::<2>(&theta);
        assert!((h.length_scales[0] - 2.0).abs() < 1e-12);
        assert_eq!(h.length_scales[0], h.length_scales[1]);
        let ard = LogBox::new(&b, false).unwrap();
        let mut theta = [0.0; MAX_SEARCH_PARAMETERS];
        theta[1] = 1.0f64.ln();
        theta[2] = 0.25f64.ln();
        theta[3] = 0.1f64.ln();
        let h = ard.hyperparameters::<2>(&theta);
        assert!((h.length_scales[0] - 1.0).abs() < 1e-12);
        assert!((h.length_scales[1] - 0.25).abs() < 1e-12);
        assert!((h.noise_variance - 0.1).abs() < 1e-12);
    }

    #[test]
    fn finds_the_maximum_of_a_concave_function_inside_the_box_within_budget() {
        let b = HyperparameterBounds::<f64, 2>::spec_default();
        let space = LogBox::new(&b, false).unwrap();
        // Peak at ln c = 2, ln ℓ₁ = −1, ln ℓ₂ = 0.5, ln σ² = −3 (inside the box).
        let peak = [2.0, -1.0, 0.5, -3.0];
        let mut seen: Vec<Theta<f64>> = Vec::new();
        let mut f = |t: &Theta<f64>| {
            seen.push(*t);
            -t.iter()
                .zip(&peak)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
        };
        let options = SearchOptions {
            max_evaluations: 400,
            restarts: 3,
            isotropic: false,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let (best, value) = maximize(&space, &options, &mut rng, &mut f);
        assert!(seen.len() <= 400);
        for t in &seen {
            let h = space.hyperparameters::<2>(t);
            assert!(b.contains(&h), "left the box at {t:?}");
            assert_eq!(&t[4..], &[0.0; 4]);
        }
        for (a, p) in best.iter().zip(&peak) {
            assert!((a - p).abs() < 1e-2, "{best:?}");
        }
        assert!(value > -1e-4);
    }

    #[test]
    fn a_peak_outside_the_box_is_found_on_its_boundary() {
        let b = HyperparameterBounds::<f64, 1>::spec_default();
        let space = LogBox::new(&b, true).unwrap();
        // Unconstrained peak at σ² = e² > 1 = the upper bound.
        let mut f = |t: &Theta<f64>| -(t[0] * t[0] + t[1] * t[1] + (t[2] - 2.0) * (t[2] - 2.0));
        let options = SearchOptions {
            max_evaluations: 200,
            restarts: 1,
            isotropic: true,
        };
        let (best, _) = maximize(&space, &options, &mut ChaCha8Rng::seed_from_u64(2), &mut f);
        assert!(best[2].abs() < 1e-3, "{best:?}");
        assert!(best[0].abs() < 1e-2 && best[1].abs() < 1e-2);
    }

    #[test]
    fn all_failures_report_negative_infinity() {
        let b = HyperparameterBounds::<f32, 1>::spec_default();
        let space = LogBox::new(&b, true).unwrap();
        let mut calls = 0;
        let mut f = |_: &Theta<f32>| {
            calls += 1;
            f32::NEG_INFINITY
        };
        let options = SearchOptions {
            max_evaluations: 20,
            restarts: 2,
            isotropic: true,
        };
        let (_, v) = maximize(&space, &options, &mut ChaCha8Rng::seed_from_u64(3), &mut f);
        assert_eq!(v, f32::NEG_INFINITY);
        assert_eq!(
            calls, 20,
            "a failing objective never converges: the budget is spent"
        );
    }
}
