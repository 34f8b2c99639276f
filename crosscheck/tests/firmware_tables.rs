//! The host side of the firmware example (`examples/firmware/`): generates the source data
//! it keeps in flash — three Dam sources' records, the reward posteriors of each source's GP
//! at its own records (§6 step 3) and the oracle score table over the candidate grid
//! (§11.1) — and checks that the committed `examples/firmware/src/tables.rs` is exactly
//! what this code generates.
//!
//! Regenerate after changing anything here (or in the core's Dam, GP or score code):
//!
//! ```sh
//! UPDATE_FIRMWARE_TABLES=1 cargo test -p awfqi-crosscheck --test firmware_tables
//! ```
//!
//! The second test does the same for the 32 KiB Puddle World footprint image
//! (`tests/on_target/src/puddle_tables.rs`): the published shared-dynamics source records
//! and their stored reward posteriors, and the realistic score table of the recommended
//! configuration — exactly the set-up `std_harness/examples/embedded_capacity.rs` measures
//! the return of (`24 11 1.25`).
//!
//! The heavy, one-off work (source GP fits on every record, the score table) happens here,
//! on the host, with the same core code the device runs; the device only reads the tables.

use std::fmt::Write as _;
use std::path::Path;

use awfqi::env::{DAM_ACTIONS, DAM_DAYS, DAM_MAX_STORAGE, DAM_MIN_STORAGE, Dam};
use awfqi::prelude::{
    Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, GenerativeModel, PointGrid, Posterior, RowSet,
    Scores, SourceMeans, SourceModel, Transition,
};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

type Record = Transition<[f32; 2], f32>;

/// Records per source (one-step transitions from uniformly drawn states, as the published
/// Dam sources are).
const RECORDS_PER_SOURCE: usize = 200;
/// Sources: the first three of the IWFQI paper's six (inflow profiles 2–4).
const SOURCES: usize = 3;
/// The candidate grid of the score table: storage 0, 50, …, 500 × days 1, 61, …, 301.
const GRID_LOWER: [f32; 2] = [0.0, 1.0];
const GRID_SPACING: [f32; 2] = [50.0, 60.0];
const GRID_POINTS: [usize; 2] = [11, 6];
const SCORE_ROWS: usize = 11 * 6 * DAM_ACTIONS;
/// Seed of the generation.
const SEED: u64 = 2018;
/// Where the tables live.
const TABLES: &str = "../examples/firmware/src/tables.rs";

/// The Dam's noise-free means, for the oracle score table (the core's Dam has them as
/// methods; `SourceModel` is how the score table asks for them).
struct DamMeans(Dam<f32>);

impl SourceModel<f32, 2> for DamMeans {
    fn predict(&self, state: [f32; 2], action: usize) -> awfqi::Result<SourceMeans<f32, 2>> {
        Ok(SourceMeans {
            reward: self.0.mean_reward(state, action)?,
            next_state: self.0.mean_next_state(state, action)?,
        })
    }
}

/// The example's own settings ([`reservoir::settings`]): the source GPs of the tables are
/// fitted with the training the device uses.
fn gp_config() -> awfqi::Result<AwfqiConfig<f32, 3>> {
    reservoir::settings()
}

struct Tables {
    records: Vec<Vec<Record>>,
    posteriors: Vec<Posterior<f32>>,
    scores: Vec<Scores<f32, 2>>,
}

fn generate() -> awfqi::Result<Tables> {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let sources = Dam::<f32>::sources();
    let sources = &sources[..SOURCES];
    let mut records = Vec::new();
    for dam in sources {
        let mut data = Vec::with_capacity(RECORDS_PER_SOURCE);
        for _ in 0..RECORDS_PER_SOURCE {
            let u = awfqi::rng::uniform::<f32, _>(&mut rng);
            let storage = DAM_MIN_STORAGE as f32 + (DAM_MAX_STORAGE - DAM_MIN_STORAGE) as f32 * u;
            let day = 1 + awfqi::rng::uniform_index(&mut rng, DAM_DAYS);
            let action = awfqi::rng::uniform_index(&mut rng, DAM_ACTIONS);
            data.push(dam.query([storage, day as f32], action, &mut rng)?);
        }
        records.push(data);
    }
    let slices: Vec<&[Record]> = records.iter().map(Vec::as_slice).collect();
    let rows = RowSet::grid(
        PointGrid::new(GRID_LOWER, GRID_SPACING, GRID_POINTS)?,
        DAM_ACTIONS,
    )?;
    assert_eq!(rows.len(), SCORE_ROWS);
    let means: Vec<DamMeans> = sources.iter().copied().map(DamMeans).collect();
    let mut posteriors = vec![Posterior::default(); SOURCES * RECORDS_PER_SOURCE];
    let mut scores = vec![Scores::ZERO; SCORE_ROWS];
    // The builder performs the set-up once; on the host, each source GP holds every one of
    // its source's records (N = 200), which the device could not afford.
    let mut storage = Box::new(AwfqiStorage::<
        f32,
        2,
        3,
        RECORDS_PER_SOURCE,
        50,
        { SOURCES * RECORDS_PER_SOURCE },
        SCORE_ROWS,
        { 10 * DAM_ACTIONS },
    >::new());
    Awfqi::builder(
        gp_config()?.validate()?,
        CellGrid::new([0.0, 1.0], [500.0, 360.0], [10, 1])?,
        &slices,
        rows,
    )
    .fit_posteriors(&mut posteriors)
    .scores_from(&means, &mut scores)?
    .build(Dam::target(), &mut *storage, &mut rng)?;
    Ok(Tables {
        records,
        posteriors,
        scores,
    })
}

/// The tables as Rust source (`{:?}` of an `f32` is the shortest text that reads back as
/// the same value, so the tables are exact).
fn render(t: &Tables) -> String {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "//! Source data of the firmware example, generated on the host by\n\
         //! `crosscheck/tests/firmware_tables.rs` (do not edit; regenerate with\n\
         //! `UPDATE_FIRMWARE_TABLES=1 cargo test -p awfqi-crosscheck --test firmware_tables`).\n\
         //!\n\
         //! {SOURCES} Dam sources (the IWFQI paper's sources 1–{SOURCES}) × {RECORDS_PER_SOURCE} \
         one-step transitions from uniform states, the\n\
         //! reward posterior of each source's GP at each of its records, and the oracle score\n\
         //! table over the candidate grid. Everything here is `static`: it stays in flash.\n\
         \n\
         use awfqi::prelude::{{Posterior, Scores, Transition}};\n\
         \n\
         /// Records per source.\n\
         pub const RECORDS_PER_SOURCE: usize = {RECORDS_PER_SOURCE};\n\
         /// Number of sources.\n\
         pub const SOURCES: usize = {SOURCES};\n\
         /// Candidate grid of the score table: first point, spacing and points per axis\n\
         /// (storage, day).\n\
         pub const GRID_LOWER: [f32; 2] = {GRID_LOWER:?};\n\
         /// Spacing of the candidate grid.\n\
         pub const GRID_SPACING: [f32; 2] = {GRID_SPACING:?};\n\
         /// Points per axis of the candidate grid.\n\
         pub const GRID_POINTS: [usize; 2] = {GRID_POINTS:?};\n\
         /// Candidate rows: grid points × actions.\n\
         pub const SCORE_ROWS: usize = {SCORE_ROWS};\n\
         \n\
         const fn r(state: [f32; 2], action: usize, reward: f32, next_state: [f32; 2]) -> Transition<[f32; 2], f32> {{\n\
         \x20   Transition {{ state, action, reward, next_state, absorbing: false }}\n\
         }}\n\
         \n\
         const fn p(mean: f32, std: f32) -> Posterior<f32> {{\n\
         \x20   Posterior {{ mean, std }}\n\
         }}\n\
         \n\
         const fn v(reward: f32, next_state: [f32; 2]) -> Scores<f32, 2> {{\n\
         \x20   Scores {{ reward, next_state }}\n\
         }}\n"
    );
    let _ = writeln!(
        w,
        "/// The source records, one array per source.\n\
         #[rustfmt::skip]\n\
         pub static SOURCE_RECORDS: [[Transition<[f32; 2], f32>; RECORDS_PER_SOURCE]; SOURCES] = ["
    );
    for source in &t.records {
        let _ = writeln!(w, "    [");
        for r in source {
            let _ = writeln!(
                w,
                "        r({:?}, {}, {:?}, {:?}),",
                r.state, r.action, r.reward, r.next_state
            );
        }
        let _ = writeln!(w, "    ],");
    }
    let _ = writeln!(w, "];\n");
    let _ = writeln!(
        w,
        "/// The reward posterior `(μ, σ)` of each source's GP at each of its records, source\n\
         /// after source (§6 step 3).\n\
         #[rustfmt::skip]\n\
         pub static SOURCE_POSTERIORS: [Posterior<f32>; SOURCES * RECORDS_PER_SOURCE] = ["
    );
    for p in &t.posteriors {
        let _ = writeln!(w, "    p({:?}, {:?}),", p.mean, p.std);
    }
    let _ = writeln!(w, "];\n");
    let _ = writeln!(
        w,
        "/// The oracle scores of the candidate rows (grid point after grid point, the\n\
         /// storage axis fastest; the actions of a point together), `V_r` and `V_s′`.\n\
         #[rustfmt::skip]\n\
         pub static SCORES: [Scores<f32, 2>; SCORE_ROWS] = ["
    );
    for v in &t.scores {
        let _ = writeln!(w, "    v({:?}, {:?}),", v.reward, v.next_state);
    }
    let _ = writeln!(w, "];");
    s
}

#[test]
fn committed_firmware_tables_are_what_the_generator_makes() {
    let tables = generate().expect("generation");
    // Independent checks of what goes to flash: every record is a valid Dam step of its
    // source (the reward is the source's own mean reward, exactly: the Dam's reward has no
    // noise), every posterior is finite with σ ≥ 0, and the scores are variances (≥ 0).
    let sources = Dam::<f32>::sources();
    for (dam, records) in sources.iter().zip(&tables.records) {
        assert_eq!(records.len(), RECORDS_PER_SOURCE);
        for r in records {
            assert_eq!(dam.mean_reward(r.state, r.action).unwrap(), r.reward);
            assert!((50.0..500.0).contains(&r.state[0]));
            assert!(r.next_state[0] >= 0.0);
        }
    }
    assert!(
        tables
            .posteriors
            .iter()
            .all(|p| p.mean.is_finite() && p.std >= 0.0)
    );
    // The source GPs hold every record, so their posterior means are close to the
    // (noise-free) rewards they were fitted on.
    let worst = tables
        .records
        .iter()
        .flatten()
        .zip(&tables.posteriors)
        .map(|(r, p)| (r.reward - p.mean).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 5.0, "a source posterior is {worst} from its reward");
    assert!(tables.scores.iter().all(|v| v.reward >= 0.0));
    // Somewhere the sources disagree about the reward (different α, β).
    assert!(tables.scores.iter().any(|v| v.reward > 1.0));

    let text = render(&tables);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(TABLES);
    if std::env::var_os("UPDATE_FIRMWARE_TABLES").is_some() {
        std::fs::write(&path, &text).expect("write the tables");
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == text,
        "{TABLES} is not what tests/firmware_tables.rs generates; regenerate it with \
         `UPDATE_FIRMWARE_TABLES=1 cargo test -p awfqi-crosscheck --test firmware_tables`"
    );
}

/// The 32 KiB configuration's GP capacity and score-grid spacing (324 rows).
const PUDDLE_GP_POINTS: usize = 24;
const PUDDLE_SPACING: f32 = 1.25;
const PUDDLE_TABLES: &str = "../tests/on_target/src/puddle_tables.rs";

#[test]
fn committed_puddle_32k_tables_are_what_the_generator_makes() {
    use awfqi::env::Dynamics;
    use awfqi_harness::transfer::algorithms::embedded::{EmbeddedConfig, EmbeddedQ, EmbeddedSetup};
    use awfqi_harness::transfer::score_tables::Mode;
    use awfqi_harness::transfer::sources::SourceSet;
    use awfqi_harness::transfer::{SCORE_TABLE, stream};

    // The harness embedded path's set-up (its stream) at this GP capacity: the f32 source
    // records, their stored posteriors and the realistic score table that
    // `std_harness/examples/embedded_capacity.rs` (`24 11 1.25`) measures the return of.
    let set = SourceSet::published(Dynamics::Shared).expect("published sources");
    let config =
        EmbeddedConfig::new(Mode::Grid, f64::from(PUDDLE_SPACING)).with_q(EmbeddedQ::Tabular(11));
    let setup =
        EmbeddedSetup::<PUDDLE_GP_POINTS>::new(&set, config, &mut stream(0, &[SCORE_TABLE, 100]))
            .unwrap();
    let records = setup.source_slices();
    let posteriors = setup.posteriors();
    let scores = setup.score_values();
    assert_eq!(scores.len(), 324);
    assert!(scores.iter().all(|v| v.reward >= 0.0) && scores.iter().any(|v| v.reward > 0.0));

    let mut s = String::new();
    let w = &mut s;
    let lens: Vec<usize> = records.iter().map(|r| r.len()).collect();
    let _ = writeln!(
        w,
        "//! Source data of the 32 KiB Puddle World footprint image, generated on the host by\n\
         //! `crosscheck/tests/firmware_tables.rs` (do not edit; regenerate with\n\
         //! `UPDATE_FIRMWARE_TABLES=1 cargo test -p awfqi-crosscheck --test firmware_tables`): the published\n\
         //! shared-dynamics source records and their stored reward posteriors, and the\n\
         //! realistic score table (`V_r` from one {PUDDLE_GP_POINTS}-point reward GP per source) over the\n\
         //! spacing-{PUDDLE_SPACING} puddle grid. All `static`: flash.\n\
         \n\
         use awfqi::prelude::{{Posterior, Scores, Transition}};\n\
         \n\
         /// Records of all sources.\n\
         pub const SOURCE_RECORDS: usize = {};\n\
         /// Candidate rows.\n\
         pub const SCORE_ROWS: usize = {};\n\
         \n\
         const fn r(state: [f32; 2], action: usize, reward: f32, next_state: [f32; 2], absorbing: bool) -> Transition<[f32; 2], f32> {{\n\
         \x20   Transition {{ state, action, reward, next_state, absorbing }}\n\
         }}\n\
         \n\
         const fn p(mean: f32, std: f32) -> Posterior<f32> {{\n\
         \x20   Posterior {{ mean, std }}\n\
         }}\n\
         \n\
         const fn v(reward: f32, next_state: [f32; 2]) -> Scores<f32, 2> {{\n\
         \x20   Scores {{ reward, next_state }}\n\
         }}\n",
        posteriors.len(),
        scores.len()
    );
    for (k, (source, len)) in records.iter().zip(&lens).enumerate() {
        let _ = writeln!(
            w,
            "/// Source {}'s records.\npub static SOURCE_{}: [Transition<[f32; 2], f32>; {len}] = [",
            k + 1,
            k + 1
        );
        for r in source.iter() {
            let _ = writeln!(
                w,
                "    r({:?}, {}, {:?}, {:?}, {}),",
                r.state, r.action, r.reward, r.next_state, r.absorbing
            );
        }
        let _ = writeln!(w, "];\n");
    }
    let _ = writeln!(
        w,
        "/// The stored reward posteriors, source after source.\n\
         pub static SOURCE_POSTERIORS: [Posterior<f32>; SOURCE_RECORDS] = ["
    );
    for p in posteriors {
        let _ = writeln!(w, "    p({:?}, {:?}),", p.mean, p.std);
    }
    let _ = writeln!(
        w,
        "];\n\n/// The score values of the candidate rows.\n\
         pub static SCORES: [Scores<f32, 2>; SCORE_ROWS] = ["
    );
    for v in scores {
        let _ = writeln!(w, "    v({:?}, {:?}),", v.reward, v.next_state);
    }
    let _ = writeln!(w, "];");

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(PUDDLE_TABLES);
    if std::env::var_os("UPDATE_FIRMWARE_TABLES").is_some() {
        std::fs::write(&path, &s).expect("write the tables");
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == s,
        "{PUDDLE_TABLES} is not what tests/firmware_tables.rs generates; regenerate it with \
         `UPDATE_FIRMWARE_TABLES=1 cargo test -p awfqi-crosscheck --test firmware_tables`"
    );
}

#[path = "../../examples/firmware/src/reservoir.rs"]
#[allow(dead_code)]
mod reservoir;
#[path = "../../examples/firmware/src/tables.rs"]
#[rustfmt::skip]
mod tables;

/// The firmware example's controller, run on the host with the device's seed: the same
/// code and f32 arithmetic, so this is what QEMU prints (docs/footprint.md, the firmware example: −1335.1 against −1798.7).
/// Adaptive AWFQI (what the firmware runs) and the thesis's AWFQI (its faithful variant)
/// both beat the baseline, every step reports consistent sizes, and the evaluation is the
/// plant's protocol (10 one-year rollouts, no absorbing state).
#[test]
fn firmware_example_beats_its_baseline_on_its_seed() {
    let mut memory = Box::new(reservoir::Memory::new());
    let mut storage = Box::new(reservoir::Storage::new());
    for thesis in [false, true] {
        let mut steps = 0;
        let check = |report: &awfqi::thesis::StepReport<f32, 3>| {
            steps += 1;
            assert_eq!(report.n_target_samples, steps * reservoir::BUDGET);
            assert_eq!(report.n_source_samples, SOURCES * RECORDS_PER_SOURCE);
            assert!(report.wr_eff > 0.0 && report.wr_eff.is_finite());
        };
        let outcome = if thesis {
            reservoir::learn_and_compare_thesis(&mut storage, 3, check)
        } else {
            reservoir::learn_and_compare(&mut memory, 3, check)
        }
        .unwrap();
        assert_eq!(steps, reservoir::STEPS);
        let (learned, baseline) = (outcome.learned, outcome.baseline);
        assert_eq!((learned.mean_steps, learned.absorbed), (360.0, 0));
        assert!(
            learned.mean_return > baseline.mean_return + 2.0 * baseline.standard_error,
            "thesis {thesis}: learned {learned:?} baseline {baseline:?}"
        );
    }
}
