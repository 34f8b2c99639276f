//! Runs one benchmarked operation `k` times, for instruction counts under callgrind.
//!
//! ```text
//! cargo build --release -p awfqi-crosscheck --example perf_ops
//! target/release/examples/perf_ops list
//! valgrind --tool=callgrind --toggle-collect='*perf_ops*measured*' \
//!     target/release/examples/perf_ops gp_fit/kernel_f64/64 10
//! ```
//!
//! Everything outside `measured` (building inputs, fitting source GPs, cloning GPs for the
//! add-point operations) is excluded by the toggle, so callgrind's total divided by `k` is
//! the instruction count of one operation. The operations and their inputs are those of
//! `crosscheck/benches/core_ops.rs` (both use `benches/common`); `scripts/perf-tables` runs every one.

#[path = "../benches/common/mod.rs"]
mod common;

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::float::Real;
use awfqi::gp::{Gp, HyperparameterBounds, SearchOptions, WhenFull};
use awfqi::identify::{Belief, Criterion as Score, compute_score};
use awfqi::score::{GpSourceModel, ScoreTable, Scores};
use awfqi_reference::gp::ReferenceGp;
use awfqi_reference::identify as ref_identify;
use common::*;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::hint::black_box;

/// The measured region: `k` calls of `op`. Callgrind collects inside this function only.
#[inline(never)]
fn measured(k: usize, op: &mut dyn FnMut()) {
    for _ in 0..k {
        op();
    }
}

type Op = Box<dyn FnMut()>;
/// Builds an operation for `k` repetitions.
type Build = Box<dyn Fn(usize) -> Op>;

fn gp_fit<T: Real, const N: usize>() -> Op {
    let case = gp_case(N);
    let (x, y) = (inputs::<T>(&case.x), values::<T>(&case.y));
    let mut gp = fitted_gp::<T, N>(&case, 0);
    Box::new(move || gp.fit(black_box(&x), black_box(&y)).expect("fit"))
}

fn gp_fit_reference(n: usize) -> Op {
    let case = gp_case(n);
    let (x, h) = (reference_inputs(&case.x), reference_hyper());
    Box::new(move || {
        black_box(ReferenceGp::fit(black_box(&x), black_box(&case.y), &h).expect("fit"));
    })
}

fn gp_fit_faithful(n: usize) -> Op {
    let case = gp_case(n);
    Box::new(move || {
        black_box(faithful_gp(black_box(&case)));
    })
}

fn gp_predict_faithful(n: usize) -> Op {
    let case = gp_case(n);
    let gp = faithful_gp(&case);
    Box::new(move || {
        black_box(faithful_predict_all(black_box(&gp), black_box(&case.test)));
    })
}

fn gp_search_faithful(n: usize) -> Op {
    let case = gp_case(n);
    Box::new(move || {
        black_box(faithful_search(black_box(&case), 5));
    })
}

fn fqi_faithful(iterations: usize) -> Op {
    let case = ForestFqiCase::new();
    Box::new(move || {
        black_box(case.fit(black_box(iterations), 13));
    })
}

fn gp_predict<T: Real, const N: usize>() -> Op {
    let case = gp_case(N);
    let gp = fitted_gp::<T, N>(&case, N);
    let test = inputs::<T>(&case.test);
    Box::new(move || {
        black_box(predict_all(black_box(&*gp), black_box(&test)));
    })
}

fn gp_predict_reference(n: usize) -> Op {
    let case = gp_case(n);
    let gp =
        ReferenceGp::fit(&reference_inputs(&case.x), &case.y, &reference_hyper()).expect("fit");
    let test = reference_inputs(&case.test);
    Box::new(move || {
        black_box(reference_predict_all(black_box(&gp), black_box(&test)));
    })
}

fn gp_fit_predict<T: Real, const N: usize>() -> Op {
    let case = gp_case(N);
    let (x, y, test) = (
        inputs::<T>(&case.x),
        values::<T>(&case.y),
        inputs::<T>(&case.test),
    );
    let mut gp = fitted_gp::<T, N>(&case, 0);
    Box::new(move || {
        gp.fit(black_box(&x), black_box(&y)).expect("fit");
        black_box(predict_all(&*gp, black_box(&test)));
    })
}

fn gp_fit_predict_reference(n: usize) -> Op {
    let case = gp_case(n);
    let (x, h, test) = (
        reference_inputs(&case.x),
        reference_hyper(),
        reference_inputs(&case.test),
    );
    Box::new(move || {
        let gp = ReferenceGp::fit(black_box(&x), black_box(&case.y), &h).expect("fit");
        black_box(reference_predict_all(&gp, black_box(&test)));
    })
}

/// `k` clones prepared before the measured region; each call extends one of them.
fn gp_add<T: Real, const N: usize>(k: usize) -> Op {
    let case = gp_case(N);
    let gp = fitted_gp::<T, N>(&case, N - 1);
    let mut fresh: Vec<Box<Gp<T, N, D>>> = (0..k).map(|_| gp.clone()).collect();
    let mut done = Vec::with_capacity(k);
    let (z, y) = (case.x[N - 1].map(T::from_f64), T::from_f64(case.y[N - 1]));
    Box::new(move || {
        let mut gp = fresh.pop().expect("a prepared clone per call");
        gp.add_point(black_box(z), black_box(y), WhenFull::Refuse)
            .expect("add");
        done.push(gp);
    })
}

fn gp_slide<T: Real, const N: usize>() -> Op {
    let case = gp_case(2 * N);
    let mut gp = fitted_gp::<T, N>(&case, N);
    let extra: Vec<([T; D], T)> = (N..2 * N)
        .map(|i| (case.x[i].map(T::from_f64), T::from_f64(case.y[i])))
        .collect();
    let mut next = 0;
    Box::new(move || {
        let (z, y) = extra[next % N];
        next += 1;
        gp.add_point(black_box(z), black_box(y), WhenFull::DropOldest)
            .expect("slide");
    })
}

fn gp_search<T: Real, const N: usize>(k: usize) -> Op {
    let case = gp_case(N);
    let gp = fitted_gp::<T, N>(&case, N);
    let mut fresh: Vec<Box<Gp<T, N, D>>> = (0..k).map(|_| gp.clone()).collect();
    let mut done = Vec::with_capacity(k);
    let (bounds, options) = (
        HyperparameterBounds::<T, D>::spec_default(),
        SearchOptions::default(),
    );
    Box::new(move || {
        let mut gp = fresh.pop().expect("a prepared clone per call");
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        gp.optimize_hyperparameters(&bounds, &options, &mut rng)
            .expect("search");
        done.push(gp);
    })
}

fn score_realistic<T: Real>() -> Op {
    // Leaked: the models borrow the GPs for the life of this one-shot process.
    let sources = Box::leak(Box::new(Sources::<T>::new()));
    let models: Vec<_> = sources
        .gps
        .iter()
        .map(|gp| GpSourceModel::new(&**gp, None))
        .collect();
    let rows = score_rows::<T>();
    let mut storage = vec![Scores::default(); rows.len()];
    Box::new(move || {
        black_box(
            ScoreTable::compute(rows, black_box(&models), &mut storage)
                .expect("table")
                .len(),
        );
    })
}

fn score_oracle<T: Real>() -> Op {
    let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
    let rows = score_rows::<T>();
    let mut storage = vec![Scores::default(); rows.len()];
    Box::new(move || {
        black_box(
            ScoreTable::compute(rows, black_box(&worlds), &mut storage)
                .expect("table")
                .len(),
        );
    })
}

fn score_reference() -> Op {
    let gps = Sources::<f64>::new().reference_gps();
    let zs: Vec<Vec<f64>> = score_rows::<f64>()
        .iter()
        .map(|(s, a)| vec![s[0], s[1], a as f64])
        .collect();
    let mut out = vec![0.0; zs.len()];
    Box::new(move || {
        for (o, z) in out.iter_mut().zip(&zs) {
            *o = reference_score_row(black_box(&gps), z);
        }
    })
}

fn alias_build<T: Real>() -> Op {
    let weights = alias_weights::<T>();
    let mut storage = vec![AliasEntry::<T>::default(); weights.len()];
    Box::new(move || {
        black_box(
            AliasTable::build(black_box(&weights).iter().copied(), &mut storage)
                .expect("table")
                .len(),
        );
    })
}

fn alias_draw<T: Real>() -> Op {
    let weights = alias_weights::<T>();
    // Leaked: the table borrows its storage for the life of this one-shot process.
    let storage = Box::leak(vec![AliasEntry::<T>::default(); weights.len()].into_boxed_slice());
    let table = AliasTable::build(weights.iter().copied(), storage).expect("table");
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut out = vec![0usize; ALIAS_DRAWS];
    Box::new(move || table.sample_into(&mut rng, black_box(&mut out)))
}

fn fqi<T: Real>(iterations: usize) -> Op {
    let mut case = FqiCase::<T>::new();
    Box::new(move || {
        black_box(case.fit(black_box(iterations)).expect("fit"));
    })
}

fn belief_update<T: Real>() -> Op {
    let case = GridCase::<T>::new();
    let (s, a, n, r) = case.observation;
    let fresh = Belief::<T, 4>::uniform(4).expect("belief");
    Box::new(move || {
        let mut belief = fresh;
        belief
            .update(black_box(&case.candidates), s, a, n, black_box(r))
            .expect("update");
        black_box(belief);
    })
}

fn belief_update_reference() -> Op {
    let case = GridCase::<f64>::new();
    let tables: Vec<_> = case
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
    Box::new(move || {
        black_box(ref_identify::posterior(
            black_box(&tables),
            &case.prior,
            black_box(&observation),
        ));
    })
}

fn identify_score<T: Real>(criterion: Score) -> Op {
    let mut case = GridCase::<T>::new();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    Box::new(move || {
        compute_score(
            &criterion,
            black_box(&case.candidates),
            &case.prior,
            &mut rng,
            &mut case.score,
        )
        .expect("score")
    })
}

fn variance_score_reference() -> Op {
    let case = GridCase::<f64>::new();
    let tables: Vec<_> = case
        .candidates
        .iter()
        .map(ref_identify::TabularMdp::from_model)
        .collect();
    Box::new(move || {
        black_box(ref_identify::variance_score(
            black_box(&tables),
            &case.prior,
        ));
    })
}

fn awfqi_step<T: Real>() -> Op {
    let mut kernel = awfqi_kernel::<T>();
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    Box::new(move || {
        kernel.reset();
        black_box(kernel.step(&mut rng).expect("step"));
    })
}

/// Every operation: `(name, constructor)`; names are the criterion ids of
/// `crosscheck/benches/core_ops.rs`.
fn operations() -> Vec<(String, Build)> {
    let mut ops: Vec<(String, Build)> = Vec::new();
    let mut add = |name: String, f: Build| ops.push((name, f));
    macro_rules! sizes {
        ($($n:literal),*) => {$(
            add(format!("gp_fit/kernel_f32/{}", $n), Box::new(|_| gp_fit::<f32, $n>()));
            add(format!("gp_fit/kernel_f64/{}", $n), Box::new(|_| gp_fit::<f64, $n>()));
            add(format!("gp_fit/reference_f64/{}", $n), Box::new(|_| gp_fit_reference($n)));
            add(format!("gp_fit/faithful_f64/{}", $n), Box::new(|_| gp_fit_faithful($n)));
            add(format!("gp_predict/kernel_f32/{}", $n), Box::new(|_| gp_predict::<f32, $n>()));
            add(format!("gp_predict/kernel_f64/{}", $n), Box::new(|_| gp_predict::<f64, $n>()));
            add(format!("gp_predict/reference_f64/{}", $n), Box::new(|_| gp_predict_reference($n)));
            add(format!("gp_predict/faithful_f64/{}", $n), Box::new(|_| gp_predict_faithful($n)));
            add(format!("gp_add_point/kernel_f32/{}", $n), Box::new(|k| gp_add::<f32, $n>(k)));
            add(format!("gp_add_point/kernel_f64/{}", $n), Box::new(|k| gp_add::<f64, $n>(k)));
            add(format!("gp_add_point/reference_f64/{}", $n), Box::new(|_| gp_fit_reference($n)));
            add(format!("gp_add_point_drop_oldest/kernel_f32/{}", $n), Box::new(|_| gp_slide::<f32, $n>()));
            add(format!("gp_add_point_drop_oldest/kernel_f64/{}", $n), Box::new(|_| gp_slide::<f64, $n>()));
            add(format!("gp_fit_search/kernel_f32/{}", $n), Box::new(|k| gp_search::<f32, $n>(k)));
            add(format!("gp_fit_search/kernel_f64/{}", $n), Box::new(|k| gp_search::<f64, $n>(k)));
            add(format!("gp_fit_search/faithful_f64/{}", $n), Box::new(|_| gp_search_faithful($n)));
        )*};
    }
    sizes!(16, 64, 128);
    add(
        "gp_fit_predict100/kernel_f32/64".into(),
        Box::new(|_| gp_fit_predict::<f32, 64>()),
    );
    add(
        "gp_fit_predict100/kernel_f64/64".into(),
        Box::new(|_| gp_fit_predict::<f64, 64>()),
    );
    add(
        "gp_fit_predict100/reference_f64/64".into(),
        Box::new(|_| gp_fit_predict_reference(64)),
    );
    add(
        "score_table/kernel_f32/realistic".into(),
        Box::new(|_| score_realistic::<f32>()),
    );
    add(
        "score_table/kernel_f64/realistic".into(),
        Box::new(|_| score_realistic::<f64>()),
    );
    add(
        "score_table/reference_f64/realistic".into(),
        Box::new(|_| score_reference()),
    );
    add(
        "score_table/kernel_f32/oracle".into(),
        Box::new(|_| score_oracle::<f32>()),
    );
    add(
        "score_table/kernel_f64/oracle".into(),
        Box::new(|_| score_oracle::<f64>()),
    );
    for (ty, build, draw) in [
        (
            "f32",
            alias_build::<f32> as fn() -> Op,
            alias_draw::<f32> as fn() -> Op,
        ),
        ("f64", alias_build::<f64>, alias_draw::<f64>),
    ] {
        add(
            format!("alias_build/kernel_{ty}/{ALIAS_ROWS}"),
            Box::new(move |_| build()),
        );
        add(
            format!("alias_draw/kernel_{ty}/{ALIAS_ROWS}"),
            Box::new(move |_| draw()),
        );
    }
    for iterations in [1usize, 60] {
        add(
            format!("fqi_fit/kernel_f32/{iterations}"),
            Box::new(move |_| fqi::<f32>(iterations)),
        );
        add(
            format!("fqi_fit/kernel_f64/{iterations}"),
            Box::new(move |_| fqi::<f64>(iterations)),
        );
    }
    for iterations in [1usize, 2] {
        add(
            format!("fqi_fit/faithful_f64/{iterations}"),
            Box::new(move |_| fqi_faithful(iterations)),
        );
    }
    add(
        "identify_belief_update/kernel_f32/grid4".into(),
        Box::new(|_| belief_update::<f32>()),
    );
    add(
        "identify_belief_update/kernel_f64/grid4".into(),
        Box::new(|_| belief_update::<f64>()),
    );
    add(
        "identify_belief_update/reference_f64/grid4".into(),
        Box::new(|_| belief_update_reference()),
    );
    for (name, criterion) in [
        ("uniform", Score::Uniform),
        ("variance", Score::Variance),
        ("mutual_information", Score::MutualInformation(mi_config())),
    ] {
        add(
            format!("identify_score_{name}/kernel_f32/grid4"),
            Box::new(move |_| identify_score::<f32>(criterion)),
        );
        add(
            format!("identify_score_{name}/kernel_f64/grid4"),
            Box::new(move |_| identify_score::<f64>(criterion)),
        );
    }
    add(
        "identify_score_variance/reference_f64/grid4".into(),
        Box::new(|_| variance_score_reference()),
    );
    add(
        "awfqi_step/kernel_f32/puddle".into(),
        Box::new(|_| awfqi_step::<f32>()),
    );
    add(
        "awfqi_step/kernel_f64/puddle".into(),
        Box::new(|_| awfqi_step::<f64>()),
    );
    ops
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let ops = operations();
    match args.first().map(String::as_str) {
        None | Some("list") => {
            for (name, _) in &ops {
                println!("{name}");
            }
        }
        Some(name) => {
            let k: usize = args
                .get(1)
                .map_or(Ok(1), |s| s.parse())
                .unwrap_or_else(|_| {
                    eprintln!("the repetition count must be a positive integer");
                    std::process::exit(2)
                });
            let Some((_, build)) = ops.iter().find(|(n, _)| n == name) else {
                eprintln!("unknown operation {name:?}; `perf_ops list` lists them");
                std::process::exit(2)
            };
            let mut op = build(k);
            measured(k, &mut *op);
        }
    }
}
