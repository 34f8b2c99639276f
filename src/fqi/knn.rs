use super::argmax::ArgMax;
use super::iteration::{self, NoDraws, Regressor};
use super::samples::load;
use super::{FqiConfig, SampleSet};
use crate::error::{Error, Result};
use crate::error::{ensure_all_finite, ensure_finite};
use crate::float::Real;
use rand_core::Rng;

/// The largest `k` (the neighbour lists of a prediction live on the stack).
pub const MAX_NEIGHBOURS: usize = 32;

/// "No neighbour" in a link slot; also the bound on the number of records.
pub const NO_LINK: u16 = u16::MAX;

/// How the `k` neighbours of a prediction are weighted (besides their sample weights).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Kernel<T> {
    /// All `k` equally.
    Uniform,
    /// `exp(−(d² − d²₀)/2h²)` with this bandwidth `h` (in range units), `d₀` the nearest
    /// neighbour's distance.
    Gaussian(T),
}

/// The geometry of a kernel-averaging Q: `k`, the length unit of each coordinate and the
/// kernel. What a caller chooses before storage exists.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Neighbours<T, const D: usize> {
    k: usize,
    scale: [T; D],
    kernel: Kernel<T>,
    /// Squared reach (∞: off), see [`Neighbours::with_reach`].
    reach2: T,
    /// One ball for every action, see [`Neighbours::with_common_ball`].
    common: bool,
}

impl<T: Real, const D: usize> Neighbours<T, D> {
    /// `k` neighbours, distances in units of `upper − lower` per coordinate, `kernel`.
    ///
    /// Errors: `k` 0 or above [`MAX_NEIGHBOURS`] ([`Error::InvalidParameter`]
    /// `neighbours`); non-finite bounds ([`Error::NonFinite`]); `lower ≥ upper` on an axis
    /// or an infinite range ([`Error::InvalidParameter`] `upper`); a Gaussian bandwidth
    /// that is not finite and positive ([`Error::InvalidParameter`] `bandwidth`).
    pub fn new(k: usize, lower: [T; D], upper: [T; D], kernel: Kernel<T>) -> Result<Self> {
        if k == 0 || k > MAX_NEIGHBOURS {
            return Err(Error::InvalidParameter {
                parameter: "neighbours",
            });
        }
        ensure_all_finite(&lower, "lower")?;
        ensure_all_finite(&upper, "upper")?;
        let mut scale = upper;
        for (s, &lo) in scale.iter_mut().zip(&lower) {
            *s -= lo;
            if !(s.is_finite() && *s > T::ZERO) {
                return Err(Error::InvalidParameter { parameter: "upper" });
            }
        }
        if let Kernel::Gaussian(h) = kernel {
            ensure_finite(h, "bandwidth")?;
            if h <= T::ZERO || !(h * h).is_finite() || h * h == T::ZERO {
                return Err(Error::InvalidParameter {
                    parameter: "bandwidth",
                });
            }
        }
        Ok(Self {
            k,
            scale,
            kernel,
            reach2: T::INFINITY,
            common: false,
        })
    }

    /// [`Neighbours::new`] on the cube `[lower, upper]^D`.
    ///
    /// Errors: as [`Neighbours::new`].
    pub fn cube(k: usize, lower: T, upper: T, kernel: Kernel<T>) -> Result<Self> {
        Self::new(k, [lower; D], [upper; D], kernel)
    }

    /// The same geometry with pessimism for actions without nearby records: where some
    /// action has a record within `reach` (range units) of the state, an action whose
    /// nearest record is farther is valued at most the lowest value of those that do (the
    /// kNN counterpart of [`EmptyCells::CappedNearest`](super::EmptyCells): an action
    /// never tried near a visited state is not preferred to the tried ones), in every
    /// iteration and prediction.
    ///
    /// Errors: a `reach` that is not positive, or whose square is not finite
    /// ([`Error::InvalidParameter`] `reach`).
    pub fn with_reach(self, reach: T) -> Result<Self> {
        let reach2 = reach.squared();
        if !(reach > T::ZERO && reach2.is_finite() && reach2 > T::ZERO) {
            return Err(Error::InvalidParameter { parameter: "reach" });
        }
        Ok(Self { reach2, ..self })
    }

    /// The same geometry with one ball for every action: at a state, the radius of the `k`
    /// nearest records of *any* action bounds every action's mean (an action with records
    /// inside averages only those) and acts as the reach (an action with none inside is
    /// valued at most the lowest of those that have some). Like a tile centred on the
    /// state, every action's value then comes from the same neighbourhood, so two
    /// neighbouring states cannot each prefer the other on values taken from different
    /// places.
    pub fn with_common_ball(self) -> Self {
        Self {
            common: true,
            ..self
        }
    }

    /// `true` after [`Neighbours::with_common_ball`].
    pub fn common_ball(&self) -> bool {
        self.common
    }

    /// The reach of [`Neighbours::with_reach`] (∞ when off).
    pub fn reach(&self) -> T {
        self.reach2.sqrt()
    }

    /// Neighbours per prediction.
    pub fn k(&self) -> usize {
        self.k
    }

    /// The kernel.
    pub fn kernel(&self) -> Kernel<T> {
        self.kernel
    }

    /// Link slots needed for `records` records and `actions` actions (`None` on overflow).
    pub fn required_links(&self, records: usize, actions: usize) -> Option<usize> {
        records.checked_mul(actions)?.checked_mul(self.k)
    }

    /// Squared distance in range units.
    fn distance2(&self, a: &[T; D], b: &[T; D]) -> T {
        let mut d2 = T::ZERO;
        for ((&x, &y), &s) in a.iter().zip(b).zip(&self.scale) {
            d2 += ((x - y) / s).squared();
        }
        d2
    }

    /// The kernel weight of a neighbour at squared distance `d2` when the nearest is at
    /// `d2_min ≤ d2` (at most 1).
    fn weight(&self, d2: T, d2_min: T) -> T {
        match self.kernel {
            Kernel::Uniform => T::ONE,
            Kernel::Gaussian(h) => {
                let excess = (d2 - d2_min).max(T::ZERO);
                (-(excess / (T::from_f64(2.0) * h * h))).exp()
            }
        }
    }
}

/// One record of a kernel-averaging Q: where it starts and ends, its transition weight and
/// the values of the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KnnRecord<T, const D: usize> {
    state: [T; D],
    next_state: [T; D],
    /// Transition weight `w_s`.
    weight: T,
    /// `R̂` at the record (after iteration 1).
    reward: T,
    /// The regression target `y` of the last iteration (the raw reward during iteration 1).
    target: T,
    /// Scratch: `maxₐ Q_{k−1}(s′, a)` during an iteration, the reward weight `w_r`
    /// during iteration 1.
    value: T,
    action: u16,
    absorbing: bool,
}

impl<T: Real, const D: usize> KnnRecord<T, D> {
    /// An unused slot; `const` and all-zero, so storage can be a `static` in `.bss`.
    pub const EMPTY: Self = Self {
        state: [T::ZERO; D],
        next_state: [T::ZERO; D],
        weight: T::ZERO,
        reward: T::ZERO,
        target: T::ZERO,
        value: T::ZERO,
        action: 0,
        absorbing: false,
    };

    /// The fitted reward model `R̂` at the record.
    pub fn reward_model(&self) -> T {
        self.reward
    }

    /// The record's regression target of the last iteration (`Q` at the record's own
    /// state-action pair when `k = 1`).
    pub fn target(&self) -> T {
        self.target
    }
}

impl<T: Real, const D: usize> Default for KnnRecord<T, D> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// The `k` nearest of a scan, ascending by distance (ties: the earlier index), on the
/// stack.
struct Nearest<T> {
    items: [(T, u16); MAX_NEIGHBOURS],
    len: usize,
    k: usize,
}

impl<T: Real> Nearest<T> {
    fn new(k: usize) -> Self {
        Self {
            items: [(T::ZERO, NO_LINK); MAX_NEIGHBOURS],
            len: 0,
            k: k.min(MAX_NEIGHBOURS),
        }
    }

    fn offer(&mut self, d2: T, index: u16) {
        if self.len == self.k {
            match self.items.get(self.len.wrapping_sub(1)) {
                Some(&(worst, _)) if d2 < worst => self.len -= 1,
                _ => return,
            }
        }
        let mut pos = self.len;
        while pos > 0 {
            match self.items.get(pos - 1).copied() {
                Some(prev) if prev.0 > d2 => {
                    if let Some(slot) = self.items.get_mut(pos) {
                        *slot = prev;
                    }
                    pos -= 1;
                }
                _ => break,
            }
        }
        if let Some(slot) = self.items.get_mut(pos) {
            *slot = (d2, index);
            self.len += 1;
        }
    }

    fn as_slice(&self) -> &[(T, u16)] {
        self.items.get(..self.len).unwrap_or(&[])
    }
}

/// The radius of the reward model at a record: that of the `k` nearest records of
/// positive weight (`nearest`, ascending, the record's action), widened until their total
/// weight reaches `min`; past [`MAX_NEIGHBOURS`] records, the nearest record whose own
/// weight reaches `min` (`trusted`) bounds it instead. `None`: no record of positive
/// weight.
fn reward_radius<T: Real, const D: usize>(
    nearest: &[(T, u16)],
    trusted: &[(T, u16)],
    records: &[KnnRecord<T, D>],
    k: usize,
    min: T,
) -> Option<T> {
    let mut mass = T::ZERO;
    for (taken, &(d2, j)) in nearest.iter().enumerate() {
        mass += records.get(usize::from(j)).map_or(T::ZERO, |r| r.value);
        if taken + 1 >= k && mass >= min {
            return Some(d2);
        }
    }
    let widest = nearest.last().map(|&(d2, _)| d2)?;
    Some(match trusted.first() {
        Some(&(d2, _)) if nearest.len() == MAX_NEIGHBOURS => widest.max(d2),
        _ => widest,
    })
}

/// Weighted FQI with a kernel-averaging Q-function over the records themselves: the
/// `k`-nearest-neighbour form of Ormoneit and Sen's kernel-based reinforcement learning
/// (Machine Learning 49, 2002), in caller-lent fixed memory.
///
/// Tiles average a record with everything in its tile; here the prediction at `(s, a)` is
/// a weighted mean over the `k` records of action `a` nearest to `s`, so where the target's
/// records are dense (a verified greedy path, a narrow passage) they decide the value
/// alone, and where the data are sparse the neighbourhood widens by itself. Like the tiles
/// it is an averager (every prediction a convex combination of regression targets), so FQI
/// is a contraction and cannot diverge. The IWFQI structure is the loop's ([module
/// docs](super)):
///
/// 1. **Reward model** `R̂` at every record `i`: the reward-weighted mean of the rewards of
///    the records of action `aᵢ` within radius `ρᵢ` of `sᵢ`, where `ρᵢ` is the distance to
///    the `k`-th nearest record whose own reward weight reaches
///    [`FqiConfig::min_weight`] (the "has data" threshold of the table, per record). A
///    source record the weights all but discard (where the target has a puddle that no
///    source has) therefore neither counts towards `k` nor outweighs the trusted records
///    around it; with no trusted record of the action, the `k` nearest of positive weight
///    are used, and with none at all `R̂ = 0`.
/// 2. **Iterations 2..N**: `yᵢ = R̂ᵢ + γ (1 − ωᵢ) maxₐ′ Q_{k−1}(s′ᵢ, a′)`, with
///    `Q_{k−1}(s, a)` the transition-weighted kernel mean of `y_{k−1}` over the `k` nearest
///    records of action `a` with positive transition weight (at least the minimum weight).
///    The neighbours of every next state are found once per fit and kept as `u16` links,
///    so an iteration costs `O(records · actions · k)`.
///
/// Distances are Euclidean in units of each coordinate's range ([`Neighbours::new`]);
/// [`Kernel::Uniform`] weighs the `k` neighbours equally, [`Kernel::Gaussian`] by
/// `exp(−(d² − d²₀)/2h²)`, `d₀` the nearest neighbour's distance (so the nearest has weight
/// 1 and no weight underflows to a 0/0). An action without any eligible record has the
/// value 0 (as the table's nearest filling and the reference's empty forest); greedy ties
/// go to an action with records, then to the smallest index.
///
/// **Memory.** One [`KnnRecord`] per record (`2D + 4` scalars and 4 bytes: 36 bytes for
/// `f32`, `D = 2`) and `records · actions · k` links of 2 bytes; at most 65 534 records.
/// Puddle World's adaptive AWFQI (300 target + 1 033 source records, 4 actions, `k = 4`):
/// 47 988 + 42 656 bytes. Fit cost: `O(records² · actions)` for the links (once), then
/// `O(records · actions · k)` per iteration; a prediction scans the records, `O(records)`.
///
/// A Q-function by kernel averaging over the records (module docs), over caller-lent
/// records and links.
#[derive(Debug)]
pub struct KnnFqi<'a, T, const D: usize> {
    neighbours: Neighbours<T, D>,
    actions: usize,
    min_weight: T,
    records: &'a mut [KnnRecord<T, D>],
    links: &'a mut [u16],
    len: usize,
}

impl<'a, T: Real, const D: usize> KnnFqi<'a, T, D> {
    /// A Q-function that is 0 everywhere, able to hold `records.len()` records.
    ///
    /// Errors: `actions` 0 or above 65 535 ([`Error::InvalidParameter`] `actions`); more
    /// than 65 534 record slots, or `links` shorter than
    /// [`Neighbours::required_links`] for them ([`Error::CapacityExceeded`] with the
    /// links' length).
    pub fn new(
        neighbours: Neighbours<T, D>,
        actions: usize,
        records: &'a mut [KnnRecord<T, D>],
        links: &'a mut [u16],
    ) -> Result<Self> {
        if actions == 0 || actions > usize::from(NO_LINK) {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        if records.len() >= usize::from(NO_LINK) {
            return Err(Error::CapacityExceeded {
                capacity: usize::from(NO_LINK) - 1,
            });
        }
        let needed =
            neighbours
                .required_links(records.len(), actions)
                .ok_or(Error::CapacityExceeded {
                    capacity: links.len(),
                })?;
        if links.len() < needed {
            return Err(Error::CapacityExceeded {
                capacity: links.len(),
            });
        }
        Ok(Self {
            neighbours,
            actions,
            min_weight: T::ZERO,
            records,
            links,
            len: 0,
        })
    }

    /// The geometry.
    pub fn neighbours(&self) -> &Neighbours<T, D> {
        &self.neighbours
    }

    /// Number of actions.
    pub fn actions(&self) -> usize {
        self.actions
    }

    /// The records of the last fit.
    pub fn records(&self) -> &[KnnRecord<T, D>] {
        self.records.get(..self.len).unwrap_or(&[])
    }

    /// Resets Q to 0 everywhere (forgets the records).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Fits Q from scratch by weighted FQI on the union of `sets` (module docs).
    ///
    /// Everything is checked before the records change. Errors: those of
    /// [`TabularFqi::fit`](super::TabularFqi::fit), and more records than slots
    /// ([`Error::CapacityExceeded`] with the slots' count).
    pub fn fit(&mut self, sets: &[SampleSet<'_, T, D>], config: &FqiConfig<T>) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config)
    }

    /// [`KnnFqi::fit`] on sets produced by an iterator (cloned once per pass).
    ///
    /// Errors: those of [`KnnFqi::fit`].
    pub fn fit_sets<'s, I>(&mut self, sets: I, config: &FqiConfig<T>) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        iteration::fit(self, sets, config, &mut NoDraws)
    }

    fn live(&self) -> &[KnnRecord<T, D>] {
        self.records.get(..self.len).unwrap_or(&[])
    }

    fn live_mut(&mut self) -> &mut [KnnRecord<T, D>] {
        self.records.get_mut(..self.len).unwrap_or(&mut [])
    }

    /// A record takes part in the Bellman means (and the links) when its transition
    /// weight is positive and reaches the minimum weight.
    fn eligible(&self, r: &KnnRecord<T, D>) -> bool {
        r.weight > T::ZERO && r.weight >= self.min_weight
    }

    /// Iteration 1: `R̂ᵢ` into every record's `reward` (the raw reward is in `target`,
    /// its weight in `value`).
    fn reward_model(&mut self) {
        let min = self.min_weight;
        let nb = self.neighbours;
        for i in 0..self.len {
            let Some(&me) = self.records.get(i) else {
                break;
            };
            let records = self.live();
            // Pass 1: the nearest records of positive reward weight, ascending.
            let mut nearest = Nearest::new(MAX_NEIGHBOURS);
            let mut trusted = Nearest::new(1);
            let mut d2_min = T::INFINITY;
            for (j, r) in records.iter().enumerate() {
                if r.action != me.action || r.value <= T::ZERO {
                    continue;
                }
                let d2 = nb.distance2(&me.state, &r.state);
                d2_min = d2_min.min(d2);
                nearest.offer(d2, j as u16);
                if r.value >= min {
                    trusted.offer(d2, j as u16);
                }
            }
            let radius = reward_radius(nearest.as_slice(), trusted.as_slice(), records, nb.k, min);
            // Pass 2: the weighted mean within the radius.
            let mut sum = T::ZERO;
            let mut mass = T::ZERO;
            if let Some(radius) = radius {
                for r in records {
                    if r.action != me.action || r.value <= T::ZERO {
                        continue;
                    }
                    let d2 = nb.distance2(&me.state, &r.state);
                    if d2 <= radius {
                        let w = r.value * nb.weight(d2, d2_min);
                        sum += w * r.target;
                        mass += w;
                    }
                }
            }
            let fitted = if mass > T::ZERO { sum / mass } else { T::ZERO };
            if let Some(r) = self.records.get_mut(i) {
                r.reward = fitted;
            }
        }
    }

    /// The `k` nearest eligible records of `action` to `point`.
    fn nearest(&self, point: &[T; D], action: usize) -> Nearest<T> {
        let mut out = Nearest::new(self.neighbours.k);
        for (j, r) in self.live().iter().enumerate() {
            if usize::from(r.action) == action && self.eligible(r) {
                out.offer(self.neighbours.distance2(point, &r.state), j as u16);
            }
        }
        out
    }

    /// The links of every non-absorbing record's next state, action after action.
    fn link(&mut self) {
        let k = self.neighbours.k;
        for i in 0..self.len {
            let Some(&me) = self.records.get(i) else {
                break;
            };
            for a in 0..self.actions {
                let found = if me.absorbing {
                    Nearest::new(0)
                } else {
                    self.nearest(&me.next_state, a)
                };
                let start = (i * self.actions + a) * k;
                if let Some(slots) = self.links.get_mut(start..start + k) {
                    slots.fill(NO_LINK);
                    for (slot, &(_, j)) in slots.iter_mut().zip(found.as_slice()) {
                        *slot = j;
                    }
                }
            }
        }
    }

    /// The kernel mean of the targets of `links` (ascending by distance to `point`) and the
    /// squared distance of the nearest, or `None` when there are none.
    fn mean_of(&self, point: &[T; D], links: impl Iterator<Item = u16>) -> Option<(T, T)> {
        let records = self.live();
        let mut d2_min = None;
        let mut sum = T::ZERO;
        let mut mass = T::ZERO;
        for j in links {
            let Some(r) = records.get(usize::from(j)) else {
                continue;
            };
            let d2 = self.neighbours.distance2(point, &r.state);
            let base = *d2_min.get_or_insert(d2);
            let w = r.weight * self.neighbours.weight(d2, base);
            sum += w * r.target;
            mass += w;
        }
        match d2_min {
            Some(d2) if mass > T::ZERO => Some((sum / mass, d2)),
            _ => None,
        }
    }

    /// The values of every action at `point` from `list(a)`, the action's nearest
    /// records (ascending), with the common ball and the reach cap applied; `visit(a,
    /// value)` gets `None` for an action without records.
    fn capped_values(
        &self,
        point: &[T; D],
        list: impl Fn(usize) -> Nearest<T>,
        mut visit: impl FnMut(usize, Option<T>),
    ) {
        let mut ball2 = T::INFINITY;
        if self.neighbours.common {
            let mut all = Nearest::new(self.neighbours.k);
            for a in 0..self.actions {
                for &(d2, j) in list(a).as_slice() {
                    all.offer(d2, j);
                }
            }
            if let Some(&(d2, _)) = all.as_slice().last() {
                ball2 = d2;
            }
        }
        let reach2 = self.neighbours.reach2.min(ball2);
        let raw = |a: usize| {
            let found = list(a);
            let items = found.as_slice();
            let inside = items
                .iter()
                .take_while(|&&(d2, _)| d2 <= ball2)
                .map(|&(_, j)| j);
            self.mean_of(point, inside)
                .or_else(|| self.mean_of(point, items.iter().map(|&(_, j)| j)))
        };
        let mut cap = T::INFINITY;
        if reach2.is_finite() {
            for a in 0..self.actions {
                if let Some((q, d2)) = raw(a) {
                    if d2 <= reach2 {
                        cap = cap.min(q);
                    }
                }
            }
        }
        for a in 0..self.actions {
            let value = raw(a).map(|(q, d2)| if d2 > reach2 { q.min(cap) } else { q });
            visit(a, value);
        }
    }

    /// One iteration k ≥ 2: `V_{k−1}` at every next state from the links, then the
    /// targets `y = R̂ + γ(1−ω)V` (Jacobi: all values before any target changes).
    fn bellman_targets(&mut self, gamma: T) {
        let k = self.neighbours.k;
        for i in 0..self.len {
            let Some(&me) = self.records.get(i) else {
                break;
            };
            let mut best = None::<T>;
            if !me.absorbing {
                let records = self.live();
                let list = |a: usize| {
                    let start = (i * self.actions + a) * k;
                    let links = self.links.get(start..start + k).unwrap_or(&[]);
                    let mut found = Nearest::new(k);
                    for &j in links.iter().take_while(|&&j| j != NO_LINK) {
                        if let Some(r) = records.get(usize::from(j)) {
                            found.offer(self.neighbours.distance2(&me.next_state, &r.state), j);
                        }
                    }
                    found
                };
                self.capped_values(&me.next_state, list, |_, q| {
                    if let Some(q) = q {
                        best = Some(best.map_or(q, |b: T| b.max(q)));
                    }
                });
            }
            if let Some(r) = self.records.get_mut(i) {
                r.value = best.unwrap_or(T::ZERO);
            }
        }
        for r in self.live_mut() {
            let future = if r.absorbing { T::ZERO } else { r.value };
            r.target = r.reward + gamma * future;
        }
    }

    /// `Q(state, a)` of every action (`None`: no records) to `visit`.
    fn values(&self, state: &[T; D], visit: impl FnMut(usize, Option<T>)) {
        self.capped_values(state, |a| self.nearest(state, a), visit);
    }

    /// `Q(state, action)` (0 for an action without records).
    ///
    /// Errors: a non-finite state, an action `≥ actions`.
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        ensure_all_finite(&state, "state")?;
        if action >= self.actions {
            return Err(Error::OutOfRange {
                parameter: "action",
            });
        }
        let mut out = T::ZERO;
        self.values(&state, |a, q| {
            if a == action {
                out = q.unwrap_or(T::ZERO);
            }
        });
        Ok(out)
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        ensure_all_finite(&state, "state")?;
        let mut best = T::NEG_INFINITY;
        self.values(&state, |_, q| best = best.max(q.unwrap_or(T::ZERO)));
        Ok(best)
    }

    /// The greedy action: the largest `Q`, ties to an action with records, then to the
    /// smallest index.
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        ensure_all_finite(&state, "state")?;
        let mut best = ArgMax::new();
        self.values(&state, |a, fitted| {
            best.offer(a, fitted.unwrap_or(T::ZERO), fitted.is_some());
        });
        Ok(best.action())
    }
}

impl<T: Real, const D: usize> Regressor<T, D> for KnnFqi<'_, T, D> {
    fn actions(&self) -> usize {
        self.actions
    }

    fn capacity(&self) -> Option<usize> {
        Some(self.records.len())
    }

    /// The records, then `R̂ᵢ` at every record, which is its first target.
    fn fit_reward_model<'s, I, R>(
        &mut self,
        sets: I,
        total: usize,
        config: &FqiConfig<T>,
        _: &mut R,
    ) where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        self.min_weight = config.min_weight();
        load(self.records, sets, |(s, reward, w_r, w_s)| KnnRecord {
            state: s.state,
            next_state: s.next_state,
            weight: w_s,
            reward: T::ZERO,
            target: reward,
            value: w_r,
            action: s.action as u16,
            absorbing: s.absorbing,
        });
        self.len = total;
        self.reward_model();
        for r in self.live_mut() {
            r.target = r.reward;
            r.value = T::ZERO;
        }
    }

    /// The links once (iteration 2), then the targets from them.
    fn bellman_iteration<'s, I, R>(&mut self, _: I, k: usize, config: &FqiConfig<T>, _: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        if k == 2 {
            self.link();
        }
        self.bellman_targets(config.discount());
    }
}

/// The memory of a learner-averaging Q as one block with const-generic capacities (`R`
/// record slots, `L` links), all-zero so it can be a `static` in `.bss`.
#[derive(Debug, Clone)]
pub struct KnnStorage<T, const D: usize, const R: usize, const L: usize> {
    records: [KnnRecord<T, D>; R],
    links: [u16; L],
}

impl<T: Real, const D: usize, const R: usize, const L: usize> KnnStorage<T, D, R, L> {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            records: [KnnRecord::EMPTY; R],
            links: [0; L],
        }
    }

    /// The block as the [`QStorage`](super::QStorage) a Q-function is built in.
    pub fn storage(&mut self) -> super::QStorage<'_, T, D> {
        super::QStorage {
            records: &mut self.records,
            links: &mut self.links,
            ..super::QStorage::default()
        }
    }
}

impl<T: Real, const D: usize, const R: usize, const L: usize> Default for KnnStorage<T, D, R, L> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
