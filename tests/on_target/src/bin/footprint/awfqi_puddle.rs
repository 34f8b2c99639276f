//! Footprint image: the AWFQI Puddle World kernel in the coarse configuration recommended for
//! a microcontroller (f32): 11 × 11 FQI cells, a 64-point target GP, the oracle score table
//! on the spacing-1 puddle grid (484 rows), 3 steps of 50 queries, 3 sources of 5 episodes,
//! GP searches of 120 evaluations with 2 restarts; source data and source GPs are built on
//! the device first. All storage is one zero-initialised static (`.bss`).
#![no_std]
#![no_main]

use awfqi_on_target::workloads::{KernelRun, KernelStorage, awfqi_puddle};

static mut STORAGE: KernelStorage<750, 484, 484, 150, 64> = KernelStorage::new();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to STORAGE.
    let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
    let run = KernelRun {
        cells: 11,
        spacing: 1.0,
        budget: 50,
        steps: 3,
        episodes: 5,
        search: (120, 2),
    };
    awfqi_puddle(
        storage,
        core::hint::black_box(run),
        core::hint::black_box(1),
        |_| {},
    )
});
