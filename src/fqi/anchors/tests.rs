extern crate std;
use super::*;
use crate::fqi::{EmptyCells, FqiConfig};
use crate::model::Transition;
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

/// Storage for `budget` nodes and `actions` actions.
struct Parts<const D: usize> {
    entries: Vec<AnchorEntry<f64>>,
    nodes: Vec<SweepNode<f64>>,
    positions: Vec<[f64; D]>,
    landings: Vec<[f64; D]>,
}

impl<const D: usize> Parts<D> {
    fn new(budget: usize, actions: usize) -> Self {
        Self {
            entries: vec![AnchorEntry::EMPTY; budget * actions],
            nodes: vec![SweepNode::EMPTY; budget],
            positions: vec![[0.0; D]; budget],
            landings: vec![[0.0; D]; budget],
        }
    }

    fn lend(&mut self) -> AnchorParts<'_, f64, D> {
        AnchorParts {
            entries: &mut self.entries,
            nodes: &mut self.nodes,
            positions: &mut self.positions,
            landings: &mut self.landings,
        }
    }
}

/// The 5-state chain on `[0, 4]`: reward −1, action 0 moves right (arriving at 4 ends the
/// episode; at 4 it stays there, ended), action 1 moves left (stays at 0).
fn chain() -> Vec<S1> {
    let mut out = Vec::new();
    for x in 0..5 {
        let x = x as f64;
        let right = (x + 1.0).min(4.0);
        out.push(at(x, 0, -1.0, right, right == 4.0));
        out.push(at(x, 1, -1.0, (x - 1.0).max(0.0), false));
    }
    out
}

/// `−Σ_{j<n} γʲ`: the return of `n` steps of reward −1.
fn steps_cost(n: usize, gamma: f64) -> f64 {
    -(0..n).map(|j| gamma.powi(j as i32)).sum::<f64>()
}

#[test]
fn on_the_chain_with_one_neighbour_it_is_value_iteration_on_the_record_states() {
    let settings = AnchorSweep::new([0.0], [4.0], 8)
        .unwrap()
        .with_neighbours(1)
        .unwrap();
    let mut parts = Parts::<1>::new(8, 2);
    let mut q = AnchorFqi::new(settings, 2, parts.lend()).unwrap();
    let data = chain();
    q.fit(&[SampleSet::unweighted(&data)], &config(60)).unwrap();
    // Every record state is a node, and nothing else.
    assert_eq!(q.placed(), 5);
    let mut placed: Vec<f64> = (0..5).map(|i| q.anchor(i).unwrap()[0]).collect();
    placed.sort_by(f64::total_cmp);
    assert_eq!(placed, vec![0.0, 1.0, 2.0, 3.0, 4.0]);
    assert_eq!(q.anchor(5), None);
    for x in 0..4usize {
        // Right: 4 − x steps to the end.
        let right = steps_cost(4 - x, 0.9);
        let got = q.value([x as f64], 0).unwrap();
        assert!((got - right).abs() < 1e-12, "x {x}: {got} vs {right}");
        assert_eq!(q.greedy_action([x as f64]).unwrap(), 0);
    }
    // Off the nodes a state reads its nearest node (1.4 → 1).
    assert_eq!(q.value([1.4], 0).unwrap(), q.value([1.0], 0).unwrap());
}

#[test]
fn the_weights_of_a_point_are_its_nearest_nodes_and_sum_to_one() {
    let settings = AnchorSweep::new([0.0, 0.0], [1.0, 2.0], 40).unwrap();
    let mut parts = Parts::<2>::new(40, 1);
    let mut q = AnchorFqi::new(settings, 1, parts.lend()).unwrap();
    // Records on a 9 × 9 lattice: more distinct states than the budget.
    let mut data = Vec::new();
    for i in 0..9 {
        for j in 0..9 {
            let s = [i as f64 / 8.0, j as f64 / 4.0];
            data.push(Transition {
                state: s,
                action: 0,
                reward: s[0],
                next_state: s,
                absorbing: false,
            });
        }
    }
    q.fit(&[SampleSet::unweighted(&data)], &config(3)).unwrap();
    let placed = q.placed();
    assert!((20..=40).contains(&placed), "placed {placed}");
    let anchors: Vec<[f64; 2]> = (0..placed).map(|i| q.anchor(i).unwrap()).collect();
    // Nodes are record states, pairwise distinct.
    for (i, a) in anchors.iter().enumerate() {
        assert!(
            data.iter().any(|r| r.state == *a),
            "{a:?} is not a record state"
        );
        for b in &anchors[..i] {
            assert_ne!(a, b);
        }
    }
    let scaled = |p: &[f64; 2]| [p[0], p[1] / 2.0];
    let mut rng = 12345u64;
    let mut uniform = || {
        rng = rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..500 {
        let x = [uniform() * 1.2 - 0.1, uniform() * 2.4 - 0.2];
        let mut got = Vec::new();
        q.layout().weights(&x, |i, w| got.push((i, w)));
        assert_eq!(got.len(), ANCHOR_LINKS);
        let total: f64 = got.iter().map(|&(_, w)| w).sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        assert!(got.iter().all(|&(_, w)| w >= 0.0));
        // They are the nearest nodes (by brute force, in units of the box).
        let xs = scaled(&[x[0].clamp(0.0, 1.0), x[1].clamp(0.0, 2.0)]);
        let mut d: Vec<f64> = anchors
            .iter()
            .map(|a| {
                let a = scaled(a);
                (a[0] - xs[0]).powi(2) + (a[1] - xs[1]).powi(2)
            })
            .collect();
        let mut chosen: Vec<f64> = got
            .iter()
            .map(|&(i, _)| {
                let a = scaled(&q.anchor(i).unwrap());
                (a[0] - xs[0]).powi(2) + (a[1] - xs[1]).powi(2)
            })
            .collect();
        d.sort_by(f64::total_cmp);
        chosen.sort_by(f64::total_cmp);
        for (c, e) in chosen.iter().zip(&d) {
            assert!((c - e).abs() < 1e-12, "{chosen:?} vs {:?}", &d[..4]);
        }
    }
}

#[test]
fn the_value_is_continuous_between_nodes() {
    let settings = AnchorSweep::new([0.0], [4.0], 8)
        .unwrap()
        .with_neighbours(2)
        .unwrap();
    let mut parts = Parts::<1>::new(8, 2);
    let mut q = AnchorFqi::new(settings, 2, parts.lend()).unwrap();
    let data = chain();
    q.fit(&[SampleSet::unweighted(&data)], &config(20)).unwrap();
    let mut last = q.value([0.0], 0).unwrap();
    for i in 1..=4000 {
        let v = q.value([i as f64 / 1000.0], 0).unwrap();
        assert!(
            (v - last).abs() < 0.01,
            "jump at {}: {last} → {v}",
            i as f64 / 1000.0
        );
        last = v;
    }
}

#[test]
fn the_same_records_give_the_same_bytes() {
    let settings = AnchorSweep::new([0.0], [4.0], 3).unwrap();
    let data = chain();
    let mut a = Parts::<1>::new(3, 2);
    let mut b = Parts::<1>::new(3, 2);
    for parts in [&mut a, &mut b] {
        let mut q = AnchorFqi::new(settings, 2, parts.lend()).unwrap();
        q.fit(&[SampleSet::unweighted(&data)], &config(10)).unwrap();
        assert!(q.placed() <= 3 && q.placed() >= 2, "{}", q.placed());
    }
    assert_eq!(a.entries, b.entries);
    assert_eq!(a.nodes, b.nodes);
    assert_eq!(a.positions, b.positions);
}

#[test]
fn bad_settings_are_refused() {
    assert_eq!(
        AnchorSweep::<f64, 1>::new([0.0], [1.0], 0),
        Err(Error::InvalidParameter {
            parameter: "budget"
        })
    );
    assert_eq!(
        AnchorSweep::<f64, 1>::new([0.0], [1.0], 70_000),
        Err(Error::CapacityExceeded { capacity: 65_535 })
    );
    assert!(AnchorSweep::<f64, 1>::new([1.0], [0.0], 4).is_err());
    assert!(AnchorSweep::<f64, 1>::new([f64::NAN], [1.0], 4).is_err());
    let ok = AnchorSweep::<f64, 1>::new([0.0], [1.0], 4).unwrap();
    for k in [0, ANCHOR_LINKS + 1] {
        assert_eq!(
            ok.with_neighbours(k),
            Err(Error::InvalidParameter {
                parameter: "neighbours"
            })
        );
    }
    assert!(ok.with_min_mass(-1.0).is_err());
    assert!(ok.with_min_mass(f64::INFINITY).is_err());
}

#[test]
fn bad_input_and_short_storage_leave_q_as_it_was() {
    let settings = AnchorSweep::new([0.0], [4.0], 8).unwrap();
    let mut short = Parts::<1>::new(8, 2);
    short.landings.truncate(7);
    assert_eq!(
        AnchorFqi::new(settings, 2, short.lend()).unwrap_err(),
        Error::CapacityExceeded { capacity: 7 }
    );
    let mut short = Parts::<1>::new(8, 2);
    short.entries.truncate(15);
    assert_eq!(
        AnchorFqi::new(settings, 2, short.lend()).unwrap_err(),
        Error::CapacityExceeded { capacity: 15 }
    );
    let mut parts = Parts::<1>::new(8, 2);
    assert_eq!(
        AnchorFqi::new(settings, 0, parts.lend()).unwrap_err(),
        Error::InvalidParameter {
            parameter: "actions"
        }
    );
    let mut q = AnchorFqi::new(settings, 2, parts.lend()).unwrap();
    let data = chain();
    q.fit(&[SampleSet::unweighted(&data)], &config(10)).unwrap();
    let before: Vec<f64> = (0..=8)
        .map(|i| q.value([i as f64 / 2.0], 0).unwrap())
        .collect();
    let placed = q.placed();
    let mut bad = data.clone();
    bad[3].action = 2;
    assert!(q.fit(&[SampleSet::unweighted(&bad)], &config(10)).is_err());
    let mut bad = data.clone();
    bad[1].next_state = [f64::NAN];
    assert!(q.fit(&[SampleSet::unweighted(&bad)], &config(10)).is_err());
    assert_eq!(q.fit(&[], &config(10)), Err(Error::EmptyData));
    let after: Vec<f64> = (0..=8)
        .map(|i| q.value([i as f64 / 2.0], 0).unwrap())
        .collect();
    assert_eq!(before, after);
    assert_eq!(q.placed(), placed);
    assert!(matches!(
        q.value([f64::NAN], 0),
        Err(Error::NonFinite { .. })
    ));
    assert_eq!(
        q.value([1.0], 2),
        Err(Error::OutOfRange {
            parameter: "action"
        })
    );
    assert!(q.greedy_action([f64::INFINITY]).is_err());
    assert!(q.max_value([f64::NAN]).is_err());
}

#[test]
fn a_fresh_or_cleared_q_is_zero_and_it_builds_from_an_approximator() {
    let mut storage = AnchorStorage::<f64, 1, 16, 8>::new();
    let settings = AnchorSweep::new([0.0], [4.0], 8).unwrap();
    let mut q = crate::fqi::Approximator::Anchors(settings)
        .build(2, &mut storage)
        .unwrap();
    assert_eq!(q.value([2.0], 1).unwrap(), 0.0);
    let data = chain();
    q.fit(
        &[SampleSet::unweighted(&data)],
        &config(10),
        &mut crate::fqi::iteration::NoDraws,
    )
    .unwrap();
    assert!(q.value([2.0], 0).unwrap() < 0.0);
    q.clear();
    assert_eq!(q.value([2.0], 0).unwrap(), 0.0);
}

#[test]
fn records_of_weight_zero_place_no_node_unless_all_weigh_zero() {
    let settings = AnchorSweep::new([0.0], [4.0], 8).unwrap();
    let data = chain();
    let mut parts = Parts::<1>::new(8, 2);
    let mut q = AnchorFqi::new(settings, 2, parts.lend()).unwrap();
    // Only the records at 0 and 4 weigh anything.
    let w: Vec<f64> = data
        .iter()
        .map(|r| {
            if r.state[0] == 0.0 || r.state[0] == 4.0 {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    q.fit(
        &[SampleSet::weighted(&data, Some(&w), Some(&w))],
        &config(5),
    )
    .unwrap();
    let mut placed: Vec<f64> = (0..q.placed()).map(|i| q.anchor(i).unwrap()[0]).collect();
    placed.sort_by(f64::total_cmp);
    assert_eq!(placed, vec![0.0, 4.0]);
    let zero = vec![0.0; data.len()];
    q.fit(
        &[SampleSet::weighted(&data, Some(&zero), Some(&zero))],
        &config(5),
    )
    .unwrap();
    assert_eq!(q.placed(), 1);
    assert_eq!(q.anchor(0), Some(data[0].state));
    assert!(q.value([2.0], 0).unwrap().is_finite());
}

#[test]
fn the_budget_a_memory_buys_is_its_bytes_over_a_nodes() {
    // f32, D = 4, 2 actions: 2 entries of 4 + 8 + 8 bytes, a node of 12, 2 × 16.
    assert_eq!(AnchorSweep::<f32, 4>::bytes_per_node(2), 2 * 20 + 12 + 32);
    assert_eq!(AnchorSweep::<f32, 4>::budget_within(84 * 512 + 83, 2), 512);
    assert_eq!(AnchorSweep::<f32, 4>::budget_within(0, 2), 0);
    assert_eq!(AnchorSweep::<f32, 1>::budget_within(usize::MAX, 1), 65_535);
    assert_eq!(
        core::mem::size_of::<AnchorStorage<f32, 4, { 512 * 2 }, 512>>(),
        512 * AnchorSweep::<f32, 4>::bytes_per_node(2)
    );
}
