//! Calls of the transfer path, from the dataset to the loop (weights, record GPs, FQI,
//! scores, evaluation), on Puddle World and on a 4-D toy plant.

use super::kernels::{adaptive, kernel};
use super::*;

/// A record with state `[t, 9 − t, t, …]` (`t = i mod 10`), action `i mod actions`.
pub(super) fn record<T: Real, const D: usize>(i: usize, actions: usize) -> Transition<[T; D], T> {
    let t = T::from_usize(i % 10);
    let state = core::array::from_fn(|k| if k % 2 == 0 { t } else { num::<T>(9.0) - t });
    Transition {
        state,
        action: i.checked_rem(actions).unwrap_or(0),
        reward: num::<T>(-1.0) - t,
        next_state: state.map(|x| x + num(1.0)),
        absorbing: i % 7 == 6,
    }
}

/// A 4-D plant for the generic API: both actions move every coordinate by ±0.5 in
/// [−1, 1]⁴ (noise from the generator); reward −|Σ s − shift| / 4.
#[derive(Clone, Copy)]
struct Toy<T> {
    shift: T,
}

impl<T: Real> SourceModel<T, 4> for Toy<T> {
    fn predict(&self, state: [T; 4], action: usize) -> awfqi::Result<SourceMeans<T, 4>> {
        if action > 1 {
            return Err(awfqi::Error::OutOfRange {
                parameter: "action",
            });
        }
        let mut sum = T::ZERO;
        for &x in &state {
            if !x.is_finite() {
                return Err(awfqi::Error::NonFinite { parameter: "state" });
            }
            sum += x;
        }
        let step = if action == 0 { num(-0.5) } else { num(0.5) };
        Ok(SourceMeans {
            reward: -(sum - self.shift).abs() / num(4.0),
            next_state: state.map(|x| (x + step).clamp_to(num(-1.0), num(1.0))),
        })
    }
}

impl<T: Real> GenerativeModel<T> for Toy<T> {
    type State = [T; 4];

    fn num_actions(&self) -> usize {
        2
    }

    fn query<R: rand_core::Rng + ?Sized>(
        &self,
        state: [T; 4],
        action: usize,
        rng: &mut R,
    ) -> awfqi::Result<Transition<[T; 4], T>> {
        let mean = self.predict(state, action)?;
        Ok(Transition {
            state,
            action,
            reward: awfqi::rng::normal(rng, mean.reward, num(0.1))?,
            next_state: mean.next_state,
            absorbing: false,
        })
    }
}

pub(super) fn transfer<T: Real>(rng: &mut ChaCha8Rng) {
    // alias
    let mut entries = [AliasEntry::<T>::EMPTY; 8];
    let weights: [T; 5] = [num(0.0), num(1.0), num(2.5), num(0.1), num(3.0)];
    if let Ok(table) = AliasTable::build(opaque(weights).into_iter().take(index(5)), &mut entries) {
        keep((
            table.len(),
            table.is_empty(),
            table.probability(index(2)),
            table.sample(rng),
        ));
        let mut out = [0usize; 4];
        table.sample_into(rng, &mut out);
        keep(out);
        if let Some(e) = table.entries().get(index(1)) {
            keep((e.threshold(), e.alias()));
        }
    }

    // weights
    let params = WeightParams::new(
        if opaque(true) {
            Estimator::Mean
        } else {
            Estimator::Heuristic
        },
        num::<T>(0.1),
        num(1000.0),
    )
    .unwrap_or_else(|_| WeightParams::reference_reward());
    keep((
        params.estimator(),
        params.noise_variance(),
        params.max_weight(),
    ));
    let (pt, ps) = (
        Posterior::new(num::<T>(-1.2), num(0.1)),
        Posterior::new(num::<T>(-1.0), num(0.05)),
    );
    keep(params.weight(num(-1.0), pt, ps));
    let ys: [T; 3] = [num(-1.0), num(-2.0), num(0.5)];
    let mut out = [T::ZERO; 3];
    keep(params.weights_into(&ys, &[pt; 3], &[ps; 3], &mut out));
    let mut variances: [T; 3] = [num(0.5), num(0.2), num(0.3)];
    let mode = [
        NoiseSubtraction::Reference,
        NoiseSubtraction::Principled,
        NoiseSubtraction::Off,
    ][index(1) % 3];
    keep(predictive_stds(mode, num::<T>(0.1), &mut variances));
    if let Ok(transform) = StdTransform::new(mode, num::<T>(0.1), num(0.2)) {
        keep(transform.apply(num(0.4)));
    }
    keep(ideal_weight(
        num::<T>(-1.05),
        num(-1.0),
        num(-1.2),
        num(0.01),
    ));
    let mut summary = WeightSummary::<T>::new();
    keep(summary.add(&out));
    summary.add_ones(index(3));
    keep((
        summary.count(),
        summary.mean(),
        summary.effective_sample_size(),
    ));
    keep(effective_sample_size(opaque(&out[..])));

    // The transfer path at two state dimensions: Puddle World and the 4-D toy plant.
    let dynamics = if opaque(true) {
        Dynamics::Shared
    } else {
        Dynamics::PuddleBased
    };
    let [a, b, c] = PuddleWorld::<T>::sources(dynamics);
    transfer_path::<T, _, 2, 3>(PuddleWorld::target(dynamics), [a, b, c], num(10.0), rng);
    let toys = [num::<T>(0.0), num(0.5), num(-0.5)].map(|shift| Toy { shift });
    transfer_path::<T, _, 4, 5>(Toy { shift: num(0.1) }, toys, num(1.0), rng);
    keep(PuddleWorld::<T>::score_grid(num(0.5)).map(|g| g.len()));
    keep(PuddleWorld::<T>::target(dynamics).evaluation_protocol());
}

/// dataset, fqi, score, evaluation, the builder and the loop for states `[T; D]`, GP inputs
/// of dimension `I = D + 1`, with `plant` as the target and `sources` as source models;
/// the state box is `[0, high]^D`.
pub(super) fn transfer_path<T, G, const D: usize, const I: usize>(
    plant: G,
    sources: [G; 3],
    high: T,
    rng: &mut ChaCha8Rng,
) where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + SourceModel<T, D> + Copy,
    awfqi::record_gp::Dims<D, I>: awfqi::record_gp::StatePlusAction,
{
    let actions = plant.num_actions();
    let mode = [
        NoiseSubtraction::Reference,
        NoiseSubtraction::Principled,
        NoiseSubtraction::Off,
    ][index(1) % 3];
    // dataset
    let records: [Transition<[T; D], T>; 12] = core::array::from_fn(|i| record::<T, D>(i, actions));
    let z: [T; I] = input(records[index(3) % 12].state, index(2));
    keep(z);
    let output = [
        Output::Reward,
        Output::NextState(0),
        Output::NextState(index(1)),
    ][index(2) % 3];
    keep(output.of(&records[index(4) % 12]));
    let rule = if opaque(true) {
        SubsetRule::Spread
    } else {
        SubsetRule::Last
    };
    keep(rule.indices(index(12), index(5)).fold(0, |a, i| a + i));
    let mut training = GpTraining::<T, I>::published();
    training.search.max_evaluations = index(20);
    training.search.restarts = index(1);
    keep(training.validate());
    let mut gp = Gp::<T, 8, I>::empty();
    keep(fit_gp(
        &mut gp,
        opaque(&records[..]),
        output,
        rule,
        &training,
        rng,
    ));
    let mut posteriors = [Posterior::<T>::default(); 12];
    keep(predict_posteriors(&gp, &records, mode, &mut posteriors));
    keep(batch_transform(&gp, &records, mode));

    // fqi
    let grid = CellGrid::<T, D>::new([num(0.0); D], [high; D], [index(3); D])
        .or_else(|_| CellGrid::cube(num(0.0), high, index(3)));
    if let Ok(grid) = grid {
        keep((
            grid.cells(),
            grid.len(),
            grid.is_empty(),
            grid.lower(),
            grid.upper(),
        ));
        keep((
            grid.cell_of([num(0.3); D]),
            grid.coordinates(index(4)),
            grid.center(index(4)),
        ));
        keep(TabularFqi::<T, D>::required_entries(&grid, index(4)));
        let mut storage = [FqiEntry::<T>::EMPTY; 400];
        if let Ok(mut fqi) = TabularFqi::new(grid, actions, &mut storage) {
            let empty = match index(1) {
                0 => EmptyCells::Nearest,
                1 => EmptyCells::CappedNearest,
                _ => EmptyCells::Value(num(-1.0)),
            };
            let config = FqiConfig::new(num::<T>(0.9), index(5), empty)
                .and_then(|c| c.with_min_weight(num(0.5)))
                .unwrap_or_else(|_| FqiConfig::published());
            keep((
                config.discount(),
                config.iterations(),
                config.empty_cells(),
                config.min_weight(),
            ));
            let w = [num::<T>(0.5); 12];
            let sets = [
                SampleSet::unweighted(&records[..6]),
                SampleSet::weighted(&records[6..], Some(&w[6..]), None),
            ];
            keep((sets[0].len(), sets[1].is_empty()));
            keep(fqi.fit(&sets, &config));
            keep(fqi.fit_sets(sets.iter().copied(), &config));
            keep((fqi.grid().len(), fqi.actions()));
            if let Some(e) = fqi.entries().get(index(5)) {
                keep((e.q(), e.reward_model(), e.transition_weight(), e.has_data()));
            }
            let s = [num::<T>(0.2); D];
            keep(fqi.value(s, index(1)));
            keep(fqi.max_value(s));
            keep(fqi.greedy_action(s));
            // evaluation
            let protocol = EvaluationProtocol {
                start: [num(0.0); D],
                rollouts: index(2),
                horizon: index(20),
                discount: num(0.99),
            };
            keep(evaluate_greedy(&plant, &fqi, &protocol, rng));
            let mut uniform = UniformPolicy::new(actions).unwrap_or_else(|_| loop {});
            keep(evaluate(&plant, &mut uniform, &protocol, rng));
            let starts = [[num(0.0); D], [num(0.5); D]];
            let multi = MultiStartProtocol {
                starts: starts.get(..index(2)).unwrap_or(&[]),
                rollouts: index(2),
                horizon: index(20),
                discount: num(0.99),
            };
            keep(evaluate_greedy_multi_start(&plant, &fqi, &multi, rng));
            keep(evaluate_multi_start(&plant, &mut uniform, &multi, rng));
            keep(rollout(
                &plant,
                &mut uniform,
                [num(0.0); D],
                index(5),
                num(0.9),
                rng,
            ));
            fqi.clear();
        }
    }

    // fqi: tile coding, and either approximator behind QFunction
    let tilings = Tilings::<T, D>::new([num(0.0); D], [high; D], index(2), index(3))
        .or_else(|_| Tilings::cube(num(0.0), high, index(2), index(2)));
    if let Ok(tilings) = tilings {
        keep((tilings.tiles(), tilings.count(), tilings.tiles_per_tiling()));
        keep(TileFqi::<T, D>::required_entries(&tilings, index(4)));
        let config = FqiConfig::new(num::<T>(0.9), index(5), EmptyCells::CappedNearest)
            .unwrap_or_else(|_| FqiConfig::published());
        let w = [num::<T>(0.5); 12];
        let sets = [
            SampleSet::unweighted(&records[..6]),
            SampleSet::weighted(&records[6..], Some(&w[6..]), Some(&w[..6])),
        ];
        let mut storage = [FqiEntry::<T>::EMPTY; 400];
        if let Ok(mut fqi) = TileFqi::new(tilings, actions, &mut storage) {
            keep(fqi.fit(&sets, &config));
            keep(fqi.fit_sets(sets.iter().copied(), &config));
            keep((fqi.tilings().count(), fqi.actions(), fqi.entries().len()));
            let s = [num::<T>(0.2); D];
            keep((
                fqi.value(s, index(1)),
                fqi.max_value(s),
                fqi.greedy_action(s),
            ));
            keep(fqi.greedy(s));
            fqi.clear();
        }
        let approximator: Approximator<T, D> = if opaque(true) {
            tilings.into()
        } else {
            match CellGrid::cube(num(0.0), high, index(3)) {
                Ok(g) => g.into(),
                Err(_) => tilings.into(),
            }
        };
        keep(approximator.required_entries(actions));
        let mut storage = [FqiEntry::<T>::EMPTY; 400];
        let q = if opaque(true) {
            approximator.build(actions, &mut storage)
        } else {
            approximator.build(actions, &mut storage[..])
        };
        if let Ok(mut q) = q {
            keep(q.fit(&sets, &config, rng));
            let s = [num::<T>(0.7); D];
            keep((
                q.value(s, 0),
                q.max_value(s),
                q.greedy_action(s),
                q.actions(),
            ));
            keep((q.entries().len(), q.as_tabular().is_some()));
            if let QFunction::Tiles(t) = &q {
                keep(t.tilings().tiles());
            }
            q.clear();
        }
    }

    // fqi: kernel averaging over the records, directly and behind QFunction
    let weighting = if opaque(true) {
        Kernel::Gaussian(num::<T>(0.1))
    } else {
        Kernel::Uniform
    };
    let neighbours = Neighbours::<T, D>::new(index(3), [num(0.0); D], [high; D], weighting)
        .or_else(|_| Neighbours::cube(index(2), num(0.0), high, Kernel::Uniform))
        .and_then(|n| n.with_reach(num(0.3)))
        .map(|n| {
            if opaque(true) {
                n.with_common_ball()
            } else {
                n
            }
        });
    if let Ok(neighbours) = neighbours {
        keep((neighbours.k(), neighbours.kernel(), neighbours.reach()));
        keep(neighbours.common_ball());
        keep(neighbours.required_links(index(12), actions));
        let config = FqiConfig::new(num::<T>(0.9), index(5), EmptyCells::CappedNearest)
            .and_then(|c| c.with_min_weight(num(0.5)))
            .unwrap_or_else(|_| FqiConfig::published());
        let w = [num::<T>(0.5); 12];
        let sets = [
            SampleSet::unweighted(&records[..6]),
            SampleSet::weighted(&records[6..], Some(&w[6..]), Some(&w[..6])),
        ];
        let mut slots = [KnnRecord::<T, D>::EMPTY; 12];
        let mut links = [0u16; 12 * 4 * 3];
        if let Ok(mut fqi) = KnnFqi::new(neighbours, actions, &mut slots, &mut links) {
            keep(fqi.fit(&sets, &config));
            keep(fqi.fit_sets(sets.iter().copied(), &config));
            keep((fqi.neighbours().k(), fqi.actions(), fqi.records().len()));
            let s = [num::<T>(0.2); D];
            keep((
                fqi.value(s, index(1)),
                fqi.max_value(s),
                fqi.greedy_action(s),
            ));
            keep(fqi.greedy(s));
            if let Some(r) = fqi.records().get(index(2)) {
                keep((r.reward_model(), r.target()));
            }
            fqi.clear();
        }
        let tilings = Tilings::<T, D>::cube(num(0.0), high, index(2), index(2));
        if let Ok(tilings) = tilings {
            let mut entries = [FqiEntry::<T>::EMPTY; 400];
            let mut block = KnnStorage::<T, D, 12, { 12 * 4 * 3 }>::new();
            let mut storage = block.storage();
            storage.entries = &mut entries;
            let hybrid = Approximator::Hybrid(tilings, neighbours);
            keep(hybrid.required_entries(actions));
            if let Ok(mut q) = hybrid.build(actions, storage) {
                keep(q.fit(&sets, &config, rng));
                let s = [num::<T>(0.4); D];
                keep((q.value(s, 0), q.max_value(s), q.greedy_action(s)));
                keep((q.actions(), q.entries().len()));
                if let QFunction::Hybrid(h) = &q {
                    keep((h.tiles().entries().len(), h.knn().records().len()));
                }
                q.clear();
            }
            let mut entries = [FqiEntry::<T>::EMPTY; 400];
            let mut slots = [KnnRecord::<T, D>::EMPTY; 12];
            let mut links = [0u16; 12 * 4 * 3];
            let halves = (
                TileFqi::new(tilings, actions, &mut entries),
                KnnFqi::new(neighbours, opaque(actions), &mut slots, &mut links),
            );
            if let (Ok(t), Ok(k)) = halves {
                if let Ok(mut h) = HybridFqi::new(t, k) {
                    keep(h.fit(&sets, &config));
                    keep(h.fit_sets(sets.iter().copied(), &config));
                    let s = [num::<T>(0.3); D];
                    keep((h.value(s, index(1)), h.max_value(s), h.greedy_action(s)));
                    keep((h.greedy(s), h.actions()));
                    h.clear();
                }
            }
        }
        let mut block = KnnStorage::<T, D, 12, { 12 * 4 * 3 }>::new();
        let approximator: Approximator<T, D> = neighbours.into();
        if let Ok(mut q) = approximator.build(actions, &mut block) {
            keep(q.fit(&sets, &config, rng));
            keep((
                q.value([num(0.7); D], 0),
                q.greedy_action([num(0.7); D]),
                q.entries().len(),
            ));
        }
    }

    // fqi: Extra-Trees forests, directly and behind QFunction
    let forests = if opaque(true) {
        ExtraTrees::new(index(3), index(15))
    } else {
        ExtraTrees::streamed(index(3), index(15))
    };
    let forests = forests
        .and_then(|f| f.with_min_samples(index(2), index(1)))
        .or_else(|_| ExtraTrees::new(index(2), index(7)));
    if let Ok(forests) = forests {
        keep((
            forests.trees(),
            forests.max_nodes(),
            forests.min_samples_split(),
            forests.min_samples_leaf(),
        ));
        keep((forests.required_nodes(actions), forests.is_streamed()));
        let config = FqiConfig::new(num::<T>(0.9), index(5), EmptyCells::CappedNearest)
            .and_then(|c| c.with_min_weight(num(0.5)))
            .unwrap_or_else(|_| FqiConfig::published());
        let w = [num::<T>(0.5); 12];
        let y = [num::<T>(-1.0); 12];
        let sets = [
            SampleSet::unweighted(&records[..6]).with_rewards(Some(&y[..6])),
            SampleSet::weighted(&records[6..], Some(&w[6..]), Some(&w[..6])),
        ];
        let mut slots = [TreeRecord::<T, D>::EMPTY; 12];
        let mut nodes = [TreeNode::<T>::EMPTY; 4 * 3 * 15];
        if let Ok(mut fqi) = TreeFqi::new(forests, actions, &mut slots, &mut nodes) {
            keep(fqi.fit(&sets, &config, rng));
            keep(fqi.fit_sets(sets.iter().copied(), &config, rng));
            keep((fqi.forests().trees(), fqi.actions(), fqi.records().len()));
            let s = [num::<T>(0.2); D];
            keep((
                fqi.value(s, index(1)),
                fqi.max_value(s),
                fqi.greedy_action(s),
            ));
            keep(fqi.greedy(s));
            if let Some(r) = fqi.records().get(index(2)) {
                keep((r.reward_model(), r.target(), r.action()));
            }
            if let Some(n) = fqi.tree(index(1), index(1)).and_then(|t| t.get(index(0))) {
                keep((n.is_leaf(), n.value(), n.feature()));
            }
            fqi.clear();
        }
        let mut block = TreeStorage::<T, D, 12, { 4 * 3 * 15 }>::new();
        let approximator: Approximator<T, D> = forests.into();
        keep(approximator.required_entries(actions));
        // The block itself, as the array of entries below (the `From` conversions).
        let q = if opaque(true) {
            approximator.build(actions, &mut block)
        } else {
            approximator.build(actions, block.storage())
        };
        if let Ok(mut q) = q {
            keep(q.fit(&sets, &config, rng));
            keep((
                q.value([num(0.7); D], 0),
                q.max_value([num(0.7); D]),
                q.greedy_action([num(0.7); D]),
                q.entries().len(),
                q.actions(),
            ));
            q.clear();
        }
    }

    // fqi: the model sweep, directly and behind QFunction
    let rewards = [
        RewardModel::PerAction,
        RewardModel::Pooled,
        RewardModel::Backfilled,
    ];
    let sweep = ModelSweep::<T, D>::cube(num(0.0), high, index(3))
        .and_then(|s| s.with_min_mass(num(0.25)))
        .map(|s| {
            s.with_rewards(rewards[index(2) % 3])
                .with_lookahead(opaque(true))
        });
    let sweep = sweep.or_else(|_| {
        CellGrid::new([num(0.0); D], [high; D], [index(2); D]).and_then(ModelSweep::new)
    });
    if let Ok(sweep) = sweep {
        keep((
            sweep.nodes(),
            sweep.required_entries(actions),
            sweep.rewards(),
            sweep.min_mass(),
            sweep.lookahead(),
            *sweep.cells(),
        ));
        let config = FqiConfig::new(num::<T>(0.9), index(5), EmptyCells::CappedNearest)
            .unwrap_or_else(|_| FqiConfig::published());
        let w = [num::<T>(0.5); 12];
        let sets = [
            SampleSet::unweighted(&records[..6]),
            SampleSet::weighted(&records[6..], Some(&w[6..]), Some(&w[..6])),
        ];
        let mut entries = [SweepEntry::<T, D>::EMPTY; 64 * 4];
        let mut nodes = [SweepNode::<T>::EMPTY; 64];
        if let Ok(mut fqi) = SweepFqi::new(sweep, actions, &mut entries, &mut nodes) {
            keep(fqi.fit(&sets, &config));
            keep(fqi.fit_sets(sets.iter().copied(), &config));
            let s = [num::<T>(0.2); D];
            keep((
                fqi.value(s, index(1)),
                fqi.max_value(s),
                fqi.greedy_action(s),
                fqi.greedy(s),
                fqi.next_state(index(3), index(1)),
                fqi.actions(),
                *fqi.sweep(),
            ));
            if let (Some(e), Some(n)) = (fqi.entries().get(index(2)), fqi.nodes().get(index(1))) {
                keep((e.reward(), n.value(), n.absorbing()));
            }
            fqi.clear();
        }
        let mut block = SweepStorage::<T, D, { 64 * 4 }, 64>::new();
        let approximator: Approximator<T, D> = sweep.into();
        keep(approximator.required_entries(actions));
        if let Ok(mut q) = approximator.build(actions, block.storage()) {
            keep(q.fit(&sets, &config, rng));
            keep((
                q.value([num(0.7); D], 0),
                q.max_value([num(0.7); D]),
                q.greedy_action([num(0.7); D]),
                q.entries().len(),
                q.actions(),
            ));
            q.clear();
        }
    }

    // fqi: the sweep on anchors, directly and behind QFunction
    let anchors = AnchorSweep::<T, D>::new([num(0.0); D], [high; D], index(16))
        .and_then(|a| a.with_neighbours(index(3)))
        .and_then(|a| a.with_min_mass(num(0.25)))
        .map(|a| {
            a.with_rewards(rewards[index(1) % 3])
                .with_lookahead(opaque(true))
        });
    if let Ok(anchors) = anchors {
        keep((
            anchors.nodes(),
            anchors.neighbours(),
            anchors.required_entries(actions),
            anchors.bounds(),
        ));
        let config = FqiConfig::new(num::<T>(0.9), index(5), EmptyCells::CappedNearest)
            .unwrap_or_else(|_| FqiConfig::published());
        let w = [num::<T>(0.5); 12];
        let sets = [
            SampleSet::unweighted(&records[..6]),
            SampleSet::weighted(&records[6..], Some(&w[6..]), Some(&w[..6])),
        ];
        let mut entries = [AnchorEntry::<T>::EMPTY; 16 * 4];
        let mut nodes = [SweepNode::<T>::EMPTY; 16];
        let mut positions = [[T::ZERO; D]; 16];
        let mut landings = [[T::ZERO; D]; 16];
        let parts = AnchorParts {
            entries: &mut entries,
            nodes: &mut nodes,
            positions: &mut positions,
            landings: &mut landings,
        };
        if let Ok(mut fqi) = AnchorFqi::new(anchors, actions, parts) {
            keep(fqi.fit(&sets, &config));
            keep(fqi.fit_sets(sets.iter().copied(), &config));
            let s = [num::<T>(0.2); D];
            keep((
                fqi.value(s, index(1)),
                fqi.max_value(s),
                fqi.greedy_action(s),
                fqi.greedy(s),
                fqi.next_state(index(3), index(1)),
                fqi.actions(),
                fqi.placed(),
                fqi.anchor(index(2)),
                *fqi.settings(),
            ));
            if let Some(e) = fqi.entries().get(index(2)) {
                keep(e.reward());
            }
            fqi.clear();
        }
        let mut block = AnchorStorage::<T, D, { 16 * 4 }, 16>::new();
        let approximator: Approximator<T, D> = anchors.into();
        if let Ok(mut q) = approximator.build(actions, &mut block) {
            keep(q.fit(&sets, &config, rng));
            keep((
                q.value([num(0.7); D], 0),
                q.max_value([num(0.7); D]),
                q.greedy_action([num(0.7); D]),
            ));
            q.clear();
        }
    }

    // score
    let point_grid = PointGrid::<T, D>::new([num(0.0); D], [num(0.5); D], [index(3); D])
        .or_else(|_| PointGrid::spanning([num(0.0); D], [high; D], num(0.5)));
    let source_sets: [&[Transition<[T; D], T>]; 2] = [&records[..4], &records[4..9]];
    let pairs = [([num::<T>(0.5); D], index(1)), ([num(0.25); D], 0)];
    let Ok(point_grid) = point_grid else {
        return;
    };
    keep((
        point_grid.points(),
        point_grid.len(),
        point_grid.is_empty(),
        point_grid.spacing(),
        point_grid.point(index(4)),
    ));
    let rows = match index(2) {
        0 => RowSet::grid(point_grid, actions),
        1 => RowSet::source_data(&source_sets),
        3 => RowSet::pairs(&pairs),
        4 => RowSet::new(Some((point_grid, actions)), &pairs, &source_sets),
        _ => RowSet::both(point_grid, actions, &source_sets),
    };
    let Ok(rows) = rows else {
        return;
    };
    keep((
        rows.len(),
        rows.is_empty(),
        rows.row(index(7)),
        rows.iter().count(),
    ));
    let mut scores = [Scores::<T, D>::ZERO; 200];
    let next = core::array::from_fn::<_, D, _>(|_| &gp);
    let models = [
        GpSourceModel::new(&gp, None),
        GpSourceModel::new(&gp, Some(next)),
    ];
    keep(models[index(1) % 2].predict([num(0.5); D], index(1)));
    keep(sources[index(1) % 3].predict([num(0.5); D], index(1)));
    let computed = match index(1) {
        0 => ScoreTable::compute(rows, &sources, &mut scores),
        1 => ScoreTable::compute(rows, &models, &mut scores),
        _ => {
            let mut scratch = [AliasEntry::<T>::EMPTY; 200];
            ScoreTable::realistic(
                rows,
                &source_sets,
                &mut gp,
                &training,
                rule,
                &mut scores,
                &mut scratch,
                rng,
                |j, g| {
                    keep((j, g.len()));
                    Ok(())
                },
            )
        }
    };
    let Ok(table) = computed else {
        return;
    };
    keep((
        table.len(),
        table.is_empty(),
        table.rows().len(),
        table.values().len(),
    ));
    if let Some(row) = table.row(index(3)) {
        keep((
            row.state,
            row.action,
            row.scores.total(),
            row.scores.get(ScoreColumn::NextState(index(1))),
        ));
    }
    keep(ScoreTable::from_parts(rows, table.values()).map(|t| t.len()));
    let mut alias = [AliasEntry::<T>::EMPTY; 200];
    let column = [
        ScoreColumn::Reward,
        ScoreColumn::NextState(0),
        ScoreColumn::NextState(index(1)),
        ScoreColumn::Total,
    ][index(3) % 4];
    if let Ok(sampler) = table.sampler(column, &mut alias) {
        keep((
            sampler.draw(rng),
            sampler.rows().len(),
            sampler.alias().len(),
        ));
    }
    let values = table.values();
    kernel::<T, G, D, I>(
        plant,
        &sources,
        values,
        &records,
        &posteriors,
        rows,
        high,
        rng,
    );
    adaptive::<T, G, D, I>(plant, &records, &posteriors, rows, high, rng);
}
