//! Criterion suite: the kernel's hot operations, each next to the harness's f64 reference
//! implementation on identical inputs where the reference has a counterpart.
//!
//! `cargo bench` runs it (about two minutes on a 2-core machine); `scripts/perf-tables`
//! turns the results in `target/criterion` into the tables of docs/performance.md.
//! Benchmark ids are `group/implementation/parameter`; implementations are `kernel_f32`,
//! `kernel_f64` and `reference_f64`. Where the reference has no counterpart the group has
//! the kernel only (see docs/performance.md).

mod common;

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::float::Real;
use awfqi::gp::{HyperparameterBounds, SearchOptions, WhenFull};
use awfqi::identify::{Belief, Criterion as Score, compute_score};
use awfqi::score::{GpSourceModel, ScoreTable, Scores};
use awfqi_reference::gp::ReferenceGp;
use awfqi_reference::identify as ref_identify;
use common::*;
use criterion::{
    BatchSize, BenchmarkGroup, BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group,
    criterion_main, measurement::WallTime,
};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::hint::black_box;
use std::time::Duration;

/// Short measurements: this is a shared 2-core machine, and a few percent of noise is
/// below what the tables need.
fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_millis(1000))
        .sample_size(20)
        .without_plots()
}

fn gp_fit_one<T: Real, const N: usize>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let case = gp_case(N);
    let (x, y) = (inputs::<T>(&case.x), values::<T>(&case.y));
    let mut gp = fitted_gp::<T, N>(&case, 0);
    g.bench_function(BenchmarkId::new(name, N), |b| {
        b.iter(|| gp.fit(black_box(&x), black_box(&y)).expect("fit"))
    });
}

fn gp_fit_reference(g: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    let case = gp_case(n);
    let (x, h) = (reference_inputs(&case.x), reference_hyper());
    g.bench_function(BenchmarkId::new("reference_f64", n), |b| {
        b.iter(|| ReferenceGp::fit(black_box(&x), black_box(&case.y), &h).expect("fit"))
    });
}

fn gp_fit_faithful(g: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    let case = gp_case(n);
    g.bench_function(BenchmarkId::new("faithful_f64", n), |b| {
        b.iter(|| faithful_gp(black_box(&case)))
    });
}

fn gp_fit(c: &mut Criterion) {
    let mut g = c.benchmark_group("gp_fit");
    gp_fit_one::<f32, 16>(&mut g, "kernel_f32");
    gp_fit_one::<f64, 16>(&mut g, "kernel_f64");
    gp_fit_reference(&mut g, 16);
    gp_fit_faithful(&mut g, 16);
    gp_fit_one::<f32, 64>(&mut g, "kernel_f32");
    gp_fit_one::<f64, 64>(&mut g, "kernel_f64");
    gp_fit_reference(&mut g, 64);
    gp_fit_faithful(&mut g, 64);
    gp_fit_one::<f32, 128>(&mut g, "kernel_f32");
    gp_fit_one::<f64, 128>(&mut g, "kernel_f64");
    gp_fit_reference(&mut g, 128);
    gp_fit_faithful(&mut g, 128);
    g.finish();
}

fn gp_predict_one<T: Real, const N: usize>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let case = gp_case(N);
    let gp = fitted_gp::<T, N>(&case, N);
    let test = inputs::<T>(&case.test);
    g.bench_function(BenchmarkId::new(name, N), |b| {
        b.iter(|| predict_all(black_box(&*gp), black_box(&test)))
    });
}

fn gp_predict_reference(g: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    let case = gp_case(n);
    let gp =
        ReferenceGp::fit(&reference_inputs(&case.x), &case.y, &reference_hyper()).expect("fit");
    let test = reference_inputs(&case.test);
    g.bench_function(BenchmarkId::new("reference_f64", n), |b| {
        b.iter(|| reference_predict_all(black_box(&gp), black_box(&test)))
    });
}

fn gp_predict_faithful(g: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    let case = gp_case(n);
    let gp = faithful_gp(&case);
    g.bench_function(BenchmarkId::new("faithful_f64", n), |b| {
        b.iter(|| faithful_predict_all(black_box(&gp), black_box(&case.test)))
    });
}

/// 100 predictions (mean and latent variance) per iteration.
fn gp_predict(c: &mut Criterion) {
    let mut g = c.benchmark_group("gp_predict");
    g.throughput(Throughput::Elements(PREDICTIONS as u64));
    gp_predict_one::<f32, 16>(&mut g, "kernel_f32");
    gp_predict_one::<f64, 16>(&mut g, "kernel_f64");
    gp_predict_reference(&mut g, 16);
    gp_predict_faithful(&mut g, 16);
    gp_predict_one::<f32, 64>(&mut g, "kernel_f32");
    gp_predict_one::<f64, 64>(&mut g, "kernel_f64");
    gp_predict_reference(&mut g, 64);
    gp_predict_faithful(&mut g, 64);
    gp_predict_one::<f32, 128>(&mut g, "kernel_f32");
    gp_predict_one::<f64, 128>(&mut g, "kernel_f64");
    gp_predict_reference(&mut g, 128);
    gp_predict_faithful(&mut g, 128);
    g.finish();
}

fn gp_fit_predict_one<T: Real, const N: usize>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let case = gp_case(N);
    let (x, y, test) = (
        inputs::<T>(&case.x),
        values::<T>(&case.y),
        inputs::<T>(&case.test),
    );
    let mut gp = fitted_gp::<T, N>(&case, 0);
    g.bench_function(BenchmarkId::new(name, N), |b| {
        b.iter(|| {
            gp.fit(black_box(&x), black_box(&y)).expect("fit");
            predict_all(&*gp, black_box(&test))
        })
    });
}

fn gp_fit_predict_reference(g: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    let case = gp_case(n);
    let (x, h, test) = (
        reference_inputs(&case.x),
        reference_hyper(),
        reference_inputs(&case.test),
    );
    g.bench_function(BenchmarkId::new("reference_f64", n), |b| {
        b.iter(|| {
            let gp = ReferenceGp::fit(black_box(&x), black_box(&case.y), &h).expect("fit");
            reference_predict_all(&gp, black_box(&test))
        })
    });
}

/// The GP's acceptance measurement: fit at N = 64 plus 100 predictions.
fn gp_fit_predict(c: &mut Criterion) {
    let mut g = c.benchmark_group("gp_fit_predict100");
    gp_fit_predict_one::<f32, 64>(&mut g, "kernel_f32");
    gp_fit_predict_one::<f64, 64>(&mut g, "kernel_f64");
    gp_fit_predict_reference(&mut g, 64);
    g.finish();
}

/// Adding the N-th point to a GP of capacity N holding N − 1 (the O(N²) row extension).
fn gp_add_one<T: Real, const N: usize>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let case = gp_case(N);
    let gp = fitted_gp::<T, N>(&case, N - 1);
    let (z, y) = (case.x[N - 1].map(T::from_f64), T::from_f64(case.y[N - 1]));
    g.bench_function(BenchmarkId::new(name, N), |b| {
        b.iter_batched_ref(
            || gp.clone(),
            |gp| gp.add_point(black_box(z), black_box(y), WhenFull::Refuse),
            BatchSize::LargeInput,
        )
    });
}

/// Adding a point to a full GP with `DropOldest` (a sliding window): O(N²) downdate and
/// extension, in steady state.
fn gp_slide_one<T: Real, const N: usize>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let case = gp_case(2 * N);
    let mut gp = fitted_gp::<T, N>(&case, N);
    let extra: Vec<([T; D], T)> = (N..2 * N)
        .map(|i| (case.x[i].map(T::from_f64), T::from_f64(case.y[i])))
        .collect();
    let mut next = 0;
    g.bench_function(BenchmarkId::new(name, N), |b| {
        b.iter(|| {
            let (z, y) = extra[next % N];
            next += 1;
            gp.add_point(black_box(z), black_box(y), WhenFull::DropOldest)
                .expect("slide")
        })
    });
}

fn gp_add_point(c: &mut Criterion) {
    let mut g = c.benchmark_group("gp_add_point");
    gp_add_one::<f32, 16>(&mut g, "kernel_f32");
    gp_add_one::<f64, 16>(&mut g, "kernel_f64");
    gp_fit_reference(&mut g, 16);
    gp_add_one::<f32, 64>(&mut g, "kernel_f32");
    gp_add_one::<f64, 64>(&mut g, "kernel_f64");
    gp_fit_reference(&mut g, 64);
    gp_add_one::<f32, 128>(&mut g, "kernel_f32");
    gp_add_one::<f64, 128>(&mut g, "kernel_f64");
    gp_fit_reference(&mut g, 128);
    g.finish();
    let mut g = c.benchmark_group("gp_add_point_drop_oldest");
    gp_slide_one::<f32, 16>(&mut g, "kernel_f32");
    gp_slide_one::<f64, 16>(&mut g, "kernel_f64");
    gp_slide_one::<f32, 64>(&mut g, "kernel_f32");
    gp_slide_one::<f64, 64>(&mut g, "kernel_f64");
    gp_slide_one::<f32, 128>(&mut g, "kernel_f32");
    gp_slide_one::<f64, 128>(&mut g, "kernel_f64");
    g.finish();
}

/// Fit with spec §4.2's hyperparameter search (isotropic, 10 restarts, 550 likelihood
/// evaluations), from the initial values: one `optimize_hyperparameters` call.
fn gp_search_one<T: Real, const N: usize>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let case = gp_case(N);
    let gp = fitted_gp::<T, N>(&case, N);
    let (bounds, options) = (
        HyperparameterBounds::<T, D>::spec_default(),
        SearchOptions::default(),
    );
    g.bench_function(BenchmarkId::new(name, N), |b| {
        b.iter_batched_ref(
            || (gp.clone(), ChaCha8Rng::seed_from_u64(5)),
            |(gp, rng)| {
                gp.optimize_hyperparameters(&bounds, &options, rng)
                    .expect("search")
            },
            BatchSize::PerIteration,
        )
    });
}

/// The faithful path's search (spec §4.2 as written: L-BFGS-style with the analytic
/// gradient from the initial values and 10 restarts).
fn gp_search_faithful(g: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    let case = gp_case(n);
    g.bench_function(BenchmarkId::new("faithful_f64", n), |b| {
        b.iter(|| faithful_search(black_box(&case), 5))
    });
}

fn gp_search(c: &mut Criterion) {
    let mut g = c.benchmark_group("gp_fit_search");
    g.sampling_mode(SamplingMode::Flat).sample_size(10);
    gp_search_one::<f32, 16>(&mut g, "kernel_f32");
    gp_search_one::<f64, 16>(&mut g, "kernel_f64");
    gp_search_faithful(&mut g, 16);
    gp_search_one::<f32, 64>(&mut g, "kernel_f32");
    gp_search_one::<f64, 64>(&mut g, "kernel_f64");
    gp_search_faithful(&mut g, 64);
    gp_search_one::<f32, 128>(&mut g, "kernel_f32");
    gp_search_one::<f64, 128>(&mut g, "kernel_f64");
    gp_search_faithful(&mut g, 128);
    g.finish();
}

fn score_kernel<T: Real>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let sources = Sources::<T>::new();
    let models: Vec<_> = sources
        .gps
        .iter()
        .map(|gp| GpSourceModel::new(&**gp, None))
        .collect();
    let rows = score_rows::<T>();
    let mut storage = vec![Scores::default(); rows.len()];
    g.bench_function(BenchmarkId::new(name, "realistic"), |b| {
        b.iter(|| {
            ScoreTable::compute(rows, black_box(&models), &mut storage)
                .expect("table")
                .len()
        })
    });
    let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
    g.bench_function(BenchmarkId::new(name, "oracle"), |b| {
        b.iter(|| {
            ScoreTable::compute(rows, black_box(&worlds), &mut storage)
                .expect("table")
                .len()
        })
    });
}

/// Score-table construction, 484 rows (11 × 11 grid × 4 actions), 3 sources; realistic
/// (one reward GP of 64 points per source) and oracle values.
fn score_table(c: &mut Criterion) {
    let mut g = c.benchmark_group("score_table");
    let rows = score_rows::<f64>();
    g.throughput(Throughput::Elements(rows.len() as u64));
    score_kernel::<f32>(&mut g, "kernel_f32");
    score_kernel::<f64>(&mut g, "kernel_f64");
    let gps = Sources::<f64>::new().reference_gps();
    let zs: Vec<Vec<f64>> = rows
        .iter()
        .map(|(s, a)| vec![s[0], s[1], a as f64])
        .collect();
    let mut out = vec![0.0; zs.len()];
    g.bench_function(BenchmarkId::new("reference_f64", "realistic"), |b| {
        b.iter(|| {
            for (o, z) in out.iter_mut().zip(&zs) {
                *o = reference_score_row(black_box(&gps), z);
            }
        })
    });
    g.finish();
}

fn alias_one<T: Real>(c: &mut Criterion, name: &str) {
    let weights = alias_weights::<T>();
    let mut storage = vec![AliasEntry::<T>::default(); weights.len()];
    let mut g = c.benchmark_group("alias_build");
    g.throughput(Throughput::Elements(ALIAS_ROWS as u64));
    g.bench_function(BenchmarkId::new(name, ALIAS_ROWS), |b| {
        b.iter(|| {
            AliasTable::build(black_box(&weights).iter().copied(), &mut storage)
                .expect("table")
                .len()
        })
    });
    g.finish();
    let table = AliasTable::build(weights.iter().copied(), &mut storage).expect("table");
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut out = vec![0usize; ALIAS_DRAWS];
    let mut g = c.benchmark_group("alias_draw");
    g.throughput(Throughput::Elements(ALIAS_DRAWS as u64));
    g.bench_function(BenchmarkId::new(name, ALIAS_ROWS), |b| {
        b.iter(|| table.sample_into(&mut rng, black_box(&mut out)))
    });
    g.finish();
}

/// Alias table on 40 804 rows (the harness's 101 × 101 × 4 grid): build, and 1 000 draws.
/// The reference has no sampler; kernel only.
fn alias(c: &mut Criterion) {
    alias_one::<f32>(c, "kernel_f32");
    alias_one::<f64>(c, "kernel_f64");
}

fn fqi_one<T: Real>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let mut case = FqiCase::<T>::new();
    for iterations in [1usize, 60] {
        g.bench_function(BenchmarkId::new(name, iterations), |b| {
            b.iter(|| case.fit(black_box(iterations)).expect("fit"))
        });
    }
}

/// Weighted tabular FQI, 41 × 41 cells × 4 actions, 3 000 samples: a fit with 1 iteration
/// (the reward model) and with 60; one sweep is (t₆₀ − t₁)/59. The reference has no tabular
/// FQI; for scale, the faithful path's FQI (IWFQI weights, 50-tree Extra-Trees per action)
/// on the same samples with 1 and 2 iterations (one sweep: t₂ − t₁).
fn fqi(c: &mut Criterion) {
    let mut g = c.benchmark_group("fqi_fit");
    fqi_one::<f32>(&mut g, "kernel_f32");
    fqi_one::<f64>(&mut g, "kernel_f64");
    g.finish();
    let case = ForestFqiCase::new();
    let mut g = c.benchmark_group("fqi_fit");
    g.sampling_mode(SamplingMode::Flat).sample_size(10);
    for iterations in [1usize, 2] {
        g.bench_function(BenchmarkId::new("faithful_f64", iterations), |b| {
            b.iter(|| case.fit(black_box(iterations), 13))
        });
    }
    g.finish();
}

fn identify_kernel<T: Real>(c: &mut Criterion, name: &str) {
    let mut case = GridCase::<T>::new();
    let (s, a, n, r) = case.observation;
    let fresh = Belief::<T, 4>::uniform(4).expect("belief");
    c.benchmark_group("identify_belief_update").bench_function(
        BenchmarkId::new(name, "grid4"),
        |b| {
            b.iter(|| {
                let mut belief = fresh;
                belief
                    .update(black_box(&case.candidates), s, a, n, black_box(r))
                    .expect("update");
                belief
            })
        },
    );
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for (score, criterion) in [
        ("uniform", Score::Uniform),
        ("variance", Score::Variance),
        ("mutual_information", Score::MutualInformation(mi_config())),
    ] {
        let mut g = c.benchmark_group(format!("identify_score_{score}"));
        if score == "mutual_information" {
            g.sampling_mode(SamplingMode::Flat).sample_size(10);
        }
        g.bench_function(BenchmarkId::new(name, "grid4"), |b| {
            b.iter(|| {
                compute_score(
                    &criterion,
                    black_box(&case.candidates),
                    &case.prior,
                    &mut rng,
                    &mut case.score,
                )
                .expect("score")
            })
        });
        g.finish();
    }
}

/// Grid World identification (the thesis's 4 candidates, 100 states × 4 actions): one
/// belief update, and the three scores from the uniform prior. The reference has the batch
/// posterior (given one observation) and the variance score; its mutual-information score
/// integrates the reward entropy exactly (a different algorithm, seconds per call), so MI
/// and the trivial uniform score are kernel only.
fn identify(c: &mut Criterion) {
    identify_kernel::<f32>(c, "kernel_f32");
    identify_kernel::<f64>(c, "kernel_f64");
    let case = GridCase::<f64>::new();
    let tables: Vec<ref_identify::TabularMdp> = case
        .candidates
        .iter()
        .map(ref_identify::TabularMdp::from_model)
        .collect();
    let (s, a, n, r) = case.observation;
    let observation = [ref_identify::Observation {
        state: s,
        action: a,
        next_state: n,
        reward: r,
    }];
    c.benchmark_group("identify_belief_update").bench_function(
        BenchmarkId::new("reference_f64", "grid4"),
        |b| {
            b.iter(|| {
                ref_identify::posterior(black_box(&tables), &case.prior, black_box(&observation))
            })
        },
    );
    c.benchmark_group("identify_score_variance")
        .bench_function(BenchmarkId::new("reference_f64", "grid4"), |b| {
            b.iter(|| ref_identify::variance_score(black_box(&tables), &case.prior))
        });
}

fn awfqi_one<T: Real>(g: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
    let mut kernel = awfqi_kernel::<T>();
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    g.bench_function(BenchmarkId::new(name, "puddle"), |b| {
        b.iter(|| {
            kernel.reset();
            kernel.step(&mut rng).expect("step")
        })
    });
}

/// One full AWFQI kernel step (thesis configuration): 50 queries drawn from the oracle
/// score table (484 rows), target reward GP (N = 64) with spec §4.2's search, reward
/// weights of 900 source records, 60 iterations of weighted FQI on 11 × 11 × 4 cells.
/// The faithful std path is measured by `scripts/perf-tables` (experiment wall times).
fn awfqi_step(c: &mut Criterion) {
    let mut g = c.benchmark_group("awfqi_step");
    g.sampling_mode(SamplingMode::Flat).sample_size(10);
    awfqi_one::<f32>(&mut g, "kernel_f32");
    awfqi_one::<f64>(&mut g, "kernel_f64");
    g.finish();
}

criterion_group! {
    name = benches;
    config = config();
    targets = gp_fit, gp_predict, gp_fit_predict, gp_add_point, gp_search, score_table,
        alias, fqi, identify, awfqi_step
}
criterion_main!(benches);
