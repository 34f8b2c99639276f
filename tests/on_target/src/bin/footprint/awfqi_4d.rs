//! Footprint image: the AWFQI loop at four state dimensions (f32) on the toy plant of
//! `tests/generic_plant.rs`: two sources of 512 records logged on the device, source GPs
//! and the realistic score table (512 rows) built on the device, a 64-point target GP over
//! (s, a) ∈ ℝ⁵, 3 steps of 40 queries, FQI on 4⁴ cells × 2 actions. Reports in how many of
//! the cells where the optimum is known in closed form the greedy action is optimal
//! (measured: 110 of 132; the host test, with twice the source records, gets all), and
//! fails unless it is more than half (what a coin would get).
#![no_std]
#![no_main]

use awfqi_on_target::workloads::{Storage4d, awfqi_4d};

static mut STORAGE: Storage4d = Storage4d::new();

awfqi_on_target::footprint_image!({
    // SAFETY: the only reference to STORAGE.
    let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
    awfqi_4d(storage, core::hint::black_box(2026)).and_then(|(checked, optimal)| {
        awfqi_on_target::probe::report("cells checked", checked);
        awfqi_on_target::probe::report("cells optimal", optimal);
        if 2 * optimal > checked {
            Ok(())
        } else {
            Err(awfqi::Error::EmptyData)
        }
    })
});
