//! Footprint image: adaptive AWFQI (`awfqi-adaptive`) on Puddle World in its
//! recommended configuration (f32): the published source data and their posteriors in
//! flash, each source's 32-point reward GP fitted on the device and kept as a mean
//! function, a 32-point target GP, 250 candidate rows of the spacing-0.1 grid per
//! sub-batch, FQI by a model sweep on 13 × 13 nodes with pooled rewards, 6 steps of 50
//! queries (3 sub-batches of 70 % verification each) with warm refits of the GPs; the
//! greedy policy's evaluation. The memory is two zero-initialised statics (`.bss`).
#![no_std]
#![no_main]

use awfqi::adaptive::AdaptiveAwfqi;
use awfqi::env::PuddleWorld;
use awfqi_on_target::workloads::{
    ADAPTIVE_RECOMMENDED, AdaptiveRecommended, AdaptiveRecommendedFqi, adaptive_puddle,
};

static mut MEMORY: AdaptiveRecommended = AdaptiveRecommended::new();
static mut FQI: AdaptiveRecommendedFqi = AdaptiveRecommendedFqi::new();

awfqi_on_target::footprint_image!({
    // SAFETY: the only references to MEMORY and FQI.
    let memory = unsafe { &mut *core::ptr::addr_of_mut!(MEMORY) };
    let fqi = unsafe { &mut *core::ptr::addr_of_mut!(FQI) };
    let report = awfqi_on_target::probe::report;
    report(
        "memory bytes",
        core::mem::size_of::<AdaptiveRecommended>()
            + core::mem::size_of::<AdaptiveRecommendedFqi>(),
    );
    report(
        "kernel bytes",
        core::mem::size_of::<AdaptiveAwfqi<'static, f32, PuddleWorld<f32>, 2, 3, 32>>(),
    );
    adaptive_puddle(
        memory,
        fqi.storage(),
        ADAPTIVE_RECOMMENDED,
        core::hint::black_box(1),
        |_| {},
    )
});
