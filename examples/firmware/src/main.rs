//! AWFQI as firmware: a water-reservoir controller that learns its release policy from
//! three other reservoirs' logged data and 200 queries to a model of its own.
//!
//! The plant is the IWFQI paper's Dam (`awfqi::env::Dam`): state `[storage, day]`, eight
//! daily releases (0, 3, 5, 7, 10, 15, 20, 30), a noisy seasonal inflow, a cost for
//! flooding (storage above 300) and for missing the demand (releasing less than 10). Our
//! reservoir (the paper's target) has its own inflow season and cost weights; the source
//! reservoirs' records were logged elsewhere. Yours would be a motor, a pump, a heater:
//! implement `awfqi::GenerativeModel` for it (one sampled step from any state and action)
//! and change the sizes in `src/reservoir.rs`.
//!
//! What runs where:
//! - **host, once** (`tests/firmware_tables.rs`): the source records, the posterior of each
//!   source's reward GP at its records, and the score table (where the sources disagree
//!   about the reward) → `src/tables.rs`, `static` arrays that stay in **flash**;
//! - **device**: the builder's set-up over those tables, four AWFQI steps (each: draw 50
//!   state-action pairs from the score table, query the plant model there, fit the target's
//!   reward GP, weight every source record by how well it agrees, weighted FQI), then the
//!   learned greedy policy and a fixed baseline are each run for one year from the same
//!   start, with the same inflows, and both returns are printed.
//!
//! RAM: one `AwfqiStorage` in `.bss` (18 KB, see `reservoir::Storage`) plus ≈ 4 KB of
//! stack; nothing is allocated and every fallible call returns `awfqi::Result`. The
//! controller itself is `src/reservoir.rs`, which also runs on the host
//! (`cargo run --release --example firmware_host`) to check a configuration before flashing.
//!
//! Build and run under QEMU: `scripts/firmware-example` (or, in this directory,
//! `cargo run --release`).
#![no_std]
#![no_main]

mod reservoir;
mod stack;
#[rustfmt::skip]
mod tables;

use awfqi::AwfqiStorage;
use cortex_m_rt::entry;
use semihosting::{println, process};

use reservoir::{Storage, learn_and_compare};

/// Seed of the run. On a device, take it from a hardware RNG or a unique ID.
const SEED: u64 = 3;

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` at the top of the entry function into a safe
    // `&'static mut`. `AwfqiStorage::new()` is all-zero, so it lands in `.bss`: RAM only,
    // no flash copy.
    static mut STORAGE: Storage = AwfqiStorage::new();

    stack::paint();
    let status = match run(STORAGE) {
        Ok(()) => 0,
        // Every failure is a typed error (bad input, capacity, ill-conditioned GP, …).
        Err(error) => {
            println!("AWFQI failed: {}", error);
            1
        }
    };
    println!("stack used: {} bytes", stack::used());
    process::exit(status)
}

fn run(storage: &'static mut Storage) -> awfqi::Result<()> {
    let outcome = learn_and_compare(storage, SEED, |report| {
        println!(
            "step {}: {} target records, reward-weight ESS {:.0} of {} records",
            report.step,
            report.n_target_samples,
            report.wr_eff,
            report.n_target_samples + report.n_source_samples
        );
    })?;
    let (learned, baseline) = (outcome.learned, outcome.baseline);
    println!(
        "greedy AWFQI policy: return {:.1} ± {:.1}",
        learned.mean_return, learned.standard_error
    );
    println!(
        "baseline, release the demand (10/day): return {:.1} ± {:.1}",
        baseline.mean_return, baseline.standard_error
    );
    Ok(())
}
