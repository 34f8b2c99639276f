//! Footprint baseline: the runtime (vector table, reset handler) and the probe, no core.
#![no_std]
#![no_main]

awfqi_on_target::footprint_image!(core::hint::black_box(awfqi::Result::Ok(())));
