extern crate std;
use super::*;
use crate::fqi::EmptyCells;
use std::vec;
use std::vec::Vec;

type S1 = Transition<[f64; 1], f64>;

fn at(x: f64, action: usize, reward: f64, next: f64, absorbing: bool) -> S1 {
    Transition {
        state: [x],
        action,
        reward,
        next_state: [next],
        absorbing,
    }
}

fn config(iterations: usize) -> FqiConfig<f64> {
    FqiConfig::new(0.9, iterations, EmptyCells::Nearest).unwrap()
}

/// A sweep over `[0, 4]` with 4 cells (nodes 0, 1, 2, 3, 4) and its storage for 2 actions.
fn chain_sweep() -> (
    ModelSweep<f64, 1>,
    Vec<SweepEntry<f64, 1>>,
    Vec<SweepNode<f64>>,
) {
    let sweep = ModelSweep::cube(0.0, 4.0, 4).unwrap();
    let entries = vec![SweepEntry::EMPTY; sweep.required_entries(2).unwrap()];
    let nodes = vec![SweepNode::EMPTY; sweep.nodes()];
    (sweep, entries, nodes)
}

/// The 5-node chain: reward −1, action 0 moves right (arriving at 4 ends the episode),
/// action 1 moves left (stays at 0); one record per node 0..3 and action.
fn chain() -> Vec<S1> {
    let mut out = Vec::new();
    for x in 0..4 {
        let x = x as f64;
        out.push(at(x, 0, -1.0, x + 1.0, x + 1.0 == 4.0));
        out.push(at(x, 1, -1.0, (x - 1.0).max(0.0), false));
    }
    out
}

/// `−Σ_{j<n} γʲ`: the return of `n` steps of reward −1.
fn steps_cost(n: usize, gamma: f64) -> f64 {
    -(0..n).map(|j| gamma.powi(j as i32)).sum::<f64>()
}

#[test]
fn the_chain_is_value_iteration_on_its_nodes() {
    let (sweep, mut entries, mut nodes) = chain_sweep();
    let mut q = SweepFqi::new(sweep, 2, &mut entries, &mut nodes).unwrap();
    let data = chain();
    for n in [1usize, 2, 3, 60] {
        q.fit(&[SampleSet::unweighted(&data)], &config(n)).unwrap();
        for x in 0..4usize {
            // Right: 4 − x steps to the goal; `V_{n−1}` sees n − 1 of them at x + 1.
            let right = -1.0 + 0.9 * steps_cost((n - 1).min(3 - x), 0.9);
            let got = q.value([x as f64], 0).unwrap();
            assert!((got - right).abs() < 1e-12, "n {n} x {x}: {got} vs {right}");
            // Left: one step back (or staying at 0), then the best from there.
            let back = x.saturating_sub(1);
            let left = -1.0 + 0.9 * steps_cost((n - 1).min(4 - back), 0.9);
            let got = q.value([x as f64], 1).unwrap();
            assert!((got - left).abs() < 1e-12, "n {n} x {x}: {got} vs {left}");
            assert_eq!(q.greedy_action([x as f64]).unwrap(), 0);
        }
    }
    // Node 4 has no records: it takes node 3's model (reward −1, step +1 clamped to 4,
    // where Ω = 1), so its Q is −1.
    assert!((q.value([4.0], 0).unwrap() + 1.0).abs() < 1e-12);
    assert_eq!(q.nodes()[4].absorbing(), 1.0);
    assert_eq!(q.nodes()[2].absorbing(), 0.0);
}

#[test]
fn decisions_interpolate_node_values_or_look_ahead() {
    let (sweep, mut entries, mut nodes) = chain_sweep();
    let data = chain();
    let fitted = |sweep: ModelSweep<f64, 1>, entries: &mut [_], nodes: &mut [_]| {
        let mut q = SweepFqi::new(sweep, 2, entries, nodes).unwrap();
        q.fit(&[SampleSet::unweighted(&data)], &config(60)).unwrap();
        [1.25, 2.5].map(|x| q.value([x], 0).unwrap())
    };
    let at_nodes = |x: usize| -1.0 + 0.9 * steps_cost(3 - x, 0.9);
    let got = fitted(sweep, &mut entries, &mut nodes);
    assert!((got[0] - (0.75 * at_nodes(1) + 0.25 * at_nodes(2))).abs() < 1e-12);
    assert!((got[1] - (0.5 * at_nodes(2) + 0.5 * at_nodes(3))).abs() < 1e-12);
    // Lookahead at 2.5: R̂ = −1, d̂ = +1, y = 3.5 with V(3.5) = (V(3) + V(4))/2 and
    // Ω(3.5) = ½ (Ω(3) = 0, Ω(4) = 1). V_59(3) = −1 and V_59(4) = −1 (node 4 copies 3).
    let got = fitted(sweep.with_lookahead(true), &mut entries, &mut nodes);
    let (v3, v4) = (-1.0, -1.0);
    let expected = -1.0 + 0.9 * 0.5 * (0.5 * v3 + 0.5 * v4);
    assert!(
        (got[1] - expected).abs() < 1e-12,
        "{} vs {expected}",
        got[1]
    );
}

#[test]
fn rewards_are_hat_weighted_means_of_the_weighted_records() {
    let sweep = ModelSweep::cube(0.0, 4.0, 4).unwrap();
    let mut entries = vec![SweepEntry::EMPTY; sweep.required_entries(1).unwrap()];
    let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
    let mut q = SweepFqi::new(sweep, 1, &mut entries, &mut nodes).unwrap();
    // Node 1: −1 (weight 1) and −5 (weight 3) exactly at it, and −9 (weight 2) at 1.25,
    // which spreads 0.75 of its weight to node 1 and 0.25 to node 2.
    let data = [
        at(1.0, 0, -1.0, 1.0, false),
        at(1.0, 0, -5.0, 1.0, false),
        at(1.25, 0, -9.0, 1.25, false),
    ];
    let weights = [1.0, 3.0, 2.0];
    q.fit(
        &[SampleSet::weighted(&data, Some(&weights), None)],
        &config(1),
    )
    .unwrap();
    let node1 = (-1.0 - 15.0 - 9.0 * 1.5) / (1.0 + 3.0 + 1.5);
    assert!((q.entries()[1].reward() - node1).abs() < 1e-12);
    assert!((q.entries()[2].reward() + 9.0).abs() < 1e-12);
    // Nodes 0, 3 and 4 have no data: their neighbours' values, round after round.
    assert!((q.entries()[0].reward() - node1).abs() < 1e-12);
    assert!((q.entries()[3].reward() + 9.0).abs() < 1e-12);
    assert!((q.entries()[4].reward() + 9.0).abs() < 1e-12);
    // One iteration: Q is R̂.
    assert!((q.value([1.0], 0).unwrap() - node1).abs() < 1e-12);
}

#[test]
fn a_node_below_the_minimum_mass_takes_its_nearest_trusted_neighbours_reward() {
    let data = [at(0.0, 0, -1.0, 0.0, false), at(2.0, 0, -7.0, 2.0, false)];
    let weights = [0.1, 1.0];
    let reward_at_0 = |min_mass: f64| {
        let sweep = ModelSweep::cube(0.0, 4.0, 4)
            .unwrap()
            .with_min_mass(min_mass)
            .unwrap();
        let mut entries = vec![SweepEntry::EMPTY; sweep.required_entries(1).unwrap()];
        let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
        let mut q = SweepFqi::new(sweep, 1, &mut entries, &mut nodes).unwrap();
        q.fit(
            &[SampleSet::weighted(&data, Some(&weights), None)],
            &config(1),
        )
        .unwrap();
        q.entries()[0].reward()
    };
    assert_eq!(reward_at_0(0.0), -1.0);
    assert_eq!(reward_at_0(0.5), -7.0);
    assert!(
        ModelSweep::<f64, 1>::cube(0.0, 4.0, 4)
            .unwrap()
            .with_min_mass(-1.0)
            .is_err()
    );
}

#[test]
fn the_reward_models_pool_the_actions_where_they_say() {
    // Action 0 was tried at node 1 (reward −3), action 1 at node 3 (−7), action 2 nowhere.
    let data = [at(1.0, 0, -3.0, 2.0, false), at(3.0, 1, -7.0, 2.0, false)];
    // R̂ at nodes 1, 2, 3 for actions 0, 1, 2.
    let cases = [
        (
            RewardModel::PerAction,
            [[-3.0, -7.0, 0.0], [-3.0, -7.0, 0.0], [-3.0, -7.0, 0.0]],
        ),
        (
            RewardModel::Pooled,
            [[-3.0, -3.0, -3.0], [-5.0, -5.0, -5.0], [-7.0, -7.0, -7.0]],
        ),
        (
            RewardModel::Backfilled,
            [[-3.0, -3.0, -3.0], [-5.0, -5.0, -5.0], [-7.0, -7.0, -7.0]],
        ),
    ];
    for (model, expected) in cases {
        let sweep = ModelSweep::cube(0.0, 4.0, 4).unwrap().with_rewards(model);
        assert_eq!(sweep.rewards(), model);
        let mut entries = vec![SweepEntry::EMPTY; sweep.required_entries(3).unwrap()];
        let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
        let mut q = SweepFqi::new(sweep, 3, &mut entries, &mut nodes).unwrap();
        q.fit(&[SampleSet::unweighted(&data)], &config(1)).unwrap();
        for (node, row) in (1..4).zip(expected) {
            for (a, r) in row.into_iter().enumerate() {
                assert_eq!(
                    q.value([node as f64], a).unwrap(),
                    r,
                    "{model:?} {node} {a}"
                );
            }
        }
        // Action 2 has no step data anywhere: it stays in place.
        assert_eq!(q.next_state(2, 2), Some([2.0]));
        // Action 0's step is +1 everywhere (filled from node 1), clamped at the border.
        assert_eq!(q.next_state(0, 0), Some([1.0]));
        assert_eq!(q.next_state(3, 0), Some([4.0]));
        assert_eq!(q.next_state(4, 0), Some([4.0]));
        assert_eq!(q.next_state(5, 0), None);
    }
    // Backfilled keeps an action's own reward where it has one: action 1 at node 1 too.
    let data = [
        at(1.0, 0, -3.0, 2.0, false),
        at(1.0, 1, -9.0, 2.0, false),
        at(3.0, 1, -7.0, 2.0, false),
    ];
    let sweep = ModelSweep::cube(0.0, 4.0, 4)
        .unwrap()
        .with_rewards(RewardModel::Backfilled);
    let mut entries = vec![SweepEntry::EMPTY; sweep.required_entries(3).unwrap()];
    let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
    let mut q = SweepFqi::new(sweep, 3, &mut entries, &mut nodes).unwrap();
    q.fit(&[SampleSet::unweighted(&data)], &config(1)).unwrap();
    assert_eq!(q.value([1.0], 0).unwrap(), -3.0);
    assert_eq!(q.value([1.0], 1).unwrap(), -9.0);
    assert_eq!(q.value([1.0], 2).unwrap(), -6.0);
    assert_eq!(q.value([3.0], 0).unwrap(), -7.0);
}

#[test]
fn transition_weights_choose_the_steps_and_the_absorption() {
    // At node 2 action 0 was seen stepping +1 (weight 1) and −1 (weight 3, absorbing).
    let data = [at(2.0, 0, -1.0, 3.0, false), at(2.0, 0, -1.0, 1.0, true)];
    let sweep = ModelSweep::cube(0.0, 4.0, 4).unwrap();
    let mut entries = vec![SweepEntry::EMPTY; sweep.required_entries(1).unwrap()];
    let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
    let mut q = SweepFqi::new(sweep, 1, &mut entries, &mut nodes).unwrap();
    let ws = [1.0, 3.0];
    q.fit(&[SampleSet::weighted(&data, None, Some(&ws))], &config(1))
        .unwrap();
    assert_eq!(q.next_state(2, 0), Some([2.0 + (1.0 - 3.0) / 4.0]));
    assert_eq!(q.nodes()[1].absorbing(), 1.0);
    assert_eq!(q.nodes()[3].absorbing(), 0.0);
    // A zero weight removes a record from the steps and the absorption.
    let ws = [1.0, 0.0];
    q.fit(&[SampleSet::weighted(&data, None, Some(&ws))], &config(1))
        .unwrap();
    assert_eq!(q.next_state(2, 0), Some([3.0]));
    assert_eq!(q.nodes()[1].absorbing(), 0.0);
}

#[test]
fn steps_out_of_the_box_are_clamped() {
    // Action 0 at node 4 steps +3 (to 7, outside [0, 4]): the step is measured between the
    // clamped states (0) and its lookahead stays inside the box.
    let data = [at(4.0, 0, -2.0, 7.0, false), at(0.0, 0, -2.0, 3.0, false)];
    let sweep = ModelSweep::cube(0.0, 4.0, 4).unwrap();
    let mut entries = vec![SweepEntry::EMPTY; sweep.required_entries(1).unwrap()];
    let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
    let mut q = SweepFqi::new(sweep, 1, &mut entries, &mut nodes).unwrap();
    q.fit(&[SampleSet::unweighted(&data)], &config(2)).unwrap();
    assert_eq!(q.next_state(4, 0), Some([4.0]));
    assert_eq!(q.next_state(0, 0), Some([3.0]));
    // Two iterations: Q = −2 + 0.9·(−2) everywhere (no absorption).
    assert!((q.value([4.0], 0).unwrap() + 3.8).abs() < 1e-12);
    assert!((q.value([1.0], 0).unwrap() + 3.8).abs() < 1e-12);
}

#[test]
fn bad_input_and_short_storage_leave_q_as_it_was() {
    let (sweep, mut entries, mut nodes) = chain_sweep();
    let mut q = SweepFqi::new(sweep, 2, &mut entries, &mut nodes).unwrap();
    let data = chain();
    q.fit(&[SampleSet::unweighted(&data)], &config(60)).unwrap();
    let before: Vec<f64> = (0..9)
        .map(|i| q.value([i as f64 / 2.0], 0).unwrap())
        .collect();
    let mut bad = data.clone();
    bad[3].reward = f64::NAN;
    assert_eq!(
        q.fit(&[SampleSet::unweighted(&bad)], &config(60)),
        Err(Error::NonFinite {
            parameter: "reward"
        })
    );
    let mut bad = data.clone();
    bad[0].action = 2;
    assert_eq!(
        q.fit(&[SampleSet::unweighted(&bad)], &config(60)),
        Err(Error::OutOfRange {
            parameter: "action"
        })
    );
    let negative = vec![-1.0; data.len()];
    assert!(
        q.fit(
            &[SampleSet::weighted(&data, Some(&negative), None)],
            &config(60)
        )
        .is_err()
    );
    assert_eq!(q.fit(&[], &config(60)), Err(Error::EmptyData));
    let after: Vec<f64> = (0..9)
        .map(|i| q.value([i as f64 / 2.0], 0).unwrap())
        .collect();
    assert_eq!(before, after);
    assert_eq!(
        q.value([f64::NAN], 0),
        Err(Error::NonFinite { parameter: "state" })
    );
    assert_eq!(
        q.value([1.0], 2),
        Err(Error::OutOfRange {
            parameter: "action"
        })
    );
    let (sweep, mut entries, mut nodes) = chain_sweep();
    assert_eq!(
        SweepFqi::new(sweep, 2, &mut entries[..9], &mut nodes).err(),
        Some(Error::CapacityExceeded { capacity: 9 })
    );
    assert_eq!(
        SweepFqi::new(sweep, 2, &mut entries, &mut nodes[..4]).err(),
        Some(Error::CapacityExceeded { capacity: 4 })
    );
    assert_eq!(
        SweepFqi::new(sweep, 0, &mut entries, &mut nodes).err(),
        Some(Error::InvalidParameter {
            parameter: "actions"
        })
    );
}

#[test]
fn a_fresh_or_cleared_q_is_zero() {
    let (sweep, mut entries, mut nodes) = chain_sweep();
    let mut q = SweepFqi::new(sweep, 2, &mut entries, &mut nodes).unwrap();
    assert_eq!(q.max_value([2.2]).unwrap(), 0.0);
    q.fit(&[SampleSet::unweighted(&chain())], &config(5))
        .unwrap();
    assert!(q.max_value([2.2]).unwrap() < 0.0);
    q.clear();
    assert_eq!(q.max_value([2.2]).unwrap(), 0.0);
}

type S2 = Transition<[f64; 2], f64>;

/// The 3 × 3 grid world on `[0, 2]²`: actions right, left, up, down move one node (walls
/// stop them), reward −1, arriving at (2, 2) ends the episode; one record per action at
/// every other node.
fn grid_world() -> Vec<S2> {
    let moves = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]];
    let mut out = Vec::new();
    for y in 0..3 {
        for x in 0..3 {
            let state = [x as f64, y as f64];
            if state == [2.0, 2.0] {
                continue;
            }
            for (action, m) in moves.iter().enumerate() {
                let next = [
                    (state[0] + m[0]).clamp(0.0, 2.0),
                    (state[1] + m[1]).clamp(0.0, 2.0),
                ];
                out.push(Transition {
                    state,
                    action,
                    reward: -1.0,
                    next_state: next,
                    absorbing: next == [2.0, 2.0],
                });
            }
        }
    }
    out
}

#[test]
fn the_grid_world_is_value_iteration_in_two_dimensions() {
    let sweep = ModelSweep::cube(0.0, 2.0, 2).unwrap();
    let mut entries = vec![SweepEntry::EMPTY; sweep.required_entries(4).unwrap()];
    let mut nodes = vec![SweepNode::EMPTY; sweep.nodes()];
    let mut q = SweepFqi::new(sweep, 4, &mut entries, &mut nodes).unwrap();
    let data = grid_world();
    q.fit(&[SampleSet::unweighted(&data)], &config(60)).unwrap();
    // V*(s) is the cost of the Manhattan distance to the goal.
    let v = |s: [f64; 2]| steps_cost((4.0 - s[0] - s[1]) as usize, 0.9);
    let moves = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]];
    for y in 0..3 {
        for x in 0..3 {
            let s = [x as f64, y as f64];
            if s == [2.0, 2.0] {
                continue;
            }
            let mut best = (0, f64::NEG_INFINITY);
            for (a, m) in moves.iter().enumerate() {
                let next = [(s[0] + m[0]).clamp(0.0, 2.0), (s[1] + m[1]).clamp(0.0, 2.0)];
                let ahead = if next == [2.0, 2.0] { 0.0 } else { v(next) };
                let expected = -1.0 + 0.9 * ahead;
                let got = q.value(s, a).unwrap();
                assert!(
                    (got - expected).abs() < 1e-12,
                    "{s:?} {a}: {got} vs {expected}"
                );
                assert_eq!(q.next_state(y * 3 + x, a), Some(next));
                if expected > best.1 {
                    best = (a, expected);
                }
            }
            assert_eq!(q.greedy_action(s).unwrap(), best.0, "{s:?}");
        }
    }
    // Between nodes the Q-values are interpolated bilinearly.
    let corners = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
    let mean = corners.iter().map(|&c| q.value(c, 2).unwrap()).sum::<f64>() / 4.0;
    assert!((q.value([0.5, 0.5], 2).unwrap() - mean).abs() < 1e-12);
    let left = 0.75 * q.value([1.0, 1.0], 0).unwrap() + 0.25 * q.value([2.0, 1.0], 0).unwrap();
    assert!((q.value([1.25, 1.0], 0).unwrap() - left).abs() < 1e-12);
}
