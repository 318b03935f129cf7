//! The cleaning pre-pass of `cluster` and `reconstruct`: the outlier and fragment
//! filters of `vsaqem_core::clean`, then smoothing, each in a buffer of its own;
//! and [`read_and_clean`], the start both commands share.

use crate::args::{arena_buffer, read_input, InputArgs, MemoryArgs};
use crate::input::Prepared;
use crate::progress::StageClock;
use std::mem::MaybeUninit;
use vsaqem_core::{Arena, CleanStats, Degeneracy, Error, Params, Rows};

/// The points of a run, read and cleaned, and the arena buffer core runs in.
pub struct Cleaned {
    /// The points after the pre-pass.
    pub input: Prepared,
    /// Points read, exact duplicates merged, before cleaning (the points
    /// cleaning works on).
    pub points_read: usize,
    /// What the cleaning filters did (`None`: both are off).
    pub stats: Option<CleanStats>,
    /// The arena buffer: the `--memory` budget, or what the run and the pre-pass
    /// can need.
    pub buf: Vec<MaybeUninit<u8>>,
    /// The k-NN table cleaning searched, when it holds for `input` as it is
    /// (every point kept, none smoothed): the run takes it instead of
    /// searching again.
    pub rows: Option<KnnTable>,
}

/// A k-NN table the host keeps between cleaning and the run.
pub struct KnnTable {
    knn: Vec<u32>,
    linear_scans: u32,
}

impl KnnTable {
    /// The table as core takes it.
    pub fn rows(&self) -> Rows<'_> {
        Rows {
            knn: &self.knn,
            linear_scans: self.linear_scans,
        }
    }
}

/// What a command needs from the arena for `(points, params)`: at most (the
/// default buffer), and `(points, params, reverse-only edges, searched)` once
/// the neighbour graph is known (its least with no reverse-only edges).
#[derive(Clone, Copy)]
pub struct RunBytes {
    /// The worst case, e.g. `vsaqem_core::arena_bytes`.
    pub most: fn(usize, &Params) -> usize,
    /// For a known graph, e.g. `vsaqem_core::reconstruct_bytes_for`.
    pub least: fn(usize, &Params, usize, bool) -> usize,
}

/// Read the input, size the arena for a command that needs `run` and for the
/// pre-pass, checked against `--memory` before any work, then clean
/// ([`clean_input`]).
pub fn read_and_clean(
    input: &InputArgs,
    memory: &MemoryArgs,
    params: &Params,
    run: RunBytes,
    clock: &mut StageClock,
) -> Result<Cleaned, String> {
    input.check_limits()?;
    // The sizes are a function of the point count and the parameters.
    // The run takes cleaning's table (no search of its own) unless cleaning
    // is off or drops points, or smoothing moves them.
    let searched = !params.cleans() || params.smooth_rounds > 0;
    let arena_size = |n: usize| {
        let needed = with_clean((run.most)(n, params), n, params, false);
        let least = with_clean((run.least)(n, params, 0, searched), n, params, true);
        memory.arena_size(needed, least, n)
    };
    if input.input.is_none() {
        // A sample's count is known before it is made: no memory goes to
        // points that no arena could take.
        arena_size(input.points)?;
    }
    let input = read_input(input, clock)?;
    let n = input.points.len();
    // Every point read at one position: merged into one, it is that, not too
    // few points.
    if n == 1 && input.duplicates > 0 {
        let e = Error::Degenerate(Degeneracy::Coincident);
        return Err(format!("{}: {e}{}", input.name, merged(&input)));
    }
    // What core would refuse first (too few points, all in a plane, ...),
    // then a cluster count that no memory could serve.
    vsaqem_core::validate::check(&input.points, input.normals.as_deref(), params)
        .map_err(|e| format!("{}: {e}{}", input.name, merged(&input)))?;
    more_points_than_clusters(&input, params, "")?;
    let mut buf = arena_buffer(arena_size(n)?)?;
    let (input, stats, rows) =
        clean_input(input, params, &mut buf, clock).inspect_err(|_| clock.finish())?;
    more_points_than_clusters(&input, params, " left after cleaning")?;
    Ok(Cleaned {
        input,
        points_read: n,
        stats,
        buf,
        rows,
    })
}

/// An error naming both numbers when `--clusters` asks for more clusters than
/// `input` has points (`which` says which points they are): checked before
/// the arena is sized, so no memory error stands in for it.
fn more_points_than_clusters(input: &Prepared, params: &Params, which: &str) -> Result<(), String> {
    let n = input.points.len();
    if params.clusters as usize > n {
        return Err(format!(
            "{}: more clusters than points{which} ({} > {n}){}: give --clusters at most {n}",
            input.name,
            params.clusters,
            merged(input)
        ));
    }
    Ok(())
}

/// What merging exact duplicates left of the points read, for an error about
/// how few points there are: `" (4 distinct of 200000 read: 199996 exact
/// duplicates merged)"`, or nothing when there were none.
fn merged(input: &Prepared) -> String {
    let (d, n) = (input.duplicates, input.points.len());
    if d == 0 {
        return String::new();
    }
    format!(
        " ({n} distinct of {} read: {d} exact duplicates merged)",
        n + d
    )
}

impl RunBytes {
    /// The least `--memory` a run on `cleaned`'s points would have taken, with
    /// `reverse_edges` one-way edges in their neighbour graph, searched by core
    /// or not: the command's bound for that graph, and what the pre-passes
    /// need on the points read, cleaning with its k-NN table outside the arena
    /// (where the host keeps it).
    pub fn needed(
        self,
        cleaned: &Prepared,
        points_read: usize,
        params: &Params,
        reverse_edges: usize,
        searched: bool,
    ) -> usize {
        let run = (self.least)(cleaned.points.len(), params, reverse_edges, searched);
        with_clean(run, points_read, params, true)
    }
}

/// The arena a run on `n` points needs when `run` bytes are enough for the
/// command itself: also enough for the pre-passes when they are on (each runs
/// first, in a buffer of its own no larger than the budget), cleaning with its
/// k-NN table in the arena unless `table_outside` (the host's own table, as
/// [`filter_input`] gives it).
fn with_clean(run: usize, n: usize, params: &Params, table_outside: bool) -> usize {
    let run = run.max(vsaqem_core::smooth_bytes(n, params));
    if params.cleans() {
        run.max(vsaqem_core::clean_bytes_for(n, params, table_outside))
    } else {
        run
    }
}

/// The cleaning pre-pass (`vsaqem_core::clean`), then the kept points compacted
/// and normalised again, then `--smooth` rounds of smoothing. `None` when both
/// filters are off; the input is handed back untouched when nothing is removed
/// and nothing smoothed, so the output is then the same as without cleaning.
///
/// Each pre-pass gets a buffer of its own, at most `buf`'s size (the budget),
/// freed when it ends: working in `buf` would leave its pages resident beside
/// those the reconstruction then touches (1M points: 175 MB peak RSS instead of
/// 139 MB), while `buf`'s own pages stay untouched until the run uses them.
pub fn clean_input(
    input: Prepared,
    params: &Params,
    buf: &mut [MaybeUninit<u8>],
    clock: &mut StageClock,
) -> Result<(Prepared, Option<CleanStats>, Option<KnnTable>), String> {
    let budget = buf.len();
    let (mut input, stats, mut rows) = filter_input(input, params, budget, clock)?;
    if params.smooth_rounds > 0 {
        // The points move: their neighbours are searched again.
        rows = None;
        let need = vsaqem_core::smooth_bytes(input.points.len(), params);
        let mut own = arena_buffer(need.min(budget))?;
        let arena = Arena::new(&mut own);
        vsaqem_core::smooth(&arena, &mut input.points, params, clock)
            .map_err(|e| format!("{}: smoothing: {e}", input.name))?;
    }
    Ok((input, stats, rows))
}

/// The cleaning filters of [`clean_input`].
fn filter_input(
    input: Prepared,
    params: &Params,
    budget: usize,
    clock: &mut StageClock,
) -> Result<(Prepared, Option<CleanStats>, Option<KnnTable>), String> {
    if !params.cleans() {
        return Ok((input, None, None));
    }
    let need = vsaqem_core::clean_bytes_for(input.points.len(), params, true);
    let mut own = arena_buffer(need.min(budget))?;
    let arena = Arena::new(&mut own);
    let mut keep = vec![true; input.points.len()];
    // The table is the run's own k-NN table when every point stays; it is
    // allocated outside the arena, as the input is (4 k bytes per point).
    let mut knn = vec![0u32; input.points.len().saturating_mul(params.k)];
    let cleaned = vsaqem_core::clean_with_rows(
        &arena,
        &input.points,
        params,
        &mut keep,
        Some(&mut knn),
        clock,
    );
    let stats = match cleaned {
        Ok((s, scans)) => {
            if s.kept == s.points {
                let rows = scans.map(|linear_scans| KnnTable { knn, linear_scans });
                return Ok((input, Some(s), rows));
            }
            s
        }
        Err(e @ Error::TooFewKept { .. }) => {
            return Err(format!(
                "{}: {e} (--outliers {}, --min-fragment {})",
                input.name, params.outlier_sigma, params.min_fragment
            ))
        }
        Err(e) => return Err(format!("{}: {e}", input.name)),
    };
    Ok((input.keep(&keep), Some(stats), None))
}
