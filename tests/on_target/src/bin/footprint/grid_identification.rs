//! Footprint image: finite-MDP identification on the thesis Grid World, f32 — K = 4
//! candidates, 400 state-action pairs, 50 adaptive queries (inter-MDP variance score), one
//! mutual-information score of the final belief (1000 samples, 30 bins), value iteration and
//! the greedy policy of the MAP candidate. Everything on the stack (about 4 KiB of arrays).
#![no_std]
#![no_main]

awfqi_on_target::footprint_image!(awfqi_on_target::workloads::grid_identification(
    core::hint::black_box(2),
    core::hint::black_box(50),
    core::hint::black_box(1000),
    core::hint::black_box(5),
));
