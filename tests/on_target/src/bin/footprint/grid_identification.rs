//! Footprint image: finite-MDP identification on the thesis Grid World, f32 — K = 4
//! candidates, 400 state-action pairs, 50 adaptive queries (inter-MDP variance score), one
//! mutual-information score of the final belief (1000 samples, 30 bins), value iteration and
//! the greedy policy of the MAP candidate. The score, value, Q and policy arrays (4 KiB) are
//! one zero-initialised static (`.bss`).
#![no_std]
#![no_main]

use awfqi_on_target::workloads::{IdentificationStorage, grid_identification};
use core::mem::MaybeUninit;

static mut STORAGE: MaybeUninit<IdentificationStorage> = MaybeUninit::zeroed();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to STORAGE; all-zero bits are valid (floats, integers).
    let storage = unsafe { (*core::ptr::addr_of_mut!(STORAGE)).assume_init_mut() };
    grid_identification(
        storage,
        core::hint::black_box(2),
        core::hint::black_box(50),
        core::hint::black_box(1000),
        core::hint::black_box(5),
    )
});
