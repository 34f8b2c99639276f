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

/// One FQI sample: state, action, reward, next state, absorbing.
fn sample(s: &mut Seed, state: [f64; 2], action: u8, reward: f64, next: [f64; 2], absorbing: bool) {
    s.nums(&state)
        .u8(action)
        .num(reward)
        .nums(&next)
        .bool(absorbing);
}

fn fqi_seeds() {
    for (f32, p) in [(true, "f32"), (false, "f64")] {
        let walk: Vec<([f64; 2], u8, f64, [f64; 2], bool)> = (0..12)
            .map(|i| {
                let x = (i % 10) as f64;
                let y = (i / 3) as f64 * 2.5;
                let up = i % 2 == 0;
                let next = if up {
                    [x, (y + 1.0).min(10.0)]
                } else {
                    [(x + 1.0).min(10.0), y]
                };
                (
                    [x, y],
                    if up { 2 } else { 0 },
                    -1.0 - (i as f64) * 0.5,
                    next,
                    i == 11,
                )
            })
            .collect();
        let write_set = |s: &mut Seed,
                         rows: &[([f64; 2], u8, f64, [f64; 2], bool)],
                         rw: Option<&[f64]>,
                         tw: Option<&[f64]>| {
            s.u8(rows.len() as u8);
            for &(st, a, r, n, ab) in rows {
                sample(s, st, a, r, n, ab);
            }
            for w in [rw, tw] {
                match w {
                    Some(w) => {
                        s.bool(true)
                            .u8(if w.len() == rows.len() { 0 } else { 0xff })
                            .nums(w);
                    }
                    None => {
                        s.bool(false);
                    }
                }
            }
        };
        // Header: precision, square grid of 5 cells, 4 actions, discount 0.99, 10 iterations,
        // capped-nearest, no min weight, two sets.
        let header = |s: &mut Seed, empty: u8, discount: f64, iterations: u8| {
            s.bool(f32)
                .bool(false)
                .u8(4)
                .u8(4)
                .bool(true)
                .num(discount)
                .u8(iterations)
                .u8(empty);
            if empty == 2 {
                s.num(-3.0);
            }
            s.bool(false);
        };
        let queries = |s: &mut Seed| {
            for (st, a) in [
                ([0.0, 0.0], 0u8),
                ([10.0, 10.0], 3),
                ([-5.0, 20.0], 1),
                ([NAN, 1.0], 2),
                ([5.0, 5.0], 4),
            ] {
                s.nums(&st).u8(a);
            }
        };
        let w: Vec<f64> = (0..12).map(|i| [0.0, 1.0, 1000.0, 1e-9][i % 4]).collect();
        for (name, empty) in [("nearest", 0u8), ("capped", 1), ("value", 2)] {
            let mut s = Seed::new();
            header(&mut s, empty, 0.99, 10);
            s.u8(1);
            write_set(&mut s, &walk[..6], None, None);
            write_set(&mut s, &walk[6..], Some(&w[6..]), Some(&w[..6]));
            queries(&mut s);
            write("weighted_fqi", &format!("two_sets_{name}_{p}"), &s);
        }
        // All weights zero: no pair has data.
        let mut s = Seed::new();
        header(&mut s, 1, 1.0, 11);
        s.u8(0);
        write_set(&mut s, &walk, Some(&[0.0; 12]), Some(&[0.0; 12]));
        queries(&mut s);
        write("weighted_fqi", &format!("zero_weights_{p}"), &s);
        // Huge rewards with discount 1 and many iterations (overflow of the sums).
        let big = if f32 { 3e38 } else { 1e307 };
        let huge: Vec<_> = walk
            .iter()
            .map(|&(st, a, _, n, _)| (st, a, -big, n, false))
            .collect();
        let mut s = Seed::new();
        header(&mut s, 0, 1.0, 11);
        s.u8(0);
        write_set(&mut s, &huge, Some(&[1e30; 12]), None);
        queries(&mut s);
        write("weighted_fqi", &format!("huge_rewards_{p}"), &s);
        // Bad samples: NaN reward, action out of range, negative weight, wrong weight length.
        for (name, bad) in [
            ("nan_reward", (walk[0].0, 0u8, NAN, walk[0].3, false)),
            ("bad_action", (walk[0].0, 5, -1.0, walk[0].3, false)),
            ("inf_next_state", (walk[0].0, 1, -1.0, [INF, 0.0], false)),
            ("outside_box", ([-100.0, 1e6], 1, -1.0, [20.0, -3.0], true)),
        ] {
            let mut rows = walk[..4].to_vec();
            rows.push(bad);
            let mut s = Seed::new();
            header(&mut s, 1, 0.9, 3);
            s.u8(0);
            write_set(&mut s, &rows, None, None);
            queries(&mut s);
            write("weighted_fqi", &format!("{name}_{p}"), &s);
        }
        let mut s = Seed::new();
        header(&mut s, 1, 0.9, 3);
        s.u8(1);
        write_set(&mut s, &walk[..4], Some(&[1.0, -1.0, 1.0, 1.0]), None);
        write_set(&mut s, &walk[4..6], Some(&[1.0, 1.0, 1.0]), None);
        queries(&mut s);
        write("weighted_fqi", &format!("bad_weights_{p}"), &s);
        // A custom grid with inverted bounds, and one of a single cell with a NaN bound.
        let mut s = Seed::new();
        s.bool(f32)
            .bool(true)
            .nums(&[10.0, 0.0, 0.0, 10.0])
            .u8(3)
            .u8(3);
        write("weighted_fqi", &format!("inverted_grid_{p}"), &s);
        let mut s = Seed::new();
        s.bool(f32)
            .bool(true)
            .nums(&[0.0, 0.0, NAN, 1.0])
            .u8(1)
            .u8(1);
        write("weighted_fqi", &format!("nan_grid_{p}"), &s);
        // Bad settings: discount outside [0, 1], zero iterations, zero actions.
        let mut s = Seed::new();
        s.bool(f32)
            .bool(false)
            .u8(4)
            .u8(4)
            .bool(true)
            .num(1.5)
            .u8(3)
            .u8(1);
        write("weighted_fqi", &format!("bad_discount_{p}"), &s);
        let mut s = Seed::new();
        s.bool(f32).bool(false).u8(4).u8(0);
        write("weighted_fqi", &format!("zero_actions_{p}"), &s);
    }
}

fn score_seeds() {
    for (mode, p) in [(0u8, "f32"), (1, "f64")] {
        for (name, weights) in [
            ("alias_mixed", vec![0.0, 1.0, 2.0, 0.0, 1e-30, 5.0]),
            ("alias_zero", vec![0.0, 0.0, 0.0]),
            ("alias_single", vec![3.0]),
            ("alias_huge", vec![3e38, 3e38, 1e-38, 0.0]),
            ("alias_nan", vec![1.0, NAN]),
            ("alias_negative", vec![1.0, -1e-30]),
            ("alias_tiny", vec![5e-324, 5e-324, 1e-300]),
        ] {
            let mut s = Seed::new();
            s.u8(mode).u8(weights.len() as u8).nums(&weights).u8(40);
            write("score_draw", &format!("{name}_{p}"), &s);
        }
        let mut s = Seed::new();
        s.u8(mode).u8(3).nums(&[1.0, 2.0, 3.0]).u8(2);
        write("score_draw", &format!("alias_short_storage_{p}"), &s);
    }
    for (mode, p) in [(2u8, "f32"), (3, "f64")] {
        let records = |s: &mut Seed| {
            s.u8(2);
            s.u8(3)
                .nums(&[0.0, 0.0])
                .u8(0)
                .nums(&[5.0, 9.0])
                .u8(2)
                .nums(&[10.0, 10.0])
                .u8(3);
            s.u8(2).nums(&[1.0, 4.0]).u8(1).nums(&[6.0, 6.0]).u8(4);
        };
        // Oracle tables on the puddle grid (d = 2.5 and 5), every row-set mode and column.
        // Columns: 0 is V_r, 1 the total, 2 then k the next-state coordinate k.
        for (rowset, column) in [(0u8, &[0u8][..]), (1, &[1]), (2, &[2, 1])] {
            let mut s = Seed::new();
            s.u8(mode).bool(false).num(2.5);
            records(&mut s);
            s.u8(4).u8(rowset).u8(0).u8(0).bool(true).u8(3);
            for &c in column {
                s.u8(c);
            }
            s.u8(1);
            write("score_draw", &format!("oracle_rowset{rowset}_{p}"), &s);
        }
        // Fuzzed sources: agreeing (all scores 0: uniform sampling), overflowing, NaN, a
        // failing model, a single source.
        for (name, values, count) in [
            ("agree", vec![[1.0, 2.0, 3.0]], 3u8),
            (
                "disagree",
                vec![[1.0, 2.0, 3.0], [-20.0, 2.5, 3.0], [0.5, 1.0, 9.0]],
                3,
            ),
            (
                "overflow",
                vec![[3e38, -3e38, 1e308], [-1e308, 1e308, 0.0]],
                2,
            ),
            ("nan", vec![[NAN, 0.0, 0.0]], 2),
            ("single", vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], 1),
        ] {
            let mut s = Seed::new();
            s.u8(mode)
                .bool(true)
                .nums(&[0.0, 0.0, 2.0, 2.0])
                .u8(3)
                .u8(3);
            records(&mut s);
            s.u8(4).u8(0).u8(0).u8(0).bool(false).u8(count);
            for k in 0..count as usize {
                let v = &values[k % values.len()];
                let rotated: Vec<[f64; 3]> = (0..values.len())
                    .map(|i| values[(i + k) % values.len()])
                    .collect();
                let _ = v;
                s.u8((rotated.len() - 1) as u8);
                for t in &rotated {
                    s.nums(t);
                }
                s.u8(0);
            }
            s.u8(3).u8(2);
            write("score_draw", &format!("fuzzed_{name}_{p}"), &s);
        }
        let mut s = Seed::new();
        s.u8(mode)
            .bool(true)
            .nums(&[0.0, 0.0, 1.0, 1.0])
            .u8(2)
            .u8(2);
        records(&mut s);
        s.u8(4).u8(0).u8(0).u8(0).bool(false).u8(2);
        s.u8(0).nums(&[1.0, 1.0, 1.0]).u8(0xff).u8(5);
        s.u8(0).nums(&[2.0, 1.0, 1.0]).u8(0);
        s.u8(0).u8(0);
        write("score_draw", &format!("failing_model_{p}"), &s);
        // Bad grids: zero spacing, NaN lower corner, a spacing that does not divide 10.
        for (name, custom, nums) in [
            ("zero_spacing", true, vec![0.0, 0.0, 0.0, 1.0]),
            ("nan_corner", true, vec![NAN, 0.0, 1.0, 1.0]),
            ("puddle_0_3", false, vec![0.3]),
            ("puddle_negative", false, vec![-1.0]),
        ] {
            let mut s = Seed::new();
            s.u8(mode).bool(custom).nums(&nums);
            if custom {
                s.u8(2).u8(2);
            }
            s.u8(0).u8(4).u8(2).u8(0).u8(0).bool(true).u8(3).u8(0).u8(0);
            write("score_draw", &format!("{name}_{p}"), &s);
        }
    }
}

fn weights_seeds() {
    for (f32, p) in [(true, "f32"), (false, "f64")] {
        for (estimator, e) in [(true, "mean"), (false, "heuristic")] {
            let mut s = Seed::new();
            s.bool(f32).bool(estimator).num(0.1).num(1000.0).u8(5);
            s.nums(&[-1.0, -20.0, 0.0, 3.0, -1.1]);
            for (m, sd) in [
                (-1.0, 0.1),
                (-22.0, 0.5),
                (0.0, 0.0),
                (1e30, 1.0),
                (-1.0, 0.3),
            ] {
                s.nums(&[m, sd]);
            }
            for (m, sd) in [
                (-1.0, 0.2),
                (-1.0, 0.31),
                (0.0, 1.0),
                (-1e30, 0.0),
                (-1.0, 0.3162),
            ] {
                s.nums(&[m, sd]);
            }
            s.u8(0).u8(2);
            s.u8(0).num(0.1).u8(4).nums(&[0.5, 0.01, 0.0, -1e-9]);
            s.num(0.01).num(0.2);
            s.nums(&[1.0, 0.0, 1.0, 0.1]);
            s.u8(5).nums(&[1.0, 1.0, 0.5, 0.0, 2.0]);
            write("weights", &format!("{e}_{p}"), &s);
        }
        // Hard cases: zero noise variance, huge and tiny posteriors, NaN, negative std,
        // lengths that differ, every noise-subtraction mode, ideal weight overflow.
        for (k, noise) in [0.0, 1e-300, 3e38, NAN].into_iter().enumerate() {
            let mut s = Seed::new();
            s.bool(f32)
                .bool(k % 2 == 0)
                .num(noise)
                .num(if k == 1 { 1e300 } else { 1.0 })
                .u8(3);
            s.nums(&[1e300, -1e-300, NAN]);
            s.nums(&[0.0, 1e150, 1.0, -1.0, 0.0, 0.0]);
            s.nums(&[1e-300, 0.0, 1.0, 1e200, 5.0, 1.0]);
            s.u8(0xff)
                .u8(k as u8)
                .num(noise)
                .u8(3)
                .nums(&[1e300, 0.0, 1e-300]);
            s.num(1e308).num(-1.0);
            s.nums(&[1e300, -1e300, 1e300, 1e-300]);
            s.u8(3).nums(&[0.0, 0.0, 0.0]);
            write("weights", &format!("hard{k}_{p}"), &s);
        }
    }
}

fn belief_seeds() {
    // Grid World candidates (K = 4): uniform prior, observations at and away from goals,
    // then each score criterion.
    let grid = |s: &mut Seed, updates: &[(u8, u8, u8, f64)]| {
        for &(st, a, n, r) in updates {
            s.u8(st).u8(a).u8(n).num(r);
        }
    };
    let goal_obs = [
        (99, 1, 98, 1.2),
        (98, 0, 99, 0.1),
        (0, 0, 1, -0.3),
        (9, 2, 19, 0.9),
        (90, 3, 80, 0.0),
        (55, 0, 56, 1.1),
    ];
    for (criterion, name) in [(0u8, "uniform"), (1, "variance"), (2, "mi")] {
        let mut s = Seed::new();
        s.bool(true).bool(false).u8(4).u8(1).bool(false).u8(0);
        grid(&mut s, &goal_obs);
        s.u8(criterion);
        if criterion == 2 {
            s.u8(10).u8(16).bool(true).bool(true);
        }
        s.u8(0);
        write("belief", &format!("grid_{name}"), &s);
    }
    // A prior with zero mass, an impossible transition (contradiction), huge and non-finite
    // rewards, out-of-range indices, a candidate list of the wrong length.
    let mut s = Seed::new();
    s.bool(true)
        .bool(true)
        .u8(4)
        .nums(&[1.0, 0.0, 0.0, 2.0])
        .u8(2)
        .bool(true)
        .u8(0);
    grid(
        &mut s,
        &[
            (0, 0, 55, 0.0),
            (99, 0, 99, 1e300),
            (99, 0, 99, NAN),
            (100, 0, 0, 0.0),
            (0, 4, 1, 0.0),
            (0, 0, 1, -INF),
        ],
    );
    s.u8(2).u8(0).u8(200).bool(false).bool(false).u8(0);
    write("belief", "grid_contradictions", &s);
    let mut s = Seed::new();
    s.bool(true).bool(false).u8(3).u8(3).bool(false).u8(0xff);
    grid(&mut s, &goal_obs);
    s.u8(1).u8(0);
    write("belief", "grid_wrong_candidate_count", &s);
    // Priors: empty, too many, NaN, negative, all zero.
    for (name, weights) in [
        ("prior_empty", vec![]),
        ("prior_five", vec![1.0; 5]),
        ("prior_nan", vec![1.0, NAN]),
        ("prior_negative", vec![1.0, -1.0]),
        ("prior_zero", vec![0.0, 0.0]),
        ("prior_tiny", vec![5e-324, 1e300]),
    ] {
        let mut s = Seed::new();
        s.bool(true)
            .bool(true)
            .u8(weights.len() as u8)
            .nums(&weights)
            .u8(1)
            .bool(false)
            .u8(0);
        grid(&mut s, &goal_obs[..2]);
        s.u8(1).u8(0);
        write("belief", name, &s);
    }
    // Fuzzed candidate models (K = 2): deterministic moves, then raw probabilities with
    // negative, NaN and > 1 entries, zero / negative / NaN variances.
    let model = |s: &mut Seed, raw: bool, variance: f64| {
        s.bool(raw);
        for i in 0..6u8 {
            if raw {
                s.nums(&[
                    0.5,
                    if i == 3 { -0.5 } else { 0.25 },
                    if i == 5 { NAN } else { 0.25 },
                ]);
            } else {
                s.u8(i % 3);
            }
            s.num(f64::from(i) - 2.0).bool(true).num(variance);
        }
    };
    for (name, raw, variance) in [
        ("models_ok", false, 0.25),
        ("models_zero_variance", false, 0.0),
        ("models_negative_variance", false, -1.0),
        ("models_nan_variance", false, NAN),
        ("models_raw_probabilities", true, 0.25),
        ("models_tiny_variance", false, 1e-300),
    ] {
        let mut s = Seed::new();
        s.bool(false).bool(false).u8(2).u8(5);
        model(&mut s, raw, variance);
        model(&mut s, false, 0.5);
        for _ in 0..2 {
            s.u8(0).u8(1).u8(1).num(-1.0);
        }
        for (st, a, n, r) in [
            (0u8, 0u8, 0u8, -2.0),
            (1, 1, 1, 1.0),
            (2, 0, 2, 0.5),
            (3, 0, 0, 0.0),
            (0, 2, 0, 0.0),
            (1, 0, 1, 1e10),
        ] {
            s.u8(st).u8(a).u8(n).num(r);
        }
        s.u8(2).u8(8).u8(32).bool(false).bool(false).u8(0);
        write("belief", name, &s);
    }
}

/// The AWFQI loop (`fuzz_targets/awfqi_loop.rs`): a well-formed set-up at `dims` state
/// dimensions (`mode`: 0/1 Puddle World f32/f64, 2/3 the 4-D toy plant f32/f64), with the
/// given candidate rows (0 grid, 1 pairs, 2 source rows), posterior stage (0 stored,
/// 1 fitted) and score stage (0 stored, 1 oracle models, 2 realistic).
fn loop_seed(mode: u8, dims: usize, rows: u8, posteriors: u8, scores: u8) -> Seed {
    let mut s = Seed::new();
    s.u8(mode);
    if mode < 2 {
        s.bool(false); // shared dynamics
    }
    // budget 5, 15 evaluations, 1 restart, initial noise kept, spread, reference noise,
    // capped nearest filling, γ = 0.9, 5 iterations, sampling on V_r.
    s.u8(5)
        .u8(15)
        .u8(1)
        .bool(false)
        .bool(true)
        .u8(0)
        .u8(1)
        .num(0.9)
        .u8(4)
        .u8(0);
    // Two sources of 6 records on a pseudo-random walk through the box.
    s.u8(2);
    let mut k = 0u32;
    let mut coordinate = || {
        k += 1;
        ((k * 97) % 251) as u8
    };
    for j in 0..2 {
        s.u8(6);
        for i in 0..6u8 {
            for _ in 0..dims {
                s.u8(coordinate());
            }
            s.u8(i % 2).num(-1.0 - f64::from(i) * 0.3 - f64::from(j));
            for _ in 0..dims {
                s.u8(coordinate());
            }
            s.bool(false);
        }
    }
    // Two candidate pairs, grid spacing (high − low)/2, 3 FQI cells per axis.
    s.u8(1);
    for a in 0..2u8 {
        for _ in 0..dims {
            s.u8(coordinate());
        }
        s.u8(a);
    }
    s.u8(1).u8(rows).u8(2);
    let rows_len = match rows {
        0 => 3usize.pow(dims as u32) * if mode < 2 { 4 } else { 2 },
        1 => 2,
        _ => 12,
    };
    // Stored posteriors and scores of the right sizes, then the stages.
    s.u8(2);
    for i in 0..12 {
        s.num(-1.0 - f64::from(i) * 0.1).num(0.05);
    }
    s.u8(2).u8(2);
    for i in 0..rows_len {
        s.num(f64::from(i as u32 % 5));
    }
    s.u8(2).u8(posteriors).u8(scores);
    if scores == 1 {
        s.u8(3);
    }
    // Two steps, buffers of the right sizes, generator seed.
    s.u8(1).u8(2).u8(2).u8(2).u8(2).u8(7);
    s
}

fn loop_seeds() {
    for (mode, dims, p) in [
        (0u8, 2, "puddle_f32"),
        (1, 2, "puddle_f64"),
        (2, 4, "toy_f32"),
        (3, 4, "toy_f64"),
    ] {
        for (rows, posteriors, scores, name) in [
            (0u8, 1u8, 2u8, "grid_fit_realistic"),
            (1, 0, 1, "pairs_stored_oracle"),
            (2, 0, 0, "sources_stored_stored"),
        ] {
            write(
                "awfqi_loop",
                &format!("{name}_{p}"),
                &loop_seed(mode, dims, rows, posteriors, scores),
            );
        }
    }
}

/// Adaptive AWFQI (`fuzz_targets/adaptive_loop.rs`): a well-formed set-up on Puddle World
/// (shared dynamics, start (0, 0)): budget 6, horizon 10, ε = 0.3, 15 evaluations and 1
/// restart per search, spread subset, 3 sub-batches, 70 % verification, floor ≈ 0.1, 15
/// candidates, every factor on; two sources of 6 records with fitted mean functions; grid
/// rows (`rows` 0) or source rows (2), the table (`tiles` false) or 2 × 2 tiles × 2, or a
/// model sweep of 4 × 4 cells with pooled rewards (`sweep`); 2 steps.
fn adaptive_seed(f32: bool, rows: u8, tiles: bool) -> Seed {
    adaptive_seed_with(f32, rows, if tiles { Fqi::Tiles } else { Fqi::Table })
}

/// The FQI approximator of an [`adaptive_seed`].
enum Fqi {
    Table,
    Tiles,
    Sweep,
}

fn adaptive_seed_with(f32: bool, rows: u8, fqi: Fqi) -> Seed {
    let mut s = Seed::new();
    s.bool(f32).bool(false).bool(false).u8(1);
    s.u8(6).u8(10).u8(60).u8(15).u8(1).bool(false).bool(true);
    s.u8(3).u8(140).bool(false).u8(25).u8(15).u8(1);
    s.bool(true).bool(true).bool(true);
    s.u8(2).bool(false);
    let mut k = 0u32;
    let mut coordinate = || {
        k += 1;
        ((k * 97) % 251) as u8
    };
    for j in 0..2 {
        s.u8(6);
        for i in 0..6u8 {
            s.u8(coordinate()).u8(coordinate()).u8(i % 4);
            s.num(-1.0 - f64::from(j) * f64::from(i));
            s.u8(coordinate()).u8(coordinate()).bool(false);
        }
    }
    s.u8(2);
    for _ in 0..12 {
        s.num(-1.5).u8(5);
    }
    s.u8(7).u8(2).bool(true).bool(true);
    s.u8(0).u8(coordinate()).u8(coordinate()).u8(1);
    s.u8(1).u8(rows);
    match fqi {
        Fqi::Tiles => s.bool(true).u8(2).u8(2),
        Fqi::Table => s.bool(false).u8(3),
        Fqi::Sweep => s.u8(5).u8(1).bool(false).bool(false).u8(4),
    };
    s.u8(1);
    for _ in 0..7 {
        s.u8(2);
    }
    s
}

fn adaptive_seeds() {
    for f32 in [true, false] {
        let p = if f32 { "f32" } else { "f64" };
        write(
            "adaptive_loop",
            &format!("grid_table_{p}"),
            &adaptive_seed(f32, 0, false),
        );
        write(
            "adaptive_loop",
            &format!("sources_tiles_{p}"),
            &adaptive_seed(f32, 2, true),
        );
        write(
            "adaptive_loop",
            &format!("grid_sweep_{p}"),
            &adaptive_seed_with(f32, 0, Fqi::Sweep),
        );
    }
}

/// The model sweep (`fuzz_targets/model_sweep.rs`), in 2-D: a 4 × 4-cell grid over
/// `[0, 10]²`, each reward model, 4 actions moving one unit, 12 records on a walk in two
/// sets (the second weighted), γ = 0.9 and 8 iterations, then four probes (one NaN, one
/// outside the box); also the same through `QFunction`, and short storage.
fn sweep_seeds() {
    let walk: Vec<([f64; 2], u8, f64, [f64; 2], bool)> = (0..12)
        .map(|i| {
            let x = f64::from(i % 4) * 2.5;
            let y = f64::from(i / 4) * 2.5;
            let a = (i % 4) as u8;
            let next = [
                (x + [1.0, -1.0, 0.0, 0.0][usize::from(a)]).clamp(0.0, 10.0),
                (y + [0.0, 0.0, 1.0, -1.0][usize::from(a)]).clamp(0.0, 10.0),
            ];
            ([x, y], a, -1.0 - f64::from(i % 3), next, i == 11)
        })
        .collect();
    for f32 in [true, false] {
        let p = if f32 { "f32" } else { "f64" };
        for (model, name) in [(0u8, "per_action"), (1, "pooled"), (2, "backfilled")] {
            for (via_q, short, how) in [
                (false, false, "direct"),
                (true, false, "q"),
                (false, true, "short"),
            ] {
                let mut s = Seed::new();
                s.u8(u8::from(f32)).bool(false).u8(3);
                s.u8(model).bool(false).bool(model == 2);
                s.u8(4).u8(if short { 0xff } else { 0 }).u8(0).bool(via_q);
                s.bool(false).u8(8);
                s.u8(1);
                for (k, part) in [&walk[..6], &walk[6..]].into_iter().enumerate() {
                    s.u8(part.len() as u8);
                    for &(st, a, r, n, end) in part {
                        s.nums(&st).u8(a).num(r).nums(&n).bool(end);
                    }
                    if k == 1 {
                        s.bool(true).u8(0).nums(&[0.5, 1.0, 2.0, 0.0, 1e-9, 3.0]);
                    } else {
                        s.bool(false);
                    }
                    s.bool(false).bool(false);
                }
                for (st, a) in [
                    ([0.0, 0.0], 0u8),
                    ([NAN, 1.0], 1),
                    ([20.0, -5.0], 2),
                    ([4.9, 7.3], 5),
                ] {
                    s.nums(&st).u8(a);
                }
                write("model_sweep", &format!("walk_{name}_{how}_{p}"), &s);
            }
        }
    }
}

fn main() {
    gp_seeds();
    loop_seeds();
    env_seeds();
    fqi_seeds();
    score_seeds();
    weights_seeds();
    belief_seeds();
    adaptive_seeds();
    sweep_seeds();
    println!("seeds written under fuzz/seeds/");
}
