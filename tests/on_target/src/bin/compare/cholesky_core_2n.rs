//! Code-size comparison (`scripts/cholesky-size`): the core's GP at two capacities (24, 64).
#![no_std]
#![no_main]

use awfqi::gp::Gp;
use awfqi_on_target::cholesky_size::core_job;
use core::hint::black_box;
use core::mem::MaybeUninit;

static mut GP24: MaybeUninit<Gp<f32, 24, 3>> = MaybeUninit::zeroed();
static mut GP64: MaybeUninit<Gp<f32, 64, 3>> = MaybeUninit::zeroed();

awfqi_on_target::footprint_image!({
    // SAFETY: the only references to GP24 and GP64; all-zero bits are valid GPs and the job
    // sets the hyperparameters before use.
    let (small, large) = unsafe {
        (
            (*core::ptr::addr_of_mut!(GP24)).assume_init_mut(),
            (*core::ptr::addr_of_mut!(GP64)).assume_init_mut(),
        )
    };
    core_job(small, black_box([5.0, 5.0, 1.0]))
        .and_then(|a| Ok(a + core_job(large, black_box([5.0, 5.0, 1.0]))?))
});
