//! Drawing rows of a table with probability proportional to a weight column, in O(1) per
//! draw: Walker's alias method with Vose's O(rows) set-up.
//!
//! AWFQI draws a budget of `n` state-action pairs from a score table with replacement
//! (§11.3, §12); the grid table has 40 804 rows, so a linear scan per draw would cost
//! 40 804·n operations per step. The alias table costs one pass to build and then one
//! random `u64`, one multiplication and one comparison per draw.
//!
//! The table lives in storage the caller provides (`&mut [AliasEntry<T>]`, one entry per
//! row: a `T` and a `u32`, 8 bytes in `f32`), and the set-up needs no other memory: Vose's
//! two work lists are threaded through the entries' alias fields as linked lists.

use crate::error::{Error, Result};

use crate::float::Real;
use rand_core::Rng;

/// End-of-list marker of the work lists threaded through the alias fields.
const NIL: u32 = u32::MAX;

/// One row of an alias table: keep the drawn row with probability `threshold`, else
/// return row `alias`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AliasEntry<T> {
    threshold: T,
    alias: u32,
}

impl<T: Real> Default for AliasEntry<T> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<T: Real> AliasEntry<T> {
    /// Unused storage; `const`, so a table can live in a `static`:
    /// `static mut ALIAS: [AliasEntry<f32>; 484] = [AliasEntry::EMPTY; 484];`.
    pub const EMPTY: Self = Self {
        threshold: T::ZERO,
        alias: 0,
    };

    /// Probability in `[0, 1]` of keeping this row once it is drawn uniformly.
    pub fn threshold(&self) -> T {
        self.threshold
    }

    /// The row returned when this row is drawn and not kept.
    pub fn alias(&self) -> usize {
        self.alias as usize
    }

    /// The entry as one `T` of working memory, before a table is built in it (the realistic
    /// score table accumulates there, see [`crate::score::ScoreTable::realistic`]).
    pub(crate) fn scratch(&mut self) -> &mut T {
        &mut self.threshold
    }
}

/// A built alias table borrowing its caller-provided entries: draws row `i` with
/// probability `weights[i] / Σ weights`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AliasTable<'a, T> {
    entries: &'a [AliasEntry<T>],
}

impl<'a, T: Real> AliasTable<'a, T> {
    /// Builds the table for `weights` (not necessarily normalised) in the first
    /// `weights.len()` entries of `storage`, in O(rows) time and no other memory.
    ///
    /// A row of weight 0 is never drawn (up to rounding of the other thresholds in the
    /// last bit). Errors: more weights than `storage` holds, or than `u32::MAX − 1`
    /// ([`Error::CapacityExceeded`]); no weights ([`Error::EmptyData`]); a NaN or infinite
    /// weight ([`Error::NonFinite`]); a negative weight or all weights 0
    /// ([`Error::InvalidParameter`], naming `weights`). On error the storage's contents
    /// are unspecified (it is scratch space until a table is built).
    pub fn build<I>(weights: I, storage: &'a mut [AliasEntry<T>]) -> Result<Self>
    where
        I: IntoIterator<Item = T>,
    {
        let capacity = storage.len().min(NIL as usize - 1);
        // Pass 1: copy the weights into the threshold fields, checking them.
        let mut rows = 0usize;
        let mut largest = T::ZERO;
        for w in weights {
            let entry = storage
                .get_mut(rows)
                .filter(|_| rows < capacity)
                .ok_or(Error::CapacityExceeded { capacity })?;
            if !w.is_finite() {
                return Err(Error::NonFinite {
                    parameter: "weights",
                });
            }
            if w < T::ZERO {
                return Err(Error::InvalidParameter {
                    parameter: "weights",
                });
            }
            largest = largest.max(w);
            *entry = AliasEntry {
                threshold: w,
                alias: NIL,
            };
            rows += 1;
        }
        if rows == 0 {
            return Err(Error::EmptyData);
        }
        if largest <= T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "weights",
            });
        }
        let entries = storage
            .get_mut(..rows)
            .ok_or(Error::CapacityExceeded { capacity })?;
        // Pass 2: scale to p_i = n·w_i/Σw (mean 1), dividing by the largest weight first
        // so the sum cannot overflow.
        let sum: T = entries.iter().map(|e| e.threshold / largest).sum();
        let scale = T::from_usize(rows) / sum;
        for e in entries.iter_mut() {
            e.threshold = e.threshold / largest * scale;
        }
        vose(entries);
        Ok(Self { entries })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// `false`: a built table has at least one row (kept for API symmetry with slices).
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The entries, e.g. to inspect or serialise the table.
    pub fn entries(&self) -> &'a [AliasEntry<T>] {
        self.entries
    }

    /// The probability of drawing `row` implied by the table (O(rows)); `None` when `row`
    /// is out of range. Meant for tests and diagnostics.
    pub fn probability(&self, row: usize) -> Option<T> {
        let own = self.entries.get(row)?.threshold;
        let mut mass = own;
        for (j, e) in self.entries.iter().enumerate() {
            if j != row && e.alias() == row {
                mass += T::ONE - e.threshold;
            }
        }
        Some(mass / T::from_usize(self.entries.len()))
    }

    /// Draws one row; consumes exactly one `u64` of `rng`.
    ///
    /// The high 64 bits of `x·rows` (for a uniform 64-bit `x`) pick a column uniformly
    /// (bias below rows/2⁶⁴), and its low bits are the uniform fraction that decides between
    /// the column and its alias.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> usize {
        let rows = self.entries.len() as u128;
        let wide = u128::from(rng.next_u64()) * rows;
        let column = (wide >> 64) as usize;
        let fraction = ((wide as u64) >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0);
        match self.entries.get(column) {
            Some(e) if T::from_f64(fraction) < e.threshold => column,
            Some(e) => e.alias(),
            None => 0,
        }
    }

    /// Fills `out` with independent draws (with replacement), one `u64` each.
    pub fn sample_into<R: Rng + ?Sized>(&self, rng: &mut R, out: &mut [usize]) {
        for o in out.iter_mut() {
            *o = self.sample(rng);
        }
    }
}

/// Vose's pairing on scaled probabilities `p_i` (mean 1) held in the threshold fields;
/// the small and large work lists are linked through the alias fields.
fn vose<T: Real>(entries: &mut [AliasEntry<T>]) {
    let mut small = NIL;
    let mut large = NIL;
    // Push in reverse so each list pops in ascending row order (deterministic layout).
    for (i, e) in entries.iter_mut().enumerate().rev() {
        let head = if e.threshold < T::ONE {
            &mut small
        } else {
            &mut large
        };
        e.alias = *head;
        *head = i as u32;
    }
    while small != NIL && large != NIL {
        let s = small;
        let l = large;
        let Some(p_s) = entries.get(s as usize).map(|e| e.threshold) else {
            break;
        };
        let Some(e_l) = entries.get_mut(l as usize) else {
            break;
        };
        large = e_l.alias;
        // The large row gives 1 − p_s of its mass to fill the small row's column.
        e_l.threshold -= T::ONE - p_s;
        let now_small = e_l.threshold < T::ONE;
        let Some(e_s) = entries.get_mut(s as usize) else {
            break;
        };
        small = e_s.alias;
        e_s.alias = l;
        if let Some(e_l) = entries.get_mut(l as usize) {
            if now_small {
                e_l.alias = small;
                small = l;
            } else {
                e_l.alias = large;
                large = l;
            }
        }
    }
    // Whatever remains has p = 1 up to rounding: keep it always.
    for mut head in [small, large] {
        while let Some(e) = entries.get_mut(head as usize) {
            let next = e.alias;
            e.threshold = T::ONE;
            e.alias = head;
            head = next;
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;
    use std::vec;
    use std::vec::Vec;

    /// Pearson's χ² statistic of `counts` against probabilities proportional to `weights`
    /// (rows of weight 0 must have count 0 and are left out).
    fn chi_square(counts: &[u64], weights: &[f64]) -> (f64, usize) {
        let total: f64 = weights.iter().sum();
        let draws: u64 = counts.iter().sum();
        let mut stat = 0.0;
        let mut df = 0;
        for (&c, &w) in counts.iter().zip(weights) {
            if w == 0.0 {
                assert_eq!(c, 0, "a zero-weight row was drawn");
                continue;
            }
            let e = draws as f64 * w / total;
            stat += (c as f64 - e).powi(2) / e;
            df += 1;
        }
        (stat, df - 1)
    }

    /// Upper 0.1 % point of χ²(df), Wilson–Hilferty approximation (z₀.₉₉₉ = 3.090).
    fn chi_square_critical(df: usize) -> f64 {
        let k = df as f64;
        let a = 2.0 / (9.0 * k);
        k * (1.0 - a + 3.090 * a.sqrt()).powi(3)
    }

    fn counts_of(table: &AliasTable<'_, f64>, draws: usize, seed: u64) -> Vec<u64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut counts = vec![0u64; table.len()];
        for _ in 0..draws {
            counts[table.sample(&mut rng)] += 1;
        }
        counts
    }

    #[test]
    fn implied_probabilities_equal_normalised_weights() {
        let weights = [1.0f64, 2.0, 3.0, 4.0, 0.0, 10.0, 0.5];
        let mut storage = [AliasEntry::default(); 10];
        let table = AliasTable::build(weights, &mut storage).unwrap();
        assert_eq!(table.len(), 7);
        let total: f64 = weights.iter().sum();
        for (i, w) in weights.iter().enumerate() {
            let p = table.probability(i).unwrap();
            assert!((p - w / total).abs() < 1e-14, "row {i}: {p}");
        }
        assert!(table.probability(7).is_none());
        // The zero-weight row keeps nothing of its own column and is nobody's alias.
        let e = table.entries();
        assert_eq!(e[4].threshold(), 0.0);
        assert!(e.iter().enumerate().all(|(j, x)| j == 4 || x.alias() != 4));
    }

    #[test]
    fn empirical_frequencies_pass_chi_square() {
        let weights = [1.0f64, 2.0, 3.0, 4.0, 0.0, 10.0, 0.5];
        let mut storage = [AliasEntry::default(); 7];
        let table = AliasTable::build(weights, &mut storage).unwrap();
        let counts = counts_of(&table, 200_000, 1);
        let (stat, df) = chi_square(&counts, &weights);
        assert_eq!(df, 5);
        // χ²₀.₉₉₉(5) = 20.52.
        assert!(stat < 20.52, "chi-square {stat}");

        // Many rows with irregular weights (a score column looks like this).
        let weights: Vec<f64> = (0..500)
            .map(|i| {
                if i % 7 == 0 {
                    0.0
                } else {
                    ((i * 37) % 101) as f64 + 0.25
                }
            })
            .collect();
        let mut storage = vec![AliasEntry::default(); 500];
        let table = AliasTable::build(weights.iter().copied(), &mut storage).unwrap();
        let counts = counts_of(&table, 400_000, 2);
        let (stat, df) = chi_square(&counts, &weights);
        assert!(stat < chi_square_critical(df), "chi-square {stat}, df {df}");
    }

    #[test]
    fn the_test_has_power_against_a_wrong_distribution() {
        // Draws from the table for `weights`, tested against slightly different weights:
        // the statistic must exceed the bound, or the test above proves nothing.
        let weights = [1.0f64, 2.0, 3.0, 4.0];
        let wrong = [1.0f64, 2.0, 3.0, 4.4];
        let mut storage = [AliasEntry::default(); 4];
        let table = AliasTable::build(weights, &mut storage).unwrap();
        let counts = counts_of(&table, 200_000, 3);
        let (stat, df) = chi_square(&counts, &wrong);
        assert!(stat > chi_square_critical(df), "chi-square {stat}");
    }

    #[test]
    fn f32_table_and_single_row() {
        let mut storage = [AliasEntry::<f32>::default(); 3];
        let table = AliasTable::build([0.0f32, 5.0, 0.0], &mut storage).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for _ in 0..1000 {
            assert_eq!(table.sample(&mut rng), 1);
        }
        let mut storage = [AliasEntry::<f32>::default(); 1];
        let table = AliasTable::build([2.0f32], &mut storage).unwrap();
        let mut out = [9usize; 5];
        table.sample_into(&mut rng, &mut out);
        assert_eq!(out, [0; 5]);
    }

    #[test]
    fn huge_weights_do_not_overflow() {
        let weights = [f32::MAX, f32::MAX, f32::MAX / 2.0];
        let mut storage = [AliasEntry::<f32>::default(); 3];
        let table = AliasTable::build(weights, &mut storage).unwrap();
        for (i, want) in [0.4f32, 0.4, 0.2].iter().enumerate() {
            assert!((table.probability(i).unwrap() - want).abs() < 1e-6);
        }
    }

    #[test]
    fn bad_input_gives_typed_errors() {
        let mut storage = [AliasEntry::<f64>::default(); 2];
        assert_eq!(
            AliasTable::build([1.0, 2.0, 3.0], &mut storage),
            Err(Error::CapacityExceeded { capacity: 2 })
        );
        assert_eq!(AliasTable::build([], &mut storage), Err(Error::EmptyData));
        assert_eq!(
            AliasTable::build([1.0, f64::NAN], &mut storage),
            Err(Error::NonFinite {
                parameter: "weights"
            })
        );
        assert_eq!(
            AliasTable::build([1.0, -1.0], &mut storage),
            Err(Error::InvalidParameter {
                parameter: "weights"
            })
        );
        assert_eq!(
            AliasTable::build([0.0, 0.0], &mut storage),
            Err(Error::InvalidParameter {
                parameter: "weights"
            })
        );
    }

    #[test]
    fn same_seed_same_draws() {
        let mut storage = [AliasEntry::<f64>::default(); 4];
        let table = AliasTable::build([1.0, 2.0, 3.0, 4.0], &mut storage).unwrap();
        let mut a = [0usize; 50];
        let mut b = [0usize; 50];
        table.sample_into(&mut ChaCha8Rng::seed_from_u64(9), &mut a);
        table.sample_into(&mut ChaCha8Rng::seed_from_u64(9), &mut b);
        assert_eq!(a, b);
        assert!(a.iter().any(|&i| i != a[0]));
    }
}
