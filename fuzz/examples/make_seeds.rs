//! Writes the seed corpora `fuzz/seeds/<target>/<name>` with the hard cases of each target,
//! in the byte layout the targets read (see `awfqi_fuzz::Bytes`).
//!
//! `cargo run --manifest-path fuzz/Cargo.toml --example make_seeds` (from the repository
//! root) rewrites them; the files are committed, so CI does not need to run this.

use awfqi_fuzz::Seed;
use std::path::Path;

const NAN: f64 = f64::NAN;
const INF: f64 = f64::INFINITY;

fn write(target: &str, name: &str, seed: &Seed) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("seeds")
        .join(target);
    std::fs::create_dir_all(&dir).expect("create the seed directory");
    std::fs::write(dir.join(name), &seed.bytes).expect("write a seed");
}

/// GP input header: precision flag, hyperparameters (c, ℓ₁, ℓ₂, σ²ₙ), generator seed.
fn gp(f32: bool, hyper: [f64; 4]) -> Seed {
    let mut s = Seed::new();
    s.bool(f32).nums(&hyper).u8(7);
    s
}

fn fit(s: &mut Seed, points: &[([f64; 2], f64)]) {
    s.u8(0).u8(points.len() as u8);
    for (x, _) in points {
        s.nums(x);
    }
    for (_, y) in points {
        s.num(*y);
    }
    s.u8(0);
}

fn add(s: &mut Seed, x: [f64; 2], y: f64, drop_oldest: bool) {
    s.u8(1).nums(&x).num(y).bool(drop_oldest);
}

fn predict(s: &mut Seed, x: [f64; 2]) {
    s.u8(2).nums(&x);
}

fn lml(s: &mut Seed) {
    s.u8(4);
}

fn optimize(s: &mut Seed, bounds: [f64; 8], evaluations: u8, restarts: u8, isotropic: bool) {
    s.u8(6)
        .nums(&bounds)
        .u8(evaluations)
        .u8(restarts)
        .bool(isotropic);
}

const SPEC_BOUNDS: [f64; 8] = [1e-5, 1e5, 1e-2, 1e3, 1e-2, 1e3, 1e-2, 1.0];

fn gp_seeds() {
    let line: Vec<([f64; 2], f64)> = (0..6)
        .map(|i| ([i as f64, 0.5 * i as f64], (i as f64).sin()))
        .collect();
    for f32 in [false, true] {
        let p = if f32 { "f32" } else { "f64" };
        // An ordinary fit, growth to capacity, a sliding window, predictions, search.
        let mut s = gp(f32, [1.0, 1.0, 1.0, 0.01]);
        fit(&mut s, &line[..3]);
        add(&mut s, [3.0, 1.5], 0.1, false);
        add(&mut s, [4.0, 2.0], -0.7, false);
        add(&mut s, [5.0, 2.5], 0.9, false);
        add(&mut s, [6.0, 3.0], 0.3, false);
        add(&mut s, [7.0, 3.5], 0.6, true);
        predict(&mut s, [2.5, 1.0]);
        lml(&mut s);
        optimize(&mut s, SPEC_BOUNDS, 30, 2, true);
        predict(&mut s, [10.0, -3.0]);
        write("gp", &format!("ordinary_{p}"), &s);

        // Noise-free duplicates: singular Gram matrix, the jitter must escalate.
        let mut s = gp(f32, [1.0, 1.0, 1.0, 0.0]);
        fit(
            &mut s,
            &[([1.0, 1.0], 1.0), ([1.0, 1.0], 1.0), ([1.0, 1.0], 2.0)],
        );
        add(&mut s, [1.0, 1.0], -1.0, true);
        predict(&mut s, [1.0, 1.0]);
        lml(&mut s);
        write("gp", &format!("duplicates_{p}"), &s);

        // Targets near the overflow limit.
        let big = if f32 { 3.0e38 } else { 1.0e300 };
        let mut s = gp(f32, [1.0, 1.0, 1.0, 0.0]);
        fit(&mut s, &[([0.0, 0.0], big), ([0.1, 0.0], -big)]);
        lml(&mut s);
        predict(&mut s, [0.05, 0.0]);
        write("gp", &format!("huge_targets_{p}"), &s);

        // Extreme hyperparameters: tiny and huge length scales, subnormal signal variance.
        let mut s = gp(f32, [5e-324, 1e-300, 1e300, 0.0]);
        fit(&mut s, &line);
        predict(&mut s, [0.0, 0.0]);
        s.u8(5).nums(&[1e300, 1e-30, 1e30, 1e300]);
        predict(&mut s, [1.0, 0.5]);
        lml(&mut s);
        write("gp", &format!("extreme_hyper_{p}"), &s);

        // Non-finite data and hyperparameters, wrong lengths, too many points, empty data.
        let mut s = gp(f32, [NAN, 1.0, -1.0, -0.0]);
        fit(&mut s, &[([NAN, 0.0], 1.0)]);
        fit(&mut s, &[([0.0, 0.0], INF)]);
        fit(&mut s, &[]);
        fit(
            &mut s,
            &line.iter().chain(&line[..1]).copied().collect::<Vec<_>>(),
        );
        s.u8(0)
            .u8(2)
            .nums(&[0.0, 0.0, 1.0, 1.0])
            .nums(&[1.0, 2.0])
            .u8(0xff);
        add(&mut s, [0.0, -INF], 0.0, true);
        predict(&mut s, [NAN, 0.0]);
        lml(&mut s);
        s.u8(5).nums(&[1.0, 0.0, 1.0, 1.0]);
        write("gp", &format!("bad_input_{p}"), &s);

        // Search: degenerate boxes (low == high), inverted and non-finite bounds,
        // budgets below the number of starts, ARD.
        let mut s = gp(f32, [1.0, 1.0, 1.0, 0.1]);
        fit(&mut s, &line);
        optimize(
            &mut s,
            [1.0, 1.0, 0.5, 0.5, 0.5, 0.5, 0.1, 0.1],
            5,
            0,
            false,
        );
        optimize(&mut s, [2.0, 1.0, 0.5, 0.5, 0.5, 0.5, 0.1, 0.1], 5, 0, true);
        optimize(&mut s, [1.0, INF, 0.5, 0.5, 0.5, 0.5, 0.1, 0.1], 5, 0, true);
        optimize(&mut s, SPEC_BOUNDS, 2, 3, true);
        optimize(
            &mut s,
            [1e-5, 1e5, 1e-2, 1e-1, 1e2, 1e3, 1e-2, 1.0],
            20,
            1,
            true,
        );
        optimize(&mut s, SPEC_BOUNDS, 39, 3, false);
        predict(&mut s, [2.0, 1.0]);
        write("gp", &format!("search_{p}"), &s);
    }
}

fn puddle(precision: u8, instance: u8, puddle_based: bool) -> Seed {
    let mut s = Seed::new();
    s.u8(precision).bool(puddle_based).u8(instance).u8(3).u8(0);
    s
}

fn step(s: &mut Seed, state: [f64; 2], action: u8, op: u8) {
    s.nums(&state).u8(action).u8(op);
}

fn env_seeds() {
    for (precision, p) in [(0u8, "f64"), (1, "f32")] {
        for instance in 0..4u8 {
            let mut s = puddle(precision, instance, instance % 2 == 1);
            // Corners, the goal edge, puddle centres, every oracle function.
            for (i, state) in [
                [0.0, 0.0],
                [10.0, 10.0],
                [5.0, 9.0],
                [6.0, 4.0],
                [0.0, 10.0],
                [1.0, 4.0],
            ]
            .into_iter()
            .enumerate()
            {
                step(&mut s, state, (i % 4) as u8, (i % 6) as u8);
            }
            write("env_step", &format!("instance{instance}_{p}"), &s);
        }
        // Bad states and actions.
        let mut s = puddle(precision, 0, false);
        step(&mut s, [NAN, 0.0], 0, 0);
        step(&mut s, [-0.0, INF], 1, 1);
        step(&mut s, [10.000001, 5.0], 2, 2);
        step(&mut s, [-1e-300, 5.0], 3, 3);
        step(&mut s, [5.0, 5.0], 4, 0);
        step(&mut s, [5.0, 5.0], 5, 1);
        write("env_step", &format!("bad_states_{p}"), &s);
        // Episodes: horizon 0 and above the 50-record buffer, ε outside [0, 1], a greedy
        // policy returning an invalid action; rollouts with bad discounts.
        let mut s = puddle(precision, 0, true);
        step(&mut s, [0.0, 0.0], 0, 6);
        s.u8(0).num(0.3).u8(0);
        step(&mut s, [0.0, 0.0], 0, 6);
        s.u8(55).num(0.3).u8(0);
        step(&mut s, [0.0, 0.0], 0, 6);
        s.u8(50).num(1.5).u8(0);
        step(&mut s, [0.0, 0.0], 0, 6);
        s.u8(50).num(0.0).u8(4);
        step(&mut s, [0.0, 0.0], 0, 6);
        s.u8(50).num(1.0).u8(2);
        step(&mut s, [0.0, 0.0], 0, 7);
        s.u8(50).num(0.99);
        step(&mut s, [0.0, 0.0], 0, 7);
        s.u8(50).num(NAN);
        step(&mut s, [0.0, 0.0], 0, 7);
        s.u8(0).num(0.5);
        write("env_step", &format!("episodes_{p}"), &s);
        // Custom instances: too many puddles, degenerate variances, a far-away goal.
        let mut s = puddle(precision, 4, true);
        s.bytes.truncate(3);
        s.nums(&[5.0, 10.0]).u8(3);
        s.nums(&[1.0, 4.0, 1.00001e-5])
            .nums(&[1e300, -1e300, 0.7])
            .nums(&[5.0, 5.0, 1e300]);
        s.u8(3).u8(0);
        step(&mut s, [5.0, 5.0], 0, 0);
        step(&mut s, [1.0, 4.0], 2, 2);
        step(&mut s, [1.0, 4.0], 2, 3);
        write("env_step", &format!("custom_puddles_{p}"), &s);
        let mut s = puddle(precision, 4, false);
        s.bytes.truncate(3);
        s.nums(&[INF, 10.0]).u8(0).u8(3).u8(0);
        step(&mut s, [5.0, 5.0], 0, 0);
        write("env_step", &format!("custom_bad_goal_{p}"), &s);
        let mut s = puddle(precision, 4, false);
        s.bytes.truncate(3);
        s.nums(&[5.0, 10.0])
            .u8(1)
            .nums(&[1.0, 1.0, 1e-5])
            .u8(3)
            .u8(0);
        step(&mut s, [5.0, 5.0], 0, 0);
        write("env_step", &format!("custom_bad_variance_{p}"), &s);
    }
    // Grid World: each thesis candidate (absorbing or not), index out of range, custom
    // grids of size 0 and 1, goal outside, bad variance; all states and bad indices.
    for index in 0..6u8 {
        let mut s = Seed::new();
        s.u8(2)
            .bool(index % 2 == 0)
            .bool(false)
            .u8(index)
            .u8(1)
            .u8(0);
        for (st, a, s2) in [
            (0u8, 0u8, 1u8),
            (99, 0, 99),
            (99, 2, 99),
            (55, 3, 45),
            (100, 0, 0),
            (0, 4, 0),
            (9, 1, 8),
            (90, 5, 255),
        ] {
            s.u8(st).u8(a).u8(s2);
        }
        write("env_step", &format!("grid_thesis{index}"), &s);
    }
    for (name, w, h, gx, gy, v) in [
        ("grid_zero_width", 0u8, 3u8, 0u8, 0u8, 0.25),
        ("grid_single_cell", 1, 1, 0, 0, 0.25),
        ("grid_goal_outside", 3, 3, 3, 0, 0.25),
        ("grid_zero_variance", 3, 3, 1, 1, 0.0),
        ("grid_nan_variance", 3, 3, 1, 1, NAN),
        ("grid_wide", 12, 1, 11, 0, 1e-30),
    ] {
        let mut s = Seed::new();
        s.u8(2)
            .bool(true)
            .bool(true)
            .u8(w)
            .u8(h)
            .u8(gx)
            .u8(gy)
            .num(v)
            .u8(2)
            .u8(0);
        for (st, a, s2) in [(0u8, 0u8, 0u8), (0, 1, 0), (11, 0, 11), (12, 2, 0)] {
            s.u8(st).u8(a).u8(s2);
        }
        write("env_step", name, &s);
    }
}

fn main() {
    gp_seeds();
    env_seeds();
    println!("seeds written under fuzz/seeds/");
}
