//! Code-size comparison (`scripts/cholesky-size`): nalgebra's fixed-size Cholesky, one
//! capacity (24).
#![no_std]
#![no_main]

use core::hint::black_box;
use core::mem::MaybeUninit;
use nalgebra::SMatrix;

static mut K: MaybeUninit<SMatrix<f32, 24, 24>> = MaybeUninit::zeroed();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to K; all-zero bits are a valid f32 matrix.
    let k = unsafe { (*core::ptr::addr_of_mut!(K)).assume_init_mut() };
    awfqi_on_target::cholesky_size::nalgebra_job(k, black_box([5.0, 5.0, 1.0]))
});
