//! The experiment a transfer command runs: its source data, protocol, options, score
//! tables, ideal weights and the embedded set-up, built once and shared by every run.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use awfqi::env::Dynamics;
use awfqi::model::Transition;
use awfqi::weights::NoiseSubtraction;
use rand_chacha::ChaCha8Rng;

use crate::domains::Domain;
use crate::transfer::algorithms::embedded::adaptive::AdaptiveOptions;
use crate::transfer::algorithms::embedded::{EmbeddedConfig, EmbeddedDomain, SharedSetup};
use crate::transfer::algorithms::{Algorithm, Experiment, TransferOptions};
use crate::transfer::domain_data::DomainData;
use crate::transfer::protocol::Protocol;
use crate::transfer::score_tables::{self, ScoreTableData};
use crate::transfer::sources::{SourceDataset, SourceSet};
use crate::transfer::{IDEAL_WEIGHTS, SCORE_TABLE, stream};

use super::Config;
use super::args::NoiseArg;

/// The core's algorithms on a domain: their set-up on the domain's plant and the
/// configuration the command line chose.
#[derive(Debug, Clone, Copy)]
pub struct EmbeddedPath<const D: usize> {
    /// Builds the shared set-up on the domain's plant from the sources, the configuration
    /// (its score table's mode and spacing set from the experiment's), the domain and a
    /// stream: [`OnPlant::shared`](crate::transfer::algorithms::embedded::OnPlant::shared)
    /// of the plant and its dimensions.
    pub setup: SetupFn<D>,
    /// What the core's algorithms need to know of the domain.
    pub domain: EmbeddedDomain<D>,
    /// The approximators.
    pub config: EmbeddedConfig,
    /// `awfqi-adaptive`'s loop.
    pub adaptive: AdaptiveOptions,
}

/// Builds an [`EmbeddedPath`]'s shared set-up.
pub type SetupFn<const D: usize> = fn(
    &SourceSet<D>,
    EmbeddedConfig,
    EmbeddedDomain<D>,
    &mut ChaCha8Rng,
) -> anyhow::Result<Arc<dyn SharedSetup<D>>>;

/// Source data generated earlier in this process, by what determines them (domain, seed,
/// generation, GP options): the same data, so a process that runs one domain at several
/// schedules (`awfqi-harness suite`) generates them once. States are kept as slices, so one
/// cache serves every state dimension and a set comes back only at the dimension it has.
static GENERATED: std::sync::Mutex<Vec<Generated>> = std::sync::Mutex::new(Vec::new());

/// A record's state and next state, whatever the dimension.
type StatePair = (Vec<f64>, Vec<f64>);

/// One cached set: its key, the set without states, and each source's states.
type Generated = (String, SourceSet<0>, Vec<Vec<StatePair>>);

/// `set` with its states moved out as slices (the records keep zero-length states).
fn erase<const D: usize>(set: &SourceSet<D>) -> (SourceSet<0>, Vec<Vec<StatePair>>) {
    let states = set
        .sources
        .iter()
        .map(|s| {
            s.records
                .iter()
                .map(|r| (r.state.to_vec(), r.next_state.to_vec()))
                .collect()
        })
        .collect();
    let sources = set
        .sources
        .iter()
        .map(|s| SourceDataset {
            times: s.times.clone(),
            records: s
                .records
                .iter()
                .map(|r| Transition {
                    state: [],
                    action: r.action,
                    reward: r.reward,
                    next_state: [],
                    absorbing: r.absorbing,
                })
                .collect(),
            reward: s.reward.clone(),
            next_state: s.next_state.clone(),
        })
        .collect();
    let origin = set.origin.clone();
    (SourceSet { sources, origin }, states)
}

/// The set [`erase`] took apart, if its states have `D` coordinates.
fn restore<const D: usize>(set: &SourceSet<0>, states: &[Vec<StatePair>]) -> Option<SourceSet<D>> {
    let sources = set
        .sources
        .iter()
        .zip(states)
        .map(|(s, pairs)| {
            let records = s
                .records
                .iter()
                .zip(pairs)
                .map(|(r, (state, next))| {
                    Some(Transition {
                        state: <[f64; D]>::try_from(state.as_slice()).ok()?,
                        action: r.action,
                        reward: r.reward,
                        next_state: <[f64; D]>::try_from(next.as_slice()).ok()?,
                        absorbing: r.absorbing,
                    })
                })
                .collect::<Option<Vec<_>>>()?;
            Some(SourceDataset {
                times: s.times.clone(),
                records,
                reward: s.reward.clone(),
                next_state: s.next_state.clone(),
            })
        })
        .collect::<Option<Vec<_>>>()?;
    Some(SourceSet {
        sources,
        origin: set.origin.clone(),
    })
}

/// The data generated under `key`, from the cache or by `generate`.
fn generated<const D: usize>(
    key: &str,
    generate: impl FnOnce() -> anyhow::Result<SourceSet<D>>,
) -> anyhow::Result<SourceSet<D>> {
    let cached = GENERATED.lock().ok().and_then(|cache| {
        cache
            .iter()
            .filter(|(k, _, _)| k == key)
            .find_map(|(_, set, states)| restore(set, states))
    });
    if let Some(set) = cached {
        return Ok(set);
    }
    let set = generate()?;
    if let Ok(mut cache) = GENERATED.lock() {
        let (erased, states) = erase(&set);
        cache.push((key.to_string(), erased, states));
    }
    Ok(set)
}

/// The source datasets `--sources` names.
fn load_sources<const D: usize>(
    config: &Config,
    domain: &Domain<D>,
    data: &DomainData<D>,
) -> anyhow::Result<SourceSet<D>> {
    let args = &config.args;
    match args.sources.as_str() {
        "published" => (data.published)(),
        "generate" => {
            let generation = data.generation.with_budget(config.iterations, config.trees);
            eprintln!("generating source data ({generation:?})…");
            let start = Instant::now();
            let key = format!(
                "{} {} {generation:?} {:?}",
                domain.name,
                args.seed,
                config.gp()
            );
            let set = generated(&key, || {
                crate::transfer::sources::generate(
                    domain,
                    &data.weighting,
                    &data.layout,
                    &generation,
                    &config.gp(),
                    args.seed,
                )
            })?;
            let dir = config.out.join("sources");
            set.write_dir(&dir, &data.layout)?;
            eprintln!(
                "source data: {:?} records, written to {} ({:.1} s)",
                set.sources.iter().map(|s| s.len()).collect::<Vec<_>>(),
                dir.display(),
                start.elapsed().as_secs_f64()
            );
            Ok(set)
        }
        dir => SourceSet::read_layout(
            Path::new(dir),
            &data.layout,
            domain.sources.len(),
            domain.num_actions(),
        ),
    }
}

/// Builds the shared experiment context (sources, score tables, ideal weights, the
/// embedded set-up) for the algorithms of `config`.
pub fn build_experiment<const D: usize>(
    config: &Config,
    domain: Arc<Domain<D>>,
    data: Arc<DomainData<D>>,
    dynamics: Option<Dynamics>,
    embedded: Option<EmbeddedPath<D>>,
) -> anyhow::Result<Experiment<D>> {
    let args = &config.args;
    let sources = Arc::new(load_sources(config, &domain, &data)?);
    let mut protocol = Protocol::published(&domain, config.steps, config.episodes_per_step);
    protocol.dynamics = dynamics;
    protocol.iterations = config.iterations;
    protocol.trees = config.trees;
    protocol.first_step = config.args.first_step.unwrap_or_default();
    protocol.q_function = config.args.q_function.unwrap_or_default();
    protocol.freeze_trees_after = config.args.freeze_trees_after.map(|k| k as usize);
    protocol.regrow_trees_every = config.args.regrow_trees_every.map(|r| r as usize);
    protocol.queries_per_step = config.args.queries_per_step;
    protocol.episode_length = config.args.episode_length;
    anyhow::ensure!(
        protocol.q_function.is_per_action()
            || (D == 2 && config.algorithms.iter().all(|&a| !a.is_active())),
        "--q-function joint (the reference's one forest over state and action value) applies \
         to 2-D states and the episodic baselines (fqi, iwfqi, iwfqi-heuristic, iwfqi-ideal, \
         rbt, sdt): use it on the Dam or Puddle World without the active algorithms"
    );
    let options = TransferOptions {
        variances: args.variances,
        noise: match args.noise {
            NoiseArg::Reference => NoiseSubtraction::Reference,
            NoiseArg::Principled => NoiseSubtraction::Principled,
        },
        gp: config.gp(),
        transition_weights: args.transition_weights,
        rbt_total: config.rbt_total,
        rbt_compliance: args.rbt_compliance,
        ideal_means: args.ideal_means,
        ..TransferOptions::default()
    };
    let wants = |a: Algorithm| config.algorithms.contains(&a);
    let start = Instant::now();
    let oracle_table = if wants(Algorithm::AwfqiOracle) {
        Some(Arc::new(ScoreTableData::oracle(
            &domain,
            config.setting,
            &sources,
            config.spacing,
        )?))
    } else {
        None
    };
    let realistic_table = if wants(Algorithm::Awfqi) {
        let gps = score_tables::fit_source_gps(
            &domain,
            &data.weighting,
            &sources,
            &options.gp,
            args.seed,
        )?;
        Some(Arc::new(ScoreTableData::realistic(
            &domain,
            config.setting,
            &sources,
            &gps,
            config.spacing,
        )?))
    } else {
        None
    };
    let setup = match &embedded {
        Some(e) if config.algorithms.iter().any(|a| a.is_embedded()) => {
            let mut rng = stream(args.seed, &[SCORE_TABLE, 100]);
            let mut c = e.config;
            c.mode = config.setting;
            c.spacing = config.spacing;
            Some((e.setup)(&sources, c, e.domain, &mut rng)?)
        }
        _ => None,
    };
    if oracle_table.is_some() || realistic_table.is_some() || setup.is_some() {
        eprintln!(
            "score tables ({} mode): built in {:.1} s",
            config.setting.name(),
            start.elapsed().as_secs_f64()
        );
    }
    let mut experiment = Experiment {
        domain,
        data,
        protocol,
        sources,
        options,
        oracle_table,
        realistic_table,
        ideal_weights: None,
        embedded: setup,
        adaptive_options: embedded.map_or_else(AdaptiveOptions::default, |e| e.adaptive),
    };
    experiment.variances()?;
    if wants(Algorithm::IwfqiIdeal) {
        let mut rng = stream(args.seed, &[IDEAL_WEIGHTS]);
        let weights = crate::transfer::algorithms::iwfqi::ideal_weights(
            &experiment.domain,
            &experiment.sources,
            experiment.domain.published.ideal_variances,
            experiment.ideal_means(),
            &mut rng,
        )?;
        experiment.ideal_weights = Some(Arc::new(weights));
    }
    Ok(experiment)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_sources_are_computed_once_per_key() {
        let record = |x: f64| Transition {
            state: [x, -x, 0.5],
            action: 2,
            reward: -x,
            next_state: [x + 0.1, -x, 0.25],
            absorbing: x > 1.0,
        };
        let set = || SourceSet::<3> {
            sources: vec![SourceDataset {
                times: vec![0, 1],
                records: vec![record(0.3), record(1.7)],
                reward: vec![awfqi::prelude::Posterior::new(-0.3, 0.1); 2],
                next_state: Vec::new(),
            }],
            origin: "generated (seed 7)".into(),
        };
        let mut calls = 0;
        let mut get = |key: &str| {
            generated(key, || {
                calls += 1;
                Ok(set())
            })
            .unwrap()
        };
        assert_eq!(get("test: a"), set());
        assert_eq!(get("test: a"), set());
        assert_eq!(get("test: b"), set());
        assert_eq!(calls, 2);
        // The same key at another dimension is not these data: generated anew.
        let other = generated::<2>("test: a", || {
            Ok(SourceSet {
                sources: Vec::new(),
                origin: "two".into(),
            })
        })
        .unwrap();
        assert_eq!(other.origin, "two");
    }
}
