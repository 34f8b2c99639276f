use super::{Awfqi, SourceData, TransitionWeighting, ValidAwfqiConfig};
use crate::alias::AliasEntry;
use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::{Approximator, FqiEntry};
use crate::gp::Gp;
use crate::model::SourceModel;
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{Dims, InputDim, Output, StatePlusAction, fit_gp, predict_posteriors};
use crate::score::{RowSet, ScoreTable, Scores};
use crate::weights::{Posterior, WeightParams};
use rand_core::Rng;

/// All the memory an AWFQI run writes, as one block with const-generic capacities: the
/// target GP (`N` points of dimension `I = D + 1`), `Q` target samples (steps × budget),
/// `W` reward weights (one per source record), `R` alias entries (one per candidate row)
/// and `E` FQI entries (cells × actions).
///
/// [`AwfqiStorage::new`] is `const` and all-zero, so the block can be a `static` in `.bss`.
/// The builder hands out its parts as slices, so the learner's code does not depend on the
/// capacities. For a plant of a fixed scalar, [`awfqi_storage!`](crate::awfqi_storage)
/// declares the same block by named capacities; this generic form is for code generic over
/// the scalar or the dimension.
#[derive(Debug, Clone)]
pub struct AwfqiStorage<
    T,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const R: usize,
    const E: usize,
> {
    gp: Gp<T, N, I>,
    samples: [Transition<[T; D], T>; Q],
    weights: [T; W],
    alias: [AliasEntry<T>; R],
    fqi: [FqiEntry<T>; E],
}

impl<
    T: Real,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const R: usize,
    const E: usize,
> AwfqiStorage<T, D, I, N, Q, W, R, E>
{
    /// Empty, all-zero storage (the GP's hyperparameters are set when a learner is built).
    /// `I` must be `D + 1` ([`Dims`]).
    pub const fn new() -> Self
    where
        Dims<D, I>: StatePlusAction,
    {
        Self {
            gp: Gp::zeroed(),
            samples: [Transition::EMPTY; Q],
            weights: [T::ZERO; W],
            alias: [AliasEntry::EMPTY; R],
            fqi: [FqiEntry::EMPTY; E],
        }
    }

    /// The block as the slices a learner borrows.
    pub fn buffers(&mut self) -> AwfqiBuffers<'_, T, D, I, N> {
        AwfqiBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            alias: &mut self.alias,
            fqi: &mut self.fqi,
        }
    }
}

impl<
    T: Real,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const R: usize,
    const E: usize,
> Default for AwfqiStorage<T, D, I, N, Q, W, R, E>
where
    Dims<D, I>: StatePlusAction,
{
    fn default() -> Self {
        Self::new()
    }
}

/// Declares the block of all the memory the thesis's AWFQI writes, sized by named
/// capacities: a `struct` with a `const fn new()` (all-zero: a `static` lands in `.bss`) and
/// `buffers()` (also `(&mut block).into()`) for [`AwfqiBuilder::build`].
///
/// ```rust
/// awfqi::awfqi_storage! {
///     /// Puddle World, 11 × 11 cells, the 324 rows of the spacing-1.25 grid.
///     pub struct PuddleStorage {
///         scalar: f32,
///         state_dim: 2,
///         gp_points: 24,
///         steps: 6,
///         budget: 50,
///         source_records: 1033,
///         candidate_rows: awfqi::score::PointGrid::<f32, 2>::rows(9, 4),
///         table_entries: 11 * 11 * 4,
///     }
/// }
/// static mut STORAGE: PuddleStorage = PuddleStorage::new();
/// ```
///
/// The target samples are `steps × budget`, the GP input dimension `state_dim + 1`; a
/// capacity of 0 does not compile.
#[macro_export]
macro_rules! awfqi_storage {
    (
        $(#[$attr:meta])*
        $vis:vis struct $name:ident {
            scalar: $t:ty,
            state_dim: $d:expr,
            gp_points: $n:expr,
            steps: $steps:expr,
            budget: $budget:expr,
            source_records: $w:expr,
            candidate_rows: $r:expr,
            table_entries: $e:expr $(,)?
        }
    ) => {
        $(#[$attr])*
        #[derive(Debug, Clone)]
        $vis struct $name {
            gp: $crate::gp::Gp<$t, { $n }, { $d + 1 }>,
            samples: [$crate::model::Transition<[$t; $d], $t>; $steps * $budget],
            weights: [$t; $w],
            alias: [$crate::alias::AliasEntry<$t>; $r],
            fqi: [$crate::fqi::FqiEntry<$t>; $e],
        }

        const _: () = {
            assert!($d > 0, "state_dim: a plant has at least one state coordinate");
            assert!($n > 0, "gp_points: a GP holds at least one point");
            assert!($steps > 0, "steps: at least one");
            assert!($budget > 0, "budget: at least one query a step");
            assert!($r > 0, "candidate_rows: at least one");
        };

        impl $name {
            /// Empty, all-zero storage.
            pub const fn new() -> Self {
                Self {
                    gp: $crate::gp::Gp::zeroed(),
                    samples: [$crate::model::Transition::EMPTY; $steps * $budget],
                    weights: [<$t as $crate::float::Real>::ZERO; $w],
                    alias: [$crate::alias::AliasEntry::EMPTY; $r],
                    fqi: [$crate::fqi::FqiEntry::EMPTY; $e],
                }
            }

            /// The block as the slices a learner borrows.
            pub fn buffers(
                &mut self,
            ) -> $crate::thesis::AwfqiBuffers<'_, $t, { $d }, { $d + 1 }, { $n }> {
                $crate::thesis::AwfqiBuffers {
                    gp: &mut self.gp,
                    samples: &mut self.samples,
                    weights: &mut self.weights,
                    alias: &mut self.alias,
                    fqi: &mut self.fqi,
                }
            }
        }

        impl ::core::default::Default for $name {
            fn default() -> Self {
                Self::new()
            }
        }

        impl<'a> ::core::convert::From<&'a mut $name>
            for $crate::thesis::AwfqiBuffers<'a, $t, { $d }, { $d + 1 }, { $n }>
        {
            fn from(storage: &'a mut $name) -> Self {
                storage.buffers()
            }
        }
    };
}

/// The memory of a learner as borrowed slices, whatever owns it: an [`AwfqiStorage`]
/// (`(&mut storage).into()`, or [`AwfqiStorage::buffers`]) or buffers sized at run time
/// (a host's vectors).
#[derive(Debug)]
pub struct AwfqiBuffers<'a, T, const D: usize, const I: usize, const N: usize> {
    /// The target GP (its contents are replaced every step; the builder also fits the
    /// source GPs in it).
    pub gp: &'a mut Gp<T, N, I>,
    /// Room for the target records of all steps (steps × budget).
    pub samples: &'a mut [Transition<[T; D], T>],
    /// Room for one reward weight per source record.
    pub weights: &'a mut [T],
    /// Room for the sampler's alias table, one entry per candidate row.
    pub alias: &'a mut [AliasEntry<T>],
    /// Room for the FQI table, one entry per (cell, action).
    pub fqi: &'a mut [FqiEntry<T>],
}

impl<
    'a,
    T: Real,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const R: usize,
    const E: usize,
> From<&'a mut AwfqiStorage<T, D, I, N, Q, W, R, E>> for AwfqiBuffers<'a, T, D, I, N>
{
    fn from(storage: &'a mut AwfqiStorage<T, D, I, N, Q, W, R, E>) -> Self {
        storage.buffers()
    }
}

/// Where the source records' stored reward posteriors come from.
#[derive(Debug)]
enum Posteriors<'a, T> {
    /// Not chosen yet (an error at build time, unless there are no source records).
    Missing,
    /// Computed earlier (e.g. on the host, in flash).
    Stored(&'a [Posterior<T>]),
    /// Fitted by the builder into this storage.
    Fit(&'a mut [Posterior<T>]),
}

/// Where the score values come from.
#[derive(Debug)]
enum ScoreValues<'a, T, const D: usize> {
    /// Not chosen yet (an error at build time).
    Missing,
    /// Computed earlier, or by [`AwfqiBuilder::scores_from`].
    Stored(&'a [Scores<T, D>]),
    /// The realistic table, computed by the builder into this storage.
    Realistic(&'a mut [Scores<T, D>]),
}

/// Setting up AWFQI once: one storage block and a builder.
///
/// The set-up of §6 and §11–§12 — source reward GPs, the posteriors stored with the source
/// records, the score table over a candidate set, its sampler, the source data, the FQI
/// table — is the same for every plant, so it lives here once. The memory is one owned
/// block, [`AwfqiStorage`], whose capacities are const generics so it fits in a `static`
/// (all-zero: `.bss`, no flash image); anything that can lend the same slices
/// ([`AwfqiBuffers`], e.g. the harness's heap vectors) works too. Memory needed only by an
/// optional stage (posteriors fitted on the device, score values) is lent to that stage.
///
/// The [crate docs](crate) show the whole loop on a plant of their own.
///
/// The set-up of an AWFQI learner, performed once by [`AwfqiBuilder::build`] (the
/// [crate docs](crate) show it on a plant of their own).
///
/// Required: the validated configuration, the FQI grid, the source records (one slice per
/// source; none is allowed) and the candidate set ([`Awfqi::builder`]); then where the
/// stored source posteriors come from ([`stored_posteriors`](Self::stored_posteriors) or
/// [`fit_posteriors`](Self::fit_posteriors)) and where the scores come from
/// ([`stored_scores`](Self::stored_scores), [`scores_from`](Self::scores_from) or
/// [`realistic_scores`](Self::realistic_scores)).
///
/// The source GPs the builder fits (for posteriors or realistic scores) use the
/// configuration's GP training, subset rule and noise subtraction, one at a time in the
/// storage's GP; with both stages, each source's GP is fitted once and serves both.
#[derive(Debug)]
pub struct AwfqiBuilder<'a, T, const D: usize, const I: usize> {
    config: ValidAwfqiConfig<T, I>,
    approximator: Approximator<T, D>,
    sources: &'a [&'a [Transition<[T; D], T>]],
    candidates: RowSet<'a, T, D>,
    posteriors: Posteriors<'a, T>,
    scores: ScoreValues<'a, T, D>,
    transitions: Option<TransitionWeighting<'a, T>>,
    steps: usize,
}

impl<'a, T: Real, const D: usize, const I: usize> AwfqiBuilder<'a, T, D, I>
where
    Dims<D, I>: StatePlusAction,
{
    /// A set-up from its required parts (also [`Awfqi::builder`]): the configuration, the
    /// Q-function approximator over the state space (a [`crate::fqi::CellGrid`] for the table,
    /// [`crate::fqi::Tilings`] for tile coding), the source records and the candidate rows.
    pub fn new(
        config: ValidAwfqiConfig<T, I>,
        approximator: impl Into<Approximator<T, D>>,
        sources: &'a [&'a [Transition<[T; D], T>]],
        candidates: RowSet<'a, T, D>,
    ) -> Self
    where
        Dims<D, I>: StatePlusAction,
    {
        let () = InputDim::<D, I>::CHECK;
        Self {
            config,
            approximator: approximator.into(),
            sources,
            candidates,
            posteriors: Posteriors::Missing,
            scores: ScoreValues::Missing,
            transitions: None,
            steps: 1,
        }
    }

    /// The steps the run must hold (default 1): [`build`](Self::build) refuses a
    /// target-sample buffer with less room than `steps × budget` records, so a run too long
    /// for its buffer fails before its first step, not at the step that overflows it.
    pub fn steps(mut self, steps: usize) -> Self {
        self.steps = steps;
        self
    }

    /// Turns transition weights on (§7.2 step 4 with every next-state dimension on; off
    /// by default, every `w_s = 1`, the shared-dynamics configuration of §7.6): every step
    /// fits one target GP per next-state coordinate in turn (in the learner's GP, before
    /// the reward GP), weighs each source record's coordinate by `params` against the
    /// stored source posterior, and FQI uses the product over coordinates from its second
    /// iteration on.
    ///
    /// `posteriors` holds the source next-state GPs' posteriors at the records' own `z`
    /// (§6, noise-subtracted), `D` per record (`posteriors[i·D + d]` for record `i`, all
    /// sources in one slice, source after source); `weights` has room for one weight per
    /// source record. Both are checked by [`build`](Self::build).
    pub fn transition_weights(
        mut self,
        params: WeightParams<T>,
        posteriors: &'a [Posterior<T>],
        weights: &'a mut [T],
    ) -> Self {
        self.transitions = Some(TransitionWeighting {
            params,
            posteriors,
            weights,
        });
        self
    }

    /// The source posteriors computed earlier, all sources in one slice, source after
    /// source (§6 step 3; e.g. computed on the host and kept in flash).
    pub fn stored_posteriors(mut self, posteriors: &'a [Posterior<T>]) -> Self {
        self.posteriors = Posteriors::Stored(posteriors);
        self
    }

    /// Fits one reward GP per source at build time and stores the posteriors at its records
    /// in `storage` (one per source record), where the learner then reads them.
    pub fn fit_posteriors(mut self, storage: &'a mut [Posterior<T>]) -> Self {
        self.posteriors = Posteriors::Fit(storage);
        self
    }

    /// Score values computed earlier for the candidate rows (e.g. shared by many runs, or
    /// kept in flash).
    pub fn stored_scores(mut self, values: &'a [Scores<T, D>]) -> Self {
        self.scores = ScoreValues::Stored(values);
        self
    }

    /// Computes the score values of the candidate rows now, from source models (e.g. the
    /// sources' own mean functions: the oracle table), into `storage`.
    ///
    /// Errors: those of [`ScoreTable::compute`].
    pub fn scores_from<S: SourceModel<T, D>>(
        mut self,
        models: &[S],
        storage: &'a mut [Scores<T, D>],
    ) -> Result<Self> {
        let table = ScoreTable::compute(self.candidates, models, storage)?;
        self.scores = ScoreValues::Stored(table.values());
        Ok(self)
    }

    /// The realistic table of §11.2 (`V_r` from one reward GP per source, fitted at build
    /// time; [`ScoreTable::realistic`]) into `storage`.
    pub fn realistic_scores(mut self, storage: &'a mut [Scores<T, D>]) -> Self {
        self.scores = ScoreValues::Realistic(storage);
        self
    }

    /// Performs the set-up in `buffers` and returns the learner, ready for its first step:
    /// checks every size, fits the source GPs (posteriors, realistic scores) drawing from
    /// `rng`, builds the score table and its sampler, pairs the sources with their
    /// posteriors and clears the FQI table and the target GP.
    ///
    /// Errors, sizes first (nothing is fitted when one is wrong): no posterior or score
    /// stage chosen ([`Error::InvalidParameter`] `posteriors` / `scores`); a model without
    /// actions, or a candidate row whose action the model does not have
    /// ([`Error::InvalidParameter`] / [`Error::OutOfRange`] `actions`); `samples` unable to
    /// hold one step, `weights` or the posterior storage shorter than the source records,
    /// `alias` or the score storage shorter than the candidate rows, `fqi` shorter than
    /// the approximator's entries ([`Error::BufferTooSmall`] naming the buffer and its
    /// const parameter, with its length and the length needed); with transition weights, a
    /// weight buffer shorter than the source records ([`Error::BufferTooSmall`]), a posterior count other than `D` per record
    /// ([`Error::InvalidParameter`] `transition_posteriors`), a non-finite posterior or a
    /// negative std ([`Error::NonFinite`] / [`Error::InvalidParameter`]
    /// `transition_posteriors`); then those of
    /// the GP fits, of [`ScoreTable::from_parts`], of [`SourceData::new`].
    pub fn build<G, R, const N: usize>(
        self,
        target: G,
        buffers: impl Into<AwfqiBuffers<'a, T, D, I, N>>,
        rng: &mut R,
    ) -> Result<Awfqi<'a, T, G, D, I, N>>
    where
        G: GenerativeModel<T, State = [T; D]>,
        R: Rng + ?Sized,
    {
        let AwfqiBuffers {
            gp,
            samples,
            weights,
            alias,
            fqi,
        } = buffers.into();
        let config = self.config;
        let records = self.sources;
        let source_records = records
            .iter()
            .try_fold(0usize, |n, r| n.checked_add(r.len()))
            .ok_or(Error::CapacityExceeded {
                capacity: usize::MAX,
            })?;
        let rows = self.candidates.len();
        // Sizes and stages, before anything is computed.
        let actions = target.num_actions();
        if actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        if self.candidates.iter().any(|(_, a)| a >= actions) {
            return Err(Error::OutOfRange {
                parameter: "actions",
            });
        }
        if let Some(entries) = self.approximator.required_entries(actions) {
            short(fqi.len(), entries, buffer::FQI)?;
        }
        let fqi = self.approximator.build(actions, fqi)?;
        let transitions = match self.transitions {
            None => None,
            Some(t) => {
                short(t.weights.len(), source_records, buffer::TRANSITION_WEIGHTS)?;
                check_transition_posteriors::<T, D>(t.posteriors, source_records)?;
                let weights =
                    t.weights
                        .get_mut(..source_records)
                        .ok_or(Error::CapacityExceeded {
                            capacity: source_records,
                        })?;
                Some(TransitionWeighting {
                    params: t.params,
                    posteriors: t.posteriors,
                    weights,
                })
            }
        };
        let room = self
            .steps
            .max(1)
            .checked_mul(config.budget)
            .ok_or(Error::CapacityExceeded {
                capacity: samples.len(),
            })?;
        short(samples.len(), room, buffer::SAMPLES)?;
        short(weights.len(), source_records, buffer::WEIGHTS)?;
        short(alias.len(), rows, buffer::ALIAS)?;
        match &self.posteriors {
            Posteriors::Missing if source_records > 0 => {
                return Err(Error::InvalidParameter {
                    parameter: "posteriors",
                });
            }
            Posteriors::Fit(storage) => short(storage.len(), source_records, buffer::POSTERIORS)?,
            _ => {}
        }
        match &self.scores {
            ScoreValues::Missing => {
                return Err(Error::InvalidParameter {
                    parameter: "scores",
                });
            }
            ScoreValues::Stored(values) => short(values.len(), rows, buffer::SCORES)?,
            ScoreValues::Realistic(storage) => short(storage.len(), rows, buffer::SCORES)?,
        }

        // Source GPs: posteriors and/or realistic scores, one source at a time.
        let (posteriors, mut fit_storage): (&'a [Posterior<T>], Option<&'a mut [Posterior<T>]>) =
            match self.posteriors {
                Posteriors::Missing => (&[], None),
                Posteriors::Stored(p) => (p, None),
                Posteriors::Fit(storage) => (&[], storage.get_mut(..source_records)),
            };
        let fitting = fit_storage.is_some();
        let noise = config.noise_subtraction;
        let mut store_posteriors = |j: usize, gp: &Gp<T, N, I>| -> Result<()> {
            let Some(storage) = fit_storage.as_deref_mut() else {
                return Ok(());
            };
            let start: usize = records.iter().take(j).map(|r| r.len()).sum();
            let source = records.get(j).copied().unwrap_or(&[]);
            let out =
                storage
                    .get_mut(start..start + source.len())
                    .ok_or(Error::CapacityExceeded {
                        capacity: source_records,
                    })?;
            predict_posteriors(gp, source, noise, out)
        };
        let table = match self.scores {
            ScoreValues::Missing => {
                return Err(Error::InvalidParameter {
                    parameter: "scores",
                });
            }
            ScoreValues::Realistic(storage) => ScoreTable::realistic(
                self.candidates,
                records,
                gp,
                &config.gp_training,
                config.subset,
                storage,
                alias,
                rng,
                &mut store_posteriors,
            )?,
            ScoreValues::Stored(values) => {
                if fitting {
                    for (j, source) in records.iter().enumerate() {
                        fit_gp(
                            gp,
                            source,
                            Output::Reward,
                            config.subset,
                            &config.gp_training,
                            rng,
                        )?;
                        store_posteriors(j, gp)?;
                    }
                }
                ScoreTable::from_parts(self.candidates, values)?
            }
        };
        let posteriors = match fit_storage {
            Some(storage) => &*storage,
            None => posteriors,
        };
        let sampler = table.sampler(config.sampling, alias)?;
        let sources = SourceData::new(records, posteriors)?;
        Awfqi::assemble(
            config,
            target,
            sampler,
            sources,
            samples,
            weights,
            gp,
            fqi,
            transitions,
        )
    }
}

/// Checks the stored transition posteriors: `D` per source record, finite, `std ≥ 0`.
fn check_transition_posteriors<T: Real, const D: usize>(
    posteriors: &[Posterior<T>],
    records: usize,
) -> Result<()> {
    let parameter = "transition_posteriors";
    if records.checked_mul(D) != Some(posteriors.len()) {
        return Err(Error::InvalidParameter { parameter });
    }
    for p in posteriors {
        crate::error::ensure_finite(p.mean, parameter)?;
        crate::error::ensure_finite(p.std, parameter)?;
        if p.std < T::ZERO {
            return Err(Error::InvalidParameter { parameter });
        }
    }
    Ok(())
}

/// `Err(BufferTooSmall { buffer, capacity: have, needed: need })` when `have < need`.
pub(crate) fn short(have: usize, need: usize, buffer: &'static str) -> Result<()> {
    if have < need {
        Err(Error::BufferTooSmall {
            buffer,
            capacity: have,
            needed: need,
        })
    } else {
        Ok(())
    }
}

/// `Ok` when `len + more` records fit in the target-sample buffer of `capacity`, else the
/// [`Error::BufferTooSmall`] naming it (a run longer than its `Q` was sized for).
pub(crate) fn room_for(len: usize, more: usize, capacity: usize) -> Result<()> {
    let needed = len.saturating_add(more);
    short(capacity, needed, buffer::SAMPLES)
}

/// The names of the lent buffers in errors ([`Error::BufferTooSmall`]), with the const
/// parameter of [`AwfqiStorage`] and [`crate::AdaptiveStorage`] that sizes each.
pub(crate) mod buffer {
    pub(crate) const SAMPLES: &str = "samples (`steps` × `budget` target records)";
    pub(crate) const WEIGHTS: &str = "weights (`source_records`: one per source record)";
    pub(crate) const ALIAS: &str = "alias (`candidate_rows`: one entry per candidate row)";
    pub(crate) const FQI: &str =
        "fqi (`table_entries` or the approximator's memory: cells × actions)";
    pub(crate) const POSTERIORS: &str = "posteriors (one per source record)";
    pub(crate) const MEANS: &str = "means (one mean function per source)";
    pub(crate) const SCORES: &str = "scores (one per candidate row)";
    pub(crate) const TRANSITION_WEIGHTS: &str = "transition weights (one per source record)";
    pub(crate) const CANDIDATES: &str = "candidates (`candidates`: min(candidates, rows))";
    pub(crate) const PATH: &str = "path (`budget`: one step's verified states)";
    pub(crate) const BELIEFS: &str = "beliefs (`sources`: one per source)";
}
