//! Expected values for the on-target suite, computed on the host in `f64` by code that does
//! not share the core's implementation: the harness's reference GP
//! (`awfqi_reference::gp`) and spec §2.3/§2.7's formulas written out directly.
//! The host test `tests/on_target_golden.rs` of the core recomputes every value here and
//! fails if one is off by more than 1e-12 (relative), so this table cannot drift.
//!
//! Plain `no_std` constants: included by the suite (`tests/on_target`) and by the host test.

/// GP case: `D = 3` inputs `(s_x, s_y, a)`, ARD hyperparameters below.
pub const GP_SIGNAL_VARIANCE: f64 = 2.0;
/// Length scales of the GP case.
pub const GP_LENGTH_SCALES: [f64; 3] = [1.5, 2.0, 1.0];
/// Noise variance of the GP case.
pub const GP_NOISE_VARIANCE: f64 = 0.05;
/// Training inputs; the first 7 are fitted, the 8th is then added with `add_point`.
pub const GP_X: [[f64; 3]; 8] = [
    [1.0, 1.0, 0.0],
    [2.0, 3.0, 1.0],
    [4.0, 2.0, 2.0],
    [5.0, 5.0, 3.0],
    [7.0, 1.0, 0.0],
    [8.0, 8.0, 1.0],
    [3.0, 7.0, 2.0],
    [6.0, 4.0, 3.0],
];
/// Training targets (rewards-like values of either sign).
pub const GP_Y: [f64; 8] = [-1.0, -2.5, 0.5, -12.0, -1.2, 0.3, -3.3, -20.0];
/// Test inputs.
pub const GP_TEST: [[f64; 3]; 3] = [[1.5, 2.0, 0.0], [5.0, 4.5, 3.0], [9.5, 9.5, 2.0]];
/// `(mean, latent variance)` at each test input after fitting the first 7 points.
pub const GP_PRED_7: [(f64, f64); 3] = [
    (-1.5064662055829412, 0.485385050007874),
    (-11.098245509626647, 0.15425340347018546),
    (0.09502640419799935, 1.8495354023571915),
];
/// `(mean, latent variance)` at each test input after adding the 8th point.
pub const GP_PRED_8: [(f64, f64); 3] = [
    (-1.546711553670312, 0.48537307501719984),
    (-13.411454535612492, 0.11469182927497812),
    (0.10458418463029509, 1.8495347269620899),
];
/// Log marginal likelihood after 7 and after 8 points.
pub const GP_LML: [f64; 2] = [-48.3651675440234, -116.94102969378012];

/// Puddle World steps: `(instance, state, action, seed)`; instance 0 = target, 1..=3 the
/// sources, all with puddle-based dynamics (κ = 5) so the step length matters.
pub const STEP_CASES: [(usize, [f64; 2], usize, u64); 4] = [
    (0, [1.0, 4.0], 0, 11),
    (1, [5.0, 5.0], 2, 12),
    (2, [2.0, 2.0], 3, 13),
    (3, [7.0, 9.5], 1, 14),
];
/// `(next state, reward, absorbing)` of each step case: spec §2.3 with the noise drawn by
/// `awfqi::rng::standard_normal::<f64>` from `ChaCha8Rng::seed_from_u64(seed)` in the
/// order ε_x, ε_y, η.
pub const STEP_EXPECTED: [([f64; 2], f64, bool); 4] = [
    (
        [1.418268773416885, 3.571342689081803],
        -23.76834917574822,
        false,
    ),
    (
        [5.170694859187505, 5.7051926150467525],
        -12.209631664422322,
        false,
    ),
    (
        [1.9539492700533485, 1.338947326719076],
        -22.43619711871286,
        false,
    ),
    (
        [6.3104769477960465, 9.513529220190286],
        -0.1363192611087896,
        true,
    ),
];

/// Acrobot steps `(instance, state, action)`: instance 0 = target, 1 and 2 the sources of
/// the IWFQI paper (noise-free dynamics, so no seed).
pub const ACROBOT_CASES: [(usize, [f64; 4], usize); 3] = [
    (0, [-1.8, 0.0, 0.0, 0.0], 1),
    (1, [0.5, -0.3, 1.0, -2.0], 0),
    (2, [3.0, 2.5, 12.0, -27.0], 1),
];
/// `(reward, next state)` of each Acrobot case: the published equations evaluated in f64
/// (`scripts/golden/iwfqi_domains.py`).
pub const ACROBOT_EXPECTED: [(f64, [f64; 4]); 3] = [
    (
        -1.545595810613826,
        [
            -1.705868437048838,
            -0.02323266077401403,
            0.9447845150673156,
            -0.2351089783750868,
        ],
    ),
    (
        -3.857649139731614,
        [
            0.6639837282633843,
            -0.6941524835873419,
            0.6060162346362343,
            -1.8839605261276888,
        ],
    ),
    (
        -8.858407346410207,
        [
            -0.9593164200396043,
            -2.549731219099285,
            10.299985021602778,
            -21.226529066087064,
        ],
    ),
];
/// Dam means `(instance, state, action)`: instance 0 = target, k = source k.
pub const DAM_CASES: [(usize, [f64; 2], usize); 3] = [
    (0, [351.7889265982291, 43.0], 6),
    (3, [487.5, 309.0], 2),
    (6, [55.0, 360.0], 7),
];
/// `(mean reward, mean next storage)` of each Dam case (the published definitions in f64).
pub const DAM_EXPECTED: [(f64, f64); 3] = [
    (-3.884169494867184, 346.9280693209469),
    (-40.3125, 496.81261989155547),
    (-13.750000000000002, 59.0),
];
