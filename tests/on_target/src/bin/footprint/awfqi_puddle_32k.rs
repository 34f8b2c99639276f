//! Footprint image: the recommended Puddle World AWFQI configuration in 32 KiB of RAM
//! (f32): a 24-point target GP, 11 × 11 FQI cells, the realistic score table on the
//! spacing-1.25 puddle grid (324 rows), 6 steps of 50 queries with the thesis's GP search;
//! the published source data, their posteriors and the score values in flash
//! (`src/puddle_tables.rs`). The kernel's storage is one zero-initialised static (`.bss`).
#![no_std]
#![no_main]

use awfqi_on_target::workloads::{Storage32k, awfqi_puddle_32k};

static mut STORAGE: Storage32k = Storage32k::new();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to STORAGE.
    let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
    awfqi_puddle_32k(storage, core::hint::black_box(1))
});
