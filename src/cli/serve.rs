//! `realcam serve`: a live lens lab in the browser (see [`crate::live`] and [`crate::server`]).

use std::io::Write;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::{Context, bail};
use clap::Args;

use super::interrupt::Interrupt;
use super::render::{RenderArgs, parse_render_arguments};
use super::values::whole;
use crate::film::output::is_stdout;
use crate::job::Job;
use crate::job::outputs::validate;
use crate::live::LiveLab;
use crate::live::lenses::LensLibrary;
use crate::live::session::{Session, default_exr};
use crate::live::settings::{LiveSettings, SpecParser};
use crate::server::Server;

#[derive(Args, Debug, Clone)]
pub struct ServeArgs {
    #[command(flatten)]
    pub render: RenderArgs,
    /// Port of the web page and API (0: any free port, printed at start).
    #[arg(long, default_value_t = 8040, value_name = "PORT", allow_hyphen_values = true, value_parser = whole::<u16>(0, 65535))]
    pub port: u16,
    /// Address to listen on [default: 127.0.0.1, this machine only]; another address (a LAN
    /// address, 0.0.0.0) lets other machines change the render and write its outputs.
    #[arg(long, value_name = "ADDR")]
    pub listen: Option<IpAddr>,
    /// A folder of lens files the page may pick from (besides the bundled lenses and the
    /// --lens files); names leading out of it are refused.
    #[arg(long, value_name = "DIR")]
    pub lens_dir: Option<PathBuf>,
}

/// `realcam render` options that describe a batch run, not a live view.
fn refuse_batch_options(args: &RenderArgs) -> anyhow::Result<()> {
    let given = [
        ("--zoom-sweep", args.zoom_sweep),
        ("--focus-sweep", args.focus_sweep.is_some()),
        ("--aperture-sweep", args.aperture_sweep.is_some()),
        ("--f-number-sweep", args.f_number_sweep.is_some()),
        ("--contact-sheet", args.contact_sheet.is_some()),
        ("--checkpoint", args.checkpoint.is_some()),
        ("--checkpoint-every", args.checkpoint_every.is_some()),
        ("--resume", args.resume.is_some()),
        ("--shard", args.shard.is_some()),
        ("--partial", args.partial.is_some()),
        ("--stats", args.stats.is_some()),
    ];
    if let Some((option, _)) = given.iter().find(|(_, given)| *given) {
        bail!(
            "{option} is for `realcam render` runs; `realcam serve` renders one live view (set focus and stop on the page, or see /api/stats)"
        );
    }
    if is_stdout(&args.out) || args.exr.as_deref().is_some_and(is_stdout) {
        bail!("--out -: Save writes files; give file names for --out and --exr");
    }
    Ok(())
}

/// The `realcam render` arguments of this `realcam serve` command line (its own options taken
/// out), with `--exr` added when missing, so Save always writes both.
fn render_arguments(argv: &[String], args: &ServeArgs) -> Vec<String> {
    let start = argv
        .iter()
        .position(|a| a == "serve")
        .map_or(argv.len(), |i| i + 1);
    let mut kept = Vec::new();
    let mut words = argv[start..].iter();
    while let Some(word) = words.next() {
        let own = ["--port", "--listen", "--lens-dir"];
        if own.contains(&word.as_str()) {
            words.next();
        } else if !own.iter().any(|o| word.starts_with(&format!("{o}="))) {
            kept.push(word.clone());
        }
    }
    if args.render.exr.is_none() {
        kept.push("--exr".into());
        kept.push(default_exr(&args.render.out).display().to_string());
    }
    kept
}

pub fn run(args: &ServeArgs) -> anyhow::Result<ExitCode> {
    refuse_batch_options(&args.render)?;
    let argv: Vec<String> = std::env::args().collect();
    let settings = LiveSettings::from_arguments(&render_arguments(&argv, args));
    let parser: SpecParser = Arc::new(parse_render_arguments);
    let render = settings.parse(&parser).map_err(anyhow::Error::msg)?;
    let formats = validate(&render)?;
    let library = LensLibrary::new(
        args.render.lens.clone(),
        args.lens_dir.as_deref(),
        render.lens.reading(),
    )?;
    if let Some(threads) = render.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .context("cannot start worker threads")?;
    }
    let interrupt = Interrupt::install()?;
    let job = Job::prepare(&render, formats)?;
    let (flag, cancel) = LiveLab::cancel_flag();
    let session = Session::new(job, settings, parser, library, cancel)?;
    let lab = LiveLab::start(session, flag);
    let address = SocketAddr::new(
        args.listen.unwrap_or(IpAddr::V4(Ipv4Addr::LOCALHOST)),
        args.port,
    );
    let server = match Server::bind(address, lab.clone()) {
        Ok(server) => server,
        Err(e) => {
            lab.stop();
            return Err(e);
        }
    };
    let bound = server.local_addr();
    let host = match bound.ip() {
        ip if ip.is_unspecified() => "127.0.0.1".to_string(),
        IpAddr::V6(ip) => format!("[{ip}]"),
        ip => ip.to_string(),
    };
    // The address is for whoever reads it; with nobody reading (`realcam serve | head -0`)
    // the lab still serves, so a closed standard output is no error here (nor a panic).
    let _ = writeln!(
        std::io::stdout(),
        "realcam serve: http://{host}:{}/",
        bound.port()
    );
    eprintln!("serving the live lens lab; Ctrl-C stops");
    server.serve(|| interrupt.requested().is_some());
    lab.stop();
    eprintln!("stopped");
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    /// The live lab's settings are read by the command line's own parser, with its ranges.
    #[test]
    fn live_settings_parse_as_the_command_line_does() {
        let parser: SpecParser = Arc::new(parse_render_arguments);
        let mut settings = LiveSettings::new(vec![]);
        settings.set("lens", "dgauss.50mm");
        settings.set("focus_distance", "3");
        let next = settings
            .changed(&json!({"film_distance": 40.5, "f_number": 4}))
            .unwrap();
        let spec = next.parse(&parser).unwrap();
        assert_eq!(spec.lens.film_distance, Some(40.5));
        assert_eq!(spec.lens.f_number, Some(4.0));
        assert_eq!(spec.lenses, vec!["dgauss.50mm".to_string()]);
        for bad in [
            json!({"spp": -1}),
            json!({"spp": "many"}),
            json!({"f_number": 0}),
            json!({"f_number": "four"}),
        ] {
            let outcome = settings.changed(&bad).and_then(|s| s.parse(&parser));
            assert!(outcome.is_err(), "{bad} was accepted");
        }
        // A JSON number beyond a whole-number setting's range is refused for its range (as the
        // live session checks a change), not as "not a whole number".
        let huge = settings
            .changed(&json!({"spp": 1e9}))
            .and_then(|s| s.parse(&parser))
            .unwrap();
        let refusal = crate::job::outputs::check_values(&huge)
            .unwrap_err()
            .to_string();
        assert!(
            refusal.contains("--spp must be at most 16777216"),
            "{refusal}"
        );
        let float_whole = settings.changed(&json!({"spp": 16.0})).unwrap();
        assert_eq!(float_whole.parse(&parser).unwrap().spp, 16);
        // The command line's text is accepted as well as JSON numbers.
        let texts = settings
            .changed(&json!({"f_number": "5.6", "focus_distance": "inf"}))
            .unwrap();
        let spec = texts.parse(&parser).unwrap();
        assert_eq!(spec.lens.f_number, Some(5.6));
        assert_eq!(spec.lens.focus_distance, Some(f64::INFINITY));
    }
}
