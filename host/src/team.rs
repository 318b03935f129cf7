//! The threads core's parallel tasks run on: the calling thread and helpers
//! that wait for work *actively* for a while before they sleep.
//!
//! Core hands over its work in many short rounds (a partition's sweeps, the
//! selection's cache refreshes and root sweeps by levels: about 500 rounds on
//! the bunny, many under 100 µs). A thread that sleeps between rounds has to
//! be woken for the next, and on a virtual machine an idle CPU is halted, so
//! a wake-up can cost more than the round: with a sleeping pool two threads
//! were slower than one on such rounds here (`bench/notes.md`). So a helper
//! spins on the round counter for a moment (2 ms) after its last task before it
//! sleeps, and the calling thread takes tasks too instead of waiting for the
//! helpers to start.
//!
//! A round: the caller publishes the tasks (under a lock, with a new round
//! number), then every thread takes tasks from a shared count of those left,
//! tagged with the round number, so a helper that comes late can never take
//! a task of a later round: several at a time while many are left, one at a
//! time near the end (see `work`); the caller returns when all have
//! finished. Which thread runs a task does not matter: core combines the
//! results in task order.
//!
//! On Linux, when the team has no more threads than the CPUs the process may
//! run on, each helper starts pinned to one of them other than the caller's
//! (the next ones of the caller's set) and is let go after its first round.
//! A helper is made where the caller runs and sleeps there until the first
//! round; left to the scheduler, that first wake-up put it back on the
//! caller's CPU in about half the traced two-thread bunny runs here, and
//! the two threads took turns on that CPU, the other idle, for up to 66 ms
//! (`bench/notes.md`). Once it has run elsewhere, a helper wakes where it
//! last ran when that CPU is idle, and a machine busy with other work can
//! still move it (the caller is never pinned: several runs at once stay
//! free to spread).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use vsaqem_core::Task;

/// How long a helper waits actively for the next round before it sleeps,
/// when the team has no more threads than the machine has cores (more
/// threads than cores sleep at once: a spinning thread would take a core
/// from one with work).
const SPIN: Duration = Duration::from_millis(2);

/// The calling thread and `threads - 1` helpers.
pub struct Team {
    shared: Arc<Shared>,
    helpers: Vec<JoinHandle<()>>,
}

/// What the caller and the helpers share.
struct Shared {
    /// The current round's tasks (a pointer to the caller's slice, valid
    /// until the round's last task has finished) and its number.
    round: Mutex<Round>,
    /// The current round's number, for helpers to watch without the lock.
    number: AtomicU64,
    /// `number << 32 | tasks not yet taken`: a task is taken by lowering the
    /// count while the round is still the one the taker read.
    left: AtomicU64,
    /// Tasks of the current round finished.
    finished: AtomicUsize,
    /// A task panicked (the caller panics in turn).
    panicked: AtomicBool,
    /// Helpers asleep wait here for the next round (or the end).
    wake: Condvar,
    /// Helpers asleep on `wake`, counted under the round's lock: a round is
    /// published with a wake-up (a system call) only when one is.
    sleepers: AtomicUsize,
    /// The team is being dropped.
    stop: AtomicBool,
    /// How long a helper spins before it sleeps.
    spin: Duration,
    /// Threads in the team, the caller's included.
    threads: usize,
}

/// A round's tasks as a raw slice: a pointer to the caller's `&mut dyn Task`
/// slice (its lifetime erased) and a length.
#[derive(Clone, Copy)]
struct Round {
    number: u64,
    tasks: *mut (),
    len: usize,
}

// SAFETY: the pointer is only followed for a task taken in its own round, and
// the caller keeps the slice alive (and untouched) until every task taken in
// that round has finished; `Task: Send`.
unsafe impl Send for Round {}

impl Team {
    /// A team of `threads` threads (the caller and `threads - 1` helpers);
    /// `None` when `threads` < 2 or a helper cannot be started.
    pub fn new(threads: usize) -> Option<Team> {
        if threads < 2 {
            return None;
        }
        let shared = Arc::new(Shared {
            round: Mutex::new(Round {
                number: 0,
                tasks: std::ptr::null_mut(),
                len: 0,
            }),
            number: AtomicU64::new(0),
            left: AtomicU64::new(0),
            finished: AtomicUsize::new(0),
            panicked: AtomicBool::new(false),
            wake: Condvar::new(),
            sleepers: AtomicUsize::new(0),
            stop: AtomicBool::new(false),
            spin: match std::thread::available_parallelism() {
                Ok(cores) if threads <= cores.get() => SPIN,
                _ => Duration::ZERO,
            },
            threads,
        });
        let cpus = affinity::spread(threads);
        let mut team = Team {
            shared,
            helpers: Vec::new(),
        };
        for i in 0..threads - 1 {
            let shared = Arc::clone(&team.shared);
            // Pinned until its first round, then given the caller's set.
            let start = cpus
                .as_ref()
                .and_then(|(mask, c)| Some((*c.get(i + 1)?, *mask)));
            let helper = std::thread::Builder::new()
                .name(format!("vsaqem-{i}"))
                .spawn(move || {
                    let unpin = start.and_then(|(cpu, mask)| affinity::pin(cpu).then_some(mask));
                    help(&shared, unpin)
                })
                .ok()?;
            team.helpers.push(helper);
        }
        Some(team)
    }

    /// Threads in the team, the caller's included.
    pub fn threads(&self) -> usize {
        self.helpers.len() + 1
    }

    /// Run every task of `tasks` exactly once, on the caller and the helpers;
    /// return when all have finished.
    pub fn run(&self, tasks: &mut [&mut dyn Task]) {
        let len = tasks.len();
        if len < 2 {
            tasks.iter_mut().for_each(|t| t.run());
            return;
        }
        let shared = &*self.shared;
        let round = {
            let mut published = lock(&shared.round);
            // The slice outlives the round: this call returns only after
            // every task has finished.
            let round = Round {
                number: published.number + 1,
                tasks: tasks.as_mut_ptr() as *mut (),
                len,
            };
            *published = round;
            shared.finished.store(0, Ordering::Relaxed);
            shared.left.store(tag(round.number, len), Ordering::Release);
            shared.number.store(round.number, Ordering::Release);
            // A helper counts itself asleep under this lock before it
            // waits, after seeing no new round: none is missed.
            if shared.sleepers.load(Ordering::Relaxed) > 0 {
                shared.wake.notify_all();
            }
            round
        };
        work(shared, round);
        // The last tasks are running: wait for them actively (yielding now
        // and then, in case their threads wait for a core).
        let mut spins = 0u32;
        while shared.finished.load(Ordering::Acquire) < len {
            std::hint::spin_loop();
            spins = spins.wrapping_add(1);
            if spins % 1024 == 0 {
                std::thread::yield_now();
            }
        }
        if shared.panicked.swap(false, Ordering::Relaxed) {
            panic!("a parallel task panicked");
        }
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        {
            let _round = lock(&self.shared.round);
            self.shared.stop.store(true, Ordering::Release);
            self.shared.wake.notify_all();
        }
        for helper in self.helpers.drain(..) {
            let _ = helper.join();
        }
    }
}

/// Pinning threads to CPUs (Linux; elsewhere nothing is pinned).
mod affinity {
    #[cfg(target_os = "linux")]
    pub use linux::*;

    #[cfg(target_os = "linux")]
    mod linux {
        use std::mem::{size_of, zeroed};

        /// A thread's set of CPUs.
        #[derive(Clone, Copy)]
        pub struct Mask(libc::cpu_set_t);

        /// The calling thread's set of CPUs and the CPUs in it, in order;
        /// `None` when it cannot be read.
        pub fn allowed() -> Option<(Mask, Vec<usize>)> {
            // SAFETY: an all-zero `cpu_set_t` is an empty set; the call
            // writes at most `size_of::<cpu_set_t>()` bytes into it.
            let mut set: libc::cpu_set_t = unsafe { zeroed() };
            if unsafe { libc::sched_getaffinity(0, size_of::<libc::cpu_set_t>(), &mut set) } != 0 {
                return None;
            }
            let cpus = (0..libc::CPU_SETSIZE as usize)
                // SAFETY: `c` is below `CPU_SETSIZE`, the set's size.
                .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
                .collect();
            Some((Mask(set), cpus))
        }

        /// The CPU the calling thread runs on (`None` when unknown).
        pub fn current() -> Option<usize> {
            // SAFETY: no arguments; returns -1 on failure.
            usize::try_from(unsafe { libc::sched_getcpu() }).ok()
        }

        /// The calling thread's set of CPUs now, and one CPU for each of
        /// `threads` threads: the one it runs on, then the next ones of its
        /// set in turn. `None` when the set has fewer than `threads` CPUs or
        /// cannot be read.
        pub fn spread(threads: usize) -> Option<(Mask, Vec<usize>)> {
            let (mask, cpus) = allowed()?;
            if threads < 2 || cpus.len() < threads {
                return None;
            }
            let first = cpus.iter().position(|&c| Some(c) == current()).unwrap_or(0);
            let order = (0..threads)
                .map(|t| cpus[(first + t) % cpus.len()])
                .collect();
            Some((mask, order))
        }

        /// Pin the calling thread to `cpu`; whether it was.
        pub fn pin(cpu: usize) -> bool {
            // SAFETY: as in `spread`; `cpu` below `CPU_SETSIZE` is checked.
            let mut set: libc::cpu_set_t = unsafe { zeroed() };
            if cpu >= libc::CPU_SETSIZE as usize {
                return false;
            }
            unsafe { libc::CPU_SET(cpu, &mut set) };
            restore(&Mask(set))
        }

        /// Let the calling thread run on `mask`'s CPUs; whether it may.
        pub fn restore(mask: &Mask) -> bool {
            // SAFETY: `mask.0` is a whole `cpu_set_t` of the size passed.
            unsafe { libc::sched_setaffinity(0, size_of::<libc::cpu_set_t>(), &mask.0) == 0 }
        }
    }

    #[cfg(not(target_os = "linux"))]
    #[derive(Clone, Copy)]
    pub struct Mask;

    #[cfg(not(target_os = "linux"))]
    pub fn spread(_threads: usize) -> Option<(Mask, Vec<usize>)> {
        None
    }

    #[cfg(not(target_os = "linux"))]
    #[allow(dead_code)]
    pub fn allowed() -> Option<(Mask, Vec<usize>)> {
        None
    }

    #[cfg(not(target_os = "linux"))]
    #[allow(dead_code)]
    pub fn current() -> Option<usize> {
        None
    }

    #[cfg(not(target_os = "linux"))]
    pub fn pin(_cpu: usize) -> bool {
        false
    }

    #[cfg(not(target_os = "linux"))]
    pub fn restore(_mask: &Mask) -> bool {
        false
    }
}

/// `number << 32 | left`.
fn tag(number: u64, left: usize) -> u64 {
    (number << 32) | (left as u64 & 0xFFFF_FFFF)
}

/// The lock, also after a panic elsewhere (the round it guards is plain data).
fn lock(m: &Mutex<Round>) -> std::sync::MutexGuard<'_, Round> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Take and run tasks of `round` until none is left or the round is over,
/// several at a time while many are left: a share of what is left (half of
/// it over the threads), one at a time near the end. Every claim is an
/// atomic operation on a line all the threads write; taking the tasks of a
/// round one at a time cost about 5 us a round of 64 here.
fn work(shared: &Shared, round: Round) {
    let mut seen = shared.left.load(Ordering::Acquire);
    loop {
        let left = (seen & 0xFFFF_FFFF) as usize;
        if seen >> 32 != round.number & 0xFFFF_FFFF || left == 0 {
            return;
        }
        let take = (left / (2 * shared.threads)).max(1);
        match shared.left.compare_exchange_weak(
            seen,
            seen - take as u64,
            Ordering::AcqRel,
            Ordering::Acquire,
        ) {
            Ok(_) => {
                for index in left - take..left {
                    if index < round.len {
                        // SAFETY: `round.tasks` points to `round.len` values
                        // of `&mut dyn Task`, live until every task taken in
                        // the round has finished; task `index` is taken by
                        // this thread alone.
                        let task: &mut &mut dyn Task =
                            unsafe { &mut *(round.tasks as *mut &mut dyn Task).add(index) };
                        if catch_unwind(AssertUnwindSafe(|| task.run())).is_err() {
                            shared.panicked.store(true, Ordering::Relaxed);
                        }
                    }
                }
                shared.finished.fetch_add(take, Ordering::AcqRel);
                seen = shared.left.load(Ordering::Acquire);
            }
            Err(now) => seen = now,
        }
    }
}

/// A helper's life: wait for a round (actively for up to [`SPIN`], then
/// asleep), work on it, and again, until the team is dropped. Before its
/// first round it sleeps at once: the team starts before the input is read,
/// and a helper spinning beside the reader slowed the reading on this
/// 2-core VM (the bunny's read stage on two threads: 5.2 ms, 3.7 ms with the
/// helper asleep; `bench/notes.md`). A helper started pinned is given
/// `unpin`'s CPUs after its first round.
fn help(shared: &Shared, mut unpin: Option<affinity::Mask>) {
    let mut done = 0u64;
    loop {
        let started = Instant::now();
        let spin = if done == 0 {
            Duration::ZERO
        } else {
            shared.spin
        };
        let mut spins = 0u32;
        while shared.number.load(Ordering::Acquire) == done && !shared.stop.load(Ordering::Acquire)
        {
            std::hint::spin_loop();
            spins = spins.wrapping_add(1);
            if spins % 1024 == 0 && started.elapsed() >= spin {
                let mut round = lock(&shared.round);
                shared.sleepers.fetch_add(1, Ordering::Relaxed);
                while round.number == done && !shared.stop.load(Ordering::Acquire) {
                    round = shared.wake.wait(round).unwrap_or_else(|e| e.into_inner());
                }
                shared.sleepers.fetch_sub(1, Ordering::Relaxed);
                break;
            }
        }
        if shared.stop.load(Ordering::Acquire) {
            return;
        }
        let round = *lock(&shared.round);
        done = round.number;
        work(shared, round);
        if let Some(mask) = unpin.take() {
            affinity::restore(&mask);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Counts its runs.
    struct Count(u32);

    impl Task for Count {
        fn run(&mut self) {
            // Uneven work, so the threads finish in different orders.
            let mut x = self.0 as u64;
            for i in 0..(x % 7) * 500 {
                x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(i));
            }
            self.0 += 1;
        }
    }

    #[test]
    fn every_task_runs_once_in_every_round() {
        for threads in [2, 3, 5] {
            let team = Team::new(threads).expect("threads start");
            assert_eq!(team.threads(), threads);
            for round in 0..3000u32 {
                let n = (round % 70) as usize;
                let mut counts: Vec<Count> = (0..n).map(|i| Count(i as u32 * 10)).collect();
                let mut tasks: Vec<&mut dyn Task> =
                    counts.iter_mut().map(|c| c as &mut dyn Task).collect();
                team.run(&mut tasks);
                for (i, c) in counts.iter().enumerate() {
                    assert_eq!(c.0, i as u32 * 10 + 1, "round {round}, task {i}");
                }
            }
        }
    }

    #[test]
    fn sleeping_helpers_wake_for_the_next_round() {
        let team = Team::new(2).expect("threads start");
        for _ in 0..3 {
            let mut counts: Vec<Count> = (0..8).map(|_| Count(0)).collect();
            let mut tasks: Vec<&mut dyn Task> =
                counts.iter_mut().map(|c| c as &mut dyn Task).collect();
            team.run(&mut tasks);
            assert!(counts.iter().all(|c| c.0 == 1));
            // Longer than the helpers spin.
            std::thread::sleep(SPIN * 3);
        }
    }

    /// Waits (up to 10 s) until `count` tasks of its kind are running at
    /// once; `met` tells whether they were.
    struct Meet<'a> {
        arrived: &'a AtomicUsize,
        count: usize,
        met: bool,
    }

    impl<'a> Meet<'a> {
        /// One of `count` tasks that meet, counting on `arrived`.
        fn of(arrived: &'a AtomicUsize, count: usize) -> Self {
            Meet {
                arrived,
                count,
                met: false,
            }
        }
    }

    impl Task for Meet<'_> {
        fn run(&mut self) {
            self.arrived.fetch_add(1, Ordering::AcqRel);
            let start = Instant::now();
            while self.arrived.load(Ordering::Acquire) < self.count {
                if start.elapsed() > Duration::from_secs(10) {
                    return;
                }
                std::hint::spin_loop();
            }
            self.met = true;
        }
    }

    /// Records the CPUs its thread may use, and whether the thread is a
    /// helper, once every task of its kind is running.
    struct Where<'a> {
        meet: Meet<'a>,
        seen: Option<(bool, Option<Vec<usize>>)>,
    }

    impl Task for Where<'_> {
        fn run(&mut self) {
            self.meet.run();
            let helper = std::thread::current().name() == Some("vsaqem-0");
            self.seen = Some((helper, affinity::allowed().map(|(_, c)| c)));
        }
    }

    /// With no more threads than CPUs, the helper runs its first round
    /// pinned to one CPU and the next with the caller's CPUs; the caller is
    /// never pinned.
    #[test]
    fn a_helper_runs_its_first_round_pinned_and_then_free() {
        let Some((_, before)) = affinity::allowed() else {
            eprintln!("skipped: the CPUs a thread may use cannot be read here");
            return;
        };
        if before.len() < 2 {
            eprintln!("skipped: one CPU");
            return;
        }
        let team = Team::new(2).expect("threads start");
        for round in 0..2 {
            let arrived = AtomicUsize::new(0);
            let mut wheres: Vec<Where> = (0..2)
                .map(|_| Where {
                    meet: Meet::of(&arrived, 2),
                    seen: None,
                })
                .collect();
            let mut tasks: Vec<&mut dyn Task> =
                wheres.iter_mut().map(|w| w as &mut dyn Task).collect();
            team.run(&mut tasks);
            let seen: Vec<_> = wheres.into_iter().filter_map(|w| w.seen).collect();
            assert_eq!(seen.len(), 2, "round {round}: both tasks met");
            for (helper, cpus) in seen {
                let cpus = cpus.expect("readable");
                if helper && round == 0 {
                    assert_eq!(cpus.len(), 1, "the helper pinned in its first round");
                } else {
                    assert_eq!(cpus, before, "round {round}, helper {helper}");
                }
            }
        }
        assert_eq!(affinity::allowed().map(|(_, c)| c), Some(before));
    }

    /// Rounds that only finish with every helper's help: a helper asleep
    /// (after more than its spin without work) is woken for each, also when
    /// the rounds come back to back or after a pause.
    #[test]
    fn a_round_wakes_the_helpers_asleep() {
        for threads in [2, 3] {
            let team = Team::new(threads).expect("threads start");
            for round in 0..6 {
                if round % 2 == 0 {
                    std::thread::sleep(SPIN * 3);
                }
                let arrived = AtomicUsize::new(0);
                let mut meets: Vec<Meet> =
                    (0..threads).map(|_| Meet::of(&arrived, threads)).collect();
                let mut tasks: Vec<&mut dyn Task> =
                    meets.iter_mut().map(|m| m as &mut dyn Task).collect();
                team.run(&mut tasks);
                assert!(
                    meets.iter().all(|m| m.met),
                    "{threads} threads, round {round}"
                );
            }
        }
    }

    /// Panics when run.
    struct Boom;

    impl Task for Boom {
        fn run(&mut self) {
            panic!("boom");
        }
    }

    #[test]
    fn a_task_that_panics_makes_the_caller_panic_and_the_team_goes_on() {
        let team = Team::new(2).expect("threads start");
        let hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            let (mut a, mut b, mut c) = (Count(0), Boom, Count(0));
            team.run(&mut [&mut a, &mut b, &mut c]);
        }));
        std::panic::set_hook(hook);
        assert!(outcome.is_err());
        let mut counts: Vec<Count> = (0..5).map(|_| Count(0)).collect();
        let mut tasks: Vec<&mut dyn Task> = counts.iter_mut().map(|c| c as &mut dyn Task).collect();
        team.run(&mut tasks);
        assert!(counts.iter().all(|c| c.0 == 1));
    }

    #[test]
    fn one_thread_is_no_team() {
        assert!(Team::new(1).is_none());
        assert!(Team::new(0).is_none());
    }
}
