use std::fs;

use super::*;

fn small(runs: &str) -> StudyConfig {
    StudyConfig {
        budgets: vec![1, 4, 16],
        runs: runs.parse().unwrap(),
        criteria: vec![
            CriterionName::Uniform,
            CriterionName::Variance,
            CriterionName::Mi,
            CriterionName::MiLiteral,
            CriterionName::MiSkip,
            CriterionName::Adaptive,
            CriterionName::AdaptiveVariance,
        ],
        mi_samples: 50,
        ..StudyConfig::default()
    }
}

fn with_threads<R: Send>(n: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn defaults_are_the_thesis_study() {
    let a = StudyConfig::default();
    assert_eq!(a.budgets, [1, 2, 4, 8, 16, 32, 64, 128]);
    assert_eq!(a.runs, RunRange { start: 0, end: 100 });
    assert_eq!(a.criteria.len(), 4);
    assert_eq!(a.policies, [PolicyName::Map, PolicyName::Belief]);
    assert_eq!(
        "20..40".parse::<RunRange>().unwrap(),
        RunRange { start: 20, end: 40 }
    );
    assert!("5..5".parse::<RunRange>().is_err());
}

#[test]
fn same_seed_same_files_whatever_the_thread_count() {
    for design in [Design::Independent, Design::Nested] {
        let args = StudyConfig {
            design,
            ..small("6")
        };
        let one = with_threads(1, || study(&args, false).unwrap());
        let two = with_threads(2, || study(&args, false).unwrap());
        assert_eq!(one, two);
        let dir =
            std::env::temp_dir().join(format!("awfqi-identify-{}-{design:?}", std::process::id()));
        write_outputs(&one, &dir.join("a"), false).unwrap();
        write_outputs(&two, &dir.join("b"), false).unwrap();
        for f in ["identify.json", "identify.csv"] {
            assert_eq!(
                fs::read(dir.join("a").join(f)).unwrap(),
                fs::read(dir.join("b").join(f)).unwrap()
            );
        }
        let csv = fs::read_to_string(dir.join("a/identify.csv")).unwrap();
        assert!(csv.starts_with(
            "criterion,policy,budget,runs,identification_rate,return_mean,return_stderr,optimal_return\n"
        ));
        // 7 criteria × 2 policies × 3 budgets rows plus the header.
        assert_eq!(csv.lines().count(), 1 + 7 * 2 * 3);
        fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn a_split_sweep_reproduces_the_whole_one() {
    let whole = study(&small("6"), false).unwrap();
    let first = study(&small("0..2"), false).unwrap();
    let second = study(&small("2..6"), false).unwrap();
    let mut merged = first.records.clone();
    merged.extend(second.records);
    assert_eq!(merged, whole.records);
    // Other seeds give other runs.
    let other = study(
        &StudyConfig {
            seed: 1,
            ..small("6")
        },
        false,
    )
    .unwrap();
    assert_ne!(other.records, whole.records);
}

#[test]
fn returns_never_exceed_the_optimum_and_identification_gives_it() {
    let s = study(&small("8"), false).unwrap();
    for r in &s.records {
        for o in &r.outcomes {
            assert!(o.return_map <= r.optimal_return + 1e-9);
            assert!(o.return_belief <= r.optimal_return + 1e-9);
            if o.identified {
                assert!((o.return_map - r.optimal_return).abs() < 1e-9);
            }
            assert!((0.0..=1.0 + 1e-12).contains(&o.posterior_true));
        }
    }
    // Common random numbers: one θ* per run, shared by all criteria and budgets.
    let rates: Vec<f64> = s.rows.iter().map(|r| r.identification_rate).collect();
    assert!(rates.iter().all(|r| (0.0..=1.0).contains(r)));
}
