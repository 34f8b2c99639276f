//! Code-size comparison (`scripts/cholesky-size`): the core's GP, one capacity (24).
#![no_std]
#![no_main]

use awfqi::gp::Gp;
use core::hint::black_box;
use core::mem::MaybeUninit;

static mut GP: MaybeUninit<Gp<f32, 24, 3>> = MaybeUninit::zeroed();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to GP; all-zero bits are a valid `Gp<f32, _, _>` and the job
    // sets the hyperparameters before use.
    let gp = unsafe { (*core::ptr::addr_of_mut!(GP)).assume_init_mut() };
    awfqi_on_target::cholesky_size::core_job(gp, black_box([5.0, 5.0, 1.0]))
});
