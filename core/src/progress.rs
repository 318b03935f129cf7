//! The caller's hooks into a run: progress reporting, cancellation and threads.
//! The caller implements [`Progress`].

use crate::parallel::Task;

/// Pipeline stages, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Stage {
    /// The optional cleaning pre-pass ([`crate::clean()`]): neighbours, outliers,
    /// fragments.
    Clean,
    /// Input checks (finite, enough points, not degenerate).
    Validate,
    /// Grid and k nearest neighbours.
    Neighbours,
    /// Normals, support areas and plane quadrics.
    Quadrics,
    /// Partition, generator update and batch splitting.
    Clustering,
    /// Candidate edges and facets.
    Candidates,
    /// Facet fitting and coverage scores.
    Scoring,
    /// Exact facet selection (branch-and-bound).
    Selection,
    /// Orientation and manifold output.
    Output,
}

impl Stage {
    /// A short lower-case name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Clean => "clean",
            Stage::Validate => "validate",
            Stage::Neighbours => "neighbours",
            Stage::Quadrics => "quadrics",
            Stage::Clustering => "clustering",
            Stage::Candidates => "candidates",
            Stage::Scoring => "scoring",
            Stage::Selection => "selection",
            Stage::Output => "output",
        }
    }
}

/// What the callback wants next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Go on.
    Continue,
    /// Stop with `Error::Cancelled`.
    Cancel,
}

/// Receives `(stage, done, total)` at stage boundaries and every few thousand items
/// of work; returning [`Flow::Cancel`] makes the run stop with `Error::Cancelled`
/// at the next report. `done == total` marks the end of a stage. Units of `done`
/// are stage-specific (points, or partition passes for clustering).
///
/// [`Progress::run`] is how a caller lends core its threads: core cuts each
/// parallel stage into independent tasks ([`crate::parallel`]) and hands them
/// here. The default runs them one after another on the calling thread. The
/// result never depends on how they are run.
pub trait Progress {
    /// Called at stage boundaries and periodically within a stage.
    fn report(&mut self, stage: Stage, done: u64, total: u64) -> Flow;

    /// Runs every task of `tasks` exactly once, on any threads, in any order,
    /// and returns when all have finished.
    fn run(&self, tasks: &mut [&mut dyn Task]) {
        for t in tasks.iter_mut() {
            t.run();
        }
    }

    /// How many tasks [`Progress::run`] runs at once (the default: 1, one
    /// after another). Core may pick the way it cuts a stage's work by it
    /// (region growing runs in two halves from 2 on); the result never
    /// depends on it.
    fn threads(&self) -> usize {
        1
    }
}

/// A [`Progress`] that never reports and never cancels.
pub struct Silent;

impl Progress for Silent {
    fn report(&mut self, _: Stage, _: u64, _: u64) -> Flow {
        Flow::Continue
    }
}

/// A [`Progress`] for tests that runs the tasks last first: a result that
/// depends on the order of the tasks shows as a difference from [`Silent`].
#[cfg(test)]
pub(crate) struct Backwards;

#[cfg(test)]
impl Progress for Backwards {
    fn report(&mut self, _: Stage, _: u64, _: u64) -> Flow {
        Flow::Continue
    }

    fn run(&self, tasks: &mut [&mut dyn Task]) {
        tasks.iter_mut().rev().for_each(|t| t.run());
    }
}

/// A [`Progress`] for tests that claims `threads` threads but runs the tasks
/// one after another on the calling thread, last first when `backwards`: a
/// stage takes its many-thread ways, and a result that depends on the order of
/// the tasks shows. Counts the rounds of exactly `threads` tasks.
#[cfg(test)]
pub(crate) struct Claimed {
    pub threads: usize,
    pub backwards: bool,
    pub full_rounds: core::cell::Cell<u32>,
}

#[cfg(test)]
impl Claimed {
    /// `threads` claimed, the tasks run last first.
    pub fn backwards(threads: usize) -> Self {
        Claimed {
            threads,
            backwards: true,
            full_rounds: core::cell::Cell::new(0),
        }
    }
}

#[cfg(test)]
impl Progress for Claimed {
    fn report(&mut self, _: Stage, _: u64, _: u64) -> Flow {
        Flow::Continue
    }

    fn run(&self, tasks: &mut [&mut dyn Task]) {
        if tasks.len() == self.threads {
            self.full_rounds.set(self.full_rounds.get() + 1);
        }
        if self.backwards {
            tasks.iter_mut().rev().for_each(|t| t.run());
        } else {
            tasks.iter_mut().for_each(|t| t.run());
        }
    }

    fn threads(&self) -> usize {
        self.threads
    }
}

/// Forward a report, turning a cancel request into an error.
pub(crate) fn tick(p: &mut dyn Progress, stage: Stage, done: u64, total: u64) -> crate::Result<()> {
    match p.report(stage, done, total) {
        Flow::Continue => Ok(()),
        Flow::Cancel => Err(crate::Error::Cancelled),
    }
}
