//! Code-size comparison (`scripts/cholesky-size`): nalgebra's fixed-size Cholesky at two
//! capacities (24, 64).
#![no_std]
#![no_main]

use awfqi_on_target::cholesky_size::nalgebra_job;
use core::hint::black_box;
use core::mem::MaybeUninit;
use nalgebra::SMatrix;

static mut K24: MaybeUninit<SMatrix<f32, 24, 24>> = MaybeUninit::zeroed();
static mut K64: MaybeUninit<SMatrix<f32, 64, 64>> = MaybeUninit::zeroed();

awfqi_on_target::footprint_image!({
    // SAFETY: the only references to K24 and K64; all-zero bits are valid f32 matrices.
    let (small, large) = unsafe {
        (
            (*core::ptr::addr_of_mut!(K24)).assume_init_mut(),
            (*core::ptr::addr_of_mut!(K64)).assume_init_mut(),
        )
    };
    nalgebra_job(small, black_box([5.0, 5.0, 1.0]))
        .and_then(|a| Ok(a + nalgebra_job(large, black_box([5.0, 5.0, 1.0]))?))
});
