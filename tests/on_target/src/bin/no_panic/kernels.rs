//! Calls of the two AWFQI kernels: `Awfqi` (every builder configuration, a step, the
//! accessors, the storage block) and `AdaptiveAwfqi` with its configuration and beliefs.

use super::*;

/// The adaptive kernel: its configuration, mean functions, beliefs, candidate scoring,
/// `AdaptiveAwfqi` itself (two steps, every accessor, `reset`) and its storage block.
pub(super) fn adaptive<T, G, const D: usize, const I: usize>(
    plant: G,
    records: &[Transition<[T; D], T>; 12],
    posteriors: &[Posterior<T>],
    rows: RowSet<'_, T, D>,
    high: T,
    rng: &mut ChaCha8Rng,
) where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + Copy,
    awfqi::record_gp::Dims<D, I>: awfqi::record_gp::StatePlusAction,
{
    let mut config = AdaptiveConfig::<T, D, I>::recommended(
        index(6),
        [num(0.5); D],
        index(5),
        num(0.3),
        [(num(0.0), high); D],
    );
    config.awfqi.gp_training.search.max_evaluations = index(10);
    config.awfqi.gp_training.search.restarts = index(1);
    config.candidates = index(20);
    config.sub_batches = index(2);
    config.verify = num(0.5);
    config.surprise = opaque(true);
    config.uncertainty = opaque(true);
    config.decision = opaque(true);
    config.refit = if opaque(true) {
        adaptive::Refit::Warm(SearchOptions {
            max_evaluations: index(6),
            restarts: index(0),
            isotropic: opaque(true),
        })
    } else {
        adaptive::Refit::Search
    };
    let Ok(config) = config.validate() else {
        return;
    };
    keep((config.sub_batches, config.horizon));
    keep((
        config.budget(),
        config.sub_batches(),
        config.verify(),
        config.candidates(),
    ));
    keep((
        config.start(),
        config.horizon(),
        config.epsilon(),
        config.bounds(),
    ));
    keep((*config.awfqi(), *config.config(), config.into_inner()));
    if let Ok(scales) = SourceScales::measure(&[&records[..]]) {
        keep(AdaptiveConfig::<T, D, I>::scaled(
            index(6),
            &scales,
            [num(0.5); D],
            index(5),
            num(0.3),
        ));
    }
    let (first, rest) = records.split_at(5);
    let sources: [&[Transition<[T; D], T>]; 2] = [first, rest];
    let Ok(data) = SourceData::new(&sources, posteriors) else {
        return;
    };
    let mut gp = Gp::<T, 8, I>::empty();
    let mut means = [MeanFunction::<T, 8, I>::EMPTY, MeanFunction::EMPTY];
    let training = config.awfqi.gp_training;
    for (m, s) in means.iter_mut().zip(&sources) {
        keep(m.fit_rewards(&mut gp, s, &training, SubsetRule::Spread, rng));
    }
    keep(means[index(1) % 2].copy_from(&gp));
    let mut alpha = [T::ZERO; 8];
    keep(gp.mean_weights(alpha.get_mut(..index(8)).unwrap_or(&mut [])));
    let z: [T; I] = input(records[index(2) % 12].state, index(1));
    keep((
        means[0].mean(&z),
        means[0].len(),
        means[0].is_empty(),
        *means[0].hyperparameters(),
    ));
    keep(fit_gp_on(
        &mut gp,
        &records[..],
        |r| Ok(r.reward + num(1.0)),
        SubsetRule::Spread,
        &training,
        rng,
    ));
    let mut mapped = [T::ZERO; 12];
    let noise = if opaque(true) {
        NoiseSubtraction::Reference
    } else {
        NoiseSubtraction::Off
    };
    keep(map_posteriors(
        &gp,
        records.get(..index(7)).unwrap_or(&[]),
        noise,
        mapped.get_mut(..index(7)).unwrap_or(&mut []),
        |i, r, p| Ok(p.mean + p.std + r.reward + T::from_usize(i)),
    ));
    // The pieces on their own.
    let mut beliefs = [adaptive::plausibility::SourceBelief::<T>::EMPTY; 3];
    adaptive::plausibility::reset(&mut beliefs);
    beliefs[index(1) % 3].squared_errors = num(2.0);
    keep(adaptive::plausibility::update(&mut beliefs, num(0.1)));
    keep(adaptive::plausibility::clipped_error(
        num::<T>(-1.0),
        num(-2.0),
        opaque(true),
        num(0.1),
    ));
    keep(adaptive::plausibility::nearest_ends(
        &records[..],
        &records[index(3) % 12].state,
        index(1),
        &[(num(0.0), high); D],
    ));
    let path = [records[index(4) % 12].state; 2];
    keep(adaptive::candidates::relevance(
        &records[index(5) % 12].state,
        path.get(..index(2)).unwrap_or(&[]),
        &[(num(0.0), high); D],
        num(0.1),
    ));
    keep(adaptive::candidates::weighted_spread(
        [Ok((num::<T>(-1.0), num(0.5))), Ok((num(-2.0), num(0.5)))].into_iter(),
    ));
    let mut slots = [adaptive::candidates::Candidate::<T>::EMPTY; 4];
    let u = |v: T| v.min(T::ONE);
    let totals =
        adaptive::candidates::finish_scores(slots.get_mut(..index(3)).unwrap_or(&mut []), Some(&u));
    keep(adaptive::candidates::probability(
        &slots[index(1) % 4],
        totals,
        num(0.1),
        index(3),
    ));
    // The kernel.
    let Ok(grid) = CellGrid::cube(num::<T>(0.0), high, index(3)) else {
        return;
    };
    let mut storage = AdaptiveBlock::<T, D, I>::new();
    let built = AdaptiveAwfqi::new(config, grid, data, &means, rows, plant, storage.buffers());
    if let Ok(mut kernel) = built {
        keep(kernel.plan(rng));
        keep(kernel.step(rng));
        keep(kernel.step(rng));
        keep(kernel.means().len());
        keep((
            kernel.config().candidates,
            kernel.steps(),
            kernel.target_samples().len(),
            kernel.reward_weights().len(),
            kernel.relabelled_rewards().len(),
            kernel.beliefs().len(),
            kernel.path().len(),
        ));
        keep((
            kernel.q().actions(),
            kernel.gp().len(),
            kernel.target().num_actions(),
        ));
        kernel.reset();
        keep(kernel.steps());
    }
    // The kernel with kernel-averaging Q: records for the target and source records.
    let neighbours = Neighbours::cube(index(3), num::<T>(0.0), high, Kernel::Uniform);
    if let Ok(neighbours) = neighbours {
        let mut storage = AdaptiveBlock::<T, D, I>::new();
        let mut knn = KnnStorage::<T, D, 24, { 24 * 4 * 3 }>::new();
        let mut buffers = storage.buffers();
        buffers.fqi = knn.storage();
        let built = AdaptiveAwfqi::new(config, neighbours, data, &means, rows, plant, buffers);
        if let Ok(mut kernel) = built {
            keep(kernel.step(rng));
            keep(kernel.q().greedy_action([num(0.5); D]));
        }
    }
    // The kernel with Extra-Trees Q (stored or streamed): records for the target and source
    // records, nodes.
    let forests = if opaque(true) {
        ExtraTrees::streamed(index(2), index(15))
    } else {
        ExtraTrees::new(index(2), index(15))
    };
    if let Ok(forests) = forests {
        let mut storage = AdaptiveBlock::<T, D, I>::new();
        let mut trees = TreeStorage::<T, D, 24, { 2 * 4 * 15 }>::new();
        let mut buffers = storage.buffers();
        buffers.fqi = trees.storage();
        let built = AdaptiveAwfqi::new(config, forests, data, &means, rows, plant, buffers);
        if let Ok(mut kernel) = built {
            keep(kernel.step(rng));
            keep(kernel.q().greedy_action([num(0.5); D]));
        }
    }
    // The kernel with a model sweep: entries and nodes.
    let sweep = ModelSweep::<T, D>::cube(num(0.0), high, index(3))
        .map(|s| s.with_rewards(RewardModel::Pooled));
    if let Ok(sweep) = sweep {
        let mut storage = AdaptiveBlock::<T, D, I>::new();
        let mut block = SweepStorage::<T, D, { 64 * 4 }, 64>::new();
        let mut buffers = storage.buffers();
        buffers.fqi = block.storage();
        let built = AdaptiveAwfqi::new(config, sweep, data, &means, rows, plant, buffers);
        if let Ok(mut kernel) = built {
            keep(kernel.plan(rng));
            keep(kernel.step(rng));
            keep(kernel.q().greedy_action([num(0.5); D]));
        }
    }
    let mut heap = AdaptiveBlock::<T, D, I>::new();
    let buffers: AdaptiveBuffers<'_, T, D, I, 8> = heap.buffers();
    keep(buffers.samples.len());
}

/// The builder in every configuration, `Awfqi` itself (a step, every accessor, `reset`),
/// and the storage block.
#[allow(clippy::too_many_arguments)]
pub(super) fn kernel<T, G, const D: usize, const I: usize>(
    plant: G,
    models: &[G],
    values: &[Scores<T, D>],
    records: &[Transition<[T; D], T>],
    posteriors: &[Posterior<T>],
    rows: RowSet<'_, T, D>,
    high: T,
    rng: &mut ChaCha8Rng,
) where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + SourceModel<T, D> + Copy,
    awfqi::record_gp::Dims<D, I>: awfqi::record_gp::StatePlusAction,
{
    // Settings that scale themselves.
    if let Ok(scales) = SourceScales::measure(&[&records[..5], &records[5..]]) {
        keep((
            scales.bounds(),
            scales.span(index(1)),
            scales.reward_scale(),
            scales.noise_floor(),
        ));
        keep(scales.gp_training::<I>());
        keep((scales.reward_weights(), scales.transition_weights()));
        keep(AwfqiConfig::<T, I>::scaled(index(4), &scales));
    }
    keep(WeightParams::<T>::reference_reward().discards(Posterior::new(num(0.1), num(0.5))));
    let mut config = AwfqiConfig::<T, I>::thesis(index(4));
    config.gp_training.search.max_evaluations = index(10);
    config.gp_training.search.restarts = index(1);
    if opaque(false) {
        config.sampling = ScoreColumn::NextState(index(1));
    }
    let Ok(config) = config.validate() else {
        return;
    };
    let sources: [&[Transition<[T; D], T>]; 2] = [&records[..5], &records[5..]];
    keep(SourceData::new(&sources, posteriors).map(|s| (s.len(), s.is_empty())));
    let Ok(grid) = CellGrid::cube(num::<T>(0.0), high, index(3)) else {
        return;
    };
    let approximator: Approximator<T, D> = if opaque(true) {
        grid.into()
    } else {
        match Tilings::cube(num::<T>(0.0), high, index(2), index(2)) {
            Ok(t) => t.into(),
            Err(_) => grid.into(),
        }
    };
    let mut storage = AwfqiStorage::<T, D, I, 8, 8, 12, 200, 400>::new();
    let mut fitted = [Posterior::<T>::default(); 12];
    let mut computed = [Scores::<T, D>::ZERO; 200];
    let mut transition_weights = [num::<T>(0.0); 12];
    let transition_posteriors = [Posterior::new(num::<T>(0.5), num(0.1)); 48];
    let builder = Awfqi::builder(config, approximator, &sources, rows);
    let builder = if opaque(true) {
        builder.transition_weights(
            WeightParams::reference_transition(),
            transition_posteriors.get(..12 * D).unwrap_or(&[]),
            &mut transition_weights,
        )
    } else {
        builder
    };
    let builder = if opaque(true) {
        builder.stored_posteriors(posteriors)
    } else {
        builder.fit_posteriors(&mut fitted)
    };
    let built = match index(2) {
        0 => Ok(builder.stored_scores(values)),
        1 => builder.scores_from(models, &mut computed),
        _ => Ok(builder.realistic_scores(&mut computed)),
    }
    // The plant lent by reference (`GenerativeModel for &G`), as the 32 KiB image does.
    .and_then(|b| b.build(&plant, &mut storage, rng));
    if let Ok(mut kernel) = built {
        if let Ok(report) = kernel.step(rng) {
            for warning in report.warnings() {
                keep(core::fmt::write(&mut Sink, format_args!("{warning}")));
            }
        }
        let valid = kernel.config();
        keep((
            valid.budget(),
            valid.weights(),
            valid.noise_subtraction(),
            valid.subset(),
        ));
        keep((valid.gp_training().search, valid.fqi(), valid.sampling()));
        keep((*valid.config(), valid.into_inner()));
        keep((
            kernel.config().budget,
            kernel.steps(),
            kernel.target_samples().len(),
            kernel.reward_weights().len(),
            kernel.transition_weights().len(),
        ));
        keep((
            kernel.q().actions(),
            kernel.gp().len(),
            kernel.target().num_actions(),
            kernel.sources().reward_posteriors().len(),
            kernel.sampler().rows().len(),
        ));
        kernel.reset();
        keep(kernel.steps());
    }
    let mut heap = AwfqiStorage::<T, D, I, 8, 8, 12, 200, 400>::default();
    let buffers: AwfqiBuffers<'_, T, D, I, 8> = heap.buffers();
    keep(buffers.samples.len());
}

/// The adaptive kernel's buffers at this image's sizes, for any scalar and dimension: an
/// 8-point GP, 12 target and 12 source records, 20 candidate slots, 400 table entries, 6
/// path states, 2 beliefs.
struct AdaptiveBlock<T, const D: usize, const I: usize> {
    gp: Gp<T, 8, I>,
    samples: [Transition<[T; D], T>; 12],
    weights: [T; 12],
    candidates: [awfqi::adaptive::candidates::Candidate<T>; 20],
    fqi: [FqiEntry<T>; 400],
    path: [[T; D]; 6],
    beliefs: [awfqi::adaptive::plausibility::SourceBelief<T>; 2],
}

impl<T: Real, const D: usize, const I: usize> AdaptiveBlock<T, D, I> {
    fn new() -> Self {
        Self {
            gp: Gp::zeroed(),
            samples: [Transition::EMPTY; 12],
            weights: [T::ZERO; 12],
            candidates: [awfqi::adaptive::candidates::Candidate::EMPTY; 20],
            fqi: [FqiEntry::EMPTY; 400],
            path: [[T::ZERO; D]; 6],
            beliefs: [awfqi::adaptive::plausibility::SourceBelief::EMPTY; 2],
        }
    }

    fn buffers(&mut self) -> AdaptiveBuffers<'_, T, D, I, 8> {
        AdaptiveBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            candidates: &mut self.candidates,
            fqi: awfqi::fqi::QStorage::from(&mut self.fqi[..]),
            path: &mut self.path,
            beliefs: &mut self.beliefs,
        }
    }
}
