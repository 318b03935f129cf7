//! The parts the `cluster` and `reconstruct` reports share: what was read and what
//! cleaning left of it ([`InputReport`], [`CleanReport`]), and what the run took and
//! where it wrote ([`RunReport`]). Each command's report struct holds them beside
//! its own numbers, filled once from the run's results; its text and its JSON read
//! only that struct, so the two cannot disagree.

use crate::input::Prepared;
use crate::json::Obj;
use crate::progress::{StageClock, Timings};
use std::path::Path;
use vsaqem_core::{CleanStats, ClusterStats, Params};

/// What was read, and what the cleaning pre-pass left for core.
#[derive(Clone, Debug)]
pub struct InputReport {
    /// What the points are (a file name or the sample's description).
    pub name: String,
    /// Points read, before cleaning.
    pub points_read: usize,
    /// Points the reader skipped as invalid (NaN or infinite coordinates in a PCD
    /// or LAS file), not counted in `points_read`.
    pub invalid_skipped: usize,
    /// Points after cleaning: those core worked on.
    pub points: usize,
    /// Whether the input gave normals (else core estimates them).
    pub normals_given: bool,
    /// Bounding-box diagonal of the points core worked on, in file units.
    pub diagonal: f64,
    /// The cleaning pre-pass.
    pub clean: CleanReport,
}

impl InputReport {
    /// The report of `input` as core got it: `points_read` points before cleaning,
    /// `clean` what cleaning with `params` removed (`None`: it did not run), `diag`
    /// core's bounding-box diagonal (core units).
    pub fn new(
        input: &Prepared,
        points_read: usize,
        clean: Option<&CleanStats>,
        params: &Params,
        diag: f32,
    ) -> Self {
        InputReport {
            name: input.name.clone(),
            points_read,
            invalid_skipped: input.invalid,
            points: input.points.len(),
            normals_given: input.normals.is_some(),
            diagonal: diag as f64 * input.frame.scale,
            clean: CleanReport::new(clean, params),
        }
    }

    /// The `input` and `clean` lines.
    pub fn text(&self) -> String {
        let normals = if self.normals_given {
            "normals given"
        } else {
            "normals by PCA"
        };
        let invalid = match self.invalid_skipped {
            0 => String::new(),
            n => format!(" ({n} invalid skipped)"),
        };
        format!(
            "input      {}: {} points{invalid}, {normals}, bounding-box diagonal {:.6}\n\
             clean      {}\n",
            self.name,
            self.points_read,
            self.diagonal,
            self.clean.text(self.points, self.points_read),
        )
    }

    /// `input`, `points`, `normals_given`, `diagonal`, `points_read`,
    /// `invalid_skipped`, then the cleaning fields.
    pub fn json(&self, o: &mut Obj) {
        o.str("input", &self.name)
            .num("points", self.points as f64)
            .bool("normals_given", self.normals_given)
            .num("diagonal", self.diagonal)
            .num("points_read", self.points_read as f64)
            .num("invalid_skipped", self.invalid_skipped as f64);
        self.clean.json(o);
    }
}

/// The cleaning pre-pass: its settings and what its filters removed.
#[derive(Clone, Copy, Debug)]
pub struct CleanReport {
    /// `--outliers`, in standard deviations (0: filter off).
    pub outlier_sigma: f32,
    /// `--min-fragment`, in points (0: filter off).
    pub min_fragment: u32,
    /// What the filters removed; `None` when both are off.
    pub counts: Option<CleanCounts>,
}

/// What the cleaning filters removed (from [`CleanStats`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct CleanCounts {
    /// Points removed by the outlier filter.
    pub outliers_removed: u32,
    /// Pieces dropped as fragments.
    pub fragments_dropped: u32,
    /// Points in the dropped fragments.
    pub fragment_points: u32,
    /// Pieces kept (0 when the fragment filter is off).
    pub pieces: u32,
}

impl CleanReport {
    /// The report of cleaning with `params`, which gave `stats` (`None`: it did
    /// not run).
    pub fn new(stats: Option<&CleanStats>, params: &Params) -> Self {
        CleanReport {
            outlier_sigma: params.outlier_sigma,
            min_fragment: params.min_fragment,
            counts: stats.map(|s| CleanCounts {
                outliers_removed: s.outliers,
                fragments_dropped: s.fragments,
                fragment_points: s.fragment_points,
                pieces: s.pieces,
            }),
        }
    }

    /// The `clean` line without its label, when `kept` of the `read` points were
    /// kept.
    pub fn text(&self, kept: usize, read: usize) -> String {
        let Some(s) = self.counts else {
            return "off".to_string();
        };
        let outliers = if self.outlier_sigma > 0.0 {
            format!(
                "{} removed (over {} standard deviations)",
                count(s.outliers_removed, "outlier"),
                self.outlier_sigma
            )
        } else {
            "outlier filter off".to_string()
        };
        let (fragments, pieces) = if self.min_fragment > 0 {
            (
                format!(
                    "{} dropped ({}; pieces under {} points)",
                    count(s.fragments_dropped, "fragment"),
                    count(s.fragment_points, "point"),
                    self.min_fragment
                ),
                format!(" in {}", count(s.pieces, "piece")),
            )
        } else {
            ("fragment filter off".to_string(), String::new())
        };
        format!("{outliers}, {fragments}; {kept} of {read} points kept{pieces}")
    }

    /// `outlier_sigma`, `min_fragment`, `outliers_removed`, `fragments_dropped`,
    /// `fragment_points` (counts 0 when cleaning is off).
    pub fn json(&self, o: &mut Obj) {
        let s = self.counts.unwrap_or_default();
        o.num("outlier_sigma", self.outlier_sigma as f64)
            .num("min_fragment", self.min_fragment as f64)
            .num("outliers_removed", s.outliers_removed as f64)
            .num("fragments_dropped", s.fragments_dropped as f64)
            .num("fragment_points", s.fragment_points as f64);
    }
}

/// `"1 point"`, `"3 points"`.
fn count(n: u32, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}

/// The clustering error fields both reports give: `max_error_relative`,
/// `tolerance_relative` (`tolerance`, as asked), `tolerance_used_relative`,
/// `noise_floor_relative`, all relative to the diagonal; `tolerance_met`
/// (the largest error within the tolerance used) and `cluster_cap` (`cap`).
pub fn error_json(o: &mut Obj, c: &ClusterStats, tolerance: f32, cap: u32) {
    o.num("max_error_relative", c.max_error as f64)
        .num("tolerance_relative", tolerance as f64)
        .num("tolerance_used_relative", c.tolerance as f64)
        .num("noise_floor_relative", c.noise as f64)
        .bool("tolerance_met", c.max_error <= c.tolerance)
        .num("cluster_cap", cap as f64);
}

/// When clustering ended with its largest error above the tolerance used:
/// what the report says, with why splitting stopped (the cluster cap `cap`, or
/// all `split_rounds` batches run), and whether the cap is the reason (then
/// the run warns on stderr too: more clusters were wanted than allowed).
pub fn tolerance_unmet(c: &ClusterStats, cap: u32, split_rounds: u32) -> Option<(String, bool)> {
    if c.max_error.is_nan() || c.max_error <= c.tolerance || c.tolerance <= 0.0 {
        return None;
    }
    // Splitting's own clusters: refinement runs after it (and may go beyond
    // the cap at the rims of gaps).
    let at_cap = c.initial_clusters.saturating_add(c.splits) >= cap;
    let why = if at_cap {
        format!("the cluster cap {cap} is reached (raise --max-clusters)")
    } else if c.split_rounds + c.rejected_batches >= split_rounds {
        format!("splitting ran its {split_rounds} batches (--split-rounds)")
    } else {
        "no split was left that lowers it".to_string()
    };
    let text = format!("tolerance {:.3}% not met: {why}", c.tolerance * 100.0);
    Some((text, at_cap))
}

/// What a run took (time, arena) and where it wrote.
#[derive(Clone, Debug)]
pub struct RunReport {
    /// Time per stage and in total.
    pub timings: Timings,
    /// Arena peak in bytes.
    pub arena_peak: usize,
    /// Arena size in bytes (the `--memory` budget, or what the run can need).
    pub arena_reserved: usize,
    /// The least `--memory` this run would have taken: what core bounds for
    /// this cloud once its neighbour graph is known, and the pre-passes.
    pub arena_needed: usize,
    /// The output file.
    pub output: String,
}

impl RunReport {
    /// The report of a run timed by `clock` (taken now: call it last), with an
    /// arena of `arena_reserved` bytes that peaked at `arena_peak` where
    /// `arena_needed` would have done, written to `output`.
    pub fn new(
        clock: &StageClock,
        arena_peak: usize,
        arena_reserved: usize,
        arena_needed: usize,
        output: &Path,
    ) -> Self {
        RunReport {
            timings: clock.timings(),
            arena_peak,
            arena_reserved,
            arena_needed,
            output: output.display().to_string(),
        }
    }

    /// The `time`, `memory` and `output` lines: `points` are those core worked on,
    /// `note` follows the output's name.
    pub fn text(&self, points: usize, note: &str) -> String {
        format!(
            "time       {}\n\
             memory     arena peak {} bytes ({:.1} bytes/point), {} reserved, {} needed\n\
             output     {}{note}\n",
            self.timings.summary(),
            self.arena_peak,
            self.arena_peak as f64 / points as f64,
            self.arena_reserved,
            self.arena_needed,
            self.output,
        )
    }

    /// `time_ms`, `arena_peak_bytes`, `arena_reserved_bytes`,
    /// `arena_needed_bytes`, `output`.
    pub fn json(&self, o: &mut Obj) {
        o.raw("time_ms", &self.timings.json())
            .num("arena_peak_bytes", self.arena_peak as f64)
            .num("arena_reserved_bytes", self.arena_reserved as f64)
            .num("arena_needed_bytes", self.arena_needed as f64)
            .str("output", &self.output);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fields(r: &CleanReport) -> String {
        let mut o = Obj::default();
        r.json(&mut o);
        o.finish()
    }

    #[test]
    fn the_clean_line_and_the_clean_fields_give_the_same_counts() {
        let stats = CleanStats {
            points: 6000,
            kept: 5957,
            outliers: 3,
            fragments: 1,
            fragment_points: 40,
            pieces: 2,
            ..CleanStats::default()
        };
        let params = Params {
            outlier_sigma: 2.0,
            min_fragment: 64,
            ..Params::default()
        };
        let r = CleanReport::new(Some(&stats), &params);
        assert_eq!(
            r.text(5957, 6000),
            "3 outliers removed (over 2 standard deviations), 1 fragment dropped \
             (40 points; pieces under 64 points); 5957 of 6000 points kept in 2 pieces"
        );
        assert_eq!(
            fields(&r),
            "{\n  \"outlier_sigma\": 2,\n  \"min_fragment\": 64,\n  \"outliers_removed\": 3,\
             \n  \"fragments_dropped\": 1,\n  \"fragment_points\": 40\n}"
        );
    }

    #[test]
    fn the_input_line_and_fields_give_the_invalid_points_skipped() {
        let params = Params {
            outlier_sigma: 0.0,
            min_fragment: 0,
            ..Params::default()
        };
        let mut r = InputReport {
            name: "scan.pcd".into(),
            points_read: 4000,
            invalid_skipped: 544,
            points: 4000,
            normals_given: false,
            diagonal: 2.0,
            clean: CleanReport::new(None, &params),
        };
        assert!(
            r.text().starts_with(
                "input      scan.pcd: 4000 points (544 invalid skipped), normals by PCA"
            ),
            "{}",
            r.text()
        );
        let mut o = Obj::default();
        r.json(&mut o);
        assert!(o.finish().contains("\"invalid_skipped\": 544"));
        r.invalid_skipped = 0;
        assert!(r
            .text()
            .starts_with("input      scan.pcd: 4000 points, normals"));
    }

    #[test]
    fn cleaning_off_reads_off_and_counts_nothing() {
        let params = Params {
            outlier_sigma: 0.0,
            min_fragment: 0,
            ..Params::default()
        };
        let r = CleanReport::new(None, &params);
        assert_eq!(r.text(100, 100), "off");
        assert!(fields(&r).contains("\"outliers_removed\": 0,\n  \"fragments_dropped\": 0"));
    }
}
