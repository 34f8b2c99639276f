//! The firmware example's controller (`examples/firmware/src/reservoir.rs`, with its flash
//! tables) on the host, over a range of seeds: how often the learned policy beats the
//! baseline, before a configuration goes to the device. The same code and `f32` arithmetic
//! as on the Cortex-M4F (seed 3 gives the returns the QEMU run prints). Both algorithms:
//! adaptive AWFQI (what the firmware runs) and the thesis's AWFQI.
//!
//! ```sh
//! cargo run --release --example firmware_host -- 100 120   # seeds 100..120
//! ```

#[path = "firmware/src/reservoir.rs"]
mod reservoir;
#[path = "firmware/src/tables.rs"]
#[rustfmt::skip]
mod tables;

fn main() -> awfqi::Result<()> {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap_or(0))
        .collect();
    let (first, end) = match args[..] {
        [a, b] if a < b => (a, b),
        _ => (100, 120),
    };
    let mut memory = Box::new(reservoir::Memory::new());
    let mut storage = Box::new(reservoir::Storage::new());
    for thesis in [false, true] {
        let name = if thesis {
            "thesis AWFQI"
        } else {
            "adaptive AWFQI"
        };
        let (mut wins, mut learned_sum, mut baseline_sum) = (0, 0.0, 0.0);
        for seed in first..end {
            let outcome = if thesis {
                reservoir::learn_and_compare_thesis(&mut storage, seed, |_| {})?
            } else {
                reservoir::learn_and_compare(&mut memory, seed, |_| {})?
            };
            let (l, b) = (outcome.learned.mean_return, outcome.baseline.mean_return);
            println!("{name}, seed {seed}: learned {l:.1}, baseline {b:.1}");
            wins += usize::from(l > b);
            learned_sum += l;
            baseline_sum += b;
        }
        let n = (end - first) as f32;
        println!(
            "{name}: learned beats the baseline in {wins} of {n} runs; mean {:.1} against {:.1}",
            learned_sum / n,
            baseline_sum / n
        );
    }
    Ok(())
}
