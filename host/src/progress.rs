//! Time per stage and a progress bar on stderr (only when stderr is a terminal),
//! and the threads core's parallel stages run on.

use crate::team::Team;
use serde::ser::{SerializeMap, Serializer};
use serde::Serialize;
use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};
use vsaqem_core::{Flow, Progress, Stage, Task};

/// Records when each core stage starts and ends, and draws a bar.
pub struct StageClock {
    started: Instant,
    current: Option<(Stage, Instant)>,
    /// `(stage name, duration)` in the order stages ran.
    pub times: Vec<(&'static str, Duration)>,
    bar: bool,
    last_draw: Option<Instant>,
    /// The threads core's parallel stages run on (none: the calling thread).
    team: Option<Team>,
}

impl StageClock {
    /// A clock that draws a bar when `show_bar` and stderr is a terminal.
    pub fn new(show_bar: bool) -> Self {
        StageClock {
            started: Instant::now(),
            current: None,
            times: Vec::new(),
            bar: show_bar && std::io::stderr().is_terminal(),
            last_draw: None,
            team: None,
        }
    }

    /// The same clock, running core's parallel stages on `threads` threads
    /// (the calling thread alone when 1, or when the threads cannot be
    /// started): the calling thread and a [`Team`] of helpers, started once,
    /// that wait for the next round actively for a moment (core hands over
    /// hundreds of short rounds a run).
    pub fn with_threads(self, threads: usize) -> Self {
        StageClock {
            team: Team::new(threads),
            ..self
        }
    }

    /// Close the running stage (call after core returns).
    pub fn finish(&mut self) {
        if let Some((stage, t)) = self.current.take() {
            self.times.push((stage.name(), t.elapsed()));
        }
        if self.bar && self.last_draw.is_some() {
            let _ = write!(std::io::stderr(), "\r\x1b[2K");
        }
    }

    /// Run `f` as the host-side stage `name` (reading, writing), recording its
    /// duration.
    pub fn time<T>(&mut self, name: &'static str, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let out = f();
        self.times.push((name, t.elapsed()));
        out
    }

    /// [`StageClock::time`] for work that may run tasks on the clock's
    /// threads: `f` is given a function that runs them.
    pub fn time_with_tasks<T>(
        &mut self,
        name: &'static str,
        f: impl FnOnce(&dyn Fn(&mut [&mut dyn Task])) -> T,
    ) -> T {
        let team = self.team.take();
        let out = self.time(name, || f(&|tasks| run_tasks(team.as_ref(), tasks)));
        self.team = team;
        out
    }

    /// Time since the clock was made.
    pub fn total(&self) -> Duration {
        self.started.elapsed()
    }

    /// Duration of a recorded stage.
    pub fn get(&self, name: &str) -> Duration {
        self.times
            .iter()
            .filter(|(n, _)| *n == name)
            .map(|(_, d)| *d)
            .sum()
    }

    /// Time per stage name, in order of first appearance (a stage run in several
    /// rounds, like selection during refinement, is summed).
    pub fn stages(&self) -> Vec<(&'static str, Duration)> {
        let mut out: Vec<(&'static str, Duration)> = Vec::new();
        for &(k, d) in &self.times {
            match out.iter_mut().find(|(n, _)| *n == k) {
                Some((_, t)) => *t += d,
                None => out.push((k, d)),
            }
        }
        out
    }

    /// The stage times and the total so far, taken once for the reports.
    pub fn timings(&self) -> Timings {
        Timings {
            stages: self.stages(),
            total: self.total(),
        }
    }

    fn draw(&mut self, stage: Stage, done: u64, total: u64) {
        let now = Instant::now();
        if let Some(t) = self.last_draw {
            if now - t < Duration::from_millis(80) && done < total {
                return;
            }
        }
        self.last_draw = Some(now);
        let frac = if total > 0 {
            (done as f64 / total as f64).min(1.0)
        } else {
            0.0
        };
        let width = 30;
        let fill = (frac * width as f64) as usize;
        let _ = write!(
            std::io::stderr(),
            "\r\x1b[2K{:<11} [{}{}] {:>3}%",
            stage.name(),
            "#".repeat(fill),
            "-".repeat(width - fill),
            (frac * 100.0) as u32
        );
    }
}

impl Progress for StageClock {
    fn report(&mut self, stage: Stage, done: u64, total: u64) -> Flow {
        match self.current {
            Some((s, _)) if s == stage => {}
            _ => {
                if let Some((s, t)) = self.current.take() {
                    self.times.push((s.name(), t.elapsed()));
                }
                self.current = Some((stage, Instant::now()));
            }
        }
        if self.bar {
            self.draw(stage, done, total);
        }
        Flow::Continue
    }

    fn run(&self, tasks: &mut [&mut dyn Task]) {
        run_tasks(self.team.as_ref(), tasks);
    }

    fn threads(&self) -> usize {
        self.team.as_ref().map_or(1, |t| t.threads())
    }
}

/// Runs each task once, on the threads of `team` or, without one, one after
/// another on the calling thread. Which thread runs a task does not matter:
/// core combines the tasks' results in task order.
pub fn run_tasks(team: Option<&Team>, tasks: &mut [&mut dyn Task]) {
    match team {
        Some(team) => team.run(tasks),
        None => tasks.iter_mut().for_each(|t| t.run()),
    }
}

/// The stage times of a run, taken once ([`StageClock::timings`]), so the text and
/// the JSON report of the run show the same numbers.
#[derive(Clone, Debug)]
pub struct Timings {
    /// Time per stage name, in order of first appearance ([`StageClock::stages`]).
    pub stages: Vec<(&'static str, Duration)>,
    /// Time from the clock's start to when the timings were taken.
    pub total: Duration,
}

impl Timings {
    /// `"read 1.2 ms, neighbours 30.4 ms, ..., total 95.0 ms"`.
    pub fn summary(&self) -> String {
        let mut parts: Vec<String> = self
            .stages
            .iter()
            .map(|(k, d)| format!("{k} {:.1} ms", ms(*d)))
            .collect();
        parts.push(format!("total {:.1} ms", ms(self.total)));
        parts.join(", ")
    }
}

/// The stage times in milliseconds (to the microsecond) as one JSON object, in
/// the order the stages ran, then `total`.
impl Serialize for Timings {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let us = |d: Duration| (ms(d) * 1e3).round() / 1e3;
        let mut map = s.serialize_map(Some(self.stages.len() + 1))?;
        for (k, d) in &self.stages {
            map.serialize_entry(k, &us(*d))?;
        }
        map.serialize_entry("total", &us(self.total))?;
        map.end()
    }
}

/// A duration in milliseconds.
pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
