//! One FQI step of the Dam IWFQI configuration on one core: the union of step 1's target
//! episode and the 64 800 published source records with IWFQI's reward and transition
//! weights (the run's own collection and target GPs, `--seed`/`--run` as the `dam`
//! command), fitted as `dam --algorithms iwfqi --q-function joint` does (one 100-tree
//! forest over storage, day and release, `min_samples_split` 20, 60 iterations).
//!
//! `cargo run --release -p awfqi-harness --example dam_fqi_step -- [--iterations N]
//! [--freeze-trees-after K] [--write-inputs FILE] [--seed S] [--run R]`
//!
//! Prints the records, the options and the CPU time of the FQI call alone (this thread's,
//! from `/proc/thread-self/schedstat`; wall time where that is missing), and a
//! fingerprint of the fitted Q at the records (equal fingerprints: equal bits).
//! `--write-inputs` writes the weighted records as CSV for `scripts/fqi-vs-sklearn`,
//! which fits scikit-learn's Extra-Trees on the same records beside this.

use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use awfqi::env::DAM_RELEASES;
use awfqi::weights::Estimator;
use awfqi_harness::commands::{dam, transfer};
use awfqi_harness::forest_fqi::FqiOptions;
use awfqi_harness::joint_q::fqi_joint;
use awfqi_harness::transfer::algorithms::Algorithm;
use awfqi_harness::transfer::algorithms::iwfqi::Iwfqi;
use awfqi_harness::transfer::{RUN, stream};
use clap::Parser;

/// The example's options.
#[derive(Parser)]
struct Cli {
    /// Experiment seed (as `dam --seed`).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Run index whose step 1 is fitted.
    #[arg(long, default_value_t = 0)]
    run: usize,
    /// FQI iterations.
    #[arg(long, default_value_t = 60)]
    iterations: usize,
    /// Keep the trees of this iteration (as `dam --freeze-trees-after`).
    #[arg(long)]
    freeze_trees_after: Option<usize>,
    /// Write the weighted records here (CSV).
    #[arg(long)]
    write_inputs: Option<PathBuf>,
}

/// The `dam` command's arguments.
#[derive(Parser)]
struct DamCommand {
    #[command(flatten)]
    args: dam::Args,
}

/// This thread's CPU time in seconds, or `None` off Linux.
fn thread_cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let seed = cli.seed.to_string();
    let command = DamCommand::parse_from([
        "dam",
        "--algorithms",
        "iwfqi",
        "--q-function",
        "joint",
        "--steps",
        "1",
        "--seed",
        &seed,
    ]);
    let domain = awfqi_harness::domains::dam::domain();
    let config = transfer::Config::resolve(
        &command.args.common,
        command.args.fixed_gp,
        &domain,
        &[Algorithm::Iwfqi],
    )?;
    let data = awfqi_harness::transfer::domain_data::dam::data();
    let experiment =
        transfer::build_experiment(&config, Arc::new(domain), Arc::new(data), None, None)?;
    let gp = experiment
        .options
        .gp
        .resolved(experiment.default_search(Algorithm::Iwfqi));
    let mut learner = Iwfqi::estimated(&experiment, Estimator::Mean, None, gp)?;
    let mut rng = stream(cli.seed, &[RUN, Algorithm::Iwfqi.id(), cli.run as u64]);
    let (data, wr, ws, _) = learner.collect_weighted(&mut rng)?;

    if let Some(path) = &cli.write_inputs {
        let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
        writeln!(
            out,
            "storage,day,release,reward,next_storage,next_day,absorbing,reward_weight,transition_weight"
        )?;
        for i in 0..data.len() {
            let (s, t) = (data.states[i], data.next_states[i]);
            writeln!(
                out,
                "{},{},{},{},{},{},{},{},{}",
                s[0],
                s[1],
                DAM_RELEASES[data.actions[i]],
                data.rewards[i],
                t[0],
                t[1],
                u8::from(data.absorbing[i]),
                wr[i],
                ws[i]
            )?;
        }
        out.flush()?;
    }

    let protocol = &experiment.protocol;
    let options = FqiOptions {
        iterations: cli.iterations,
        n_trees: protocol.trees,
        tree: protocol.tree,
        gamma: experiment.domain.discount,
        num_actions: DAM_RELEASES.len(),
        freeze_after: cli.freeze_trees_after,
        ..FqiOptions::iwfqi(&wr, &ws)
    };
    let (cpu0, wall0) = (thread_cpu_seconds(), Instant::now());
    let q = fqi_joint(&data, &options, &DAM_RELEASES, &mut rng)?;
    let wall = wall0.elapsed().as_secs_f64();
    let (seconds, clock) = match (cpu0, thread_cpu_seconds()) {
        (Some(a), Some(b)) => (b - a, "CPU"),
        _ => (wall, "wall"),
    };
    let fingerprint = data.states.iter().fold(0u64, |h, s| {
        (0..DAM_RELEASES.len()).fold(h, |h, a| h.rotate_left(5) ^ q.predict(s, a).to_bits())
    });
    println!(
        "records {} (target {}, zero reward weight {}), trees {}, min_samples_split {}, \
         iterations {}, frozen after {}",
        data.len(),
        data.len() - experiment.sources.total_records(),
        wr.iter().filter(|&&w| w == 0.0).count(),
        options.n_trees,
        options.tree.min_samples_split,
        options.iterations,
        options
            .freeze_after
            .map_or_else(|| "never".to_string(), |k| k.to_string()),
    );
    println!("fqi seconds ({clock}): {seconds:.3}");
    println!("fingerprint {fingerprint:016x}");
    Ok(())
}
