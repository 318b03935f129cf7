//! `vsaqem`: point cloud to compact, feature-preserving mesh by VSA-QEM.

use clap::{Parser, Subcommand};
use std::process::ExitCode;
use vsaqem::cmd;

#[derive(Parser)]
#[command(name = "vsaqem", version, about = "Point cloud to compact, feature-preserving mesh (VSA-QEM)", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Cluster a point cloud and write the points coloured by cluster plus the
    /// generators (the paper's "input points after clustering").
    Cluster(cmd::cluster::Cmd),
    /// Reconstruct a mesh from a point cloud (without INPUT: a built-in sample).
    Reconstruct(cmd::reconstruct::Cmd),
    /// Measure a mesh against a point cloud: distances both ways, topology, triangle
    /// quality.
    Eval(cmd::eval::Cmd),
    /// Render a mesh (optionally with points and wireframe) to a PNG image.
    Render(cmd::render::Cmd),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Cluster(c) => cmd::cluster::run(c),
        Command::Reconstruct(c) => cmd::reconstruct::run(c),
        Command::Eval(c) => cmd::eval::run(c),
        Command::Render(c) => cmd::render::run(c),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
