//! The traps a firmware engineer met writing a controller against the public API, each
//! shown gone: arrays where slices are taken, a `const` empty value for every buffer element
//! type, getters on validated configurations, the generator trait re-exported, and a path
//! dependency from inside another workspace. (The `I = D + 1` check at `cargo check` is the
//! compile-fail doctest of `awfqi::record_gp::Dims`; named capacity errors are in `tests/bad_input.rs`
//! and the kernels' unit tests; `Real`'s methods are the doctest of `awfqi::float`.)

use awfqi::adaptive::candidates::Candidate;
use awfqi::adaptive::plausibility::SourceBelief;
use awfqi::prelude::{
    AdaptiveConfig, AliasEntry, Approximator, AwfqiConfig, CellGrid, EmptyCells, ExtraTrees,
    FqiConfig, FqiEntry, Kernel, KnnRecord, KnnStorage, MeanFunction, ModelSweep, Neighbours,
    Posterior, SampleSet, Scores, SweepEntry, SweepNode, SweepStorage, Transition, TreeNode,
    TreeRecord, TreeStorage,
};
use awfqi::rand_core::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Every element type of a buffer a kernel borrows has a `const` empty value, so every
/// buffer can be a zero-initialised `static` (`.bss`).
#[test]
fn every_buffer_element_type_has_a_const_empty_value() {
    static SAMPLES: [Transition<[f32; 3], f32>; 4] = [Transition::EMPTY; 4];
    static POSTERIORS: [Posterior<f32>; 4] = [Posterior::EMPTY; 4];
    static SCORES: [Scores<f32, 3>; 4] = [Scores::EMPTY; 4];
    static ENTRIES: [FqiEntry<f32>; 4] = [FqiEntry::EMPTY; 4];
    static ALIAS: [AliasEntry<f32>; 4] = [AliasEntry::EMPTY; 4];
    static CANDIDATES: [Candidate<f32>; 4] = [Candidate::EMPTY; 4];
    static BELIEFS: [SourceBelief<f32>; 4] = [SourceBelief::EMPTY; 4];
    static KNN: [KnnRecord<f32, 3>; 4] = [KnnRecord::EMPTY; 4];
    static TREE_RECORDS: [TreeRecord<f32, 3>; 4] = [TreeRecord::EMPTY; 4];
    static NODES: [TreeNode<f32>; 4] = [TreeNode::EMPTY; 4];
    static MEANS: [MeanFunction<f32, 8, 4>; 2] = [MeanFunction::EMPTY, MeanFunction::EMPTY];
    static SWEEP_ENTRIES: [SweepEntry<f32, 3>; 4] = [SweepEntry::EMPTY; 4];
    static SWEEP_NODES: [SweepNode<f32>; 4] = [SweepNode::EMPTY; 4];
    // The empty values are the all-zero ones (what `.bss` holds), and the defaults.
    assert_eq!(POSTERIORS[0], Posterior::new(0.0, 0.0));
    assert_eq!(POSTERIORS[3], Posterior::default());
    assert_eq!(SCORES[1], Scores::ZERO);
    assert_eq!(SAMPLES[2].reward, 0.0);
    assert_eq!(ENTRIES[0].q(), 0.0);
    assert_eq!(ALIAS[0], AliasEntry::default());
    assert_eq!(CANDIDATES[0].row, 0);
    assert_eq!(BELIEFS[0].squared_errors, 0.0);
    assert_eq!(KNN.len() + TREE_RECORDS.len() + NODES.len(), 12);
    assert!(MEANS[1].is_empty());
    assert_eq!(SWEEP_ENTRIES[0].reward(), 0.0);
    assert_eq!(SWEEP_NODES[0].value(), 0.0);
}

/// An array is accepted wherever a slice of entries is: `Approximator::build` takes
/// `&mut [FqiEntry<T>; E]` (and a tree, kernel-averaging or model-sweep storage block)
/// directly.
#[test]
fn approximators_build_in_arrays_and_storage_blocks() {
    let samples = [
        Transition {
            state: [0.25f32],
            action: 0,
            reward: 1.0,
            next_state: [0.25],
            absorbing: true,
        },
        Transition {
            state: [0.75],
            action: 1,
            reward: -1.0,
            next_state: [0.75],
            absorbing: true,
        },
    ];
    let config = FqiConfig::new(0.9, 5, EmptyCells::Nearest).unwrap();
    let sets = [SampleSet::unweighted(&samples)];
    let mut rng = ChaCha8Rng::seed_from_u64(3);

    let mut entries = [FqiEntry::<f32>::EMPTY; 4]; // 2 cells × 2 actions
    let grid = CellGrid::cube(0.0, 1.0, 2).unwrap();
    let mut q = Approximator::Table(grid).build(2, &mut entries).unwrap();
    q.fit(&sets, &config, &mut rng).unwrap();
    assert_eq!(q.value([0.2], 0).unwrap(), 1.0);
    assert_eq!(q.value([0.8], 1).unwrap(), -1.0);

    let mut trees = TreeStorage::<f32, 1, 2, 7>::new();
    let forest = ExtraTrees::streamed(3, 7).unwrap();
    let mut q = Approximator::Trees(forest).build(2, &mut trees).unwrap();
    q.fit(&sets, &config, &mut rng).unwrap();
    assert!((q.value([0.25], 0).unwrap() - 1.0).abs() < 1e-6);

    let mut knn = KnnStorage::<f32, 1, 2, { 2 * 2 * 3 }>::new();
    let neighbours = Neighbours::new(1, [0.0], [1.0], Kernel::Uniform).unwrap();
    let mut q = Approximator::from(neighbours).build(2, &mut knn).unwrap();
    q.fit(&sets, &config, &mut rng).unwrap();
    assert!((q.value([0.75], 1).unwrap() + 1.0).abs() < 1e-6);

    // A model sweep: 1 cell, 2 nodes × 2 actions. Each action has one absorbing record, so
    // its Q-value is that record's reward at every node.
    let mut sweep = SweepStorage::<f32, 1, 4, 2>::new();
    let model = ModelSweep::cube(0.0, 1.0, 1).unwrap();
    let mut q = Approximator::from(model).build(2, &mut sweep).unwrap();
    q.fit(&sets, &config, &mut rng).unwrap();
    assert!((q.value([0.2], 0).unwrap() - 1.0).abs() < 1e-6);
    assert!((q.value([0.8], 1).unwrap() + 1.0).abs() < 1e-6);
}

/// A validated configuration answers for each of its settings.
#[test]
fn validated_configurations_have_getters() {
    let mut config = AwfqiConfig::<f32, 4>::thesis(25);
    config.gp_training.search.restarts = 2;
    let valid = config.validate().unwrap();
    assert_eq!(valid.budget(), 25);
    assert_eq!(valid.weights(), config.weights);
    assert_eq!(valid.noise_subtraction(), config.noise_subtraction);
    assert_eq!(valid.subset(), config.subset);
    assert_eq!(valid.gp_training().search.restarts, 2);
    assert_eq!(valid.fqi(), config.fqi);
    assert_eq!(valid.sampling(), config.sampling);
    assert_eq!(*valid.config(), config);
    assert_eq!(valid.into_inner(), config);

    let adaptive = AdaptiveConfig::<f32, 3, 4>::recommended(30, [0.5; 3], 40, 0.2, [(0.0, 1.0); 3]);
    let valid = adaptive.validate().unwrap();
    assert_eq!(valid.budget(), 30);
    assert_eq!(valid.sub_batches(), adaptive.sub_batches);
    assert_eq!(valid.verify(), adaptive.verify);
    assert_eq!(valid.candidates(), adaptive.candidates);
    assert_eq!(valid.start(), [0.5; 3]);
    assert_eq!(valid.horizon(), 40);
    assert_eq!(valid.epsilon(), 0.2);
    assert_eq!(valid.bounds(), [(0.0, 1.0); 3]);
    assert_eq!(*valid.awfqi(), adaptive.awfqi);
    assert_eq!(valid.into_inner(), adaptive);
}

/// The generator trait the core takes is the one the crate re-exports: a generator named
/// through `awfqi::rand_core` is accepted by every randomised call.
#[test]
fn the_generator_trait_is_re_exported() {
    struct Counter(u64);
    impl awfqi::rand_core::TryRng for Counter {
        type Error = core::convert::Infallible;
        fn try_next_u32(&mut self) -> Result<u32, Self::Error> {
            self.try_next_u64().map(|x| x as u32)
        }
        fn try_next_u64(&mut self) -> Result<u64, Self::Error> {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1);
            Ok(self.0)
        }
        fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Self::Error> {
            dst.fill(7);
            Ok(())
        }
    }
    let mut rng = Counter(1);
    let u: f64 = awfqi::rng::uniform(&mut rng);
    let want = ((6364136223846793005u64.wrapping_add(1)) >> 11) as f64 / (1u64 << 53) as f64;
    assert_eq!(u, want);
    // ChaCha8 (rand_core 0.10, as the crate's) passes through the re-exported trait too.
    let mut chacha = ChaCha8Rng::seed_from_u64(9);
    let x = chacha.next_u64();
    assert_eq!(ChaCha8Rng::seed_from_u64(9).next_u64(), x);
}

/// The crate as a path dependency of a package inside another workspace: without the
/// `exclude` line the README gives, cargo refuses ("multiple workspace roots"); with it,
/// the workspace loads. Checked with `cargo metadata --no-deps --offline` on a scratch
/// workspace whose `vendor/awfqi` is this repository (a symbolic link, as a checkout or a
/// git submodule would be a directory).
#[cfg(unix)]
#[test]
fn a_path_dependency_inside_another_workspace_needs_the_exclude_line() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let root = std::env::temp_dir().join(format!("awfqi-workspace-trap-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("vendor")).unwrap();
    std::fs::create_dir_all(root.join("app/src")).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_MANIFEST_DIR"), root.join("vendor/awfqi")).unwrap();
    std::fs::write(
        root.join("app/Cargo.toml"),
        "[package]\nname = \"app\"\nversion = \"0.1.0\"\nedition = \"2024\"\n\n\
         [dependencies]\nawfqi = { path = \"../vendor/awfqi\" }\n",
    )
    .unwrap();
    std::fs::write(root.join("app/src/main.rs"), "fn main() {}\n").unwrap();
    let metadata = |workspace: &str| {
        std::fs::write(root.join("Cargo.toml"), workspace).unwrap();
        std::process::Command::new(&cargo)
            .args([
                "metadata",
                "--no-deps",
                "--offline",
                "--format-version",
                "1",
            ])
            .current_dir(root.join("app"))
            .output()
            .unwrap()
    };
    let trap = metadata("[workspace]\nmembers = [\"app\"]\nresolver = \"3\"\n");
    let stderr = String::from_utf8_lossy(&trap.stderr);
    assert!(!trap.status.success(), "loaded without the exclude line");
    assert!(stderr.contains("multiple workspace roots"), "{stderr}");
    let fixed = metadata(
        "[workspace]\nmembers = [\"app\"]\nexclude = [\"vendor/awfqi\"]\nresolver = \"3\"\n",
    );
    let stderr = String::from_utf8_lossy(&fixed.stderr);
    assert!(fixed.status.success(), "{stderr}");
    let _ = std::fs::remove_dir_all(&root);
}
