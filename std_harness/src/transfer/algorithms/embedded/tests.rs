use std::sync::Arc;

use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::model::GenerativeModel;
use awfqi::weights::Posterior;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

use super::adaptive::{AdaptiveOptions, GpCapacity};
use super::{EmbeddedConfig, EmbeddedDomain, OnPlant};
use crate::domains::puddle;
use crate::transfer::algorithms::{Algorithm, Experiment, TransferOptions};
use crate::transfer::domain_data;
use crate::transfer::protocol::{Diagnostics, Protocol};
use crate::transfer::score_tables::Mode;
use crate::transfer::sources::{SourceDataset, SourceSet};

/// Two small sources of Puddle World (shared dynamics): every action from a 4 × 4 grid of
/// states, answered by the sources' own models, with exact reward posteriors.
fn sources() -> SourceSet<2> {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let models = PuddleWorld::<f64>::sources(Dynamics::Shared);
    let sources = models[..2]
        .iter()
        .map(|model| {
            let mut records = Vec::new();
            for i in 0..4 {
                for j in 0..4 {
                    let state = [1.0 + 2.5 * i as f64, 1.0 + 2.5 * j as f64];
                    for action in 0..model.num_actions() {
                        records.push(model.query(state, action, &mut rng).unwrap());
                    }
                }
            }
            SourceDataset {
                times: (0..records.len()).collect(),
                reward: records
                    .iter()
                    .map(|r| Posterior::new(r.reward, 0.1))
                    .collect(),
                records,
                next_state: Vec::new(),
            }
        })
        .collect();
    SourceSet {
        sources,
        origin: "test".into(),
    }
}

/// An experiment of one step of `budget` queries on Puddle World with the embedded set-up
/// (a score table of the source records) and `awfqi-adaptive` at `capacity`.
fn experiment(budget: usize, capacity: GpCapacity) -> Experiment<2> {
    let domain = Arc::new(puddle::domain(Dynamics::Shared));
    let sources = Arc::new(sources());
    let mut protocol = Protocol::published(&domain, 1, 1);
    protocol.dynamics = Some(Dynamics::Shared);
    protocol.queries_per_step = Some(budget);
    let config = EmbeddedConfig::new(Mode::Source, 1.0);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let setup = OnPlant::<PuddleWorld<f32>, 2, 3>::shared(
        &sources,
        config,
        EmbeddedDomain::puddle(),
        &mut rng,
    )
    .unwrap();
    Experiment {
        domain,
        data: Arc::new(domain_data::puddle::data(Dynamics::Shared)),
        protocol,
        sources,
        options: TransferOptions::default(),
        oracle_table: None,
        realistic_table: None,
        ideal_weights: None,
        embedded: Some(setup),
        adaptive_options: AdaptiveOptions {
            gp_points: capacity,
            candidates: 40,
            ..AdaptiveOptions::default()
        },
    }
}

/// One step of `algorithm` on `experiment`: its diagnostics and the target samples it holds.
fn one_step(experiment: &Experiment<2>, algorithm: Algorithm) -> (Diagnostics, usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut out = None;
    experiment
        .with_learner(algorithm, &mut rng, &mut |learner, rng| {
            let diagnostics = learner.step(0, rng)?;
            out = Some((diagnostics, learner.target_samples().len()));
            Ok(())
        })
        .unwrap();
    out.unwrap()
}

#[test]
fn each_adaptive_capacity_runs_a_step_with_target_gps_of_its_size() {
    // More queries than the largest capacity: every target GP is full.
    let budget = 70;
    let shared = experiment(budget, GpCapacity::P16);
    for capacity in GpCapacity::ALL {
        let mut experiment = shared.clone();
        experiment.adaptive_options.gp_points = capacity;
        let (diagnostics, samples) = one_step(&experiment, Algorithm::AwfqiAdaptive);
        assert_eq!(samples, budget, "{capacity}");
        let gp = diagnostics.reward_gp.unwrap();
        assert_eq!(gp.points, capacity.points(), "{capacity}");
        assert!(gp.log_marginal_likelihood.is_finite(), "{capacity}");
        let recorded = experiment.parameters(Algorithm::AwfqiAdaptive);
        assert_eq!(
            recorded["embedded"]["gp_capacity"],
            capacity.points(),
            "{capacity}"
        );
        assert_eq!(
            recorded["adaptive"]["gp_points"],
            capacity.points(),
            "{capacity}"
        );
    }
}

#[test]
fn the_thesis_learner_runs_a_step_on_the_shared_set_up() {
    let experiment = experiment(20, GpCapacity::P16);
    let (diagnostics, samples) = one_step(&experiment, Algorithm::AwfqiEmbedded);
    assert_eq!(samples, 20);
    assert_eq!(diagnostics.reward_gp.unwrap().points, 20);
    // No transition weights unless asked for: every one is 1.
    assert_eq!(diagnostics.ws_mean, Some(1.0));
    let recorded = experiment.parameters(Algorithm::AwfqiEmbedded);
    assert_eq!(recorded["embedded"]["gp_capacity"], super::GP_POINTS);
    assert_eq!(recorded["embedded"]["score_rows"], 2 * 16 * 4);
}

#[test]
fn an_experiment_without_the_set_up_refuses_the_embedded_algorithms() {
    let mut experiment = experiment(4, GpCapacity::P16);
    experiment.embedded = None;
    for algorithm in [Algorithm::AwfqiEmbedded, Algorithm::AwfqiAdaptive] {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let err = experiment
            .with_learner(algorithm, &mut rng, &mut |_, _| Ok(()))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(algorithm.name()) && err.contains("not available"),
            "{err}"
        );
    }
}

#[test]
fn each_capacity_is_chosen_by_its_number_of_points() {
    let points: Vec<usize> = GpCapacity::ALL.iter().map(|c| c.points()).collect();
    assert_eq!(points, [16, 24, 32, 48, 64]);
    for capacity in GpCapacity::ALL {
        let n = capacity.points();
        assert_eq!(GpCapacity::try_from(n).unwrap(), capacity);
        assert_eq!(n.to_string().parse::<GpCapacity>().unwrap(), capacity);
        assert_eq!(capacity.to_string(), n.to_string());
        assert_eq!(serde_json::to_value(capacity).unwrap(), n);
    }
    assert_eq!(AdaptiveOptions::default().gp_points, GpCapacity::P32);
}

#[test]
fn a_capacity_not_built_is_refused_naming_those_that_are() {
    for n in [0, 20, 63, 65, 128] {
        let err = GpCapacity::try_from(n).unwrap_err().to_string();
        assert!(err.contains(&format!("{n} points")), "{err}");
        assert!(err.contains("16, 24, 32, 48, 64"), "{err}");
    }
    let err = "sixteen".parse::<GpCapacity>().unwrap_err().to_string();
    assert!(err.contains("\"sixteen\" is not a number"), "{err}");
}
