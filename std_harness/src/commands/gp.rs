//! The `gp` subcommand: Gaussian-process regression cases from a JSON file, computed by the
//! core (`awfqi::gp::Gp`, f64 or f32) or by the harness's reference GP
//! ([`awfqi_reference::gp`]).
//!
//! Input: `{"cases":[{"name":…, "x":[[…D],…N], "y":[…N], "signal_variance":c,
//! "length_scales":[…D], "noise_variance":s2, "x_test":[[…D],…M]}]}` with
//! `k(x,x′) = c·exp(−½ Σ_d ((x_d−x′_d)/l_d)²)` plus `s2` on the diagonal of the training
//! matrix.
//!
//! Output: `{"cases":[{"name":…, "mean":[…M], "std":[…M], "log_marginal_likelihood":…,
//! "jitter":…}]}`; `std` is the latent function's (noise excluded) and `jitter` is what was
//! added to the training diagonal beyond `s2` (the core's `Gp::jitter()`, or `--jitter` for
//! the reference), so a fit that needed more than the base jitter never passes silently.
//! A case that cannot be computed gives `{"name":…, "error":"…"}` and the other cases
//! still run; the command then ends with an error naming the failed cases (exit status 1),
//! after writing the whole output.
//!
//! The core's capacity `N` and dimension `D` are const generics; this command supports
//! `D` in `1..=MAX_DIM` and picks the smallest capacity of [`CAPACITIES`] that holds the
//! case (up to 256 points).

use std::fmt;
use std::path::PathBuf;

use anyhow::Context;
use awfqi::float::Real;
use awfqi::gp::{Conditioning, Gp, Hyperparameters};
use serde::{Deserialize, Serialize};

use awfqi_reference::gp::{Hyperparameters as ReferenceHyperparameters, ReferenceGp};

/// The capacities (training points) the command can run the core with; a case uses the
/// smallest one that holds it.
pub const CAPACITIES: [usize; 5] = [16, 32, 64, 128, 256];

/// The largest input dimension the command dispatches to the core.
pub const MAX_DIM: usize = 8;

/// Arguments of `awfqi-harness gp`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// JSON file with the cases: {"cases":[{"name", "x", "y", "signal_variance",
    /// "length_scales", "noise_variance", "x_test"}, …]}. The core takes 1 to 8 input
    /// dimensions and at most 256 training points per case.
    #[arg(long, value_name = "FILE.json")]
    pub cases: PathBuf,
    /// Floating-point type the core computes in.
    #[arg(long, value_enum, default_value_t = Precision::F64)]
    pub precision: Precision,
    /// Compute with the harness's reference GP (f64, heap, plain Cholesky) instead of the
    /// core.
    #[arg(long, conflicts_with = "precision")]
    pub reference: bool,
    /// With --reference: add this much to the training diagonal beyond the noise variance,
    /// to reproduce a core fit that reported this jitter.
    #[arg(long, requires = "reference", value_name = "J")]
    pub jitter: Option<f64>,
    /// Core: factorise K + σ²ₙI without the base jitter 1e-10 (the exact model asked for).
    #[arg(long, conflicts_with = "reference")]
    pub no_base_jitter: bool,
    /// Core: the largest escalated jitter relative to σ²ₙ + base jitter (default √ε of the
    /// precision; 0 forbids escalation, inf allows the whole ladder). A fit that needs more
    /// is an error naming the jitter it needed.
    #[arg(long, conflicts_with = "reference", value_name = "RATIO")]
    pub max_jitter_ratio: Option<f64>,
    /// Core: the largest trusted condition estimate (default 1e-2/ε of the precision).
    #[arg(long, conflicts_with = "reference", value_name = "KAPPA")]
    pub max_condition: Option<f64>,
    /// Write the JSON here instead of standard output.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// Floating-point type of the core.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// 64-bit (the host default).
    F64,
    /// 32-bit (the microcontroller default).
    F32,
}

/// Who computes a case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Engine {
    /// The core `awfqi::gp::Gp` in the given precision, under a conditioning policy.
    Core(Precision, ConditioningOptions),
    /// The reference GP, with `extra_diagonal` added to the training diagonal.
    Reference {
        /// Added to the diagonal beyond the noise variance (≥ 0).
        extra_diagonal: f64,
    },
}

/// One regression case of the input file.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Case {
    /// Name echoed in the output.
    pub name: String,
    /// Training inputs, `N` rows of `D` coordinates.
    pub x: Vec<Vec<f64>>,
    /// Training targets, `N` values.
    pub y: Vec<f64>,
    /// Signal variance `c`.
    pub signal_variance: f64,
    /// Length scales, one per dimension (their count is `D`).
    pub length_scales: Vec<f64>,
    /// Noise variance `s2` (training diagonal only).
    pub noise_variance: f64,
    /// Test inputs, `M` rows of `D` coordinates.
    pub x_test: Vec<Vec<f64>>,
}

impl Case {
    /// The hyperparameters in the reference GP's form.
    pub fn reference_hyperparameters(&self) -> ReferenceHyperparameters {
        ReferenceHyperparameters {
            signal_variance: self.signal_variance,
            length_scales: self.length_scales.clone(),
            noise_variance: self.noise_variance,
        }
    }
}

/// The numbers computed for one case.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Fit {
    /// Predictive mean at each test input.
    pub mean: Vec<f64>,
    /// Latent (noise-free) predictive standard deviation at each test input.
    pub std: Vec<f64>,
    /// Log marginal likelihood of the training data.
    pub log_marginal_likelihood: f64,
    /// Added to the training diagonal beyond the noise variance.
    pub jitter: f64,
}

/// Why a case could not be computed.
#[derive(Clone, Debug, PartialEq)]
pub enum CaseError {
    /// The case is malformed or outside what the command supports (dimension, capacity,
    /// mismatched lengths), found before the core is called.
    Unsupported(String),
    /// The core returned this error.
    Core(awfqi::Error),
    /// The reference GP returned this error.
    Reference(String),
}

impl fmt::Display for CaseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CaseError::Unsupported(message) | CaseError::Reference(message) => f.write_str(message),
            CaseError::Core(error) => write!(f, "{error}"),
        }
    }
}

impl std::error::Error for CaseError {}

/// One case of the output: its numbers or its error.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(untagged)]
pub enum CaseOutput {
    /// The case was computed.
    Fit {
        /// The case's name.
        name: String,
        /// Its numbers.
        #[serde(flatten)]
        fit: Fit,
    },
    /// The case could not be computed.
    Failed {
        /// The case's name (or `#i` when the case had none).
        name: String,
        /// What went wrong.
        error: String,
    },
}

/// The whole output document.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct OutputFile {
    /// One entry per input case, in input order.
    pub cases: Vec<CaseOutput>,
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let engine = if args.reference {
        Engine::Reference {
            extra_diagonal: args.jitter.unwrap_or(0.0),
        }
    } else {
        Engine::Core(
            args.precision,
            ConditioningOptions {
                base_jitter: !args.no_base_jitter,
                max_jitter_ratio: args.max_jitter_ratio,
                max_condition: args.max_condition,
            },
        )
    };
    let text = std::fs::read_to_string(&args.cases)
        .with_context(|| format!("reading {}", args.cases.display()))?;
    check_document(&text).with_context(|| format!("{}", args.cases.display()))?;
    let output = run_json(&text, engine)?;
    let json = serde_json::to_string_pretty(&output)?;
    match &args.out {
        Some(path) => std::fs::write(path, json + "\n")
            .with_context(|| format!("writing {}", path.display()))?,
        None => println!("{json}"),
    }
    let failed: Vec<&str> = output
        .cases
        .iter()
        .filter_map(|c| match c {
            CaseOutput::Failed { name, .. } => Some(name.as_str()),
            CaseOutput::Fit { .. } => None,
        })
        .collect();
    if !failed.is_empty() {
        anyhow::bail!(
            "{} of {} case(s) failed: {} (each has an `error` entry in the output)",
            failed.len(),
            output.cases.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// Checks a case file strictly before anything is computed: every case must have every
/// field with the right type (serde's message names the field, the line and the column).
/// The command refuses such a file; [`run_json`] (the library) keeps turning a malformed
/// case into an `error` entry.
pub fn check_document(text: &str) -> anyhow::Result<()> {
    #[derive(Deserialize)]
    #[allow(dead_code)]
    struct Strict {
        cases: Vec<Case>,
    }
    let doc: Strict = serde_json::from_str(text).map_err(|e| {
        anyhow::anyhow!(
            "line {}, column {}: {e} (the input must be {{\"cases\":[{{\"name\", \"x\", \"y\", \
             \"signal_variance\", \"length_scales\", \"noise_variance\", \"x_test\"}}, …]}})",
            e.line(),
            e.column()
        )
    })?;
    // Shapes the core cannot take (dimension, capacity) stay per-case `error` entries.
    drop(doc);
    Ok(())
}

/// Computes every case of an input document. Fails only when the document is not
/// `{"cases":[…]}`; a malformed or failing case becomes an `error` entry.
pub fn run_json(text: &str, engine: Engine) -> anyhow::Result<OutputFile> {
    #[derive(Deserialize)]
    struct Input {
        cases: Vec<serde_json::Value>,
    }
    let input: Input = serde_json::from_str(text).context("the input must be {\"cases\":[…]}")?;
    let cases = input
        .cases
        .into_iter()
        .enumerate()
        .map(|(i, value)| {
            let fallback_name = value
                .get("name")
                .and_then(|n| n.as_str())
                .map_or_else(|| format!("#{i}"), str::to_owned);
            match serde_json::from_value::<Case>(value) {
                Ok(case) => run_case(&case, engine),
                Err(error) => CaseOutput::Failed {
                    name: fallback_name,
                    error: format!("malformed case: {error}"),
                },
            }
        })
        .collect();
    Ok(OutputFile { cases })
}

/// Computes one case with `engine`, turning an error into an `error` entry.
pub fn run_case(case: &Case, engine: Engine) -> CaseOutput {
    let result = match engine {
        Engine::Core(precision, policy) => fit_core_under(case, precision, &policy),
        Engine::Reference { extra_diagonal } => fit_reference(case, extra_diagonal),
    };
    match result {
        Ok(fit) => CaseOutput::Fit {
            name: case.name.clone(),
            fit,
        },
        Err(error) => CaseOutput::Failed {
            name: case.name.clone(),
            error: error.to_string(),
        },
    }
}

/// Computes a case with the reference GP, `extra_diagonal` added to the training diagonal.
pub fn fit_reference(case: &Case, extra_diagonal: f64) -> Result<Fit, CaseError> {
    let hyper = case.reference_hyperparameters();
    let gp = ReferenceGp::fit_with_diagonal(&case.x, &case.y, &hyper, extra_diagonal)
        .map_err(CaseError::Reference)?;
    let mut mean = Vec::with_capacity(case.x_test.len());
    let mut std = Vec::with_capacity(case.x_test.len());
    for (i, point) in case.x_test.iter().enumerate() {
        gp.check_point(point)
            .map_err(|e| CaseError::Reference(format!("x_test[{i}]: {e}")))?;
        let (m, v) = gp.predict(point);
        mean.push(m);
        std.push(v.sqrt());
    }
    let log_marginal_likelihood = gp.log_marginal_likelihood();
    if !(log_marginal_likelihood.is_finite() && mean.iter().all(|m| m.is_finite())) {
        return Err(CaseError::Reference(
            "`y` is too large for f64: the log marginal likelihood or a mean overflows".into(),
        ));
    }
    Ok(Fit {
        mean,
        std,
        log_marginal_likelihood,
        jitter: extra_diagonal,
    })
}

/// Computes a case with the core in `precision`, choosing the capacity that fits.
///
/// The case is checked first (dimension in `1..=MAX_DIM`, row lengths, `y` length, at most
/// the largest of [`CAPACITIES`] points); everything else (values, hyperparameters, a
/// matrix that is not positive definite) is left to the core, whose error is returned as
/// [`CaseError::Core`]. With `f32` the inputs are rounded to `f32` first and the outputs
/// widened back to `f64` exactly.
pub fn fit_core(case: &Case, precision: Precision) -> Result<Fit, CaseError> {
    fit_core_under(case, precision, &ConditioningOptions::default())
}

/// The core GP's conditioning policy for a case (`awfqi::gp::Conditioning`, in f64 so one
/// value serves both precisions): base jitter on or off, the largest escalated jitter
/// relative to the noise variance and the largest trusted condition estimate (`None`: the
/// precision's default).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConditioningOptions {
    /// Add the base jitter `1e-10` (the reference's `alpha`).
    pub base_jitter: bool,
    /// `Conditioning::with_max_jitter_ratio`, when set.
    pub max_jitter_ratio: Option<f64>,
    /// `Conditioning::with_max_condition`, when set.
    pub max_condition: Option<f64>,
}

impl Default for ConditioningOptions {
    fn default() -> Self {
        Self {
            base_jitter: true,
            max_jitter_ratio: None,
            max_condition: None,
        }
    }
}

impl ConditioningOptions {
    fn conditioning<T: Real>(&self) -> awfqi::Result<Conditioning<T>> {
        let mut c = Conditioning::DEFAULT;
        if !self.base_jitter {
            c = c.without_base_jitter();
        }
        if let Some(r) = self.max_jitter_ratio {
            c = c.with_max_jitter_ratio(T::from_f64(r))?;
        }
        if let Some(k) = self.max_condition {
            c = c.with_max_condition(T::from_f64(k))?;
        }
        Ok(c)
    }
}

/// [`fit_core`] under [`ConditioningOptions`].
pub fn fit_core_under(
    case: &Case,
    precision: Precision,
    policy: &ConditioningOptions,
) -> Result<Fit, CaseError> {
    check_shape(case)?;
    let capacity = capacity_for(case.x.len())?;
    match precision {
        Precision::F64 => dispatch_dimension::<f64>(case, capacity, policy),
        Precision::F32 => dispatch_dimension::<f32>(case, capacity, policy),
    }
}

/// The smallest capacity of [`CAPACITIES`] that holds `n` points (an empty case takes the
/// smallest and gets the core's `EmptyData` error).
pub fn capacity_for(n: usize) -> Result<usize, CaseError> {
    CAPACITIES
        .iter()
        .copied()
        .find(|&capacity| capacity >= n)
        .ok_or_else(|| {
            CaseError::Unsupported(format!(
                "{n} training points exceed the largest built-in capacity, {}",
                CAPACITIES[CAPACITIES.len() - 1]
            ))
        })
}

/// Checks the lengths the const-generic core cannot be called with otherwise.
fn check_shape(case: &Case) -> Result<(), CaseError> {
    let d = case.length_scales.len();
    if !(1..=MAX_DIM).contains(&d) {
        return Err(CaseError::Unsupported(format!(
            "{d} length scales: the input dimension must be 1 to {MAX_DIM}"
        )));
    }
    if case.y.len() != case.x.len() {
        return Err(CaseError::Unsupported(format!(
            "{} training inputs but {} targets",
            case.x.len(),
            case.y.len()
        )));
    }
    for (field, rows) in [("x", &case.x), ("x_test", &case.x_test)] {
        if let Some((i, row)) = rows.iter().enumerate().find(|(_, row)| row.len() != d) {
            return Err(CaseError::Unsupported(format!(
                "{field}[{i}] has {} coordinates, expected {d} (the number of length scales)",
                row.len()
            )));
        }
    }
    Ok(())
}

fn dispatch_dimension<T: Real>(
    case: &Case,
    capacity: usize,
    policy: &ConditioningOptions,
) -> Result<Fit, CaseError> {
    match case.length_scales.len() {
        1 => dispatch_capacity::<T, 1>(case, capacity, policy),
        2 => dispatch_capacity::<T, 2>(case, capacity, policy),
        3 => dispatch_capacity::<T, 3>(case, capacity, policy),
        4 => dispatch_capacity::<T, 4>(case, capacity, policy),
        5 => dispatch_capacity::<T, 5>(case, capacity, policy),
        6 => dispatch_capacity::<T, 6>(case, capacity, policy),
        7 => dispatch_capacity::<T, 7>(case, capacity, policy),
        8 => dispatch_capacity::<T, 8>(case, capacity, policy),
        d => Err(CaseError::Unsupported(format!(
            "input dimension {d} is not supported (1 to {MAX_DIM})"
        ))),
    }
}

fn dispatch_capacity<T: Real, const D: usize>(
    case: &Case,
    capacity: usize,
    policy: &ConditioningOptions,
) -> Result<Fit, CaseError> {
    match capacity {
        16 => on_large_stack::<T, 16, D>(case, policy),
        32 => on_large_stack::<T, 32, D>(case, policy),
        64 => on_large_stack::<T, 64, D>(case, policy),
        128 => on_large_stack::<T, 128, D>(case, policy),
        256 => on_large_stack::<T, 256, D>(case, policy),
        n => Err(CaseError::Unsupported(format!("no built-in capacity {n}"))),
    }
}

/// Stack of the thread a case runs on, beyond the room for the GP itself.
const BASE_STACK_BYTES: usize = 4 << 20;

/// Runs the case on a thread whose stack holds several copies of `Gp<T, N, D>`.
///
/// The core's `Gp` is a plain value (up to 512 KiB of matrix for `N = 256` in f64) and
/// `Gp::new` returns it by value, so it cannot be built straight into a `Box`; an
/// unoptimised build moves it through several stack temporaries. Instead of relying on the
/// optimiser, each case runs on its own thread with `BASE_STACK_BYTES` plus eight times
/// the GP's size of stack, in debug and release alike.
fn on_large_stack<T: Real, const N: usize, const D: usize>(
    case: &Case,
    policy: &ConditioningOptions,
) -> Result<Fit, CaseError> {
    let stack = BASE_STACK_BYTES + 8 * std::mem::size_of::<Gp<T, N, D>>();
    std::thread::scope(|scope| {
        let worker = std::thread::Builder::new()
            .name(format!("gp-case-{N}x{D}"))
            .stack_size(stack)
            .spawn_scoped(scope, || fit_core_with::<T, N, D>(case, policy))
            .map_err(|e| CaseError::Unsupported(format!("could not start a worker thread: {e}")))?;
        worker
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })
}

/// Fits `Gp<T, N, D>` to the case and predicts at every test input.
fn fit_core_with<T: Real, const N: usize, const D: usize>(
    case: &Case,
    policy: &ConditioningOptions,
) -> Result<Fit, CaseError> {
    let to_point = |row: &[f64]| -> [T; D] { std::array::from_fn(|d| T::from_f64(row[d])) };
    let hyper = Hyperparameters {
        signal_variance: T::from_f64(case.signal_variance),
        length_scales: to_point(&case.length_scales),
        noise_variance: T::from_f64(case.noise_variance),
    };
    let x: Vec<[T; D]> = case.x.iter().map(|row| to_point(row)).collect();
    let y: Vec<T> = case.y.iter().map(|&v| T::from_f64(v)).collect();
    let mut gp = Gp::<T, N, D>::new(hyper).map_err(CaseError::Core)?;
    gp.set_conditioning(policy.conditioning().map_err(CaseError::Core)?)
        .map_err(CaseError::Core)?;
    gp.fit(&x, &y).map_err(CaseError::Core)?;
    let log_marginal_likelihood = gp.log_marginal_likelihood().map_err(CaseError::Core)?;
    let mut mean = Vec::with_capacity(case.x_test.len());
    let mut std = Vec::with_capacity(case.x_test.len());
    for row in &case.x_test {
        let prediction = gp.predict(&to_point(row)).map_err(CaseError::Core)?;
        mean.push(prediction.mean.to_f64());
        std.push(prediction.latent_variance.to_f64().max(0.0).sqrt());
    }
    Ok(Fit {
        mean,
        std,
        log_marginal_likelihood: log_marginal_likelihood.to_f64(),
        jitter: gp.jitter().to_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(n: usize, d: usize) -> Case {
        let x: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..d).map(|k| (i * (k + 1)) as f64 * 0.1).collect())
            .collect();
        Case {
            name: format!("{n}x{d}"),
            y: x.iter().map(|p| p[0].cos()).collect(),
            x,
            signal_variance: 1.0,
            length_scales: vec![2.0; d],
            noise_variance: 0.1,
            x_test: vec![vec![0.25; d]],
        }
    }

    #[test]
    fn capacity_is_the_smallest_that_fits() {
        assert_eq!(capacity_for(0), Ok(16));
        assert_eq!(capacity_for(16), Ok(16));
        assert_eq!(capacity_for(17), Ok(32));
        assert_eq!(capacity_for(129), Ok(256));
        assert_eq!(capacity_for(256), Ok(256));
        assert!(matches!(capacity_for(257), Err(CaseError::Unsupported(_))));
    }

    /// The largest GP (256 points, 8 dimensions, f64) is fitted from a thread with a small
    /// stack: the case runs on its own big-stack thread, in debug builds too.
    #[test]
    fn largest_gp_runs_from_a_small_stack() {
        let big = case(256, 8);
        let fit = std::thread::Builder::new()
            .stack_size(256 << 10)
            .spawn(move || fit_core(&big, Precision::F64))
            .unwrap()
            .join()
            .unwrap()
            .unwrap();
        let reference = fit_reference(&case(256, 8), fit.jitter).unwrap();
        let scale = 1.0;
        assert!((fit.mean[0] - reference.mean[0]).abs() <= 1e-9 * scale);
        assert!((fit.std[0] - reference.std[0]).abs() <= 1e-9 * scale);
    }

    #[test]
    fn shapes_outside_the_dispatch_are_errors() {
        let mut c = case(3, 2);
        c.length_scales = vec![1.0; MAX_DIM + 1];
        c.x = vec![vec![0.0; MAX_DIM + 1]; 3];
        c.x_test = vec![vec![0.0; MAX_DIM + 1]];
        assert!(matches!(
            fit_core(&c, Precision::F64),
            Err(CaseError::Unsupported(_))
        ));
        let mut c = case(3, 2);
        c.x_test = vec![vec![0.0; 3]];
        assert!(matches!(
            fit_core(&c, Precision::F32),
            Err(CaseError::Unsupported(_))
        ));
        let mut c = case(3, 2);
        c.y.pop();
        assert!(matches!(
            fit_core(&c, Precision::F64),
            Err(CaseError::Unsupported(_))
        ));
    }

    #[test]
    fn core_errors_are_typed() {
        let mut c = case(3, 1);
        c.y[1] = f64::NAN;
        assert!(matches!(
            fit_core(&c, Precision::F64),
            Err(CaseError::Core(awfqi::Error::NonFinite { .. }))
        ));
        let c = case(0, 1);
        assert_eq!(
            fit_core(&c, Precision::F64),
            Err(CaseError::Core(awfqi::Error::EmptyData))
        );
    }
}
