//! Adaptive AWFQI as firmware on a plant nobody tuned by hand: three heated zones in a row
//! (state: each zone's temperature in [0, 1]; actions: heater off, or heat zone 1, 2 or 3),
//! learned from two other wings' logs that each agree with our building on part of the
//! space, and 100 queries to a model of our own.
//!
//! Nothing about the GP or the weights is set by hand: the settings come from the logs
//! (`awfqi::thesis::SourceScales` → `AdaptiveConfig::scaled`), the Q-function is the recommended
//! adaptive kernel's (a model sweep), and each step's report warns when its
//! numbers should not be trusted. The program prints the learned policy's return next to
//! FQI's on the same target queries and a hand-written thermostat's, over the same starts.
//!
//! RAM: one `Memory` block in `.bss` (see `zones::Memory`); every fallible call returns
//! `awfqi::Result`. The controller is `src/zones.rs`, which also runs on the host
//! (`cargo run --release --example zones_host -- 0 20`) to check it over many seeds.
//!
//! Build and run under QEMU: `scripts/firmware-example zones` (or, in this directory,
//! `cargo run --release`).
#![no_std]
#![no_main]

// The stack painting is the Dam firmware's, shared rather than copied.
#[path = "../../firmware/src/stack.rs"]
mod stack;
mod zones;

use cortex_m_rt::entry;
use semihosting::{println, process};

use zones::{Memory, learn_and_compare};

/// Seed of the run. On a device, take it from a hardware RNG or a unique ID.
const SEED: u64 = 0;

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` at the top of the entry function into a safe
    // `&'static mut`; `Memory::new()` is all-zero, so it lands in `.bss`.
    static mut MEMORY: Memory = Memory::new();

    stack::paint();
    let status = match run(MEMORY) {
        Ok(()) => 0,
        Err(error) => {
            println!("AWFQI failed: {}", error);
            1
        }
    };
    println!("stack used: {} bytes", stack::used());
    process::exit(status)
}

fn run(memory: &'static mut Memory) -> awfqi::Result<()> {
    println!("memory: {} bytes", core::mem::size_of::<Memory>());
    let outcome = learn_and_compare(memory, SEED, |report| {
        println!(
            "step {}: {} target records, reward-weight ESS of the {} source records {:.0}",
            report.step, report.n_target_samples, report.n_source_samples, report.wr_source_eff
        );
        for warning in report.warnings() {
            println!("  warning: {}", warning);
        }
    })?;
    for (name, e) in [
        ("adaptive AWFQI", outcome.awfqi),
        ("FQI, same target queries", outcome.fqi),
        ("hand-written thermostat", outcome.thermostat),
    ] {
        println!(
            "{}: return {:.2} ± {:.2}",
            name, e.mean_return, e.standard_error
        );
    }
    Ok(())
}
