//! The growing GP, in both storages, against a refit ([`FixedGp`]) on all points: the
//! same posterior to rounding, the same blocks and jitter, and errors that leave it
//! unchanged.

use super::*;
use crate::gp_large::fixed::tests::points;
use crate::gp_large::fixed::{FixedGp, RbfTerm};

fn split_kernel() -> FixedKernel {
    FixedKernel {
        terms: vec![
            RbfTerm {
                signal_variance: 2.0,
                length_scales: vec![1.3, 1e5, 0.0161],
            },
            RbfTerm {
                signal_variance: 0.5,
                length_scales: vec![4.0, 1e5, 4.75e-5],
            },
        ],
        noise_variance: 0.0,
    }
}

fn queries() -> Vec<[f64; 3]> {
    (0..40)
        .map(|i| {
            [
                i as f64 * 0.13,
                (i % 9) as f64 * 1.1,
                [0.0, 3.0, 5.0, 7.0][i % 4],
            ]
        })
        .collect()
}

const STORAGES: [Storage; 2] = [Storage::Stored, Storage::Compact];

/// Means and stds of the growing GP (keeping `storage`) fed in `batches`, and of a refit
/// on all points.
fn both(
    storage: Storage,
    xs: &[[f64; 3]],
    ys: &[f64],
    kernel: &FixedKernel,
    batches: &[usize],
    queries: &[[f64; 3]],
) -> (GrowingFixedGp<3>, FixedGp<3>, [Vec<f64>; 4]) {
    let mut growing = GrowingFixedGp::new(kernel, Some(2), queries.to_vec(), Par::Seq)
        .unwrap()
        .with_storage(storage);
    assert_eq!(growing.storage(), storage);
    let mut start = 0;
    for &b in batches {
        growing
            .extend(&xs[start..start + b], &ys[start..start + b])
            .unwrap();
        start += b;
    }
    assert_eq!(growing.len(), start);
    let refit = FixedGp::fit(&xs[..start], &ys[..start], kernel, Some(2), Par::Seq).unwrap();
    let q = queries.len();
    let (mut gm, mut gs, mut rm, mut rs) = (vec![0.0; q], vec![0.0; q], vec![0.0; q], vec![0.0; q]);
    growing.posterior_into(&mut gm, &mut gs).unwrap();
    refit.predict_into(queries, &mut rm, &mut rs).unwrap();
    (growing, refit, [gm, gs, rm, rs])
}

fn assert_close(a: &[f64], b: &[f64], tolerance: f64, what: &str) {
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tolerance * y.abs().max(1.0),
            "{what} {i}: {x} vs {y}"
        );
    }
}

#[test]
fn batches_give_the_refit_posterior_with_and_without_splitting() {
    let (xs, ys) = points(60);
    let noisy = FixedKernel::isotropic(1.5, 2.0, 3, 0.3);
    // Some noise on the split kernel keeps its blocks well conditioned, so the two routes
    // agree to rounding (the noise-free case is the next test's).
    let split_noisy = FixedKernel {
        noise_variance: 1e-3,
        ..split_kernel()
    };
    for storage in STORAGES {
        for (kernel, blocks) in [(split_noisy.clone(), 3), (noisy.clone(), 1)] {
            for batches in [&[60][..], &[20, 25, 15], &[1, 1, 58], &[7; 8]] {
                let (growing, refit, [gm, gs, rm, rs]) =
                    both(storage, &xs, &ys, &kernel, batches, &queries());
                assert_eq!(growing.blocks(), blocks);
                assert_eq!(refit.blocks(), blocks);
                assert_eq!(growing.jitter(), refit.jitter());
                assert_close(&gm, &rm, 1e-10, "mean");
                assert_close(&gs, &rs, 1e-10, "std");
            }
        }
        // A query at an action without training points keeps the prior, as in the refit.
        let (_, _, [gm, gs, ..]) = both(storage, &xs, &ys, &split_kernel(), &[30, 30], &queries());
        assert_eq!(gm[3], 0.0);
        assert_eq!(gs[3], split_kernel().prior_variance().sqrt());
    }
}

#[test]
fn a_noise_free_kernel_on_many_close_points_matches_the_refit() {
    // Acrobot's situation: noise-free isotropic kernel, points close together.
    let xs: Vec<[f64; 3]> = (0..240)
        .map(|i| {
            let t = i as f64;
            [
                (t * 0.731).sin() * 2.0,
                (t * 0.377).cos() * 2.5,
                (i % 2) as f64,
            ]
        })
        .collect();
    let ys: Vec<f64> = xs.iter().map(|x| x[0] * x[1] - x[2]).collect();
    let kernel = FixedKernel::isotropic(4.0, 1.5, 3, 0.0);
    let qs: Vec<[f64; 3]> = (0..50)
        .map(|i| [i as f64 * 0.08 - 2.0, 1.0 - i as f64 * 0.05, (i % 2) as f64])
        .collect();
    for storage in STORAGES {
        let (growing, refit, [gm, gs, rm, rs]) =
            both(storage, &xs, &ys, &kernel, &[80, 80, 80], &qs);
        assert_eq!(growing.jitter(), refit.jitter());
        assert_close(&gm, &rm, 1e-5, "mean");
        assert_close(&gs, &rs, 1e-4, "std");
    }
}

#[test]
fn a_batch_that_ends_the_separation_reconditions_unsplit() {
    let (mut xs, ys) = points(45);
    // The last batch's action 3.00001 is correlated with action 3's block.
    for x in &mut xs[40..] {
        x[2] = 3.00001;
    }
    for storage in STORAGES {
        let (growing, refit, [gm, gs, rm, rs]) =
            both(storage, &xs, &ys, &split_kernel(), &[40, 5], &queries());
        assert_eq!(growing.blocks(), 1);
        assert_eq!(refit.blocks(), 1);
        assert_close(&gm, &rm, 1e-6, "mean");
        assert_close(&gs, &rs, 1e-6, "std");
    }
}

#[test]
fn duplicates_climb_the_same_jitter_ladder_as_a_refit() {
    for c in [1.0, 1e7, 1e9] {
        let kernel = FixedKernel::isotropic(c, 1.0, 3, 0.0);
        let xs = vec![[0.5, 0.5, 1.0]; 20];
        let ys = vec![2.0; 20];
        let qs = vec![[0.5, 0.5, 1.0], [0.7, 0.2, 1.0]];
        // The reference's 10⁻¹⁰ is below half an ulp of c = 10⁷ and 10⁹: the ladder
        // climbs to the first jitter that survives the rounding, whatever the batches.
        let expected = [(1.0, 1e-10), (1e7, 1e-8), (1e9, 1e-6)]
            .iter()
            .find(|(k, _)| *k == c)
            .map(|(_, j)| *j)
            .unwrap();
        for (storage, batches) in STORAGES
            .iter()
            .flat_map(|&s| [(s, &[1, 19][..]), (s, &[10, 10]), (s, &[20])])
        {
            let (growing, refit, [gm, _, rm, _]) = both(storage, &xs, &ys, &kernel, batches, &qs);
            assert_eq!(refit.jitter(), expected);
            assert_eq!(growing.jitter(), expected, "{c} {storage:?} {batches:?}");
            assert!((gm[0] - 2.0).abs() < 1e-9, "{}", gm[0]);
            assert_close(&gm, &rm, 1e-12, "mean");
        }
    }
}

#[test]
fn bad_input_is_an_error_and_leaves_the_gp_as_it_was() {
    for storage in STORAGES {
        bad_input_leaves_the_gp_as_it_was(storage);
    }
}

fn bad_input_leaves_the_gp_as_it_was(storage: Storage) {
    let (xs, ys) = points(30);
    let kernel = split_kernel();
    let mut gp = GrowingFixedGp::new(&kernel, Some(2), queries(), Par::Seq)
        .unwrap()
        .with_storage(storage);
    let (mut m, mut s) = (vec![0.0; 40], vec![0.0; 40]);
    assert_eq!(gp.posterior_into(&mut m, &mut s), Err(Error::EmptyData));
    gp.extend(&xs[..20], &ys[..20]).unwrap();
    gp.posterior_into(&mut m, &mut s).unwrap();
    let before = (m.clone(), s.clone());
    let mut bad = ys[20..].to_vec();
    bad[3] = f64::NAN;
    assert!(matches!(
        gp.extend(&xs[20..], &bad),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        gp.extend(&xs[20..], &ys[20..25]),
        Err(Error::InvalidParameter { .. })
    ));
    assert_eq!(gp.len(), 20);
    gp.posterior_into(&mut m, &mut s).unwrap();
    assert_eq!((m.clone(), s.clone()), before);
    assert!(gp.posterior_into(&mut m[..39], &mut s).is_err());
    // An empty batch changes nothing.
    gp.extend(&[], &[]).unwrap();
    assert_eq!(gp.len(), 20);
    // Invalid kernels and queries are refused up front.
    let negative = FixedKernel::isotropic(-1.0, 1.0, 3, 0.0);
    assert!(GrowingFixedGp::<3>::new(&negative, None, queries(), Par::Seq).is_err());
    assert!(GrowingFixedGp::new(&kernel, None, vec![[f64::INFINITY, 0.0, 0.0]], Par::Seq).is_err());
    // A query between two split values is correlated with both: refused, as the refit does.
    let mut between =
        GrowingFixedGp::new(&kernel, Some(2), vec![[1.0, 1.0, 3.00001]], Par::Seq).unwrap();
    between.extend(&xs, &ys).unwrap();
    assert_eq!(between.blocks(), 3);
    let (mut m1, mut s1) = ([0.0], [0.0]);
    assert_eq!(
        between.posterior_into(&mut m1, &mut s1),
        Err(Error::OutOfRange {
            parameter: "queries"
        })
    );
}

#[test]
fn scaled_inputs_give_the_kernels_covariances() {
    let (xs, _) = points(30);
    // Two terms, one listing fewer length scales than coordinates (the rest ignored).
    let kernel = FixedKernel {
        terms: vec![
            RbfTerm {
                signal_variance: 2.0,
                length_scales: vec![1.3, 0.7, 0.0161],
            },
            RbfTerm {
                signal_variance: 0.5,
                length_scales: vec![4.0],
            },
        ],
        noise_variance: 0.25,
    };
    let scaled = Scaled::new(&kernel, &xs);
    let mut out = vec![f64::NAN; xs.len()];
    for z in queries() {
        scaled.covariances_into(&z, &mut out);
        let expected: Vec<f64> = xs.iter().map(|x| kernel.covariance(x, &z)).collect();
        assert_close(&out, &expected, 1e-13, "covariance");
    }
}

#[test]
fn the_storage_is_chosen_before_the_first_point() {
    let (xs, ys) = points(20);
    let mut gp = GrowingFixedGp::new(&split_kernel(), Some(2), queries(), Par::Seq).unwrap();
    assert_eq!(gp.storage(), Storage::Stored);
    gp.extend(&xs, &ys).unwrap();
    // Blocks laid out for one storage are not reinterpreted as the other's.
    let gp = gp.with_storage(Storage::Compact);
    assert_eq!(gp.storage(), Storage::Stored);
    assert_eq!(gp.len(), 20);
}
