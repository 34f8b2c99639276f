//! The incremental fixed-kernel target GP ([`GrowingRecordGp`]) against the reference's
//! per-step refit, on Acrobot's published sources and target records.

use super::*;
use crate::domains::acrobot;
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// `n` target records of Acrobot, episodes of 100 steps under random torques.
fn target_records(n: usize) -> Vec<Record<4>> {
    let domain = acrobot::domain();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut records = Vec::with_capacity(n);
    let mut state = domain.target.initial_state(&mut rng);
    while records.len() < n {
        let action = (rng.next_u32() % 2) as usize;
        let r = domain.target.query(state, action, &mut rng).unwrap();
        state = r.next_state;
        if r.absorbing || records.len() % 100 == 99 {
            state = domain.target.initial_state(&mut rng);
        }
        records.push(r);
    }
    records
}

fn largest_difference(a: &[Vec<Posterior<f64>>], b: &[Vec<Posterior<f64>>]) -> (f64, f64) {
    let (mut mean, mut std) = (0.0f64, 0.0f64);
    for (x, y) in a.iter().flatten().zip(b.iter().flatten()) {
        mean = mean.max((x.mean - y.mean).abs());
        std = std.max((x.std - y.std).abs());
    }
    (mean, std)
}

/// Appending three batches (keeping `V`, or only the factor's triangle) lands as close to a
/// refit on all records as two refits on the
/// same records in two orders land to each other: the incremental route adds no error
/// beyond the rounding the refit itself carries (Acrobot's kernels are noise-free, so
/// that rounding is far above machine precision).
#[test]
fn appended_batches_stay_within_the_refits_own_rounding() {
    let domain = acrobot::domain();
    let data = crate::transfer::domain_data::acrobot::data();
    let sources = (data.published)().unwrap();
    let zs: Vec<Vec<GpInput>> = sources
        .sources
        .iter()
        .map(|s| s.records.iter().map(|r| domain.input(r)).collect())
        .collect();
    let records = target_records(300);
    let mut reversed = records.clone();
    reversed.reverse();
    let options = GpOptions::published();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    for output in [
        Output::Reward,
        Output::NextState(0),
        Output::NextState(1),
        Output::NextState(2),
        Output::NextState(3),
    ] {
        let spec = data.weighting.gp_spec(output);
        let refit = |records: &[Record<4>], rng: &mut ChaCha8Rng| {
            let gp = RecordGp::fit_records(&domain, records, output, &spec, &options, rng).unwrap();
            zs.iter()
                .map(|z| gp.posteriors(z, spec.noise(NoiseSubtraction::Reference)))
                .collect::<Vec<_>>()
        };
        let in_order = refit(&records, &mut rng);
        let in_reverse = refit(&reversed, &mut rng);
        let rounding = largest_difference(&in_order, &in_reverse);
        for storage in [Storage::Stored, Storage::Compact] {
            let mut growing = GrowingRecordGp::new(&domain, &spec, output, &zs, storage)
                .unwrap()
                .unwrap();
            for end in [120, 250, 300] {
                assert!(growing.update(&domain, &records[..end], 10_000).unwrap());
            }
            assert_eq!(growing.summary().points, 300);
            let appended = growing.posteriors(NoiseSubtraction::Reference);
            let incremental = largest_difference(&appended, &in_order);
            eprintln!("{output:?} {storage:?}: refits {rounding:?}, incremental {incremental:?}");
            assert!(
                incremental.0 <= 4.0 * rounding.0 + 1e-12,
                "{output:?} {storage:?} means"
            );
            assert!(
                incremental.1 <= 4.0 * rounding.1 + 1e-12,
                "{output:?} {storage:?} stds"
            );
        }
    }
}

#[test]
fn the_growing_gp_refuses_what_it_cannot_follow() {
    let domain = acrobot::domain();
    let records = target_records(30);
    let zs = vec![records.iter().map(|r| domain.input(r)).collect::<Vec<_>>()];
    // A fitted kernel (Puddle World's) has no growing GP.
    let puddle = crate::domains::puddle::domain(awfqi::env::Dynamics::Shared);
    let fitted = crate::transfer::domain_data::puddle::data(awfqi::env::Dynamics::Shared)
        .weighting
        .reward;
    assert!(
        GrowingRecordGp::new(
            &puddle,
            &fitted,
            Output::Reward,
            &[vec![[0.0; GP_INPUT]]],
            Storage::Stored
        )
        .is_none()
    );
    let reward = crate::transfer::domain_data::acrobot::data()
        .weighting
        .reward;
    let mut gp = GrowingRecordGp::new(&domain, &reward, Output::Reward, &zs, Storage::Stored)
        .unwrap()
        .unwrap();
    assert!(gp.update(&domain, &records[..10], 10_000).unwrap());
    // More than `max_gp` records: the window would slide, so the caller must refit.
    assert!(!gp.update(&domain, &records[..20], 15).unwrap());
    // Records that do not continue the conditioned ones.
    assert!(!gp.update(&domain, &records[5..25], 10_000).unwrap());
    assert!(!gp.update(&domain, &records[..5], 10_000).unwrap());
    assert_eq!(gp.summary().points, 10);
    // At a training point of a noise-free GP the mean is the target and the std ≈ 0.
    let post = gp.posteriors(NoiseSubtraction::Reference);
    for (p, r) in post[0][..10].iter().zip(&records) {
        assert!(
            (p.mean - r.reward).abs() < 1e-4,
            "{} vs {}",
            p.mean,
            r.reward
        );
        assert!(p.std < 1e-3, "{}", p.std);
    }
}
