//! Tests of the large-N GP: against the core's fixed-capacity GP (an independent
//! implementation), finite differences, the optimiser's box, the `max_gp` cap, the
//! noise-subtraction rule, and the reference's own source-GP predictions.

use super::kernel::{exp_nonpositive, kernel_column};
use super::*;
use awfqi::Error;
use faer::Par;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Puddle-like GP data: z = (s_x, s_y, a) with a smooth reward-like target plus noise.
fn data(n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<f64>) {
    let mut r = rng(seed);
    let mut u = move || awfqi::rng::uniform_f64(&mut r);
    let zs: Vec<[f64; 3]> = (0..n)
        .map(|_| [10.0 * u(), 10.0 * u(), (4.0 * u()).floor()])
        .collect();
    let ys = zs
        .iter()
        .map(|z| {
            -1.0 - 3.0 * (-((z[0] - 5.0).powi(2) + (z[1] - 5.0).powi(2)) / 4.0).exp()
                + 0.1 * (u() - 0.5)
        })
        .collect();
    (zs, ys)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn matches_the_core_gp_for_fixed_hyperparameters() {
    let (zs, ys) = data(24, 1);
    for &(c, l, s2) in &[(2.0, 0.7, 0.05), (0.3, 3.0, 0.5), (50.0, 1.5, 0.01)] {
        let hyper = GpHyperparameters {
            signal_variance: c,
            length_scale: l,
            noise_variance: s2,
        };
        let gp = LargeGp::new(&zs, &ys, hyper, Par::Seq).unwrap();
        let mut core =
            awfqi::gp::Gp::<f64, 32, 3>::new(awfqi::gp::Hyperparameters::isotropic(c, l, s2))
                .unwrap();
        core.fit(&zs, &ys).unwrap();
        assert_eq!(core.jitter(), JITTER, "the core escalated its jitter");
        let lml = core.log_marginal_likelihood().unwrap();
        assert!(rel(gp.log_marginal_likelihood(), lml) < 1e-8);
        let probes: Vec<[f64; 3]> = (0..30)
            .map(|i| [i as f64 * 0.33, 10.0 - i as f64 * 0.3, (i % 4) as f64])
            .chain(zs.iter().copied().take(5))
            .collect();
        let mut means = vec![0.0; probes.len()];
        let mut stds = vec![0.0; probes.len()];
        gp.predict_into(&probes, &mut means, &mut stds).unwrap();
        for ((z, &m), &s) in probes.iter().zip(&means).zip(&stds) {
            let p = core.predict(z).unwrap();
            assert!(
                (m - p.mean).abs() <= 1e-8 * (1.0 + p.mean.abs()),
                "{m} vs {}",
                p.mean
            );
            let std = p.noisy_variance.sqrt();
            assert!((s - std).abs() <= 1e-8 * (1.0 + std), "{s} vs {std}");
            // One input is solved alone, a batch blockwise: equal up to rounding.
            let single = gp.predict(z);
            assert!((single.mean - m).abs() <= 1e-12 * (1.0 + m.abs()));
            assert!((single.std - s).abs() <= 1e-12 * (1.0 + s));
        }
    }
}

#[test]
fn matches_the_harness_reference_gp() {
    // The textbook reference of `awfqi_reference::gp`, on more points than the core holds,
    // with the jitter 10⁻¹⁰ passed as its extra diagonal.
    let (zs, ys) = data(150, 20);
    let rows: Vec<Vec<f64>> = zs.iter().map(|z| z.to_vec()).collect();
    for &(c, l, s2) in &[(2.0, 0.7, 0.05), (30.0, 1.3, 0.01), (0.5, 4.0, 0.9)] {
        let hyper = GpHyperparameters {
            signal_variance: c,
            length_scale: l,
            noise_variance: s2,
        };
        let gp = LargeGp::new(&zs, &ys, hyper, Par::Seq).unwrap();
        let reference = awfqi_reference::gp::ReferenceGp::fit_with_diagonal(
            &rows,
            &ys,
            &awfqi_reference::gp::Hyperparameters {
                signal_variance: c,
                length_scales: vec![l; 3],
                noise_variance: s2,
            },
            JITTER,
        )
        .unwrap();
        assert!(
            rel(
                gp.log_marginal_likelihood(),
                reference.log_marginal_likelihood()
            ) < 1e-8
        );
        let probes: Vec<[f64; 3]> = (0..40)
            .map(|i| [i as f64 * 0.25, 10.0 - i as f64 * 0.21, (i % 4) as f64])
            .chain(zs.iter().copied().take(10))
            .collect();
        let mut means = vec![0.0; probes.len()];
        let mut stds = vec![0.0; probes.len()];
        gp.predict_into(&probes, &mut means, &mut stds).unwrap();
        for ((z, &m), &sd) in probes.iter().zip(&means).zip(&stds) {
            let (mean, latent) = reference.predict(z);
            let std = (latent + s2).sqrt();
            assert!(
                (m - mean).abs() <= 1e-8 * (1.0 + mean.abs()),
                "{m} vs {mean}"
            );
            assert!((sd - std).abs() <= 1e-8 * (1.0 + std), "{sd} vs {std}");
        }
    }
}

#[test]
fn gradient_matches_finite_differences() {
    let (zs, ys) = data(40, 2);
    let mut eval = LikelihoodEvaluator::new(&zs, &ys, Par::Seq).unwrap();
    for theta in [
        [0.0, 0.0, 0.0],
        [1.3, -0.4, -3.0],
        [-2.0, 1.5, -1.0],
        [4.0, 0.2, -4.5],
    ] {
        eval.value(&theta).unwrap();
        let g = eval.gradient().unwrap();
        assert!(eval.gradient().is_none(), "a gradient needs a fresh value");
        for k in 0..3 {
            let h = 1e-5;
            let mut plus = theta;
            plus[k] += h;
            let mut minus = theta;
            minus[k] -= h;
            let fd = (eval.value(&plus).unwrap() - eval.value(&minus).unwrap()) / (2.0 * h);
            assert!(
                (g[k] - fd).abs() <= 1e-6 * (1.0 + fd.abs()),
                "θ = {theta:?}, k = {k}: analytic {} vs finite difference {fd}",
                g[k]
            );
        }
    }
}

#[test]
fn fit_stays_in_bounds_and_improves_on_the_start() {
    let (zs, ys) = data(60, 3);
    let options = FitOptions::default();
    let (gp, report) = LargeGp::fit(&zs, &ys, &options, &mut rng(4)).unwrap();
    assert_eq!(report.runs.len(), 1 + DEFAULT_RESTARTS);
    let (lo, hi) = options.bounds.log_bounds();
    let initial = LargeGp::new(&zs, &ys, GpHyperparameters::SPEC_INITIAL, Par::Seq).unwrap();
    for run in &report.runs {
        for k in 0..3 {
            assert!(lo[k] <= run.theta[k] && run.theta[k] <= hi[k], "{run:?}");
            assert!(lo[k] <= run.start[k] && run.start[k] <= hi[k]);
        }
        assert!(run.log_marginal_likelihood <= gp.log_marginal_likelihood() + 1e-9);
    }
    assert_eq!(report.runs[0].start, [0.0, 0.0, 0.0]);
    assert!(report.runs[0].log_marginal_likelihood > initial.log_marginal_likelihood());
    assert!(gp.log_marginal_likelihood() > initial.log_marginal_likelihood() + 10.0);
    // The kept hyperparameters are the best run's, and the GP is conditioned on them.
    let best = &report.runs[report.best];
    assert_eq!(
        gp.hyperparameters(),
        GpHyperparameters::from_log(&best.theta)
    );
    assert!(rel(gp.log_marginal_likelihood(), best.log_marginal_likelihood) < 1e-12);
    // Noise 0.1·U(−½, ½) has variance 0.1²/12 ≈ 8·10⁻⁴, below the box: σ²ₙ sits at 10⁻².
    assert!((gp.hyperparameters().noise_variance - 1e-2).abs() < 1e-9);
    // At the optimum the gradient in the free coordinates vanishes.
    let mut eval = LikelihoodEvaluator::new(&zs, &ys, Par::Seq).unwrap();
    eval.value(&best.theta).unwrap();
    let g = eval.gradient().unwrap();
    assert!(g[0].abs() < 1e-3 && g[1].abs() < 1e-3, "{g:?}");
    assert!(
        g[2] < 0.0,
        "the noise bound is active: the likelihood wants less noise"
    );
}

#[test]
fn same_seed_same_fit() {
    let (zs, ys) = data(30, 5);
    let options = FitOptions {
        restarts: 3,
        ..FitOptions::default()
    };
    let (a, ra) = LargeGp::fit(&zs, &ys, &options, &mut rng(6)).unwrap();
    let (b, rb) = LargeGp::fit(&zs, &ys, &options, &mut rng(6)).unwrap();
    assert_eq!(ra, rb);
    assert_eq!(a.hyperparameters(), b.hyperparameters());
    let (_, rc) = LargeGp::fit(&zs, &ys, &options, &mut rng(7)).unwrap();
    assert_ne!(ra.runs[1].start, rc.runs[1].start);
}

#[test]
fn max_points_keeps_the_last_samples() {
    let (zs, ys) = data(50, 8);
    let options = FitOptions {
        restarts: 0,
        max_points: 30,
        ..FitOptions::default()
    };
    let (gp, _) = LargeGp::fit(&zs, &ys, &options, &mut rng(9)).unwrap();
    assert_eq!(gp.len(), 30);
    assert_eq!(gp.inputs(), &zs[20..]);
    let direct = LargeGp::new(&zs[20..], &ys[20..], gp.hyperparameters(), Par::Seq).unwrap();
    assert_eq!(
        direct.log_marginal_likelihood(),
        gp.log_marginal_likelihood()
    );
}

#[test]
fn invalid_input_is_rejected() {
    let (zs, ys) = data(5, 10);
    let h = GpHyperparameters::SPEC_INITIAL;
    assert_eq!(
        LargeGp::<3>::new(&[], &[], h, Par::Seq).err(),
        Some(Error::EmptyData)
    );
    assert_eq!(
        LargeGp::new(&zs, &ys[1..], h, Par::Seq).err(),
        Some(Error::InvalidParameter {
            parameter: "targets"
        })
    );
    let mut bad = zs.clone();
    bad[2][1] = f64::NAN;
    assert_eq!(
        LargeGp::new(&bad, &ys, h, Par::Seq).err(),
        Some(Error::NonFinite {
            parameter: "inputs"
        })
    );
    let zero_length = GpHyperparameters {
        length_scale: 0.0,
        ..h
    };
    assert_eq!(
        LargeGp::new(&zs, &ys, zero_length, Par::Seq).err(),
        Some(Error::InvalidParameter {
            parameter: "length_scale"
        })
    );
    let options = FitOptions {
        max_points: 0,
        ..FitOptions::default()
    };
    assert_eq!(
        LargeGp::fit(&zs, &ys, &options, &mut rng(11)).err(),
        Some(Error::InvalidParameter {
            parameter: "max_points"
        })
    );
    // Two identical inputs with no noise: singular Gram matrix (up to the 10⁻¹⁰ jitter,
    // which keeps it positive definite in f64, so this still succeeds).
    let twins = [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let noiseless = GpHyperparameters {
        noise_variance: 0.0,
        ..h
    };
    assert!(LargeGp::new(&twins, &[0.0, 1.0], noiseless, Par::Seq).is_ok());
}

#[test]
fn screened_strategy_finds_the_spec_optimum() {
    let (zs, ys) = data(120, 13);
    let spec = FitOptions::default();
    let screened = FitOptions {
        strategy: FitStrategy::Screened {
            subsample: 40,
            merge_radius: 0.5,
        },
        ..spec
    };
    let (a, ra) = LargeGp::fit(&zs, &ys, &spec, &mut rng(14)).unwrap();
    let (b, rb) = LargeGp::fit(&zs, &ys, &screened, &mut rng(14)).unwrap();
    // Same starts (same draws), far fewer full-data evaluations, same optimum.
    let starts = |r: &FitReport| r.runs.iter().map(|run| run.start).collect::<Vec<_>>();
    assert_eq!(starts(&ra), starts(&rb));
    let full = |r: &FitReport| {
        r.runs
            .iter()
            .filter(|run| run.merged_into.is_none())
            .map(|run| run.evaluations)
            .sum::<usize>()
    };
    assert!(full(&rb) * 3 < full(&ra), "{} vs {}", full(&rb), full(&ra));
    assert!(rb.runs.iter().all(|run| run.screening.is_some()));
    assert!(rel(b.log_marginal_likelihood(), a.log_marginal_likelihood()) < 1e-9);
    let (ta, tb) = (a.hyperparameters().to_log(), b.hyperparameters().to_log());
    for k in 0..3 {
        assert!((ta[k] - tb[k]).abs() < 1e-3, "{ta:?} vs {tb:?}");
    }
    // A subsample at least as large as the data is the spec's procedure.
    let whole = FitOptions {
        strategy: FitStrategy::Screened {
            subsample: 120,
            merge_radius: 0.5,
        },
        ..spec
    };
    let (_, rc) = LargeGp::fit(&zs, &ys, &whole, &mut rng(14)).unwrap();
    assert_eq!(rc, ra);
}

#[test]
fn staged_strategy_finds_the_spec_optimum_with_fewer_full_data_evaluations() {
    let (zs, ys) = data(240, 13);
    let spec = FitOptions::default();
    let screened = FitStrategy::Screened {
        subsample: 40,
        merge_radius: 0.5,
    };
    let staged = |warm_hessian| FitStrategy::Staged {
        subsample: 40,
        intermediate: 100,
        merge_radius: 0.5,
        warm_hessian,
    };
    let fit =
        |strategy| LargeGp::fit(&zs, &ys, &FitOptions { strategy, ..spec }, &mut rng(14)).unwrap();
    let (a, ra) = fit(FitStrategy::AllStarts);
    let (b, rb) = fit(screened);
    let (c, rc) = fit(staged(true));
    let full = |r: &FitReport| {
        r.runs
            .iter()
            .filter(|run| run.merged_into.is_none())
            .map(|run| run.factorizations)
            .sum::<usize>()
    };
    // Same starts and screening as the screened search; every refined start went through
    // the intermediate stage; the same optimum as the spec's; fewer full-data
    // factorisations than the screened search (which has fewer than the spec's).
    let starts = |r: &FitReport| r.runs.iter().map(|run| run.start).collect::<Vec<_>>();
    assert_eq!(starts(&ra), starts(&rc));
    let screening = |r: &FitReport| r.runs.iter().map(|run| run.screening).collect::<Vec<_>>();
    assert_eq!(screening(&rb), screening(&rc));
    assert!(
        rc.runs
            .iter()
            .all(|run| run.merged_into.is_some() || run.staging.is_some())
    );
    assert!(full(&rc) < full(&rb), "{} vs {}", full(&rc), full(&rb));
    for gp in [&b, &c] {
        assert!(rel(gp.log_marginal_likelihood(), a.log_marginal_likelihood()) < 1e-9);
        let (ta, tb) = (a.hyperparameters().to_log(), gp.hyperparameters().to_log());
        for k in 0..3 {
            assert!((ta[k] - tb[k]).abs() < 1e-3, "{ta:?} vs {tb:?}");
        }
    }
    // Without the warm curvature model the same optimum, in more full-data evaluations.
    let (d, rd) = fit(staged(false));
    assert!(rel(d.log_marginal_likelihood(), a.log_marginal_likelihood()) < 1e-9);
    assert!(full(&rc) < full(&rd), "{} vs {}", full(&rc), full(&rd));
    // No more points than the intermediate stage: the screened search exactly.
    let small = FitStrategy::Staged {
        subsample: 40,
        intermediate: 240,
        merge_radius: 0.5,
        warm_hessian: true,
    };
    assert_eq!(fit(small).1, rb);
}

#[test]
fn comparison_keeps_the_strategy_gp_and_reports_the_other_optimum() {
    let (zs, ys) = data(120, 13);
    let spec = FitOptions::default();
    let screened = FitStrategy::Screened {
        subsample: 40,
        merge_radius: 0.5,
    };
    let checked = FitOptions {
        compare: Some(screened),
        ..spec
    };
    let (a, ra) = LargeGp::fit(&zs, &ys, &spec, &mut rng(14)).unwrap();
    let (b, rb) = LargeGp::fit(&zs, &ys, &checked, &mut rng(14)).unwrap();
    let (c, _) = LargeGp::fit(
        &zs,
        &ys,
        &FitOptions {
            strategy: screened,
            ..spec
        },
        &mut rng(14),
    )
    .unwrap();
    // The kept GP is the spec's, bit for bit (the comparison draws nothing).
    assert_eq!(ra.runs, rb.runs);
    assert_eq!(ra.best, rb.best);
    assert_eq!(a.hyperparameters(), b.hyperparameters());
    assert_eq!(
        a.log_marginal_likelihood().to_bits(),
        b.log_marginal_likelihood().to_bits()
    );
    assert_eq!(a.predict(&[5.0, 5.0, 1.0]), b.predict(&[5.0, 5.0, 1.0]));
    // The comparison reports both optima: the kept run's and the screened fit's.
    let cmp = rb.comparison.unwrap();
    assert_eq!(
        cmp.log_marginal_likelihood,
        ra.runs[ra.best].log_marginal_likelihood
    );
    assert!(
        rel(
            cmp.other_log_marginal_likelihood,
            c.log_marginal_likelihood()
        ) < 1e-12
    );
    assert!(cmp.relative_difference() < 1e-9, "{cmp:?}");
    assert!(cmp.other_factorizations * 3 < cmp.factorizations, "{cmp:?}");
    assert!(ra.comparison.is_none());
}

fn read_source(path: &str) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect()
}

/// Fits one GP of one published source as spec §6 says and compares its noise-subtracted
/// predictions at the source's own records with the reference's (sklearn, L-BFGS-B, 10
/// restarts), stored in the source file: the worst absolute differences of the means and of
/// the stds must stay below `tolerance`. The files are the repository's copies
/// (`std_harness/data/puddle-sources/`).
fn check_source_gp(
    dynamics: &str,
    source: usize,
    column: usize,
    strategy: FitStrategy,
    tolerance: (f64, f64),
) {
    let path = format!(
        "{}/data/puddle-sources/{dynamics}_source_{source}.csv",
        env!("CARGO_MANIFEST_DIR")
    );
    let rows = read_source(&path);
    let zs: Vec<[f64; 3]> = rows.iter().map(|r| [r[1], r[2], r[3]]).collect();
    let ys: Vec<f64> = rows.iter().map(|r| r[column]).collect();
    // Targets r, next x, next y (columns 4, 5, 6); reference mean and std columns follow.
    let (mean_col, std_col) = (8 + 2 * (column - 4), 9 + 2 * (column - 4));
    let options = FitOptions {
        strategy,
        ..FitOptions::default()
    };
    let (gp, _) = LargeGp::fit(&zs, &ys, &options, &mut rng(12)).unwrap();
    let mut means = vec![0.0; zs.len()];
    let mut stds = vec![0.0; zs.len()];
    gp.predict_into(&zs, &mut means, &mut stds).unwrap();
    // Spec §6: σ̂ ≤ min std for source GPs, so the published rule subtracts σ̂ itself.
    let noise_std = gp.hyperparameters().noise_variance.sqrt();
    let min_std = stds.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(noise_std <= min_std, "σ̂ = {noise_std} > min std {min_std}");
    stds.iter_mut().for_each(|s| *s -= noise_std);
    let (mut worst_mean, mut worst_std) = (0.0f64, 0.0f64);
    for ((r, m), s) in rows.iter().zip(&means).zip(&stds) {
        worst_mean = worst_mean.max((m - r[mean_col]).abs());
        worst_std = worst_std.max((s - r[std_col]).abs());
    }
    eprintln!(
        "{dynamics} source {source}, column {column}, {strategy:?}: |Δmean| ≤ {worst_mean:.1e}, \
         |Δstd| ≤ {worst_std:.1e}, {:?}",
        gp.hyperparameters()
    );
    assert!(
        worst_mean < tolerance.0 && worst_std < tolerance.1,
        "{dynamics} source {source}, column {column}: |Δmean| ≤ {worst_mean:.1e}, \
         |Δstd| ≤ {worst_std:.1e}, {:?}",
        gp.hyperparameters()
    );
}

/// Source 1's reward GP (291 records), fitted exactly as spec §4.2 says, reproduces the
/// reference's predictions.
#[test]
fn reproduces_the_reference_source_gp_predictions() {
    check_source_gp(
        "shared_dynamics",
        1,
        4,
        FitStrategy::AllStarts,
        (1e-5, 1e-5),
    );
}

/// Every GP of every published source (reward, next x, next y; both dynamics), with both
/// strategies. Some next-state GPs are nearly linear (`ℓ` in the hundreds, `c` in the
/// thousands): their likelihood has a flat ridge along which `c` and `ℓ` trade off, so the
/// optimum found depends on the optimiser's path: there the stds agree to
/// `10⁻³` and the means to `10⁻⁴` only (elsewhere both agree to `10⁻⁵` or better). Slow in
/// debug builds:
/// `cargo test --release -p awfqi-harness --lib -- --ignored reproduces_every`.
#[test]
#[ignore]
fn reproduces_every_reference_source_gp() {
    for dynamics in ["shared_dynamics", "puddle_dynamics"] {
        for source in 1..=3 {
            for column in 4..=6 {
                for strategy in [FitStrategy::AllStarts, FitStrategy::SCREENED] {
                    check_source_gp(dynamics, source, column, strategy, (1e-4, 1e-3));
                }
            }
        }
    }
}

/// Distance in units in the last place between two non-negative finite doubles.
fn ulps(a: f64, b: f64) -> u64 {
    a.to_bits().abs_diff(b.to_bits())
}

#[test]
fn fast_exp_is_within_one_ulp_of_libm() {
    let check = |x: f64| {
        let (fast, libm) = (exp_nonpositive(x), x.exp());
        assert!(
            ulps(fast, libm) <= 1,
            "exp({x:e}): fast {fast:e} vs libm {libm:e} ({} ulp)",
            ulps(fast, libm)
        );
    };
    // Exact points and the smallest arguments.
    assert_eq!(exp_nonpositive(0.0), 1.0);
    assert_eq!(exp_nonpositive(-0.0), 1.0);
    for x in [-1e-300, -1e-20, -1e-17, -1e-9, -f64::MIN_POSITIVE, -5e-324] {
        check(x);
    }
    // A dense grid over the whole range of normal results, and random points in decades
    // down to the smallest (the kernel's k·d² spans all of them).
    let mut x = 0.0;
    while x > -708.0 {
        check(x);
        x -= 1e-3;
    }
    let mut r = rng(11);
    for decade in -20..3 {
        for _ in 0..20_000 {
            check(
                -(10f64)
                    .powf(decade as f64 + awfqi::rng::uniform_f64(&mut r))
                    .min(708.0),
            );
        }
    }
    // Around multiples of ln 2 / 2, where the reduction switches k.
    for m in 1..2000 {
        let x0 = -(m as f64) * std::f64::consts::LN_2 / 2.0;
        if x0 < -708.0 {
            break;
        }
        for i in -3..=3 {
            check(f64::from_bits((x0.to_bits() as i64 + i) as u64));
        }
    }
}

#[test]
fn fast_exp_underflows_gradually_then_to_zero() {
    // Subnormal results (x between −745.13 and −708.4) within one subnormal step of libm's.
    let mut x = -708.0;
    while x > -745.2 {
        let (fast, libm) = (exp_nonpositive(x), x.exp());
        assert!(ulps(fast, libm) <= 1, "exp({x}): {fast:e} vs {libm:e}");
        x -= 1e-3;
    }
    assert_eq!(exp_nonpositive(-745.0), (-745.0f64).exp());
    assert!(exp_nonpositive(-745.0) > 0.0);
    for x in [
        -745.2,
        -746.0,
        -800.0,
        -1e10,
        -1e300,
        f64::MIN,
        f64::NEG_INFINITY,
    ] {
        assert_eq!(exp_nonpositive(x), 0.0, "exp({x})");
    }
}

#[test]
fn kernel_column_matches_its_scalar_definition() {
    // The dispatched (vector) column, over an odd length that leaves a remainder after the
    // vector lanes, is bitwise the scalar function applied elementwise.
    let mut r = rng(12);
    let d2: Vec<f64> = (0..1003)
        .map(|i| match i % 5 {
            0 => 0.0,
            1 => 1e4 * awfqi::rng::uniform_f64(&mut r),
            _ => 3.0 * awfqi::rng::uniform_f64(&mut r),
        })
        .collect();
    for (k, c) in [(-0.5, 1.0), (-3.7, 42.0), (-1e-6, 1e-5), (-1e3, 1e5)] {
        let (mut e, mut out) = (vec![f64::NAN; d2.len()], vec![f64::NAN; d2.len()]);
        kernel_column(k, c, &d2, &mut e, &mut out);
        for ((&d, &ev), &o) in d2.iter().zip(&e).zip(&out) {
            assert_eq!(ev.to_bits(), exp_nonpositive(k * d).to_bits());
            assert_eq!(o.to_bits(), (c * exp_nonpositive(k * d)).to_bits());
            assert!(ulps(ev, (k * d).exp()) <= 1);
        }
    }
}

/// The objective without the memo: every value is a factorisation.
struct PlainNegativeLml<'e, 'a>(&'e mut LikelihoodEvaluator<'a, 3>);

impl optimizer::Objective<3> for PlainNegativeLml<'_, '_> {
    fn value(&mut self, x: &[f64; 3]) -> Option<f64> {
        self.0.value(x).map(|v| -v)
    }
    fn gradient(&mut self) -> [f64; 3] {
        self.0.gradient().map(|g| g.map(|v| -v)).unwrap()
    }
}

#[test]
fn memoised_fit_takes_the_same_path_with_fewer_factorisations() {
    // Every optimisation of a fit is bitwise the one a memo-free objective gives from the same
    // start (same end point, value, counts and stop), and repeated points are not refactorised.
    let (lower, upper) = HyperparameterBox::SPEC.log_bounds();
    let (mut asked, mut spent) = (0, 0);
    for seed in 0..4 {
        let (zs, ys) = data(50, 20 + seed);
        let options = FitOptions::default();
        let (_, report) = LargeGp::fit(&zs, &ys, &options, &mut rng(seed)).unwrap();
        for run in &report.runs {
            let mut eval = LikelihoodEvaluator::new(&zs, &ys, Par::Seq).unwrap();
            let m = optimizer::minimize(
                &mut PlainNegativeLml(&mut eval),
                &run.start,
                &lower,
                &upper,
                &options.optimizer,
            );
            assert_eq!(m.x, run.theta, "seed {seed}: {run:?}");
            assert_eq!((-m.f).to_bits(), run.log_marginal_likelihood.to_bits());
            assert_eq!(m.evaluations, run.evaluations);
            assert_eq!(m.gradients, run.gradients);
            assert_eq!(m.stop, run.stop);
            assert!(run.factorizations <= run.evaluations + run.gradients);
            asked += run.evaluations;
            spent += run.factorizations;
        }
    }
    assert!(
        spent < asked,
        "no repeated point: the memo was not exercised"
    );
}

#[test]
fn conditioning_policy_sets_the_jitter_and_refuses_untrusted_factors() {
    // Two duplicated inputs with noise 1e-8: K + (σ² + j)I has pivots 1 + σ² + j and
    // (σ² + j)(2 + σ² + j)/(1 + σ² + j), so the diagonal estimate is known in closed form.
    let zs = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
    let ys = [1.0, 1.0];
    let hyper = GpHyperparameters {
        signal_variance: 1.0,
        length_scale: 1.0,
        noise_variance: 1e-8,
    };
    let kappa = |s: f64| (1.0 + s) * (1.0 + s) / (s * (2.0 + s));
    let default = LargeGp::new(&zs, &ys, hyper, Par::Seq).unwrap();
    assert_eq!(default.jitter(), JITTER);
    assert!((default.condition_estimate() / kappa(1e-8 + JITTER) - 1.0).abs() < 1e-6);
    let exact = LargeConditioning {
        jitter: 0.0,
        ..LargeConditioning::default()
    };
    let none = LargeGp::new_with(&zs, &ys, hyper, Par::Seq, &exact).unwrap();
    assert_eq!(none.jitter(), 0.0);
    assert!((none.condition_estimate() / kappa(1e-8) - 1.0).abs() < 1e-6);
    // LML moves by −½ ln(1 + j/σ²) from the determinant (the fit term changes by 1e-10).
    let shift = default.log_marginal_likelihood() - none.log_marginal_likelihood();
    assert!((shift + 0.5 * 1.01f64.ln()).abs() < 1e-6, "{shift}");
    let strict = LargeConditioning {
        max_condition: 1e6,
        ..LargeConditioning::default()
    };
    match LargeGp::new_with(&zs, &ys, hyper, Par::Seq, &strict) {
        Err(Error::IllConditioned { condition, limit }) => {
            assert_eq!(limit.value(), 1e6);
            assert!((condition.value() / kappa(1e-8 + JITTER) - 1.0).abs() < 1e-6);
        }
        other => panic!("{other:?}"),
    }
    for bad in [
        LargeConditioning {
            jitter: -1.0,
            ..LargeConditioning::default()
        },
        LargeConditioning {
            max_condition: f64::NAN,
            ..LargeConditioning::default()
        },
    ] {
        assert!(matches!(
            LargeGp::new_with(&zs, &ys, hyper, Par::Seq, &bad),
            Err(Error::InvalidParameter { .. })
        ));
    }
    // A fit under a strict limit is refused, not returned with a factor beyond it.
    let options = FitOptions {
        restarts: 0,
        conditioning: strict,
        initial: hyper,
        ..FitOptions::default()
    };
    let bounds_box = HyperparameterBox {
        noise_variance: (1e-8, 1e-8),
        ..HyperparameterBox::SPEC
    };
    let options = FitOptions {
        bounds: bounds_box,
        ..options
    };
    let result = LargeGp::fit(&zs, &ys, &options, &mut rng(3));
    assert!(
        matches!(result, Err(Error::IllConditioned { .. })),
        "{:?}",
        result.map(|(gp, _)| gp.hyperparameters())
    );
}
