//! The memory an adaptive run writes, declared by name: [`adaptive_storage!`](crate::adaptive_storage)
//! makes one block (a `static` in `.bss` on a device) from named capacities, and
//! [`AdaptiveBuffers`] is the same memory as borrowed slices, whatever owns it.
//!
//! Each buffer has one user: the target GP, the samples and the weights belong to the
//! run, the candidate slots to the drawn queries, the path to the verification, the
//! beliefs and the sources' mean functions to the evidence, the posteriors to the source
//! data; the Q-function's memory to its approximator.

use super::candidates::Candidate;
use super::mean_function::MeanFunction;
use super::plausibility::SourceBelief;
use crate::fqi::QStorage;
use crate::gp::Gp;
use crate::model::Transition;
use crate::weights::Posterior;

/// The memory of an adaptive learner as borrowed slices, whatever owns it (a block of
/// [`adaptive_storage!`](crate::adaptive_storage), or a host's vectors sized at run
/// time).
#[derive(Debug)]
pub struct AdaptiveBuffers<'a, T, const D: usize, const I: usize, const N: usize> {
    /// The target GP: the weights' reward GP during a re-plan, then the residual GP that
    /// scores the next sub-batch's rows.
    pub gp: &'a mut Gp<T, N, I>,
    /// Room for the target records of all steps (steps × budget).
    pub samples: &'a mut [Transition<[T; D], T>],
    /// Room for one reward weight per source record.
    pub weights: &'a mut [T],
    /// The candidate slots of a sub-batch (at least `min(candidates, rows)`).
    pub candidates: &'a mut [Candidate<T>],
    /// Room for the approximator: FQI entries (table, tiles), a model sweep's entries and
    /// nodes, or records and links (kernel averaging: one record slot per target and
    /// source record).
    pub fqi: QStorage<'a, T, D>,
    /// Room for one step's verified states (at least the budget).
    pub path: &'a mut [[T; D]],
    /// One belief per source.
    pub beliefs: &'a mut [SourceBelief<T>],
}

/// A block declared by [`adaptive_storage!`](crate::adaptive_storage): the learner's
/// buffers and the set-up's (each source's reward mean function, the posteriors stored
/// with the source records), which [`AdaptiveBuilder`](super::AdaptiveBuilder) wires.
pub trait AdaptiveStorage<T, const D: usize, const I: usize, const N: usize> {
    /// The capacities the block was declared with.
    fn capacities(&self) -> AdaptiveCapacities;
    /// The block as the parts the builder fills and lends.
    fn parts(&mut self) -> AdaptiveParts<'_, T, D, I, N>;
}

/// The named capacities of an [`adaptive_storage!`](crate::adaptive_storage) block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub struct AdaptiveCapacities {
    /// Actions of the plant.
    pub actions: usize,
    /// Points of every GP (the target GP, each source's mean function).
    pub gp_points: usize,
    /// Steps the target-sample buffer holds at `budget` queries each.
    pub steps: usize,
    /// Queries per step.
    pub budget: usize,
    /// Source tasks.
    pub sources: usize,
    /// Source records, all sources together.
    pub source_records: usize,
    /// Stored reward posteriors the builder fits (0 when they are stored elsewhere, e.g.
    /// in flash: [`AdaptiveBuilder::stored_posteriors`](super::AdaptiveBuilder::stored_posteriors)).
    pub source_posteriors: usize,
    /// Candidate slots of a sub-batch.
    pub candidates: usize,
    /// Cells per axis of the model sweep (0 for a table).
    pub sweep_cells: usize,
    /// Entries of the table (0 for a model sweep).
    pub table_entries: usize,
}

impl AdaptiveCapacities {
    /// The capacities as the macro declares them (use the macro).
    #[doc(hidden)]
    #[allow(clippy::too_many_arguments)]
    pub const fn declared(
        actions: usize,
        gp_points: usize,
        steps: usize,
        budget: usize,
        sources: usize,
        source_records: usize,
        source_posteriors: usize,
        candidates: usize,
        sweep_cells: usize,
        table_entries: usize,
    ) -> Self {
        Self {
            actions,
            gp_points,
            steps,
            budget,
            sources,
            source_records,
            source_posteriors,
            candidates,
            sweep_cells,
            table_entries,
        }
    }
}

/// An [`AdaptiveStorage`] block as borrowed parts: the learner's buffers and the set-up's.
#[derive(Debug)]
pub struct AdaptiveParts<'a, T, const D: usize, const I: usize, const N: usize> {
    /// What the learner borrows for its run.
    pub buffers: AdaptiveBuffers<'a, T, D, I, N>,
    /// One reward mean function per source.
    pub means: &'a mut [MeanFunction<T, N, I>],
    /// One stored reward posterior per source record.
    pub posteriors: &'a mut [Posterior<T>],
}

/// Declares a block of all the memory an adaptive learner and its set-up write, sized by
/// named capacities: a `struct` with a `const fn new()` (all-zero, so a `static` lands in
/// `.bss`), `buffers()` for [`AdaptiveAwfqi::new`](crate::adaptive::AdaptiveAwfqi::new) and
/// the [`AdaptiveStorage`](crate::adaptive::AdaptiveStorage) trait for
/// [`AdaptiveAwfqi::builder`](crate::adaptive::AdaptiveAwfqi::builder).
///
/// The fields come in this order, each named: `source_posteriors` is the source records
/// (the builder fits and stores their posteriors here) or 0 (they are stored elsewhere,
/// e.g. in flash); the last is either `sweep_cells`, the cells per axis of a model sweep,
/// or `table_entries`, the entries of a table or tiles (0 when the approximator's memory
/// is lent beside the block):
///
/// ```rust
/// awfqi::adaptive_storage! {
///     /// Puddle World's recommended learner, 2 steps of 50 queries.
///     pub struct PuddleMemory {
///         scalar: f32,
///         state_dim: 2,
///         actions: 4,
///         gp_points: 32,
///         steps: 2,
///         budget: 50,
///         sources: 3,
///         source_records: 300,
///         source_posteriors: 300,
///         candidates: 250,
///         sweep_cells: 12,
///     }
/// }
/// static mut MEMORY: PuddleMemory = PuddleMemory::new();
/// ```
///
/// Every size follows from these: the target samples (`steps × budget`), the path
/// (`budget`), the sweep's nodes and entries ([`sweep_nodes`](crate::fqi::sweep_nodes),
/// [`sweep_entries`](crate::fqi::sweep_entries)), the GP input dimension (`state_dim + 1`).
/// A capacity of 0, or fewer source records than sources, does not compile:
///
/// ```compile_fail
/// awfqi::adaptive_storage! {
///     struct NoSources {
///         scalar: f32, state_dim: 2, actions: 4, gp_points: 32, steps: 2, budget: 50,
///         sources: 0, source_records: 300, source_posteriors: 300, candidates: 250,
///         sweep_cells: 12,
///     }
/// }
/// ```
///
/// and neither does a block of another plant's dimension (its `state_dim` is part of its
/// type).
#[macro_export]
macro_rules! adaptive_storage {
    (
        $(#[$attr:meta])*
        $vis:vis struct $name:ident {
            scalar: $t:ty,
            state_dim: $d:expr,
            actions: $a:expr,
            gp_points: $n:expr,
            steps: $steps:expr,
            budget: $budget:expr,
            sources: $m:expr,
            source_records: $w:expr,
            source_posteriors: $p:expr,
            candidates: $c:expr,
            $fqi:ident: $x:expr $(,)?
        }
    ) => {
        $(#[$attr])*
        #[derive(Debug, Clone)]
        $vis struct $name {
            gp: $crate::gp::Gp<$t, { $n }, { $d + 1 }>,
            samples: [$crate::model::Transition<[$t; $d], $t>; $steps * $budget],
            weights: [$t; $w],
            candidates: [$crate::adaptive::candidates::Candidate<$t>; $c],
            path: [[$t; $d]; $budget],
            beliefs: [$crate::adaptive::plausibility::SourceBelief<$t>; $m],
            means: [$crate::adaptive::MeanFunction<$t, { $n }, { $d + 1 }>; $m],
            posteriors: [$crate::weights::Posterior<$t>; $p],
            fqi: $crate::__adaptive_fqi!(type $fqi, $t, $d, $a, $x),
        }

        const _: () = {
            assert!($d > 0, "state_dim: a plant has at least one state coordinate");
            assert!($a > 0, "actions: a plant has at least one action");
            assert!($n > 0, "gp_points: a GP holds at least one point");
            assert!($steps > 0, "steps: at least one");
            assert!($budget > 0, "budget: at least one query a step");
            assert!($m > 0, "sources: at least one");
            assert!($w >= $m, "source_records: at least one per source");
            assert!($c > 0, "candidates: at least one slot");
        };

        impl $name {
            /// The capacities it was declared with.
            pub const CAPACITIES: $crate::adaptive::AdaptiveCapacities =
                $crate::__adaptive_fqi!(capacities $fqi, $a, $n, $steps, $budget, $m, $w, $p, $c, $x);

            /// Empty, all-zero storage.
            pub const fn new() -> Self {
                Self {
                    gp: $crate::gp::Gp::zeroed(),
                    samples: [$crate::model::Transition::EMPTY; $steps * $budget],
                    weights: [<$t as $crate::float::Real>::ZERO; $w],
                    candidates: [$crate::adaptive::candidates::Candidate::EMPTY; $c],
                    path: [[<$t as $crate::float::Real>::ZERO; $d]; $budget],
                    beliefs: [$crate::adaptive::plausibility::SourceBelief::EMPTY; $m],
                    means: [$crate::adaptive::MeanFunction::EMPTY; $m],
                    posteriors: [$crate::weights::Posterior::EMPTY; $p],
                    fqi: <$crate::__adaptive_fqi!(type $fqi, $t, $d, $a, $x)>::new(),
                }
            }

            /// The learner's buffers as slices (for
            /// [`AdaptiveAwfqi::new`]($crate::adaptive::AdaptiveAwfqi::new)).
            pub fn buffers(
                &mut self,
            ) -> $crate::adaptive::AdaptiveBuffers<'_, $t, { $d }, { $d + 1 }, { $n }> {
                $crate::adaptive::AdaptiveBuffers {
                    gp: &mut self.gp,
                    samples: &mut self.samples,
                    weights: &mut self.weights,
                    candidates: &mut self.candidates,
                    fqi: self.fqi.storage(),
                    path: &mut self.path,
                    beliefs: &mut self.beliefs,
                }
            }
        }

        impl ::core::default::Default for $name {
            fn default() -> Self {
                Self::new()
            }
        }

        impl<'a> ::core::convert::From<&'a mut $name>
            for $crate::adaptive::AdaptiveBuffers<'a, $t, { $d }, { $d + 1 }, { $n }>
        {
            fn from(storage: &'a mut $name) -> Self {
                storage.buffers()
            }
        }

        impl $crate::adaptive::AdaptiveStorage<$t, { $d }, { $d + 1 }, { $n }> for $name {
            fn capacities(&self) -> $crate::adaptive::AdaptiveCapacities {
                Self::CAPACITIES
            }

            fn parts(
                &mut self,
            ) -> $crate::adaptive::AdaptiveParts<'_, $t, { $d }, { $d + 1 }, { $n }> {
                $crate::adaptive::AdaptiveParts {
                    buffers: $crate::adaptive::AdaptiveBuffers {
                        gp: &mut self.gp,
                        samples: &mut self.samples,
                        weights: &mut self.weights,
                        candidates: &mut self.candidates,
                        fqi: self.fqi.storage(),
                        path: &mut self.path,
                        beliefs: &mut self.beliefs,
                    },
                    means: &mut self.means,
                    posteriors: &mut self.posteriors,
                }
            }
        }
    };
}

/// The Q-function's memory of an [`adaptive_storage!`](crate::adaptive_storage) block.
#[doc(hidden)]
#[macro_export]
macro_rules! __adaptive_fqi {
    (type sweep_cells, $t:ty, $d:expr, $a:expr, $x:expr) => {
        $crate::fqi::SweepStorage<
            $t,
            { $d },
            { $crate::fqi::sweep_entries($d, $x, $a) },
            { $crate::fqi::sweep_nodes($d, $x) },
        >
    };
    (type table_entries, $t:ty, $d:expr, $a:expr, $x:expr) => {
        $crate::fqi::TableStorage<$t, { $x }>
    };
    (capacities sweep_cells, $a:expr, $n:expr, $s:expr, $b:expr, $m:expr, $w:expr, $p:expr, $c:expr, $x:expr) => {
        $crate::adaptive::AdaptiveCapacities::declared($a, $n, $s, $b, $m, $w, $p, $c, $x, 0)
    };
    (capacities table_entries, $a:expr, $n:expr, $s:expr, $b:expr, $m:expr, $w:expr, $p:expr, $c:expr, $x:expr) => {
        $crate::adaptive::AdaptiveCapacities::declared($a, $n, $s, $b, $m, $w, $p, $c, 0, $x)
    };
}
