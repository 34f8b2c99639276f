//! Host timing of the core's Extra-Trees Q-function (`awfqi::fqi::TreeFqi`, f32) at the size of
//! `awfqi-adaptive`'s last re-plan on Puddle World: the 1 033 published source records
//! and 300 target records (uniform states and actions, queried from the target), 60 FQI
//! iterations; then greedy decisions at 1 000 uniform states. One thread, one repetition
//! per configuration (the fits take seconds).
//!
//! `cargo run --release -p awfqi-harness --example core_tree_timing`

use std::time::Instant;

use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::model::GenerativeModel;
use awfqi::prelude::{ExtraTrees, FqiConfig, SampleSet, Transition, TreeFqi, TreeNode, TreeRecord};
use awfqi_harness::transfer::sources::SourceSet;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

type R32 = Transition<[f32; 2], f32>;

fn main() -> anyhow::Result<()> {
    let sources = SourceSet::<2>::published(Dynamics::Shared)?;
    let records: Vec<R32> = sources
        .sources
        .iter()
        .flat_map(|s| s.records.iter())
        .map(|r| Transition {
            state: r.state.map(|x| x as f32),
            action: r.action,
            reward: r.reward as f32,
            next_state: r.next_state.map(|x| x as f32),
            absorbing: r.absorbing,
        })
        .collect();
    let world = PuddleWorld::<f32>::target(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let target: Vec<R32> = (0..300)
        .map(|i| {
            let s = [
                awfqi::rng::uniform::<f32, _>(&mut rng) * 10.0,
                awfqi::rng::uniform::<f32, _>(&mut rng) * 10.0,
            ];
            world.query(s, i % 4, &mut rng).expect("a valid query")
        })
        .collect();
    let sets = [
        SampleSet::unweighted(&target),
        SampleSet::unweighted(&records),
    ];
    let n = target.len() + records.len();
    let config = FqiConfig::<f32>::published();
    let states: Vec<[f32; 2]> = (0..1000)
        .map(|_| {
            [
                awfqi::rng::uniform::<f32, _>(&mut rng) * 10.0,
                awfqi::rng::uniform::<f32, _>(&mut rng) * 10.0,
            ]
        })
        .collect();
    println!("{n} records, 4 actions, {} iterations", config.iterations());
    for (name, forests) in [
        ("stored 10 x 255", ExtraTrees::new(10, 255)?),
        ("stored 50 x 2047", ExtraTrees::new(50, 2047)?),
        ("streamed 10, scratch 1023", ExtraTrees::streamed(10, 1023)?),
        ("streamed 20, scratch 1023", ExtraTrees::streamed(20, 1023)?),
        ("streamed 50, scratch 1023", ExtraTrees::streamed(50, 1023)?),
    ] {
        let mut slots = vec![TreeRecord::<f32, 2>::EMPTY; n];
        let mut nodes = vec![TreeNode::<f32>::EMPTY; forests.required_nodes(4).unwrap_or(0)];
        let mut q = TreeFqi::new(forests, 4, &mut slots, &mut nodes)?;
        let t = Instant::now();
        q.fit(&sets, &config, &mut ChaCha8Rng::seed_from_u64(2))?;
        let fit = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut actions = 0usize;
        for s in &states {
            actions += q.greedy_action(*s)?;
        }
        let decide = t.elapsed().as_secs_f64() / states.len() as f64;
        let ram = n * size_of::<TreeRecord<f32, 2>>()
            + forests.required_nodes(4).unwrap_or(0) * size_of::<TreeNode<f32>>();
        println!(
            "{name}: fit {fit:.2} s, greedy decision {:.3} ms, Q memory {ram} B ({actions})",
            decide * 1e3
        );
    }
    Ok(())
}
