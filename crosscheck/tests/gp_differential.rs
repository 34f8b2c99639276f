//! Differential test of the core GP (`awfqi::gp::Gp`, through the harness's capacity
//! dispatch `awfqi_harness::commands::gp::fit_core`) against the harness's independent
//! reference GP (`awfqi_reference::gp`, f64, plain Cholesky).
//!
//! Seeded generators draw random well-conditioned cases and four classes of hard cases
//! (duplicate inputs, nearly collinear inputs, noise 1e-6, outputs offset by 1e4), with `N`
//! from 1 to 128 (the first two cases of every batch are `N = 1` and `N = 128`). Every case is
//! computed by the core in f64 and in f32 and by the reference, and each quantity (predictive
//! mean, latent std, log marginal likelihood) must agree within the [`TOLERANCES`] table.
//!
//! * **Same model.** The core may add a jitter to the training diagonal (it reports it via
//!   `Gp::jitter()`); the reference is then fitted with *the same* extra diagonal, so both
//!   compute the same model and any difference is arithmetic. The number of cases where the
//!   jitter was positive is printed per class. For f32 the reference is given the inputs
//!   rounded to f32 (the numbers the core actually saw), so input rounding, which is not the
//!   core's doing, does not count as error.
//! * **Relative error.** `|core − reference| / max(|reference|, scale)`, with the scale of
//!   each quantity: `max_i |y_i|` for the mean, `√c` for the std (the prior std), and `N` for
//!   the log marginal likelihood (so an LML near zero is compared in absolute terms per
//!   point).
//! * **Hard cases.** A hard case must either agree within its row of the table or return
//!   `Error::NotPositiveDefinite` or one of the conditioning policy's errors
//!   (`Error::JitterLimit`, `Error::IllConditioned`). The bound of a hard row grows with the 1-norm condition
//!   number `κ₁` of the matrix the core factorised (noise and jitter included):
//!   `tol = min(cap, max(floor, per_condition · ε · κ₁))`, `ε` the machine epsilon of the
//!   core's precision — the classical forward-error bound of a Cholesky solve — but never
//!   above `cap`: an error beyond the cap is a wrong number, and returning it without an
//!   error is what this test exists to catch (the core must then escalate its jitter or
//!   refuse). A case where the core returns numbers but the reference cannot factorise the
//!   same matrix in f64 fails too.
//! * **Well-conditioned cases** (distinct random inputs, noise ≥ 1e-2·c, so `κ₂ ≤ 1 + 100·N`)
//!   must succeed: f64 to 1e-9 on every quantity, f32 to 1e-3 on mean and std for `N ≤ 64`.
//!
//! * **Exact hard cases** (condition 1e6–1e9, computed in 60-digit arithmetic by
//!   `scripts/gp-exact-cases`) are compared against the model the caller asked for, with and
//!   without the base jitter: each agrees within the table or is refused, never a wrong `Ok`.
//!
//! The worst measured errors per class, precision and quantity are printed (run with
//! `cargo test -p awfqi-crosscheck --test gp_differential -- --nocapture`).

use awfqi::Error;
use awfqi::gp::BASE_JITTER;
use awfqi::rng::{standard_normal, uniform_f64};
use awfqi_harness::commands::gp::{
    Case, CaseError, ConditioningOptions, Fit, Precision, fit_core, fit_core_under, fit_reference,
};
use awfqi_reference::gp::condition;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;

/// What kind of case a generator draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    /// Distinct uniform inputs, noise in [1e-2·c, c]: `κ₂(K) ≤ 1 + N·c/s2 ≤ 1 + 100·N`.
    WellConditioned,
    /// About half the inputs repeat an earlier input exactly (with a different target),
    /// noise in [1e-6·c, 1e-2·c].
    Duplicates,
    /// As `Duplicates`, with noise variance 0: the kernel matrix is exactly singular and only
    /// the core's jitter makes it factorisable.
    NoiselessDuplicates,
    /// Inputs on a line in 2-3 dimensions, moved off it by 1e-6, length scales longer than
    /// the spread of the points, noise in [1e-6·c, 1e-2·c].
    NearlyCollinear,
    /// Well-spread inputs with noise variance exactly 1e-6.
    TinyNoise,
    /// Well-conditioned inputs and noise, targets offset by +1e4 (the prior mean is 0, so the
    /// GP must carry the offset through `α` = K⁻¹y).
    LargeOffset,
}

/// Which number is compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Quantity {
    /// Predictive mean at the test inputs; scale `max |y|`.
    Mean,
    /// Latent predictive standard deviation at the test inputs; scale `√c`.
    Std,
    /// Log marginal likelihood; scale `N`.
    LogMarginalLikelihood,
}

/// One row of the tolerance table: the relative error allowed is
/// `min(cap, max(floor, per_condition · ε · κ₁))`.
struct Tolerance {
    class: Class,
    precision: Precision,
    quantity: Quantity,
    floor: f64,
    per_condition: f64,
    cap: f64,
}

const fn row(
    class: Class,
    precision: Precision,
    quantity: Quantity,
    floor: f64,
    per_condition: f64,
    cap: f64,
) -> Tolerance {
    Tolerance {
        class,
        precision,
        quantity,
        floor,
        per_condition,
        cap,
    }
}

use Class::*;
use Precision::{F32, F64};
use Quantity::*;

/// The tolerance table: `row(class, precision, quantity, floor, per_condition, cap)`, the
/// relative error allowed being `min(cap, max(floor, per_condition · ε · κ₁(K + jitter·I)))`.
/// `floor` is always allowed; `per_condition · ε · κ₁` is the error a backward-stable
/// Cholesky solve may make on a matrix of that condition (the hard classes reach κ₁ ≈ 1e13);
/// `cap` is the largest error that is still an answer rather than a wrong number.
const TOLERANCES: &[Tolerance] = &[
    // The requirement for f64 on well-conditioned cases: 1e-9 relative, flat.
    row(WellConditioned, F64, Mean, 1e-9, 0.0, 1e-9),
    row(WellConditioned, F64, Std, 1e-9, 0.0, 1e-9),
    row(WellConditioned, F64, LogMarginalLikelihood, 1e-9, 0.0, 1e-9),
    // The requirement for f32, N ≤ 64: 1e-3 on mean and latent std.
    row(WellConditioned, F32, Mean, 1e-3, 0.0, 1e-3),
    row(WellConditioned, F32, Std, 1e-3, 0.0, 1e-3),
    // Not required; the LML sums N terms of data fit and log-determinant.
    row(WellConditioned, F32, LogMarginalLikelihood, 1e-3, 0.0, 1e-3),
    // A large offset leaves K as well-conditioned as above: the f64 target still holds.
    row(LargeOffset, F64, Mean, 1e-9, 0.0, 1e-9),
    row(LargeOffset, F64, Std, 1e-9, 0.0, 1e-9),
    row(LargeOffset, F64, LogMarginalLikelihood, 1e-9, 0.0, 1e-9),
    // In f32 y ≈ 1e4 keeps only ~1e-3 absolute, and α = K⁻¹y is amplified by κ.
    row(LargeOffset, F32, Mean, 1e-3, 0.0, 1e-3),
    row(LargeOffset, F32, Std, 1e-3, 0.0, 1e-3),
    row(LargeOffset, F32, LogMarginalLikelihood, 1e-2, 0.0, 1e-2),
    // Ill-conditioned classes: the forward-error bound c·ε·κ₁ (c = 1 for mean and std; the
    // LML's yᵀK⁻¹y carries κ twice through α, allow 10), never below the flat target, capped
    // at 1e-6 in f64 (six correct digits: κ₁ up to 1e13 here, ε·κ₁ up to 2e-3) and at 1e-2
    // in f32 (1 % of the data scale, the prior std, or 0.01 nats per point of the LML).
    row(Duplicates, F64, Mean, 1e-9, 1.0, 1e-6),
    row(Duplicates, F64, Std, 1e-9, 1.0, 1e-6),
    row(Duplicates, F64, LogMarginalLikelihood, 1e-9, 10.0, 1e-6),
    row(Duplicates, F32, Mean, 1e-3, 1.0, 1e-2),
    row(Duplicates, F32, Std, 1e-3, 1.0, 1e-2),
    row(Duplicates, F32, LogMarginalLikelihood, 1e-3, 10.0, 1e-2),
    row(NoiselessDuplicates, F64, Mean, 1e-9, 1.0, 1e-6),
    row(NoiselessDuplicates, F64, Std, 1e-9, 1.0, 1e-6),
    row(
        NoiselessDuplicates,
        F64,
        LogMarginalLikelihood,
        1e-9,
        10.0,
        1e-6,
    ),
    row(NoiselessDuplicates, F32, Mean, 1e-3, 1.0, 1e-2),
    row(NoiselessDuplicates, F32, Std, 1e-3, 1.0, 1e-2),
    row(
        NoiselessDuplicates,
        F32,
        LogMarginalLikelihood,
        1e-3,
        10.0,
        1e-2,
    ),
    row(NearlyCollinear, F64, Mean, 1e-9, 1.0, 1e-6),
    row(NearlyCollinear, F64, Std, 1e-9, 1.0, 1e-6),
    row(
        NearlyCollinear,
        F64,
        LogMarginalLikelihood,
        1e-9,
        10.0,
        1e-6,
    ),
    row(NearlyCollinear, F32, Mean, 1e-3, 1.0, 1e-2),
    row(NearlyCollinear, F32, Std, 1e-3, 1.0, 1e-2),
    row(
        NearlyCollinear,
        F32,
        LogMarginalLikelihood,
        1e-3,
        10.0,
        1e-2,
    ),
    row(TinyNoise, F64, Mean, 1e-9, 1.0, 1e-6),
    row(TinyNoise, F64, Std, 1e-9, 1.0, 1e-6),
    row(TinyNoise, F64, LogMarginalLikelihood, 1e-9, 10.0, 1e-6),
    row(TinyNoise, F32, Mean, 1e-3, 1.0, 1e-2),
    row(TinyNoise, F32, Std, 1e-3, 1.0, 1e-2),
    row(TinyNoise, F32, LogMarginalLikelihood, 1e-3, 10.0, 1e-2),
];

fn tolerance(class: Class, precision: Precision, quantity: Quantity, kappa: f64) -> f64 {
    let row = TOLERANCES
        .iter()
        .find(|t| t.class == class && t.precision == precision && t.quantity == quantity)
        .unwrap_or_else(|| panic!("no tolerance for {class:?} {precision:?} {quantity:?}"));
    row.floor
        .max(row.per_condition * epsilon(precision) * kappa)
        .min(row.cap)
}

fn epsilon(precision: Precision) -> f64 {
    match precision {
        F64 => f64::EPSILON,
        F32 => f32::EPSILON as f64,
    }
}

// ---------------------------------------------------------------------------------------
// Case generators.

fn uniform(rng: &mut ChaCha8Rng, low: f64, high: f64) -> f64 {
    low + (high - low) * uniform_f64(rng)
}

fn log_uniform(rng: &mut ChaCha8Rng, low: f64, high: f64) -> f64 {
    uniform(rng, low.ln(), high.ln()).exp()
}

fn index(rng: &mut ChaCha8Rng, n: usize) -> usize {
    ((uniform_f64(rng) * n as f64) as usize).min(n - 1)
}

/// `N` for the `i`-th case of a batch: 1, then `max_n`, then uniform in `1..=max_n`.
fn size(rng: &mut ChaCha8Rng, i: usize, max_n: usize) -> usize {
    match i {
        0 => 1,
        1 => max_n,
        _ => 1 + index(rng, max_n),
    }
}

/// A smooth target function of the inputs plus observation noise.
fn targets(rng: &mut ChaCha8Rng, x: &[Vec<f64>], c: f64, s2: f64) -> Vec<f64> {
    let w: Vec<f64> = (0..x[0].len()).map(|_| uniform(rng, -1.5, 1.5)).collect();
    let phase = uniform(rng, 0.0, 6.0);
    x.iter()
        .map(|xi| {
            let t: f64 = xi.iter().zip(&w).map(|(a, b)| a * b).sum::<f64>() + phase;
            c.sqrt() * t.sin() + s2.sqrt() * standard_normal::<f64, _>(rng)
        })
        .collect()
}

/// Test inputs: five random points in the box, two training points, one far away.
fn test_points(rng: &mut ChaCha8Rng, x: &[Vec<f64>], d: usize, high: f64) -> Vec<Vec<f64>> {
    let mut points: Vec<Vec<f64>> = (0..5)
        .map(|_| (0..d).map(|_| uniform(rng, -0.5, high + 0.5)).collect())
        .collect();
    points.push(x[index(rng, x.len())].clone());
    points.push(x[index(rng, x.len())].clone());
    points.push(vec![100.0; d]);
    points
}

fn draw_case(rng: &mut ChaCha8Rng, class: Class, i: usize, max_n: usize) -> Case {
    let n = size(rng, i, max_n);
    let c = log_uniform(rng, 0.1, 10.0);
    let d = match class {
        NearlyCollinear => 2 + index(rng, 2),
        _ => 1 + index(rng, 3),
    };
    let high = 5.0;
    let mut length_scales: Vec<f64> = (0..d).map(|_| uniform(rng, 0.3, 3.0)).collect();
    let noise_variance = match class {
        WellConditioned | LargeOffset => c * log_uniform(rng, 1e-2, 1.0),
        Duplicates | NearlyCollinear => c * log_uniform(rng, 1e-6, 1e-2),
        NoiselessDuplicates => 0.0,
        TinyNoise => 1e-6,
    };
    let mut x: Vec<Vec<f64>> = Vec::with_capacity(n);
    match class {
        NearlyCollinear => {
            let origin: Vec<f64> = (0..d).map(|_| uniform(rng, 0.0, high)).collect();
            let direction: Vec<f64> = (0..d).map(|_| uniform(rng, -1.0, 1.0)).collect();
            for _ in 0..n {
                let t = uniform(rng, 0.0, 1.0);
                x.push(
                    origin
                        .iter()
                        .zip(&direction)
                        .map(|(o, v)| o + t * v + 1e-6 * uniform(rng, -1.0, 1.0))
                        .collect(),
                );
            }
            // Longer than the spread of the points: a very smooth, nearly rank-deficient kernel.
            length_scales = (0..d).map(|_| uniform(rng, 1.0, 10.0)).collect();
        }
        Duplicates | NoiselessDuplicates => {
            for k in 0..n {
                if k > 0 && uniform_f64(rng) < 0.5 {
                    let earlier = x[index(rng, k)].clone();
                    x.push(earlier);
                } else {
                    x.push((0..d).map(|_| uniform(rng, 0.0, high)).collect());
                }
            }
        }
        _ => {
            for _ in 0..n {
                x.push((0..d).map(|_| uniform(rng, 0.0, high)).collect());
            }
        }
    }
    let mut y = targets(rng, &x, c, noise_variance);
    if class == LargeOffset {
        for v in &mut y {
            *v += 1e4;
        }
    }
    let x_test = test_points(rng, &x, d, high);
    Case {
        name: format!("{class:?} #{i} N={n} D={d}"),
        x,
        y,
        signal_variance: c,
        length_scales,
        noise_variance,
        x_test,
    }
}

/// The case with every number rounded to f32 (what the core in f32 computes with).
fn rounded_to_f32(case: &Case) -> Case {
    let r = |v: &f64| *v as f32 as f64;
    let rows = |m: &[Vec<f64>]| m.iter().map(|row| row.iter().map(r).collect()).collect();
    Case {
        name: case.name.clone(),
        x: rows(&case.x),
        y: case.y.iter().map(r).collect(),
        signal_variance: r(&case.signal_variance),
        length_scales: case.length_scales.iter().map(r).collect(),
        noise_variance: r(&case.noise_variance),
        x_test: rows(&case.x_test),
    }
}

// ---------------------------------------------------------------------------------------
// Comparison.

fn relative_error(core: f64, reference: f64, scale: f64) -> f64 {
    (core - reference).abs() / reference.abs().max(scale)
}

/// What happened to the cases of one (class, precision) batch.
#[derive(Default)]
struct Summary {
    cases: usize,
    compared: usize,
    not_positive_definite: usize,
    jittered: usize,
    max_jitter_over_c: f64,
    max_kappa: f64,
    worst: [f64; 3],
    worst_case: [String; 3],
}

impl Summary {
    fn print(&self, class: Class, precision: Precision) {
        eprintln!(
            "{class:?} {precision:?}: {} cases, {} compared, {} NotPositiveDefinite, {} with escalated \
             jitter (max jitter/c {:.1e}), max κ₁ {:.2e}",
            self.cases,
            self.compared,
            self.not_positive_definite,
            self.jittered,
            self.max_jitter_over_c,
            self.max_kappa
        );
        for (q, name) in ["mean", "std", "lml"].iter().enumerate() {
            eprintln!(
                "    worst {name:4} relative error {:.2e}  ({})",
                self.worst[q], self.worst_case[q]
            );
        }
    }
}

/// Runs the core on `case` in `precision` and checks it against the reference; returns
/// failure messages (empty when the case passed).
fn check_case(
    case: &Case,
    class: Class,
    precision: Precision,
    summary: &mut Summary,
) -> Vec<String> {
    summary.cases += 1;
    let core = match fit_core(case, precision) {
        Ok(fit) => fit,
        Err(CaseError::Core(
            Error::NotPositiveDefinite | Error::JitterLimit { .. } | Error::IllConditioned { .. },
        )) if class != WellConditioned => {
            summary.not_positive_definite += 1;
            return Vec::new();
        }
        Err(error) => return vec![format!("{}: core failed: {error}", case.name)],
    };
    let seen = match precision {
        F64 => case.clone(),
        F32 => rounded_to_f32(case),
    };
    // The core always adds `BASE_JITTER`; count the fits that had to escalate it.
    let base_jitter = match precision {
        F64 => BASE_JITTER,
        F32 => BASE_JITTER as f32 as f64,
    };
    if core.jitter > base_jitter {
        summary.jittered += 1;
        summary.max_jitter_over_c = summary
            .max_jitter_over_c
            .max(core.jitter / seen.signal_variance);
    }
    let reference: Fit = match fit_reference(&seen, core.jitter) {
        Ok(fit) => fit,
        Err(error) => {
            return vec![format!(
                "{}: the core returned numbers (jitter {:e}) for a matrix the reference cannot \
                 factorise in f64: {error}",
                case.name, core.jitter
            )];
        }
    };
    let kappa = condition(&seen.x, &seen.reference_hyperparameters(), core.jitter)
        .expect("valid case")
        .condition_number;
    summary.max_kappa = summary.max_kappa.max(kappa);
    summary.compared += 1;

    let n = seen.x.len() as f64;
    let y_scale = seen.y.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
    let std_scale = seen.signal_variance.sqrt();
    let mut errors = [0.0f64; 3];
    for (a, b) in core.mean.iter().zip(&reference.mean) {
        errors[0] = errors[0].max(relative_error(*a, *b, y_scale));
    }
    for (a, b) in core.std.iter().zip(&reference.std) {
        errors[1] = errors[1].max(relative_error(*a, *b, std_scale));
    }
    errors[2] = relative_error(
        core.log_marginal_likelihood,
        reference.log_marginal_likelihood,
        n,
    );
    let mut failures = Vec::new();
    for (q, quantity) in [Mean, Std, LogMarginalLikelihood].into_iter().enumerate() {
        if errors[q] > summary.worst[q] {
            summary.worst[q] = errors[q];
            summary.worst_case[q] = format!("{}, κ₁ {kappa:.1e}", case.name);
        }
        let allowed = tolerance(class, precision, quantity, kappa);
        if errors[q].is_nan() || errors[q] > allowed {
            failures.push(format!(
                "{}: {quantity:?} relative error {:.3e} > {allowed:.3e} (κ₁ {kappa:.2e}, jitter {:e})",
                case.name, errors[q], core.jitter
            ));
        }
    }
    failures
}

fn run_batch(class: Class, precision: Precision, seed: u64, count: usize, max_n: usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut summary = Summary::default();
    let mut failures = Vec::new();
    for i in 0..count {
        let case = draw_case(&mut rng, class, i, max_n);
        failures.extend(check_case(&case, class, precision, &mut summary));
    }
    summary.print(class, precision);
    assert!(
        failures.is_empty(),
        "{} of {count} {class:?} {precision:?} cases failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
    assert!(
        summary.compared > 0,
        "no {class:?} {precision:?} case was compared"
    );
}

#[test]
fn well_conditioned_f64_agrees_to_1e_9() {
    run_batch(WellConditioned, F64, 1, 120, 128);
}

#[test]
fn well_conditioned_f32_agrees_to_1e_3_up_to_64_points() {
    run_batch(WellConditioned, F32, 2, 120, 64);
}

#[test]
fn large_offsets_agree() {
    run_batch(LargeOffset, F64, 3, 60, 128);
    run_batch(LargeOffset, F32, 4, 60, 64);
}

#[test]
fn f64_duplicate_inputs_agree_or_are_not_positive_definite() {
    run_batch(Duplicates, F64, 5, 60, 128);
}

#[test]
fn f64_noiseless_duplicates_agree_or_are_not_positive_definite() {
    run_batch(NoiselessDuplicates, F64, 13, 60, 128);
}

#[test]
fn f64_nearly_collinear_inputs_agree_or_are_not_positive_definite() {
    run_batch(NearlyCollinear, F64, 7, 60, 128);
}

#[test]
fn f64_tiny_noise_agrees_or_is_not_positive_definite() {
    run_batch(TinyNoise, F64, 9, 60, 128);
}

// The f32 hard classes. Before the core's pivot guard (`cholesky::PIVOT_GUARD`), its f32
// Cholesky succeeded on matrices whose condition ε·κ₁ is far above 1 (pivots positive by
// rounding) and returned means and log-likelihoods off by up to 10× the data scale; these
// tests caught it.

#[test]
fn f32_duplicate_inputs_agree_or_are_not_positive_definite() {
    run_batch(Duplicates, F32, 6, 60, 128);
}

#[test]
fn f32_noiseless_duplicates_agree_or_are_not_positive_definite() {
    run_batch(NoiselessDuplicates, F32, 14, 60, 128);
}

#[test]
fn f32_nearly_collinear_inputs_agree_or_are_not_positive_definite() {
    run_batch(NearlyCollinear, F32, 8, 60, 128);
}

#[test]
fn f32_tiny_noise_agrees_or_is_not_positive_definite() {
    run_batch(TinyNoise, F32, 10, 60, 128);
}

/// The generators draw what they claim: well-conditioned cases have κ₂ ≤ 1 + 100·N (checked
/// through κ₁ ≤ N·(1 + 100·N)), and the hard classes reach condition numbers far beyond it.
#[test]
fn generators_draw_the_intended_conditioning() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for i in 0..40 {
        let case = draw_case(&mut rng, WellConditioned, i, 128);
        let n = case.x.len() as f64;
        let kappa = condition(&case.x, &case.reference_hyperparameters(), 0.0)
            .unwrap()
            .condition_number;
        assert!(
            kappa <= n * (1.0 + 100.0 * n),
            "{}: κ₁ {kappa:e}",
            case.name
        );
    }
    for class in [Duplicates, NearlyCollinear, TinyNoise] {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let worst = (0..20)
            .map(|i| draw_case(&mut rng, class, i, 128))
            .map(|case| {
                condition(&case.x, &case.reference_hyperparameters(), 0.0)
                    .unwrap()
                    .condition_number
            })
            .fold(0.0, f64::max);
        assert!(worst > 1e6, "{class:?}: worst κ₁ only {worst:e}");
    }
}

// ---------------------------------------------------------------------------------------
// Exactly computed hard cases (condition numbers 1e6–1e9).
//
// `tests/data/gp_hard_cases.json` is written by `scripts/gp-exact-cases`: three classes
// (duplicated inputs with noise 1e-8, long length scales with tiny noise, nearly collinear
// inputs), every number representable in f32, and the exact mean, latent std and log
// marginal likelihood in 60-digit arithmetic (mpmath) for the model as asked (`exact`) and
// with the base jitter 1e-10 on the diagonal (`exact_base_jitter`). Unlike the tests above,
// the core is compared against the model the caller asked for, not against the one it
// chose after adding jitter: an escalated jitter that moves the answer beyond the table is a
// wrong number. Every case must agree within its row of `TOLERANCES` (κ₁ of the exact
// matrix) or return a conditioning error — never a wrong `Ok`.

/// The hard classes of the exact cases, mapped to the rows of [`TOLERANCES`] they are held to.
fn exact_class(name: &str) -> Class {
    match name {
        "duplicates" => Duplicates,
        "long_scales" => TinyNoise,
        "near_collinear" => NearlyCollinear,
        other => panic!("unknown class {other}"),
    }
}

#[derive(Default)]
struct ExactSummary {
    cases: usize,
    accepted: usize,
    refused: usize,
    worst: [f64; 3],
    max_jitter_over_noise: f64,
}

fn exact_cases() -> Vec<serde_json::Value> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/gp_hard_cases.json"
    );
    let text = std::fs::read_to_string(path).expect("tests/data/gp_hard_cases.json");
    let doc: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
    doc["cases"].as_array().expect("cases").clone()
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Runs every exact case in `precision` under `policy`, against `expected` ("exact" or
/// "exact_base_jitter"); returns the summaries per class and the failures.
fn run_exact(
    precision: Precision,
    policy: &ConditioningOptions,
    expected: &str,
) -> (Vec<(String, ExactSummary)>, Vec<String>) {
    let mut summaries: Vec<(String, ExactSummary)> = Vec::new();
    let mut failures = Vec::new();
    for value in exact_cases() {
        let class_name = value["class"].as_str().expect("class").to_owned();
        let class = exact_class(&class_name);
        let case: Case = serde_json::from_value(value.clone()).expect("a gp case");
        let kappa = value["condition_number"]
            .as_f64()
            .expect("condition_number");
        assert!((1e6..=1e9).contains(&kappa), "{}: κ₁ {kappa:e}", case.name);
        if !summaries.iter().any(|(c, _)| *c == class_name) {
            summaries.push((class_name.clone(), ExactSummary::default()));
        }
        let summary = &mut summaries
            .iter_mut()
            .find(|(c, _)| *c == class_name)
            .expect("inserted")
            .1;
        summary.cases += 1;
        let fit = match fit_core_under(&case, precision, policy) {
            Ok(fit) => fit,
            Err(CaseError::Core(
                Error::JitterLimit { .. }
                | Error::IllConditioned { .. }
                | Error::NotPositiveDefinite,
            )) => {
                summary.refused += 1;
                continue;
            }
            Err(e) => {
                failures.push(format!("{}: unexpected error {e}", case.name));
                continue;
            }
        };
        summary.accepted += 1;
        let base = if policy.base_jitter { BASE_JITTER } else { 0.0 };
        let escalated = (fit.jitter - base).max(0.0);
        summary.max_jitter_over_noise = summary
            .max_jitter_over_noise
            .max(escalated / case.noise_variance);
        let exact = &value[expected];
        let (mean, std) = (numbers(&exact["mean"]), numbers(&exact["std"]));
        let lml = exact["log_marginal_likelihood"].as_f64().expect("lml");
        let y_scale = case.y.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
        let std_scale = case.signal_variance.sqrt();
        let mut errors = [0.0f64; 3];
        for (a, b) in fit.mean.iter().zip(&mean) {
            errors[0] = errors[0].max(relative_error(*a, *b, y_scale));
        }
        for (a, b) in fit.std.iter().zip(&std) {
            errors[1] = errors[1].max(relative_error(*a, *b, std_scale));
        }
        errors[2] = relative_error(fit.log_marginal_likelihood, lml, case.x.len() as f64);
        for (q, quantity) in [Mean, Std, LogMarginalLikelihood].into_iter().enumerate() {
            summary.worst[q] = summary.worst[q].max(errors[q]);
            let allowed = tolerance(class, precision, quantity, kappa);
            if errors[q].is_nan() || errors[q] > allowed {
                failures.push(format!(
                    "{} ({precision:?}, {expected}): a wrong Ok — {quantity:?} relative error \
                     {:.3e} > {allowed:.3e} (κ₁ {kappa:.2e}, jitter {:e})",
                    case.name, errors[q], fit.jitter
                ));
            }
        }
    }
    for (class, s) in &summaries {
        eprintln!(
            "exact {class:15} {precision:?} {expected:17}: {} cases, {} accepted, {} refused; \
             worst accepted relative error mean {:.2e}, std {:.2e}, lml {:.2e}; max escalated \
             jitter/σ²ₙ {:.1e}",
            s.cases,
            s.accepted,
            s.refused,
            s.worst[0],
            s.worst[1],
            s.worst[2],
            s.max_jitter_over_noise
        );
    }
    (summaries, failures)
}

fn assert_exact(precision: Precision, policy: ConditioningOptions, expected: &str) {
    let (summaries, failures) = run_exact(precision, &policy, expected);
    assert!(
        failures.is_empty(),
        "{} wrong answers:\n{}",
        failures.len(),
        failures.join("\n")
    );
    assert_eq!(summaries.len(), 3, "three hard classes");
    assert!(summaries.iter().all(|(_, s)| s.cases >= 20));
}

const EXACT_MODEL: ConditioningOptions = ConditioningOptions {
    base_jitter: false,
    max_jitter_ratio: None,
    max_condition: None,
};

#[test]
fn exact_hard_cases_f64_agree_or_are_refused() {
    assert_exact(F64, EXACT_MODEL, "exact");
    assert_exact(F64, ConditioningOptions::default(), "exact_base_jitter");
}

#[test]
fn exact_hard_cases_f32_agree_or_are_refused() {
    assert_exact(F32, EXACT_MODEL, "exact");
    assert_exact(F32, ConditioningOptions::default(), "exact_base_jitter");
}

/// Without the policy's limits (the core before it had one) f32 returns wrong numbers on
/// these cases: the test above would catch it.
#[test]
fn without_limits_f32_gives_wrong_answers_the_policy_refuses() {
    let unbounded = ConditioningOptions {
        base_jitter: false,
        max_jitter_ratio: Some(f64::INFINITY),
        max_condition: Some(f64::INFINITY),
    };
    let (_, failures) = run_exact(F32, &unbounded, "exact");
    assert!(
        !failures.is_empty(),
        "unbounded escalation gave no wrong answer: the hard cases are not hard"
    );
}
