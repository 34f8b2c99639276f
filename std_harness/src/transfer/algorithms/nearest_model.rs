//! A nearest-record model of a task: the transitions and rewards an algorithm already
//! holds (target and source records), replayed around any state. `awfqi-adaptive` rolls
//! its plans out in it without spending queries (simulated relevance centres, plan
//! selection).

use rand_chacha::ChaCha8Rng;

use crate::domains::Record;
use crate::forest_fqi::Dataset;

/// How many nearest records (same action) a simulated step draws its transition from:
/// more than one, so simulated rollouts spread as noisy ones do.
pub const NEIGHBOURS: usize = 5;

/// One record of the model: state, action, reward, next state, absorbing.
type Entry<const D: usize> = ([f64; D], usize, f64, [f64; D], bool);

/// The records of a task, searched by scaled distance.
#[derive(Debug, Clone)]
pub struct NearestModel<const D: usize> {
    records: Vec<Entry<D>>,
    bounds: [(f64, f64); D],
}

impl<const D: usize> NearestModel<D> {
    /// The target records followed by the source records, with `rewards` (one per source
    /// record, e.g. relabelled ones) replacing the sources' own when given.
    pub fn new(
        target: &[Record<D>],
        sources: &Dataset<D>,
        rewards: Option<&[f64]>,
        bounds: [(f64, f64); D],
    ) -> Self {
        let records = target
            .iter()
            .map(|r| (r.state, r.action, r.reward, r.next_state, r.absorbing))
            .chain((0..sources.len()).map(|i| {
                let reward = rewards.and_then(|r| r.get(i)).copied();
                (
                    sources.states[i],
                    sources.actions[i],
                    reward.unwrap_or(sources.rewards[i]),
                    sources.next_states[i],
                    sources.absorbing[i],
                )
            }))
            .collect();
        Self { records, bounds }
    }

    /// One simulated step from `state` with `action`: the displacement `s′ − s`, reward and
    /// absorbing flag of one of the [`NEIGHBOURS`] records of that action nearest to
    /// `state` (distance in units of each coordinate's range), drawn uniformly; the next
    /// state is clipped to the bounds. `None` when no record has that action.
    pub fn step(
        &self,
        state: &[f64; D],
        action: usize,
        rng: &mut ChaCha8Rng,
    ) -> Option<(f64, [f64; D], bool)> {
        let mut nearest: Vec<(f64, usize)> = self
            .records
            .iter()
            .enumerate()
            .filter(|(_, r)| r.1 == action)
            .map(|(j, r)| {
                let d: f64 = (0..D)
                    .map(|d| ((r.0[d] - state[d]) / (self.bounds[d].1 - self.bounds[d].0)).powi(2))
                    .sum();
                (d, j)
            })
            .collect();
        if nearest.is_empty() {
            return None;
        }
        let k = NEIGHBOURS.min(nearest.len());
        nearest.select_nth_unstable_by(k - 1, |x, y| x.0.total_cmp(&y.0));
        nearest[..k].sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let (_, j) = nearest[awfqi::rng::uniform_index(rng, k)];
        let (from, _, reward, to, absorbing) = self.records[j];
        let mut next = *state;
        for d in 0..D {
            next[d] = (state[d] + to[d] - from[d]).clamp(self.bounds[d].0, self.bounds[d].1);
        }
        Some((reward, next, absorbing))
    }

    /// The discounted return of one simulated rollout of `policy` from `start`, at most
    /// `horizon` steps; `visit` sees every state the rollout acts in.
    pub fn rollout(
        &self,
        start: [f64; D],
        policy: &dyn Fn(&[f64; D]) -> usize,
        horizon: usize,
        discount: f64,
        rng: &mut ChaCha8Rng,
        mut visit: impl FnMut(&[f64; D]),
    ) -> f64 {
        let (mut state, mut ret, mut weight) = (start, 0.0, 1.0);
        for _ in 0..horizon {
            visit(&state);
            let Some((reward, next, absorbing)) = self.step(&state, policy(&state), rng) else {
                break;
            };
            ret += weight * reward;
            weight *= discount;
            if absorbing {
                break;
            }
            state = next;
        }
        ret
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::SeedableRng;

    fn record(state: [f64; 2], action: usize, next: [f64; 2], absorbing: bool) -> Record<2> {
        Record {
            state,
            action,
            reward: -1.0,
            next_state: next,
            absorbing,
        }
    }

    #[test]
    fn a_chain_of_records_is_replayed_to_its_absorbing_end() {
        // Action 0 moves +1 along x from 0, 1, 2; the record at 2 absorbs. Fewer records
        // than NEIGHBOURS per state would mix displacements, so each state has its own
        // identical copies.
        let mut target = Vec::new();
        for x in 0..3 {
            for _ in 0..NEIGHBOURS {
                let x = f64::from(x) * 4.0;
                target.push(record([x, 0.0], 0, [x + 4.0, 0.0], x == 8.0));
            }
        }
        let model = NearestModel::new(&target, &Dataset::new(), None, [(0.0, 10.0); 2]);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut visited = Vec::new();
        let ret = model.rollout([0.0, 0.0], &|_| 0, 50, 0.5, &mut rng, |s| visited.push(*s));
        assert_eq!(visited, vec![[0.0, 0.0], [4.0, 0.0], [8.0, 0.0]]);
        // −1 − 0.5 − 0.25, by hand.
        assert!((ret + 1.75).abs() < 1e-12);
        // No record of action 1: the rollout stops at once with return 0.
        let ret = model.rollout([0.0, 0.0], &|_| 1, 50, 0.5, &mut rng, |_| {});
        assert_eq!(ret, 0.0);
    }

    #[test]
    fn replacement_rewards_and_clipping() {
        let mut sources = Dataset::new();
        for _ in 0..NEIGHBOURS {
            sources.push(record([9.5, 5.0], 0, [10.5, 5.0], false));
        }
        let rewards = vec![-7.0; NEIGHBOURS];
        let model = NearestModel::new(&[], &sources, Some(&rewards), [(0.0, 10.0); 2]);
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let (reward, next, absorbing) = model.step(&[9.8, 5.0], 0, &mut rng).unwrap();
        assert_eq!((reward, absorbing), (-7.0, false));
        assert_eq!(next, [10.0, 5.0]);
    }
}
