//! The `gp` subcommand: Gaussian-process regression cases from a JSON file, computed by the
//! core (`awfqi::gp::Gp`, f64 or f32) or by the harness's reference GP
//! ([`crate::reference::gp`]).
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
//! still run.
//!
//! The core's capacity `N` and dimension `D` are const generics; this command supports
//! `D` in `1..=MAX_DIM` and picks the smallest capacity of [`CAPACITIES`] that holds the
//! case (up to 256 points).

use std::fmt;
use std::path::PathBuf;

use anyhow::Context;
use serde::{Deserialize, Serialize};

use crate::reference::gp::{Hyperparameters as ReferenceHyperparameters, ReferenceGp};

/// The capacities (training points) the command can run the core with; a case uses the
/// smallest one that holds it.
pub const CAPACITIES: [usize; 5] = [16, 32, 64, 128, 256];

/// The largest input dimension the command dispatches to the core.
pub const MAX_DIM: usize = 8;

/// Arguments of `awfqi-harness gp`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// JSON file with the cases: {"cases":[{"name", "x", "y", "signal_variance",
    /// "length_scales", "noise_variance", "x_test"}, …]}.
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
    /// The core `awfqi::gp::Gp` in the given precision.
    Core(Precision),
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
pub struct Output {
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
        Engine::Core(args.precision)
    };
    let text = std::fs::read_to_string(&args.cases)
        .with_context(|| format!("reading {}", args.cases.display()))?;
    let output = run_json(&text, engine)?;
    let json = serde_json::to_string_pretty(&output)?;
    match &args.out {
        Some(path) => std::fs::write(path, json + "\n")
            .with_context(|| format!("writing {}", path.display()))?,
        None => println!("{json}"),
    }
    Ok(())
}

/// Computes every case of an input document. Fails only when the document is not
/// `{"cases":[…]}`; a malformed or failing case becomes an `error` entry.
pub fn run_json(text: &str, engine: Engine) -> anyhow::Result<Output> {
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
    Ok(Output { cases })
}

/// Computes one case with `engine`, turning an error into an `error` entry.
pub fn run_case(case: &Case, engine: Engine) -> CaseOutput {
    let result = match engine {
        Engine::Core(precision) => fit_core(case, precision),
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
    Ok(Fit {
        mean,
        std,
        log_marginal_likelihood: gp.log_marginal_likelihood(),
        jitter: extra_diagonal,
    })
}

/// Computes a case with the core in `precision`, choosing the capacity that fits.
pub fn fit_core(case: &Case, precision: Precision) -> Result<Fit, CaseError> {
    let _ = (case, precision);
    Err(CaseError::Unsupported(
        "the core GP is not wired in yet".into(),
    ))
}
