//! `vsaqem`: point cloud to compact, feature-preserving mesh by VSA-QEM
//! (the command line is `vsaqem::cli`).

use std::process::ExitCode;

fn main() -> ExitCode {
    vsaqem::cli::main()
}
