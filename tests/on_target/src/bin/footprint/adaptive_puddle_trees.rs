//! Footprint image: adaptive AWFQI (`awfqi-adaptive --adaptive-q trees`) on
//! Puddle World with the Extra-Trees FQI it had before the model sweep (f32): the published source data and their posteriors in
//! flash, each source's 64-point reward GP fitted on the device and kept as a mean
//! function, a 64-point target GP, 4 000 candidate rows of the spacing-0.1 grid per
//! sub-batch, 50 streamed Extra-Trees per action (1 333 record slots, a 1 023-node scratch
//! tree), one step of 50 queries (3 sub-batches of 70 % verification each: 4 fits of 60
//! iterations and the verification rollouts' decisions) with the thesis's GP search; the
//! greedy policy's evaluation. The memory is one zero-initialised static (`.bss`). One step,
//! not the protocol's 6, keeps the QEMU run within the script's time limit: the memory is
//! the same, and the 6-step run (measured once: 17 min under QEMU) reached the same peak
//! stack.
#![no_std]
#![no_main]

use awfqi::adaptive::AdaptiveAwfqi;
use awfqi::env::PuddleWorld;
use awfqi_on_target::workloads::{
    ADAPTIVE_TREES, AdaptiveRun, AdaptiveTreeMemory, AdaptiveTrees, adaptive_puddle,
};

static mut MEMORY: AdaptiveTrees = AdaptiveTrees::new();
static mut TREES: AdaptiveTreeMemory = AdaptiveTreeMemory::new();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to MEMORY.
    let memory = unsafe { &mut *core::ptr::addr_of_mut!(MEMORY) };
    // SAFETY: the only reference to TREES.
    let trees = unsafe { &mut *core::ptr::addr_of_mut!(TREES) };
    let report = awfqi_on_target::probe::report;
    report(
        "memory bytes",
        core::mem::size_of::<AdaptiveTrees>() + core::mem::size_of::<AdaptiveTreeMemory>(),
    );
    report(
        "kernel bytes",
        core::mem::size_of::<AdaptiveAwfqi<'static, f32, PuddleWorld<f32>, 2, 3, 64>>(),
    );
    adaptive_puddle(
        memory,
        trees.storage(),
        AdaptiveRun {
            steps: 1,
            ..ADAPTIVE_TREES
        },
        core::hint::black_box(1),
        |_| {},
    )
});
