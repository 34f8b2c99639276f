//! Footprint image: the GP reward model with capacity N = 64, D = 3, f32
//! ([`awfqi_on_target::workloads::gp_reward_model`]), the GP in a zero-initialised static
//! (`.bss`: no flash copy of its initial value).
#![no_std]
#![no_main]

use awfqi::gp::Gp;
use core::mem::MaybeUninit;

static mut GP: MaybeUninit<Gp<f32, 64, 3>> = MaybeUninit::zeroed();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to GP. All-zero bits are a valid `Gp<f32, _, _>` (floats
    // and integers only); the workload re-initialises it before use.
    let gp = unsafe { (*core::ptr::addr_of_mut!(GP)).assume_init_mut() };
    awfqi_on_target::workloads::gp_reward_model(gp, core::hint::black_box(7))
});
