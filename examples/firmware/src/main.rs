//! Adaptive AWFQI as firmware: a water-reservoir controller that learns its release policy
//! from three other reservoirs' logged data and 200 queries to a model of its own.
//!
//! The plant is the IWFQI paper's Dam (`awfqi::env::Dam`): state `[storage, day]`, eight
//! daily releases (0, 3, 5, 7, 10, 15, 20, 30), a noisy seasonal inflow, a cost for
//! flooding (storage above 300) and for missing the demand (releasing less than 10). Our
//! reservoir (the paper's target) has its own inflow season and cost weights; the source
//! reservoirs' records were logged elsewhere. Yours would be a motor, a pump, a heater:
//! implement `awfqi::model::GenerativeModel` for it (one sampled step from any state and action)
//! and change the sizes in `src/reservoir.rs`.
//!
//! What runs where:
//! - **host, once** (`crosscheck/tests/firmware_tables.rs`): the source records and the posterior of
//!   each source's reward GP at its records → `src/tables.rs`, `static` arrays that stay in
//!   **flash** (and the score table the thesis's AWFQI draws from);
//! - **device**: each source's reward mean function fitted at set-up, the plan on the
//!   sources alone, then four adaptive steps (each in three sub-batches: follow the current
//!   greedy policy in the plant model from the evaluation's start, query where the
//!   reservoir surprised the sources, fit the target's reward GP, weight every source
//!   record by how well it agrees, re-plan by value iteration on a grid model of the
//!   records), then the learned greedy policy and a fixed baseline are each run for one
//!   year from the same start, with the same inflows, and both returns are printed.
//!
//! RAM: one `reservoir::Memory` in `.bss` (about 25 KB) plus a few KB of stack; nothing is
//! allocated and every fallible call returns `awfqi::Result`. The controller itself is
//! `src/reservoir.rs`, which also runs on the host (`cargo run --release --example
//! firmware_host`) to check a configuration before flashing; it keeps the thesis's AWFQI
//! (`learn_and_compare_thesis`, 18 KB) as the faithful variant.
//!
//! Build and run under QEMU: `scripts/firmware-example` (or, in this directory,
//! `cargo run --release`; `cargo run --release --features thesis` flashes the thesis's
//! AWFQI instead).
#![no_std]
#![no_main]

// The variant not flashed is left unused (both run on the host).
#[allow(dead_code)]
mod reservoir;
mod stack;
#[rustfmt::skip]
#[allow(dead_code)]
mod tables;

use cortex_m_rt::entry;
use semihosting::{println, process};

#[cfg(not(feature = "thesis"))]
use reservoir::{Memory, learn_and_compare};
#[cfg(feature = "thesis")]
use reservoir::{Storage as Memory, learn_and_compare_thesis as learn_and_compare};

/// Seed of the run. On a device, take it from a hardware RNG or a unique ID.
const SEED: u64 = 3;

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` at the top of the entry function into a safe
    // `&'static mut`. `Memory::new()` is all-zero, so it lands in `.bss`: RAM only, no
    // flash copy.
    static mut MEMORY: Memory = Memory::new();

    stack::paint();
    let status = match run(MEMORY) {
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

fn run(memory: &'static mut Memory) -> awfqi::Result<()> {
    let outcome = learn_and_compare(memory, SEED, |report| {
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
        "greedy {} policy: return {:.1} ± {:.1}",
        if cfg!(feature = "thesis") {
            "thesis AWFQI"
        } else {
            "adaptive AWFQI"
        },
        learned.mean_return,
        learned.standard_error
    );
    println!(
        "baseline, release the demand (10/day): return {:.1} ± {:.1}",
        baseline.mean_return, baseline.standard_error
    );
    Ok(())
}
