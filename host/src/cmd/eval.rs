//! `vsaqem eval POINTS MESH`: how well a mesh fits the point cloud it came from.

use crate::eval::{
    evaluate, Evaluation, Quality, Stats, Topology, Validity, DEFAULT_SAMPLES, FAR_FRACTION,
};
use crate::io::{read_cloud, read_mesh};
use crate::limits::{at_most, MAX_EVAL_SAMPLES};
use crate::progress::ms;
use crate::report::report_json;
use crate::stdout;
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// `vsaqem eval`.
#[derive(Args, Debug)]
pub struct Cmd {
    /// The input point cloud (any format `reconstruct` reads: .ply, .xyz/.xyzn/.txt/
    /// .pts/.csv, .pcd, .las/.laz, .e57, .obj, .off, .stl), at most 4 GiB.
    pub points: PathBuf,
    /// The mesh to measure (.ply, .obj, .off, .stl), at most 4 GiB.
    pub mesh: PathBuf,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Surface samples for the mesh -> points distances (seeded, area-uniform;
    /// at most 10,000,000).
    #[arg(long, default_value_t = DEFAULT_SAMPLES)]
    pub samples: usize,
    /// The genus the surface should have (0 for a sphere, 1 for a torus): the
    /// "valid solid" verdict then also requires the closed components' genera to sum
    /// to it.
    #[arg(long, value_name = "G")]
    pub expect_genus: Option<u64>,
}

/// Run the command.
pub fn run(cmd: &Cmd) -> Result<(), String> {
    at_most(
        "--samples",
        cmd.samples as u64,
        MAX_EVAL_SAMPLES as u64,
        "surface samples",
    )?;
    let t = Instant::now();
    let cloud = read_cloud(&cmd.points).map_err(|e| e.to_string())?;
    let (vertices, triangles) = read_mesh(&cmd.mesh).map_err(|e| e.to_string())?;
    if triangles.is_empty() {
        return Err(format!(
            "{}: the mesh has no faces ({} vertices)",
            cmd.mesh.display(),
            vertices.len()
        ));
    }
    let read_ms = ms(t.elapsed());
    let t = Instant::now();
    let evaluation = evaluate(&cloud.positions, &vertices, &triangles, cmd.samples);
    let eval_ms = ms(t.elapsed());
    let report = EvalReport {
        points_file: cmd.points.display().to_string(),
        mesh_file: cmd.mesh.display().to_string(),
        evaluation,
        expect_genus: cmd.expect_genus,
        read_ms,
        eval_ms,
    };
    if cmd.json {
        stdout::print(&report.json()?)
    } else {
        stdout::print(&report.text())
    }
}

/// The report of a run, filled once: the text and the JSON read only this.
pub struct EvalReport {
    /// The point cloud, as named on the command line.
    pub points_file: String,
    /// The mesh, as named on the command line.
    pub mesh_file: String,
    /// What was measured.
    pub evaluation: Evaluation,
    /// The genus asked for with `--expect-genus`, if any.
    pub expect_genus: Option<u64>,
    /// Time to read both files, in milliseconds.
    pub read_ms: f64,
    /// Time to evaluate, in milliseconds.
    pub eval_ms: f64,
}

/// `d` as "0.123% (1.234e-4)": percent of the diagonal, then file units.
fn dist(e: &Evaluation, d: f64) -> String {
    format!("{:.4}% ({d:.4e})", 100.0 * e.rel(d))
}

/// `v` as `[a, b, c]`, at most `MAX` items then the number left out.
fn list(v: &[u32]) -> String {
    const MAX: usize = 10;
    let items: Vec<String> = v.iter().take(MAX).map(u32::to_string).collect();
    let more = if v.len() > MAX {
        format!(", ... +{} more", v.len() - MAX)
    } else {
        String::new()
    };
    format!("[{}{more}]", items.join(", "))
}

impl EvalReport {
    /// The verdict, with the genus asked for if any.
    pub fn valid_solid(&self) -> bool {
        self.evaluation.is_valid_solid(self.expect_genus)
    }

    /// "yes", "no", and why the genus alone fails or passes when one was asked for.
    fn verdict(&self) -> String {
        let yes = if self.valid_solid() { "yes" } else { "no" };
        match self.expect_genus {
            None => yes.into(),
            Some(g) => {
                let h = self.evaluation.validity.handles();
                if h == g {
                    format!("{yes} (genus {h} as expected)")
                } else {
                    format!("{yes} (genus {h}, expected {g})")
                }
            }
        }
    }

    /// The text report: one line per group.
    pub fn text(&self) -> String {
        let e = &self.evaluation;
        let (read_ms, eval_ms) = (self.read_ms, self.eval_ms);
        let t = &e.topology;
        let p = &e.point_to_mesh.stats;
        let m = &e.mesh_to_points;
        let q = &e.quality;
        let v = &e.validity;
        let yes = |b: bool| if b { "yes" } else { "no" };
        format!(
            "input         {}: {} points, bounding-box diagonal {:.6}; {}: {} vertices, {} faces\n\
             points->mesh  max {}, mean {}, rms {}, p99 {}; {} points farther than {}% of the diagonal\n\
             mesh->points  {} samples: max {}, mean {}\n\
             chamfer       {}, hausdorff {}\n\
             topology      V {} (+{} unreferenced), E {}, F {}, Euler {}, components {}, boundary edges {}, \
             non-manifold edges {}, non-manifold vertices {}, inconsistent edges {}, degenerate faces {}, \
             duplicate faces {}, invalid faces {}; closed manifold: {}\n\
             validity      self-intersecting pairs {}, coincident vertices {}, folded edges {}, \
             bubbles {} ({} faces), closed components {}, genus {}; valid solid: {}\n\
             volume        {:.6e} (signed: {})\n\
             min angle     min {:.2}°, p1 {:.2}°, p5 {:.2}°, median {:.2}°\n\
             time          read {read_ms:.1} ms, evaluate {eval_ms:.1} ms\n",
            self.points_file,
            e.points,
            e.diagonal,
            self.mesh_file,
            t.vertices,
            t.faces,
            dist(e, p.max),
            dist(e, p.mean),
            dist(e, p.rms),
            dist(e, p.p99),
            e.point_to_mesh.far,
            FAR_FRACTION * 100.0,
            m.count,
            dist(e, m.max),
            dist(e, m.mean),
            dist(e, e.chamfer),
            dist(e, e.hausdorff),
            t.referenced_vertices,
            t.unreferenced_vertices,
            t.edges,
            t.faces - t.invalid_faces,
            t.euler,
            t.components,
            t.boundary_edges,
            t.non_manifold_edges,
            t.non_manifold_vertices,
            t.inconsistent_edges,
            t.degenerate_faces,
            t.duplicate_faces,
            t.invalid_faces,
            yes(t.is_closed_manifold()),
            v.crossings_text(),
            v.coincident_vertices,
            v.folded_edges,
            v.bubbles,
            v.bubble_faces,
            v.closed_components,
            list(&v.genus),
            self.verdict(),
            e.signed_volume,
            if e.signed_volume >= 0.0 {
                "faces point outwards if closed"
            } else {
                "faces point inwards if closed"
            },
            q.min,
            q.p1,
            q.p5,
            q.p50,
        )
    }

    /// The JSON report: every number of [`Evaluation`], distances also relative.
    pub fn json(&self) -> Result<String, String> {
        let e = &self.evaluation;
        let (t, v) = (&e.topology, &e.validity);
        report_json(&EvalJson {
            points_file: &self.points_file,
            mesh_file: &self.mesh_file,
            points: e.points,
            diagonal: e.diagonal,
            point_to_mesh: ToMesh {
                distance: StatsJson::new(e, &e.point_to_mesh.stats),
                far: e.point_to_mesh.far,
                far_threshold_relative: FAR_FRACTION,
            },
            mesh_to_points: StatsJson::new(e, &e.mesh_to_points),
            chamfer: e.chamfer,
            chamfer_relative: e.rel(e.chamfer),
            hausdorff: e.hausdorff,
            hausdorff_relative: e.rel(e.hausdorff),
            signed_volume: e.signed_volume,
            topology: TopologyJson {
                topology: t,
                closed_manifold: t.is_closed_manifold(),
            },
            validity: ValidityJson {
                validity: v,
                handles: v.handles(),
                expected_genus: self.expect_genus,
                valid_solid: self.valid_solid(),
            },
            quality: &e.quality,
            time_ms: Times {
                read: self.read_ms,
                evaluate: self.eval_ms,
            },
        })
    }
}

/// The JSON of an [`EvalReport`]: its numbers, each distance also relative to
/// the diagonal, the verdicts beside the counts they come from.
#[derive(Serialize)]
struct EvalJson<'a> {
    points_file: &'a str,
    mesh_file: &'a str,
    points: usize,
    diagonal: f64,
    point_to_mesh: ToMesh<'a>,
    mesh_to_points: StatsJson<'a>,
    chamfer: f64,
    chamfer_relative: f64,
    hausdorff: f64,
    hausdorff_relative: f64,
    signed_volume: f64,
    topology: TopologyJson<'a>,
    validity: ValidityJson<'a>,
    quality: &'a Quality,
    time_ms: Times,
}

#[derive(Serialize)]
struct ToMesh<'a> {
    distance: StatsJson<'a>,
    far: usize,
    far_threshold_relative: f64,
}

/// [`Stats`] in file units, then relative to the diagonal.
#[derive(Serialize)]
struct StatsJson<'a> {
    #[serde(flatten)]
    stats: &'a Stats,
    max_relative: f64,
    mean_relative: f64,
    rms_relative: f64,
    p99_relative: f64,
}

impl<'a> StatsJson<'a> {
    fn new(e: &Evaluation, s: &'a Stats) -> Self {
        StatsJson {
            stats: s,
            max_relative: e.rel(s.max),
            mean_relative: e.rel(s.mean),
            rms_relative: e.rel(s.rms),
            p99_relative: e.rel(s.p99),
        }
    }
}

#[derive(Serialize)]
struct TopologyJson<'a> {
    #[serde(flatten)]
    topology: &'a Topology,
    closed_manifold: bool,
}

#[derive(Serialize)]
struct ValidityJson<'a> {
    #[serde(flatten)]
    validity: &'a Validity,
    handles: u64,
    expected_genus: Option<u64>,
    valid_solid: bool,
}

#[derive(Serialize)]
struct Times {
    read: f64,
    evaluate: f64,
}
