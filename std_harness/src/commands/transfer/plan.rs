//! What one invocation of a transfer command computes, decided before any run starts: the
//! experiment, the output directory opened for its configuration, the runs to compute
//! (the longest first) and the runs kept because a result file already holds them.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, bail};
use awfqi::env::Dynamics;

use crate::domains::Domain;
use crate::transfer::algorithms::{Algorithm, Experiment};
use crate::transfer::domain_data::DomainData;
use crate::transfer::protocol;
use crate::transfer::result_dir::ResultDir;

use super::{Config, EmbeddedPath, build_experiment};

/// The plan of one invocation.
pub(super) struct Plan<const D: usize> {
    /// The experiment every run shares.
    pub experiment: Experiment<D>,
    /// The output directory, opened for this configuration.
    pub store: ResultDir,
    /// The runs to compute, `(algorithm, run index)`, the costliest algorithms first.
    pub jobs: Vec<(Algorithm, usize)>,
    /// The runs skipped because the directory holds them (none with `--replace`).
    pub kept: BTreeMap<Algorithm, Vec<usize>>,
}

impl<const D: usize> Plan<D> {
    /// Builds the experiment of `config`, opens `--out` for it (every result file there
    /// must hold this configuration, else nothing is written) and lists the runs to
    /// compute; with `--no-run`, none.
    ///
    /// Errors: no algorithm, those of [`build_experiment`], an output directory that cannot
    /// be written or holds another configuration.
    pub fn new(
        config: &Config,
        domain: Arc<Domain<D>>,
        data: Arc<DomainData<D>>,
        dynamics: Option<Dynamics>,
        embedded: Option<EmbeddedPath<D>>,
    ) -> anyhow::Result<Self> {
        let args = &config.args;
        if config.algorithms.is_empty() {
            bail!("--algorithms needs at least one algorithm");
        }
        let (algorithms, runs): (Vec<Algorithm>, Vec<usize>) = if args.no_run {
            (Vec::new(), Vec::new())
        } else {
            (
                config.algorithms.clone(),
                (config.runs.start..config.runs.end).collect(),
            )
        };
        let build = Config {
            algorithms,
            ..config.clone()
        };
        let experiment = build_experiment(&build, domain, data, dynamics, embedded)?;
        ensure_writable(&config.out)?;
        let json = experiment_json(config, &experiment);
        // Before any run: every result file in --out must hold this configuration.
        let parameters = build
            .algorithms
            .iter()
            .map(|&a| (a, experiment.parameters(a)))
            .collect();
        let (store, notes) = ResultDir::open(
            &config.out,
            json,
            parameters,
            &runs,
            &args.command,
            args.replace,
        )?;
        for note in &notes {
            eprintln!("note: {note}");
        }
        let mut kept: BTreeMap<Algorithm, Vec<usize>> = BTreeMap::new();
        let mut jobs: Vec<(Algorithm, usize)> = Vec::new();
        for &a in &build.algorithms {
            for &r in &runs {
                if !store.replaces() && store.present(a).is_some_and(|p| p.contains(&r)) {
                    kept.entry(a).or_default().push(r);
                } else {
                    jobs.push((a, r));
                }
            }
        }
        jobs.sort_by_key(|&(a, r)| (cost_rank(a), r));
        Ok(Self {
            experiment,
            store,
            jobs,
            kept,
        })
    }
}

/// The configuration every run of a file shares (runs merge only when it is equal).
fn experiment_json<const D: usize>(
    config: &Config,
    experiment: &Experiment<D>,
) -> serde_json::Value {
    let mut json = serde_json::json!({
        "environment": experiment.domain.name,
        "setting": config.setting.name(),
        "sources": experiment.sources.origin,
        "source_records": experiment.sources.sources.iter().map(|s| s.len()).collect::<Vec<_>>(),
        "seed": config.args.seed,
        "protocol": experiment.protocol,
        "options": experiment.options,
        "score_spacing": config.spacing,
    });
    if let Some(d) = experiment.protocol.dynamics {
        json["dynamics"] = protocol::dynamics_name::name(d).into();
    }
    json
}

/// Rough cost order, so the longest runs start first.
fn cost_rank(a: Algorithm) -> usize {
    match a {
        Algorithm::Iwfqi | Algorithm::IwfqiHeuristic | Algorithm::AwfqiAdaptive => 0,
        Algorithm::Awfqi | Algorithm::AwfqiOracle => 1,
        Algorithm::Sdt | Algorithm::IwfqiIdeal | Algorithm::Rbt => 2,
        Algorithm::Fqi => 3,
        Algorithm::AwfqiEmbedded => 4,
    }
}

/// Creates `out` and checks that a file can be written in it, before any run starts (and
/// after every check that can refuse the invocation, so a refusal creates no directory).
pub fn ensure_writable(out: &Path) -> anyhow::Result<()> {
    if out.exists() && !out.is_dir() {
        bail!(
            "output directory {}: it exists and is not a directory",
            out.display()
        );
    }
    std::fs::create_dir_all(out)
        .with_context(|| format!("output directory {}: cannot be created", out.display()))?;
    // One probe per process: writers sharing the directory must not remove each other's.
    let probe = out.join(format!(".awfqi-write-probe.{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("output directory {}: cannot be written", out.display()))?;
    std::fs::remove_file(&probe).with_context(|| {
        format!(
            "output directory {}: cannot remove {}",
            out.display(),
            probe.display()
        )
    })
}
