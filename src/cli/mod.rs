//! The `realcam` command line.

pub mod bench;
pub mod devices;
pub mod glass;
pub mod interrupt;
pub mod lens;
pub mod lenses;
pub mod merge;
pub mod options;
pub mod render;
pub mod serve;
pub mod values;

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
    Lens(Box<lens::LensArgs>),
    /// List the lenses built into realcam: focal length, f-number, field of view on 35 mm,
    /// elements, aspheres, year and source.
    Lenses(lenses::LensesArgs),
    /// Combine the shard partials of `realcam render --shard I/N` into the full frame.
    Merge(merge::MergeArgs),
    /// Look up optical glass: catalogue formulas, n at the F, d, C lines, V_d, the nearest
    /// catalogue glasses to an n_d and V_d.
    Glass(glass::GlassArgs),
    /// Serve a live lens lab on a web page: change lens, focus, stop and film on a progressive
    /// render (scene and BVH loaded once), with a JSON API.
    Serve(Box<serve::ServeArgs>),
    /// Measure lens-tracing speed on this CPU: scalar per-ray vs SoA batches, one thread.
    Bench(bench::BenchArgs),
    /// List the GPU adapters `--device gpu` can render on, and the one it picks.
    Devices(devices::DevicesArgs),
}

impl Cli {
    /// Parses `argv` (program name first) as the command line does; a refusal as the first line
    /// of clap's message, without its `error: ` prefix.
    pub fn try_parse_from_args(
        argv: impl IntoIterator<Item = String>,
    ) -> Result<Option<Command>, String> {
        Cli::try_parse_from(argv)
            .map(|cli| cli.command)
            .map_err(|e| {
                // The message without clap's usage and help hints: its lines up to the first
                // blank one ("the following required arguments were not provided:" is
                // followed by the arguments on lines of their own).
                let text = e.render().to_string();
                let message = text
                    .lines()
                    .take_while(|line| !line.trim().is_empty())
                    .map(str::trim)
                    .collect::<Vec<_>>()
                    .join(" ");
                let message = message.strip_prefix("error: ").unwrap_or(&message);
                if message.is_empty() {
                    "invalid setting".to_string()
                } else {
                    message.to_string()
                }
            })
    }
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
        Some(Command::Devices(args)) => devices::run(&args),
        Some(Command::Serve(args)) => serve::run(&args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;
    use clap::error::ErrorKind;

    /// The arguments a subcommand needs besides the option under test.
    fn required(subcommand: &str) -> &'static [&'static str] {
        match subcommand {
            "lens" => &["dgauss.50mm"],
            "merge" => &["part.exr", "--out", "m.png"],
            _ => &[],
        }
    }

    /// Whether `arg` takes numbers or vectors of numbers: not names, paths or keywords
    /// (`--env` takes a radiance vector or a file).
    fn numeric(arg: &clap::Arg) -> bool {
        use std::any::TypeId;
        let parser = arg.get_value_parser().type_id();
        let words = [
            TypeId::of::<String>(),
            TypeId::of::<std::path::PathBuf>(),
            TypeId::of::<crate::lens::focus::FocusMode>(),
            TypeId::of::<crate::lens::pupil::PupilSampling>(),
            TypeId::of::<crate::lens::LensFormat>(),
            TypeId::of::<crate::cli::render::Switch>(),
            TypeId::of::<crate::pipeline::RenderDevice>(),
            TypeId::of::<crate::lens::coating::CoatingModel>(),
            TypeId::of::<crate::film::filter::Filter>(),
            TypeId::of::<std::net::IpAddr>(),
        ];
        arg.get_action().takes_values()
            && (!words.iter().any(|w| parser == *w) || arg.get_long() == Some("env"))
    }

    /// Every numeric and vector option of every subcommand takes a value starting with `-`:
    /// a negative number or a vector with a negative first component reaches realcam (which
    /// may refuse it in its own words), never clap's "unexpected argument '-0' found".
    #[test]
    fn every_numeric_option_takes_values_that_start_with_a_minus() {
        let cli = Cli::command();
        let mut tried = Vec::new();
        for subcommand in cli.get_subcommands() {
            let name = subcommand.get_name();
            for arg in subcommand.get_arguments().filter(|a| numeric(a)) {
                let Some(long) = arg.get_long() else { continue };
                tried.push(format!("{name} --{long}"));
                for value in ["-1", "-0.041,0.998,-0.032", "-2.5"] {
                    let option = format!("--{long}");
                    let mut argv = vec!["realcam", name, option.as_str(), value];
                    argv.extend(required(name));
                    let Err(error) = Cli::try_parse_from(&argv) else {
                        continue;
                    };
                    let text = error.to_string();
                    assert!(
                        !matches!(error.kind(), ErrorKind::UnknownArgument)
                            && !text.contains("unexpected argument"),
                        "{argv:?}: {text}"
                    );
                    // A refusal of the value itself is realcam's, not the parser's default.
                    for default in ["invalid digit", "invalid float literal", "number too large"] {
                        assert!(!text.contains(default), "{argv:?}: {text}");
                    }
                }
            }
        }
        // The options the issue names, and all the numeric ones of every subcommand.
        for expected in [
            "render --up",
            "render --look-from",
            "render --look-at",
            "render --env",
            "render --exposure",
            "render --seed",
            "render --spp",
            "render --focus-distance",
            "render --focus-sweep",
            "merge --exposure",
            "lens --film-distance",
            "bench --rays",
        ] {
            assert!(
                tried.iter().any(|t| t == expected),
                "{expected} not tried: {tried:?}"
            );
        }
    }

    #[test]
    fn negative_vectors_parse_to_their_values() {
        let argv = [
            "realcam",
            "render",
            "--look-from",
            "-3,1,2",
            "--look-at",
            "-0.5,-1,-2",
            "--up",
            "-0.041,0.998,-0.032",
            "--exposure",
            "-2",
        ];
        let Some(Command::Render(args)) = Cli::try_parse_from(argv).unwrap().command else {
            panic!("a render");
        };
        assert_eq!(args.look_from, Some(glam::Vec3::new(-3.0, 1.0, 2.0)));
        assert_eq!(args.look_at, Some(glam::Vec3::new(-0.5, -1.0, -2.0)));
        assert_eq!(args.up, glam::Vec3::new(-0.041, 0.998, -0.032));
        assert_eq!(args.exposure, Some(-2.0));
    }
}
