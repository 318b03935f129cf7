//! The command line: the subcommands, how a parse error or a help text leaves
//! the process, and the shell completions and man pages made from the same
//! definition (`vsaqem completions SHELL`, `vsaqem man`).

use crate::cmd;
use crate::io::write_atomic;
use crate::stdout;
use clap::{CommandFactory, Parser, Subcommand};
use clap_complete::Shell;
use std::path::PathBuf;
use std::process::ExitCode;

/// `vsaqem`.
#[derive(Parser, Debug)]
#[command(name = "vsaqem", version, about = "Point cloud to compact, feature-preserving mesh (VSA-QEM)", long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
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
    /// Print a completion script for SHELL to stdout (e.g. `vsaqem completions
    /// bash > /etc/bash_completion.d/vsaqem`).
    Completions {
        /// bash, zsh, fish, elvish or powershell.
        shell: Shell,
    },
    /// Print the man page vsaqem(1) to stdout, or with --dir write one page per
    /// command (vsaqem.1, vsaqem-reconstruct.1, ...) into DIR.
    Man {
        /// Directory to write every page into (it must exist).
        #[arg(long, value_name = "DIR")]
        dir: Option<PathBuf>,
    },
}

/// Parses the arguments, runs the command and says how it ended: 0, 1 after
/// an error (printed on stderr as `error: ...`), 2 after a usage error (as
/// clap prints it). `--help` and `--version` go to stdout, which may fail too.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.use_stderr() => {
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
        Err(e) => return finish(stdout::print(&e.render().to_string())),
    };
    finish(run(&cli.command))
}

fn finish(result: Result<(), String>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Not `eprintln!`, which panics when stderr is a closed pipe (the
            // error may be that stderr could not take the report's text).
            let _ = stdout::eprint(&format!("error: {e}\n"));
            ExitCode::FAILURE
        }
    }
}

/// Runs one command.
pub fn run(command: &Command) -> Result<(), String> {
    match command {
        Command::Cluster(c) => cmd::cluster::run(c),
        Command::Reconstruct(c) => cmd::reconstruct::run(c),
        Command::Eval(c) => cmd::eval::run(c),
        Command::Render(c) => cmd::render::run(c),
        Command::Completions { shell } => {
            let mut script = Vec::new();
            clap_complete::generate(*shell, &mut Cli::command(), "vsaqem", &mut script);
            stdout::write(&script)
        }
        Command::Man { dir: None } => {
            let mut page = Vec::new();
            clap_mangen::Man::new(Cli::command())
                .render(&mut page)
                .map_err(|e| format!("cannot make the man page: {e}"))?;
            stdout::write(&page)
        }
        Command::Man { dir: Some(dir) } => {
            if !dir.is_dir() {
                return Err(format!("{}: not a directory", dir.display()));
            }
            for (name, page) in man_pages()? {
                write_atomic(&dir.join(name), |w| w.write_all(&page)).map_err(|e| e.to_string())?;
            }
            Ok(())
        }
    }
}

/// Every man page as `(file name, roff)`, as `clap_mangen::generate_to` names
/// and renders them, made before any is written; they are then written as
/// [`write_atomic`] writes (`generate_to` truncates each file and writes it in
/// place, so a failure could leave half a page).
fn man_pages() -> Result<Vec<(String, Vec<u8>)>, String> {
    fn add(cmd: &clap::Command, pages: &mut Vec<(String, Vec<u8>)>) -> Result<(), String> {
        for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
            add(sub, pages)?;
        }
        let man = clap_mangen::Man::new(cmd.clone());
        let mut page = Vec::new();
        man.render(&mut page)
            .map_err(|e| format!("cannot make the man page: {e}"))?;
        pages.push((man.get_filename(), page));
        Ok(())
    }
    let mut cmd = Cli::command().disable_help_subcommand(true);
    cmd.build();
    let mut pages = Vec::new();
    add(&cmd, &mut pages)?;
    Ok(pages)
}
