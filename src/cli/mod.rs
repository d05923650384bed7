//! The `realcam` command line.

pub mod bench;
pub mod glass;
pub mod interrupt;
pub mod lens;
pub mod lenses;
pub mod merge;
pub mod options;
pub mod plan;
pub mod render;
pub mod setup;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "realcam",
    version,
    about = "Render glTF scenes through real multi-element camera lenses",
    long_about = "Render glTF scenes through real multi-element camera lenses.\n\nWith no command, `realcam` renders the built-in default scene through the bundled dgauss.50mm lens (same as `realcam render`)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a glTF scene (default: the built-in "dof dragons" scene) through a lens.
    Render(Box<render::RenderArgs>),
    /// Inspect a lens: first-order data, focus, pupils; trace rays; draw its cross-section.
    Lens(lens::LensArgs),
    /// List the lenses built into realcam: focal length, f-number, field of view on 35 mm,
    /// elements, aspheres, year and source.
    Lenses(lenses::LensesArgs),
    /// Combine the shard partials of `realcam render --shard I/N` into the full frame.
    Merge(merge::MergeArgs),
    /// Look up optical glass: catalogue formulas, n at the F, d, C lines, V_d, the nearest
    /// catalogue glasses to an n_d and V_d.
    Glass(glass::GlassArgs),
    /// Measure lens-tracing speed on this CPU: scalar per-ray vs SoA batches, one thread.
    Bench(bench::BenchArgs),
}

/// Runs the command line; errors are printed as `error: …` with a non-zero exit.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let result = match cli.command {
        None => match Cli::parse_from(["realcam", "render"]).command {
            Some(Command::Render(args)) => render::run(&args),
            _ => unreachable!("`realcam render` parses as the render command"),
        },
        Some(Command::Render(args)) => render::run(&args),
        Some(Command::Lens(args)) => lens::run(&args),
        Some(Command::Lenses(args)) => lenses::run(&args),
        Some(Command::Merge(args)) => merge::run(&args),
        Some(Command::Glass(args)) => glass::run(&args),
        Some(Command::Bench(args)) => bench::run(&args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
