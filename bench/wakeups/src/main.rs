//! Rounds of two tasks after a stretch of serial work, as core hands them
//! over: on one thread, on a rayon pool of two (the caller sleeps, idle
//! workers sleep), and with a helper thread that spins on a round counter.
//! Prints the time a round, medians of five sets of 500 rounds.
//!
//! `cargo run --release --manifest-path bench/wakeups/Cargo.toml`

use std::sync::atomic::{AtomicU64, Ordering::*};
use std::sync::Arc;
use std::time::Instant;

/// `n` dependent multiply-adds: about `n / 7` µs here.
fn spin(n: u64) -> u64 {
    let mut x = 1u64;
    for i in 0..n {
        x = x.wrapping_mul(6364136223846793005).wrapping_add(i);
    }
    x
}

/// Median time a round, µs, of `f` run 500 times, over five sets.
fn per_round(mut f: impl FnMut()) -> f64 {
    let mut sets: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..500 {
                f();
            }
            t.elapsed().as_secs_f64() / 500.0 * 1e6
        })
        .collect();
    sets.sort_by(f64::total_cmp);
    sets[2]
}

fn main() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    // The spinning helper runs the second task of a round when the round
    // number moves on, and says so in `done`.
    let (round, done, size) = (
        Arc::new(AtomicU64::new(0)),
        Arc::new(AtomicU64::new(0)),
        Arc::new(AtomicU64::new(0)),
    );
    {
        let (round, done, size) = (round.clone(), done.clone(), size.clone());
        std::thread::spawn(move || {
            let mut seen = 0;
            loop {
                let r = round.load(Acquire);
                if r == seen {
                    std::hint::spin_loop();
                    continue;
                }
                seen = r;
                std::hint::black_box(spin(size.load(Relaxed)));
                done.store(r, Release);
            }
        });
    }
    println!(
        "two tasks a round after serial work (sizes in multiply-adds); time a round, µs (medians)"
    );
    println!(
        "{:>10} {:>10} {:>12} {:>12} {:>16}",
        "task", "serial", "one thread", "rayon pool", "spinning helper"
    );
    for (task, gap) in [
        (20_000u64, 0u64),
        (20_000, 100_000),
        (200_000, 100_000),
        (1_000_000, 300_000),
    ] {
        let one = per_round(|| {
            std::hint::black_box(spin(gap));
            std::hint::black_box(spin(task));
            std::hint::black_box(spin(task));
        });
        let mut out = [0u64; 2];
        let rayon_pool = per_round(|| {
            std::hint::black_box(spin(gap));
            pool.install(|| {
                use rayon::prelude::*;
                out.par_iter_mut()
                    .with_max_len(1)
                    .for_each(|o| *o = spin(task));
            });
        });
        let spinning = per_round(|| {
            std::hint::black_box(spin(gap));
            size.store(task, Relaxed);
            let r = round.load(Relaxed) + 1;
            round.store(r, Release);
            std::hint::black_box(spin(task));
            while done.load(Acquire) != r {
                std::hint::spin_loop();
            }
        });
        println!("{task:>10} {gap:>10} {one:>12.0} {rayon_pool:>12.0} {spinning:>16.0}");
    }
}
