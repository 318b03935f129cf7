//! `vsaqem render MESH... -o FILE.png`: look at meshes (side by side when several).
//! `-o -` writes the PNG to standard output (and the line saying so to standard error).

use crate::io::{is_stdio, read_cloud, read_mesh, stage_to};
use crate::outputs::check_targets;
use crate::render::{
    check_point_radius, check_size, hstack, render_mesh, write_png, RenderOptions, Up, View,
    MAX_SAMPLES,
};
use crate::report::publish;
use clap::Args;
use std::path::{Path, PathBuf};

/// `vsaqem render`.
#[derive(Args, Debug)]
pub struct Cmd {
    /// Meshes to render (.ply, .obj, .off, .stl); several are put side by side, labelled
    /// with their file names and framed alike.
    #[arg(required = true)]
    pub meshes: Vec<PathBuf>,
    /// Output PNG; - writes it to standard output.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Size of each image, WIDTHxHEIGHT: each 1 to 8192, and WIDTH x HEIGHT x
    /// SUPERSAMPLE^2, as well as the pixels of all panels side by side, at most
    /// 67,108,864 (8192x8192).
    #[arg(long, default_value = "800x800", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Camera: front, side, top or iso (three-quarter view from front-right-top).
    #[arg(long, default_value = "iso", value_parser = parse_view)]
    pub view: View,
    /// The models' up axis: x, y, z, -x, -y or -z.
    #[arg(long, default_value = "y", value_parser = parse_up)]
    pub up: Up,
    /// Draw the triangle edges.
    #[arg(long)]
    pub wireframe: bool,
    /// Overlay this point cloud as red dots (depth-tested).
    #[arg(long)]
    pub points: Option<PathBuf>,
    /// Radius of the overlay dots in pixels, 0 to 64.
    #[arg(long, default_value_t = RenderOptions::default().point_radius,
          value_parser = parse_radius)]
    pub point_radius: f64,
    /// Mild perspective instead of an orthographic camera.
    #[arg(long)]
    pub perspective: bool,
    /// Antialiasing: samples per pixel along each axis (1 to 4; 1 = off).
    #[arg(long, default_value_t = RenderOptions::default().supersample)]
    pub supersample: u32,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("size '{s}': expected WIDTHxHEIGHT, e.g. 800x600");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    Ok((w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?))
}

fn parse_radius(s: &str) -> Result<f64, String> {
    let r: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number of pixels"))?;
    check_point_radius(r).map_err(|e| e.to_string())?;
    Ok(r)
}

fn parse_view(s: &str) -> Result<View, String> {
    View::from_name(s).ok_or_else(|| format!("unknown view '{s}': use front, side, top or iso"))
}

fn parse_up(s: &str) -> Result<Up, String> {
    Up::from_name(s).ok_or_else(|| format!("unknown up axis '{s}': use x, y, z, -x, -y or -z"))
}

/// Run the command.
pub fn run(cmd: &Cmd) -> Result<(), String> {
    let (width, height) = cmd.size;
    check_size(width, height, cmd.supersample).map_err(|e| e.to_string())?;
    let pixels = u64::from(width) * u64::from(height) * cmd.meshes.len() as u64;
    if cmd.meshes.len() > 1 && pixels > MAX_SAMPLES {
        return Err(format!(
            "{} meshes side by side at {width}x{height} make {pixels} pixels, more than the \
             limit of {MAX_SAMPLES}: give a smaller --size",
            cmd.meshes.len()
        ));
    }
    // Before any mesh is read: an output that cannot be written, or that is
    // one of the inputs, fails at once.
    let inputs: Vec<&Path> = cmd
        .meshes
        .iter()
        .chain(&cmd.points)
        .map(PathBuf::as_path)
        .collect();
    check_targets(&inputs, &cmd.output, None)?;
    let mut meshes = Vec::with_capacity(cmd.meshes.len());
    for path in &cmd.meshes {
        meshes.push(read_mesh(path).map_err(|e| e.to_string())?);
    }
    let points = match &cmd.points {
        Some(p) => Some(read_cloud(p).map_err(|e| e.to_string())?.positions),
        None => None,
    };
    let mut opts = RenderOptions {
        width: cmd.size.0,
        height: cmd.size.1,
        view: cmd.view,
        up: cmd.up,
        perspective: cmd.perspective,
        wireframe: cmd.wireframe,
        supersample: cmd.supersample,
        point_radius: cmd.point_radius,
        fit: None,
    };
    if meshes.len() > 1 {
        // One framing for all, so the panels compare.
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (v, t) in &meshes {
            for &i in t.iter().flatten() {
                for a in 0..3 {
                    lo[a] = lo[a].min(v[i as usize][a]);
                    hi[a] = hi[a].max(v[i as usize][a]);
                }
            }
        }
        opts.fit = lo[0].is_finite().then_some((lo, hi));
    }
    let mut images = Vec::with_capacity(meshes.len());
    for ((v, t), path) in meshes.iter().zip(&cmd.meshes) {
        let img = render_mesh(v, t, points.as_deref(), &opts)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        images.push(img);
    }
    let img = if images.len() == 1 {
        images.pop().expect("one image")
    } else {
        let names: Vec<String> = cmd
            .meshes
            .iter()
            .map(|p| {
                p.file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        let labels: Vec<&str> = names.iter().map(String::as_str).collect();
        hstack(&images, Some(&labels))
    };
    let staged = stage_to(&cmd.output, |w| write_png(w, &img))?;
    let done = if is_stdio(&cmd.output) {
        format!(
            "wrote the PNG to standard output ({}x{})\n",
            img.width, img.height
        )
    } else {
        format!(
            "wrote {} ({}x{})\n",
            cmd.output.display(),
            img.width,
            img.height
        )
    };
    // As the other commands' reports: the line goes to stderr when the PNG
    // is on stdout, and the file is put in place only once the line is out.
    publish(&done, &cmd.output, staged, None, || Ok(String::new()))
}
