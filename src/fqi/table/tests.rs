extern crate std;
use super::*;
use crate::fqi::fill::nearest_visited;
use crate::fqi::{EmptyCells, TileFqi, Tilings};
use crate::model::Transition;
use std::vec;
use std::vec::Vec;

type Sample = Transition<[f64; 2], f64>;

fn sample(state: [f64; 2], action: usize, reward: f64, next: [f64; 2], absorbing: bool) -> Sample {
    Transition {
        state,
        action,
        reward,
        next_state: next,
        absorbing,
    }
}

/// Centre of cell `i` of a 1-row grid of unit cells.
fn at(i: usize) -> [f64; 2] {
    [i as f64 + 0.5, 0.5]
}

fn line(n: usize) -> CellGrid<f64, 2> {
    CellGrid::new([0.0, 0.0], [n as f64, 1.0], [n, 1]).unwrap()
}

/// A deterministic chain of 5 cells: action 0 moves right, action 1 left (clipped at
/// cell 0), reward −1 per move, reaching cell 4 is absorbing. Cell 4 itself has no sample.
fn chain() -> Vec<Sample> {
    let mut v = Vec::new();
    for c in 0..4 {
        v.push(sample(at(c), 0, -1.0, at(c + 1), c + 1 == 4));
        v.push(sample(at(c), 1, -1.0, at(c.saturating_sub(1)), false));
    }
    v
}

#[test]
fn deterministic_chain_converges_to_the_known_q_star() {
    let gamma = 0.9f64;
    let grid = line(5);
    let mut storage = vec![FqiEntry::default(); 10];
    let mut fqi = TabularFqi::new(grid, 2, &mut storage).unwrap();
    let samples = chain();
    let config = FqiConfig::new(gamma, 60, EmptyCells::Nearest).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &config)
        .unwrap();
    // V*(c) = −(1 − γ^(4−c)) / (1 − γ): 4 − c moves right, each −1, the last one absorbing.
    let v_star = |c: usize| -(1.0 - gamma.powi(4 - c as i32)) / (1.0 - gamma);
    for c in 0..4 {
        let right = fqi.value(at(c), 0).unwrap();
        let left = fqi.value(at(c), 1).unwrap();
        assert!((right - v_star(c)).abs() < 1e-12, "Q({c}, right) = {right}");
        let want_left = -1.0 + gamma * v_star(c.saturating_sub(1));
        assert!((left - want_left).abs() < 1e-12, "Q({c}, left) = {left}");
        assert_eq!(fqi.greedy_action(at(c)).unwrap(), 0);
        assert!((fqi.max_value(at(c)).unwrap() - v_star(c)).abs() < 1e-12);
    }
    // The goal cell has no data: it copies its nearest visited cell, cell 3.
    assert_eq!(fqi.value(at(4), 0).unwrap(), fqi.value(at(3), 0).unwrap());
}

#[test]
fn deterministic_chain_in_f32() {
    let grid = CellGrid::new([0.0f32, 0.0], [5.0, 1.0], [5, 1]).unwrap();
    let mut storage = [FqiEntry::default(); 10];
    let mut fqi = TabularFqi::new(grid, 2, &mut storage).unwrap();
    let samples: Vec<Transition<[f32; 2], f32>> = chain()
        .iter()
        .map(|s| Transition {
            state: [s.state[0] as f32, s.state[1] as f32],
            action: s.action,
            reward: s.reward as f32,
            next_state: [s.next_state[0] as f32, s.next_state[1] as f32],
            absorbing: s.absorbing,
        })
        .collect();
    fqi.fit(&[SampleSet::unweighted(&samples)], &FqiConfig::published())
        .unwrap();
    for c in 0..4usize {
        let want = -(1.0 - 0.99f64.powi(4 - c as i32)) / 0.01;
        let got = fqi.value([c as f32 + 0.5, 0.5], 0).unwrap() as f64;
        assert!((got - want).abs() < 1e-5, "{got} vs {want}");
    }
}

/// Cell 0 has two samples, to cells 1 and 2, which are absorbing with rewards −2 and −4.
fn fork() -> Vec<Sample> {
    vec![
        sample(at(0), 0, -1.0, at(1), false),
        sample(at(0), 0, -3.0, at(2), false),
        sample(at(1), 0, -2.0, at(0), true),
        sample(at(2), 0, -4.0, at(0), true),
    ]
}

#[test]
fn reward_weights_fit_the_reward_model_and_transition_weights_the_bootstrap() {
    let gamma = 0.5;
    let mut storage = [FqiEntry::default(); 3];
    let mut fqi = TabularFqi::new(line(3), 1, &mut storage).unwrap();
    let samples = fork();
    let w_r = [3.0, 1.0, 1.0, 1.0];
    let w_s = [1.0, 3.0, 1.0, 1.0];
    let config = FqiConfig::new(gamma, 10, EmptyCells::Nearest).unwrap();
    fqi.fit(
        &[SampleSet::weighted(&samples, Some(&w_r), Some(&w_s))],
        &config,
    )
    .unwrap();
    // R̂(0) = (3·−1 + 1·−3)/4 = −1.5; bootstrap mean (1·V(1) + 3·V(2))/4 = (−2 − 12)/4.
    // Using the observed rewards with w_s instead of r̂ would give −2.5 + … (IWFQI uses r̂).
    let want = -1.5 + gamma * (-14.0 / 4.0);
    assert!((fqi.value(at(0), 0).unwrap() - want).abs() < 1e-12);
    assert!((fqi.entries()[0].reward_model() + 1.5).abs() < 1e-12);
    assert_eq!(fqi.value(at(1), 0).unwrap(), -2.0);
    assert_eq!(fqi.value(at(2), 0).unwrap(), -4.0);

    // Unweighted = plain FQI: mean reward −2, mean bootstrap (−2 − 4)/2.
    fqi.fit(&[SampleSet::unweighted(&samples)], &config)
        .unwrap();
    let want = -2.0 + gamma * (-3.0);
    assert!((fqi.value(at(0), 0).unwrap() - want).abs() < 1e-12);
    // Explicit unit weights give the same table.
    let ones = [1.0; 4];
    let mut storage2 = [FqiEntry::default(); 3];
    let mut fqi2 = TabularFqi::new(line(3), 1, &mut storage2).unwrap();
    fqi2.fit(
        &[SampleSet::weighted(&samples, Some(&ones), Some(&ones))],
        &config,
    )
    .unwrap();
    assert_eq!(fqi.entries(), fqi2.entries());
}

#[test]
fn sets_are_a_union_and_one_iteration_is_the_reward_model() {
    let samples = fork();
    let config1 = FqiConfig::new(0.5, 1, EmptyCells::Nearest).unwrap();
    let config = FqiConfig::new(0.5, 5, EmptyCells::Nearest).unwrap();
    let mut s1 = [FqiEntry::default(); 3];
    let mut s2 = [FqiEntry::default(); 3];
    let mut whole = TabularFqi::new(line(3), 1, &mut s1).unwrap();
    let mut split = TabularFqi::new(line(3), 1, &mut s2).unwrap();
    whole
        .fit(&[SampleSet::unweighted(&samples)], &config1)
        .unwrap();
    assert_eq!(whole.value(at(0), 0).unwrap(), -2.0);
    whole
        .fit(&[SampleSet::unweighted(&samples)], &config)
        .unwrap();
    let (a, b) = samples.split_at(1);
    split
        .fit(
            &[SampleSet::unweighted(a), SampleSet::unweighted(b)],
            &config,
        )
        .unwrap();
    assert_eq!(whole.entries(), split.entries());
}

#[test]
fn zero_weight_samples_have_no_say() {
    // A sample with zero reward and transition weight in cell 0 that would change both the
    // reward and the bootstrap: the fit must equal the one without it.
    let mut samples = fork();
    samples.push(sample(at(0), 0, 100.0, at(1), false));
    let w = [1.0, 1.0, 1.0, 1.0, 0.0];
    let config = FqiConfig::new(0.5, 10, EmptyCells::Nearest).unwrap();
    let mut s1 = [FqiEntry::default(); 3];
    let mut with = TabularFqi::new(line(3), 1, &mut s1).unwrap();
    with.fit(
        &[SampleSet::weighted(&samples, Some(&w), Some(&w))],
        &config,
    )
    .unwrap();
    let mut s2 = [FqiEntry::default(); 3];
    let mut without = TabularFqi::new(line(3), 1, &mut s2).unwrap();
    without
        .fit(&[SampleSet::unweighted(&fork())], &config)
        .unwrap();
    assert_eq!(with.value(at(0), 0), without.value(at(0), 0));
}

#[test]
fn a_cell_whose_reward_weights_are_zero_takes_the_nearest_reward_model() {
    // Cell 1's only sample has reward weight 0 but transition weight 1: its R̂ comes from
    // cell 0 (distance 1, smaller index than cell 2), and it still bootstraps.
    let samples = vec![
        sample(at(0), 0, -1.0, at(0), true),
        sample(at(1), 0, -50.0, at(2), false),
        sample(at(2), 0, -5.0, at(2), true),
    ];
    let w_r = [1.0, 0.0, 1.0];
    let config = FqiConfig::new(0.5, 10, EmptyCells::Nearest).unwrap();
    let mut s = [FqiEntry::default(); 3];
    let mut fqi = TabularFqi::new(line(3), 1, &mut s).unwrap();
    fqi.fit(&[SampleSet::weighted(&samples, Some(&w_r), None)], &config)
        .unwrap();
    assert_eq!(fqi.entries()[1].reward_model(), -1.0);
    assert!((fqi.value(at(1), 0).unwrap() - (-1.0 + 0.5 * -5.0)).abs() < 1e-12);
}

#[test]
fn empty_cells_take_the_nearest_visited_cell_with_smallest_index_ties() {
    // 3×3 grid, one action, data only in cells (0,0) [value −1] and (2,2) [value −9].
    let grid = CellGrid::new([0.0, 0.0], [3.0, 3.0], [3, 3]).unwrap();
    let c = |i: usize, j: usize| [i as f64 + 0.5, j as f64 + 0.5];
    let samples = vec![
        sample(c(0, 0), 0, -1.0, c(0, 0), true),
        sample(c(2, 2), 0, -9.0, c(2, 2), true),
    ];
    let mut s = [FqiEntry::default(); 9];
    let mut fqi = TabularFqi::new(grid, 1, &mut s).unwrap();
    let config = FqiConfig::new(0.9, 3, EmptyCells::Nearest).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &config)
        .unwrap();
    let v = |i, j| fqi.value(c(i, j), 0).unwrap();
    // Nearer to (0,0): (1,0), (0,1). Nearer to (2,2): (2,1), (1,2).
    assert_eq!(v(1, 0), -1.0);
    assert_eq!(v(0, 1), -1.0);
    assert_eq!(v(2, 1), -9.0);
    assert_eq!(v(1, 2), -9.0);
    // Equidistant (d² = 2 or 4): the smaller cell index, (0,0).
    assert_eq!(v(1, 1), -1.0);
    assert_eq!(v(2, 0), -1.0);
    assert_eq!(v(0, 2), -1.0);

    // Euclidean, not Chebyshev: from (3,3), (0,0) is at Chebyshev distance 3 but d² = 18,
    // (3,7) at Chebyshev distance 4 but d² = 16.
    let grid = CellGrid::new([0.0, 0.0], [5.0, 8.0], [5, 8]).unwrap();
    let samples = vec![
        sample(c(0, 0), 0, -1.0, c(0, 0), true),
        sample(c(3, 7), 0, -7.0, c(3, 7), true),
    ];
    let mut s = [FqiEntry::default(); 40];
    let mut fqi = TabularFqi::new(grid, 1, &mut s).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &config)
        .unwrap();
    assert_eq!(fqi.value(c(3, 3), 0).unwrap(), -7.0);
    assert_eq!(fqi.value(c(2, 2), 0).unwrap(), -1.0);
}

#[test]
fn empty_cells_fixed_value_and_actions_without_data() {
    let samples = vec![sample(at(0), 0, -1.0, at(0), true)];
    let config = FqiConfig::new(0.9, 3, EmptyCells::Value(-20.0)).unwrap();
    let mut s = [FqiEntry::default(); 6];
    let mut fqi = TabularFqi::new(line(3), 2, &mut s).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &config)
        .unwrap();
    assert_eq!(fqi.value(at(0), 0).unwrap(), -1.0);
    assert_eq!(fqi.value(at(2), 0).unwrap(), -20.0);
    assert_eq!(fqi.value(at(0), 1).unwrap(), -20.0);
    // Nearest: action 1 has no data anywhere → 0.
    let nearest = FqiConfig::new(0.9, 3, EmptyCells::Nearest).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &nearest)
        .unwrap();
    assert_eq!(fqi.value(at(2), 0).unwrap(), -1.0);
    assert_eq!(fqi.value(at(1), 1).unwrap(), 0.0);
    // Greedy: action 1 (0) beats action 0 (−1); a tie goes to the smaller index.
    assert_eq!(fqi.greedy_action(at(0)).unwrap(), 1);
    // Capped: in cell 0, the untried action 1 is capped at the tried action's −1; in the
    // unvisited cells 1 and 2 nothing caps it.
    fqi.fit(&[SampleSet::unweighted(&samples)], &FqiConfig::published())
        .unwrap();
    assert_eq!(fqi.value(at(0), 1).unwrap(), -1.0);
    assert_eq!(fqi.value(at(1), 1).unwrap(), 0.0);
    assert_eq!(fqi.greedy_action(at(0)).unwrap(), 0);
    // A tie between a filled value and a fitted one goes to the fitted one, whatever the
    // index: only action 1 was tried, action 0 is capped at its value.
    let only_1 = vec![sample(at(0), 1, -1.0, at(0), true)];
    fqi.fit(&[SampleSet::unweighted(&only_1)], &FqiConfig::published())
        .unwrap();
    assert_eq!(fqi.value(at(0), 0).unwrap(), -1.0);
    assert!(fqi.entries()[1].has_data() && !fqi.entries()[0].has_data());
    assert_eq!(fqi.greedy_action(at(0)).unwrap(), 1);
    let tie = vec![
        sample(at(0), 0, -1.0, at(0), true),
        sample(at(0), 1, -1.0, at(0), true),
    ];
    fqi.fit(&[SampleSet::unweighted(&tie)], &FqiConfig::published())
        .unwrap();
    assert_eq!(fqi.greedy_action(at(0)).unwrap(), 0);
}

#[test]
fn capped_nearest_keeps_an_untried_action_from_looping_at_a_border() {
    // A 3-cell corridor, goal beyond cell 2. Action 0 moves right (tried everywhere); action
    // 1 "stays" (tried only in cell 2, where it is absorbing with reward 0 — the goal's
    // neighbourhood). Plain nearest filling copies that 0 to cells 0 and 1, so the greedy
    // policy would stay forever; the cap keeps "stay" below "right" where right was tried.
    let samples = vec![
        sample(at(0), 0, -1.0, at(1), false),
        sample(at(1), 0, -1.0, at(2), false),
        sample(at(2), 0, -1.0, at(2), true),
        sample(at(2), 1, 0.0, at(2), true),
    ];
    let mut s = [FqiEntry::default(); 6];
    let mut fqi = TabularFqi::new(line(3), 2, &mut s).unwrap();
    let nearest = FqiConfig::new(0.9, 20, EmptyCells::Nearest).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &nearest)
        .unwrap();
    assert_eq!(fqi.value(at(0), 1).unwrap(), 0.0);
    assert_eq!(fqi.greedy_action(at(0)).unwrap(), 1);
    let capped = FqiConfig::new(0.9, 20, EmptyCells::CappedNearest).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &capped)
        .unwrap();
    // V(2) = max(−1, 0) = 0, so Q(1, right) = −1 + 0.9·0 = −1; "stay" in cell 1 is capped
    // at −1, so V(1) = −1 and Q(0, right) = −1 + 0.9·(−1) = −1.9, which caps "stay" in 0.
    assert!((fqi.value(at(0), 0).unwrap() + 1.9).abs() < 1e-12);
    assert!((fqi.value(at(0), 1).unwrap() + 1.9).abs() < 1e-12);
    assert_eq!(fqi.greedy_action(at(0)).unwrap(), 0);
    assert_eq!(fqi.value(at(2), 1).unwrap(), 0.0);
}

#[test]
fn bad_input_is_rejected_and_leaves_q_intact() {
    let samples = fork();
    let config = FqiConfig::new(0.5, 10, EmptyCells::Nearest).unwrap();
    let mut s = [FqiEntry::default(); 3];
    let mut fqi = TabularFqi::new(line(3), 1, &mut s).unwrap();
    fqi.fit(&[SampleSet::unweighted(&samples)], &config)
        .unwrap();
    let before: Vec<_> = fqi.entries().to_vec();

    let mut bad = samples.clone();
    bad[3].next_state[1] = f64::NAN;
    assert_eq!(
        fqi.fit(&[SampleSet::unweighted(&bad)], &config),
        Err(Error::NonFinite {
            parameter: "next_state"
        })
    );
    let mut bad = samples.clone();
    bad[2].action = 1;
    assert_eq!(
        fqi.fit(&[SampleSet::unweighted(&bad)], &config),
        Err(Error::OutOfRange {
            parameter: "action"
        })
    );
    let short = [1.0; 3];
    assert_eq!(
        fqi.fit(
            &[SampleSet::weighted(&samples, Some(&short), None)],
            &config
        ),
        Err(Error::InvalidParameter {
            parameter: "reward_weights"
        })
    );
    let negative = [1.0, 1.0, -1.0, 1.0];
    assert_eq!(
        fqi.fit(
            &[SampleSet::weighted(&samples, None, Some(&negative))],
            &config
        ),
        Err(Error::InvalidParameter {
            parameter: "transition_weights"
        })
    );
    assert_eq!(fqi.fit(&[], &config), Err(Error::EmptyData));
    assert_eq!(fqi.entries(), &before[..]);

    assert!(fqi.value([f64::NAN, 0.0], 0).is_err());
    assert!(fqi.value(at(0), 1).is_err());
    assert!(FqiConfig::new(1.5, 10, EmptyCells::<f64>::Nearest).is_err());
    assert!(FqiConfig::new(0.5, 0, EmptyCells::<f64>::Nearest).is_err());
    let mut small = [FqiEntry::default(); 2];
    assert_eq!(
        TabularFqi::new(line(3), 1, &mut small).err(),
        Some(Error::CapacityExceeded { capacity: 2 })
    );
    assert!(TabularFqi::new(line(3), 0, &mut small).is_err());
}

#[test]
fn nearest_search_matches_brute_force() {
    // Exhaustive comparison on a 9×7 grid with a pseudo-random visited pattern.
    let (nx, ny) = (9usize, 7usize);
    let grid = CellGrid::new([0.0f64; 2], [1.0; 2], [nx, ny]).unwrap();
    for seed in 0..20u64 {
        let visited: Vec<bool> = (0..nx * ny)
            .map(|c| (c as u64 * 2_654_435_761 + seed * 97) % 11 < 2)
            .collect();
        for cell in 0..nx * ny {
            if visited[cell] {
                continue;
            }
            let (cx, cy) = ((cell % nx) as i64, (cell / nx) as i64);
            let brute = (0..nx * ny).filter(|&c| visited[c]).min_by_key(|&c| {
                let (x, y) = ((c % nx) as i64, (c / nx) as i64);
                ((x - cx).pow(2) + (y - cy).pow(2), c)
            });
            assert_eq!(nearest_visited(&grid, cell, |c| visited[c]), brute);
        }
    }
}

#[test]
fn nearest_search_matches_brute_force_in_one_three_and_four_dimensions() {
    fn check<const D: usize>(dims: [usize; D], density: u64) {
        let grid = CellGrid::new([0.0f64; D], [1.0; D], dims).unwrap();
        let n = grid.len();
        for seed in 0..6u64 {
            let visited: Vec<bool> = (0..n)
                .map(|c| (c as u64 * 2_654_435_761 + seed * 97) % 31 < density)
                .collect();
            for cell in 0..n {
                if visited[cell] {
                    continue;
                }
                let at = grid.coordinates(cell).unwrap();
                let brute = (0..n).filter(|&c| visited[c]).min_by_key(|&c| {
                    let other = grid.coordinates(c).unwrap();
                    let d2: i64 = at
                        .iter()
                        .zip(&other)
                        .map(|(&a, &b)| (a as i64 - b as i64).pow(2))
                        .sum();
                    (d2, c)
                });
                assert_eq!(
                    nearest_visited(&grid, cell, |c| visited[c]),
                    brute,
                    "{dims:?} cell {cell}"
                );
            }
        }
    }
    check([13], 3);
    check([5, 4, 6], 2);
    check([4, 3, 5, 3], 1);
    check([3, 3, 3, 3], 0); // nothing visited: no donor
}

#[test]
fn replacement_rewards_fit_as_if_the_records_carried_them() {
    // The chain with rewards −1 replaced by −2 on its right moves: Q equals the fit on a
    // copy of the records that carries those rewards, for every approximator that reads
    // sample sets (table, tiles, kernel averaging); bad replacements are refused.
    let samples = chain();
    let rewards: Vec<f64> = samples
        .iter()
        .map(|s| if s.action == 0 { -2.0 } else { s.reward })
        .collect();
    let carried: Vec<Sample> = samples
        .iter()
        .zip(&rewards)
        .map(|(s, &reward)| Transition { reward, ..*s })
        .collect();
    let config = FqiConfig::new(0.9, 30, EmptyCells::Nearest).unwrap();
    let mut a = vec![FqiEntry::default(); 10];
    let mut b = vec![FqiEntry::default(); 10];
    let mut replaced = TabularFqi::new(line(5), 2, &mut a).unwrap();
    let mut copied = TabularFqi::new(line(5), 2, &mut b).unwrap();
    let set = SampleSet::unweighted(&samples).with_rewards(Some(&rewards));
    replaced.fit(&[set], &config).unwrap();
    copied
        .fit(&[SampleSet::unweighted(&carried)], &config)
        .unwrap();
    assert_eq!(replaced.entries(), copied.entries());
    // V*(0) moves right 4 times at −2: −2(1 − 0.9⁴)/(1 − 0.9).
    let want = -2.0 * (1.0 - 0.9f64.powi(4)) / 0.1;
    assert!((replaced.max_value(at(0)).unwrap() - want).abs() < 1e-12);

    let tiles = Tilings::new([0.0, 0.0], [5.0, 1.0], 5, 2).unwrap();
    let mut ta = vec![FqiEntry::EMPTY; 144];
    let mut tb = vec![FqiEntry::EMPTY; 144];
    let mut replaced = TileFqi::new(tiles, 2, &mut ta).unwrap();
    let mut copied = TileFqi::new(tiles, 2, &mut tb).unwrap();
    replaced.fit(&[set], &config).unwrap();
    copied
        .fit(&[SampleSet::unweighted(&carried)], &config)
        .unwrap();
    for c in 0..5 {
        for a in 0..2 {
            assert_eq!(replaced.value(at(c), a), copied.value(at(c), a));
        }
    }

    let before = replaced.value(at(0), 0);
    let short = [-1.0; 3];
    assert_eq!(
        replaced.fit(
            &[SampleSet::unweighted(&samples).with_rewards(Some(&short))],
            &config
        ),
        Err(Error::InvalidParameter {
            parameter: "rewards"
        })
    );
    let mut nan = rewards.clone();
    nan[2] = f64::NAN;
    assert_eq!(
        replaced.fit(
            &[SampleSet::unweighted(&samples).with_rewards(Some(&nan))],
            &config
        ),
        Err(Error::NonFinite {
            parameter: "reward"
        })
    );
    assert_eq!(replaced.value(at(0), 0), before);
}
