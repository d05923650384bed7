//! Planning a render run: which frames (lens × focus × aperture), and where each one goes.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::film::samples::SampleSequence;
use crate::lens::aperture::ApertureSetting;
use crate::lens::elements::FocusSetting;
use crate::lens::focus::FocusMode;

/// `NEAR:FAR:FRAMES`, e.g. a rack focus from 1 m to 10 m in 24 frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sweep {
    pub from: f64,
    pub to: f64,
    pub frames: u32,
}

impl FromStr for Sweep {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parts: Vec<&str> = s.split(':').collect();
        let bad =
            || format!("'{s}' is not FROM:TO:FRAMES (two positive numbers and a frame count ≥ 1)");
        let [from, to, frames] = parts[..] else {
            return Err(bad());
        };
        let (from, to): (f64, f64) = (
            from.trim().parse().map_err(|_| bad())?,
            to.trim().parse().map_err(|_| bad())?,
        );
        let frames: u32 = frames.trim().parse().map_err(|_| bad())?;
        if !(from.is_finite() && to.is_finite() && from > 0.0 && to > 0.0)
            || frames == 0
            || frames > 10_000
        {
            return Err(bad());
        }
        Ok(Sweep { from, to, frames })
    }
}

impl Sweep {
    /// Values spaced evenly in 1/value (focus: evenly in dioptres, so a rack focus moves the
    /// film at a steady pace) or geometrically (apertures: evenly in stops). The ends are
    /// exactly `from` and `to`, so frame 0 equals a single render at `from`.
    pub fn values(&self, spacing: Spacing) -> Vec<f64> {
        let n = self.frames;
        (0..n)
            .map(|k| {
                if k == 0 {
                    return self.from;
                }
                if k == n - 1 {
                    return self.to;
                }
                let t = k as f64 / (n - 1) as f64;
                match spacing {
                    Spacing::Reciprocal => {
                        1.0 / (1.0 / self.from + t * (1.0 / self.to - 1.0 / self.from))
                    }
                    Spacing::Geometric => self.from * (self.to / self.from).powf(t),
                }
            })
            .collect()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spacing {
    Reciprocal,
    Geometric,
}

/// `I/N`: the I-th (0-based) of N disjoint sample subsets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            format!(
                "'{s}' is not I/N with 0 ≤ I < N (shards count from 0, as Slurm array and Kubernetes indices do)"
            )
        };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (u32, u32) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// This shard's sample indices of 0..spp: those ≡ index (mod count).
    pub fn samples(&self, spp: u32) -> SampleSequence {
        SampleSequence::every(self.index, self.count, spp)
    }
}

/// Most frames one run renders (lenses × zoom positions × focus frames × stop frames): a run
/// plans all its frames up front, and a contact sheet holds them all.
pub const MAX_FRAMES: usize = 10_000;

/// How many frames a run renders whose lenses render `zoom_frames` zoom positions each (1 for
/// every lens without `--zoom-sweep`; no lenses: the one default lens), with these sweeps;
/// refuses more than [`MAX_FRAMES`].
pub fn frame_count(
    zoom_frames: &[usize],
    focus_sweep: Option<Sweep>,
    stop_sweep: Option<Sweep>,
) -> anyhow::Result<usize> {
    let per_lens = |sweep: Option<Sweep>| sweep.map_or(1, |s| s.frames as usize);
    let lens_frames = zoom_frames.iter().sum::<usize>().max(1);
    let frames = lens_frames
        .saturating_mul(per_lens(focus_sweep))
        .saturating_mul(per_lens(stop_sweep));
    if frames > MAX_FRAMES {
        let lenses = if lens_frames == zoom_frames.len().max(1) {
            format!("{} lens(es)", lens_frames)
        } else {
            format!("{lens_frames} lens settings (zoom positions)")
        };
        anyhow::bail!(
            "this run would render {frames} frames ({lenses} × {} focus × {} stop settings), more than realcam's limit of {MAX_FRAMES} per run; split it into several runs",
            per_lens(focus_sweep),
            per_lens(stop_sweep)
        );
    }
    Ok(frames)
}

/// A stop sweep: frames from one stop to another, evenly in stops, named by the stop's
/// diameter (mm, `--aperture-sweep`) or by the f-number (`--f-number-sweep`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StopSweep {
    Diameter(Sweep),
    FNumber(Sweep),
}

impl StopSweep {
    /// The range and frame count, whatever names the stops.
    pub fn sweep(self) -> Sweep {
        match self {
            StopSweep::Diameter(sweep) | StopSweep::FNumber(sweep) => sweep,
        }
    }

    /// The stops of the sweep's frames: a stop is a factor of √2 in diameter or f-number, so
    /// even steps in stops are geometric in either.
    fn settings(self) -> Vec<ApertureSetting> {
        let setting = match self {
            StopSweep::Diameter(_) => ApertureSetting::Diameter,
            StopSweep::FNumber(_) => ApertureSetting::FNumber,
        };
        self.sweep()
            .values(Spacing::Geometric)
            .into_iter()
            .map(setting)
            .collect()
    }
}

/// One image the run renders.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Index into the run's lenses.
    pub lens: usize,
    /// Frame number within its lens's sequence.
    pub number: usize,
    /// The zoom position (0-based) a zoom lens renders at; `None`: as its surfaces are written.
    pub zoom: Option<usize>,
    pub focus: FocusSetting,
    pub aperture: ApertureSetting,
    pub out: PathBuf,
    pub exr: Option<PathBuf>,
}

/// Per-lens defaults (from the scene's hints or autofocus) and the run's sweeps.
pub struct FrameRequest<'a> {
    pub lens_names: &'a [String],
    /// Per lens, the zoom positions it renders: its one setting, or with `--zoom-sweep` each of
    /// its positions in turn ([`ZoomFrames`]).
    pub zoom: &'a [ZoomFrames],
    pub focus: &'a [FocusSetting],
    pub aperture: &'a [ApertureSetting],
    pub focus_sweep: Option<Sweep>,
    pub focus_mode: FocusMode,
    pub stop_sweep: Option<StopSweep>,
    pub out: &'a Path,
    pub exr: Option<&'a Path>,
}

/// The zoom positions one lens renders in a run.
#[derive(Clone, Debug, PartialEq)]
pub enum ZoomFrames {
    /// One setting: a position (0-based), or `None` for the lens as its surfaces are written.
    Fixed(Option<usize>),
    /// `--zoom-sweep`: each of the lens's this many positions, in order.
    Sweep(usize),
}

impl ZoomFrames {
    /// `--zoom-sweep` over a lens with `positions` zoom positions: each of them, or for a lens
    /// with fixed spacings its one picture.
    pub fn sweep(positions: usize) -> ZoomFrames {
        if positions == 0 {
            ZoomFrames::Fixed(None)
        } else {
            ZoomFrames::Sweep(positions)
        }
    }

    /// How many frames of each focus and stop setting the lens renders.
    pub fn count(&self) -> usize {
        match *self {
            ZoomFrames::Fixed(_) => 1,
            ZoomFrames::Sweep(positions) => positions,
        }
    }

    fn settings(&self) -> Vec<Option<usize>> {
        match *self {
            ZoomFrames::Fixed(setting) => vec![setting],
            ZoomFrames::Sweep(positions) => (0..positions).map(Some).collect(),
        }
    }
}

/// Every frame of the run: for each lens, its zoom positions × focus sweep × stop sweep (or the
/// single setting). Outputs are named `<stem>[-<lens>][-<NNN>][-zoom<P>][-f<N>].<ext>`: the
/// lens part when there are several lenses, the number when a lens has several frames, the zoom
/// position (1-based, as `--zoom-position` counts) in a zoom sweep, the f-number (to a tenth)
/// in an f-number sweep.
pub fn plan_frames(request: &FrameRequest) -> Vec<Frame> {
    let mut frames = Vec::new();
    let several_lenses = request.lens_names.len() > 1;
    for (lens, name) in request.lens_names.iter().enumerate() {
        let focuses: Vec<FocusSetting> = match request.focus_sweep {
            Some(sweep) => sweep
                .values(Spacing::Reciprocal)
                .into_iter()
                .map(|metres| FocusSetting::Distance {
                    metres,
                    mode: request.focus_mode,
                })
                .collect(),
            None => vec![request.focus[lens]],
        };
        let apertures: Vec<ApertureSetting> = match request.stop_sweep {
            Some(sweep) => sweep.settings(),
            None => vec![request.aperture[lens]],
        };
        let zooms = request.zoom[lens].settings();
        let zoom_sweep = matches!(request.zoom[lens], ZoomFrames::Sweep(_));
        let sequence = zooms.len() * focuses.len() * apertures.len() > 1;
        let (focuses, apertures) = (&focuses, &apertures);
        let settings = zooms.iter().flat_map(|&z| {
            focuses
                .iter()
                .flat_map(move |&f| apertures.iter().map(move |&a| (z, f, a)))
        });
        for (number, (zoom, focus, aperture)) in settings.enumerate() {
            let suffix = format!(
                "{}{}{}{}",
                if several_lenses {
                    format!("-{name}")
                } else {
                    String::new()
                },
                if sequence {
                    format!("-{number:03}")
                } else {
                    String::new()
                },
                match zoom {
                    Some(position) if zoom_sweep => format!("-zoom{}", position + 1),
                    _ => String::new(),
                },
                match aperture {
                    ApertureSetting::FNumber(n)
                        if matches!(request.stop_sweep, Some(StopSweep::FNumber(_))) =>
                    {
                        format!("-f{}", f_number_label(n))
                    }
                    _ => String::new(),
                }
            );
            frames.push(Frame {
                lens,
                number,
                zoom,
                focus,
                aperture,
                out: with_suffix(request.out, &suffix),
                exr: request.exr.map(|p| with_suffix(p, &suffix)),
            });
        }
    }
    frames
}

/// An f-number as a frame's name gives it: to a tenth, without a trailing `.0` (`2`, `2.8`).
fn f_number_label(n: f64) -> String {
    let tenth = format!("{n:.1}");
    tenth.strip_suffix(".0").unwrap_or(&tenth).to_string()
}

/// `dir/stem.ext` → `dir/stem<suffix>.ext`.
pub fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!("{stem}{suffix}.{}", ext.to_string_lossy()),
        None => format!("{stem}{suffix}"),
    };
    path.with_file_name(name)
}

/// `dir/stem.ext` → `dir/stem.<what>.exr` (checkpoints and shard partials); for standard
/// output (`-`), `render.<what>.exr` in the working folder.
pub fn sidecar(path: &Path, what: &str) -> PathBuf {
    let path = if crate::film::output::is_stdout(path) {
        Path::new("render.png")
    } else {
        path
    };
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.{what}.exr"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweeps_hit_their_ends_exactly_and_space_sensibly() {
        let focus: Sweep = "1:4:4".parse().unwrap();
        let v = focus.values(Spacing::Reciprocal);
        assert_eq!((v[0], v[3]), (1.0, 4.0));
        // Evenly in dioptres: 1, 0.75, 0.5, 0.25 → 1, 1.333, 2, 4 m.
        assert!((v[1] - 4.0 / 3.0).abs() < 1e-12 && (v[2] - 2.0).abs() < 1e-12);
        let stops: Sweep = "2:8:3".parse().unwrap();
        let v = stops.values(Spacing::Geometric);
        assert!((v[1] - 4.0).abs() < 1e-12);
        for bad in ["1:2", "0:2:3", "1:2:0", "a:b:c", "-1:2:3"] {
            assert!(bad.parse::<Sweep>().is_err(), "{bad}");
        }
    }

    #[test]
    fn shards_partition_the_samples() {
        let parts: Vec<Vec<u32>> = (0..3)
            .map(|i| Shard { index: i, count: 3 }.samples(10).to_vec())
            .collect();
        let mut all: Vec<u32> = parts.concat();
        all.sort();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(parts[1], vec![1, 4, 7]);
        for bad in ["3/3", "1/0", "x/2", "2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn frames_are_named_after_lens_and_number() {
        let names = vec!["dgauss.50mm".to_string(), "wide.22mm".to_string()];
        let focus = [FocusSetting::default(); 2];
        let aperture = [ApertureSetting::Full; 2];
        let zoom = [ZoomFrames::Fixed(None), ZoomFrames::Fixed(None)];
        let request = FrameRequest {
            lens_names: &names,
            zoom: &zoom,
            focus: &focus,
            aperture: &aperture,
            focus_sweep: Some("1:10:3".parse().unwrap()),
            focus_mode: FocusMode::Paraxial,
            stop_sweep: None,
            out: Path::new("out/render.png"),
            exr: None,
        };
        let frames = plan_frames(&request);
        assert_eq!(frames.len(), 6);
        assert_eq!(frames[0].out, Path::new("out/render-dgauss.50mm-000.png"));
        assert_eq!(frames[5].out, Path::new("out/render-wide.22mm-002.png"));
        let single = FrameRequest {
            lens_names: &names[..1],
            focus_sweep: None,
            ..request
        };
        assert_eq!(plan_frames(&single)[0].out, Path::new("out/render.png"));
    }

    #[test]
    fn an_f_number_sweep_steps_evenly_in_stops_and_names_its_frames() {
        let names = vec!["dgauss.50mm".to_string()];
        let request = FrameRequest {
            lens_names: &names,
            zoom: &[ZoomFrames::Fixed(None)],
            focus: &[FocusSetting::default()],
            aperture: &[ApertureSetting::Full],
            focus_sweep: None,
            focus_mode: FocusMode::Paraxial,
            stop_sweep: Some(StopSweep::FNumber("2:16:4".parse().unwrap())),
            out: Path::new("out/stops.png"),
            exr: Some(Path::new("out/stops.exr")),
        };
        let frames = plan_frames(&request);
        assert_eq!(frames.len(), 4);
        for (i, frame) in frames.iter().enumerate() {
            // N_i = A·(B/A)^(i/(FRAMES−1)): 2, 4, 8, 16 — a stop is a factor of √2 in N, so
            // these are two stops apart (ln(N_i+1/N_i)/ln √2 = 2).
            let expected = 2.0 * 8f64.powf(i as f64 / 3.0);
            let ApertureSetting::FNumber(n) = frame.aperture else {
                panic!("{:?}", frame.aperture)
            };
            assert!((n - expected).abs() < 1e-12 * expected, "{n} vs {expected}");
        }
        let names: Vec<&Path> = frames.iter().map(|f| f.out.as_path()).collect();
        assert_eq!(
            names,
            [
                "out/stops-000-f2.png",
                "out/stops-001-f4.png",
                "out/stops-002-f8.png",
                "out/stops-003-f16.png"
            ]
            .map(Path::new)
        );
        assert_eq!(
            frames[1].exr.as_deref(),
            Some(Path::new("out/stops-001-f4.exr"))
        );
        let odd = FrameRequest {
            stop_sweep: Some(StopSweep::FNumber("1.4:2.8:3".parse().unwrap())),
            ..request
        };
        // 1.4·√2 = 1.98: named to a tenth.
        assert_eq!(plan_frames(&odd)[1].out, Path::new("out/stops-001-f2.png"));
    }

    #[test]
    fn a_zoom_sweep_renders_each_position_named_by_its_number() {
        let names = vec!["zoom".to_string(), "dgauss.50mm".to_string()];
        let zoom = [ZoomFrames::sweep(3), ZoomFrames::sweep(0)];
        let request = FrameRequest {
            lens_names: &names,
            zoom: &zoom,
            focus: &[FocusSetting::default(); 2],
            aperture: &[ApertureSetting::Full; 2],
            focus_sweep: None,
            focus_mode: FocusMode::Paraxial,
            stop_sweep: Some(StopSweep::FNumber("4:8:2".parse().unwrap())),
            out: Path::new("z.png"),
            exr: None,
        };
        let frames = plan_frames(&request);
        let named: Vec<(&Path, Option<usize>)> =
            frames.iter().map(|f| (f.out.as_path(), f.zoom)).collect();
        assert_eq!(
            named,
            [
                ("z-zoom-000-zoom1-f4.png", Some(0)),
                ("z-zoom-001-zoom1-f8.png", Some(0)),
                ("z-zoom-002-zoom2-f4.png", Some(1)),
                ("z-zoom-003-zoom2-f8.png", Some(1)),
                ("z-zoom-004-zoom3-f4.png", Some(2)),
                ("z-zoom-005-zoom3-f8.png", Some(2)),
                // A lens with fixed spacings renders its one setting.
                ("z-dgauss.50mm-000-f4.png", None),
                ("z-dgauss.50mm-001-f8.png", None),
            ]
            .map(|(p, z)| (Path::new(p), z))
        );
    }

    #[test]
    fn runs_of_too_many_frames_are_refused_before_planning() {
        let sweep = |frames| {
            Some(Sweep {
                from: 1.0,
                to: 2.0,
                frames,
            })
        };
        assert_eq!(frame_count(&[], None, None).unwrap(), 1);
        assert_eq!(frame_count(&[1, 1], sweep(3), sweep(4)).unwrap(), 24);
        assert_eq!(frame_count(&[1], sweep(10_000), None).unwrap(), 10_000);
        let message = frame_count(&[1, 1, 1], sweep(10_000), sweep(10_000))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("300000000 frames")
                && message.contains("3 lens(es)")
                && message.contains("10000"),
            "{message}"
        );
        // A zoom sweep renders each position of each zoom lens: 3 + 1 lens settings.
        assert_eq!(frame_count(&[3, 1], sweep(2), None).unwrap(), 8);
        let message = frame_count(&[3, 1], sweep(10_000), None)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("4 lens settings (zoom positions)"),
            "{message}"
        );
    }

    #[test]
    fn standard_output_keeps_its_sidecars_in_the_working_folder() {
        assert_eq!(
            sidecar(Path::new("-"), "checkpoint"),
            Path::new("render.checkpoint.exr")
        );
        assert_eq!(
            sidecar(Path::new("a/shot.jpg"), "shard-0-of-2"),
            Path::new("a/shot.shard-0-of-2.exr")
        );
    }
}
