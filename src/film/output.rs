//! Writing outputs: sRGB tone mapping, and putting bytes where an output path says, safely.
//!
//! Every output path goes through [`write_output`] (or [`write_atomically`] for one that must
//! be a file):
//!
//! - a regular file, or a name that does not exist yet, is written atomically: a temporary
//!   file beside it, then a rename, so readers never see half an image, even if realcam is
//!   killed mid-write;
//! - a symbolic link is written *through*: its final target is replaced atomically and the
//!   link stays a link;
//! - a FIFO or a character device (`/dev/null`, a terminal, `/dev/stdout`) is written in
//!   place, never renamed over, so a device node is never replaced by a regular file;
//! - a directory, a block device or a socket is refused;
//! - `-` is standard output ([`write_output`] only).
//!
//! A write that fails (a full disk, a reader that went away) is an error naming the path.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use super::Image;
use super::format::{ImageFormat, Tone, encode_image};

/// The output path that means standard output.
pub const STDOUT: &str = "-";

/// Whether `path` means standard output (`-`).
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == STDOUT
}

/// Whether `path` is standard output (`-`) or names a stream: a FIFO or a character device
/// (`/dev/stdout`, `/dev/null`), whose name need not carry an extension.
pub fn is_stream(path: &Path) -> bool {
    if is_stdout(path) {
        return true;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        std::fs::metadata(path)
            .is_ok_and(|m| m.file_type().is_fifo() || m.file_type().is_char_device())
    }
    #[cfg(not(unix))]
    false
}

/// How messages name an output: its path, or "standard output" for `-`.
pub fn shown(path: &Path) -> String {
    if is_stdout(path) {
        "standard output".to_string()
    } else {
        path.display().to_string()
    }
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// How far below the image's bright end (its [`METERED_PERCENTILE`] luminance) a pixel still
/// counts toward the automatic exposure, in stops. An 8-bit sRGB picture shows about 11.7 stops
/// below white (its first step is 1/(255 · 12.92) of it), and the bright end sits a few stops
/// under white, so light this far below it is black in any picture that shows the bright end.
pub const METERED_STOPS: i32 = 10;

/// The luminance percentile that marks the image's bright end for [`METERED_STOPS`]: high
/// enough to hold the scene's highlights, low enough that a few fireflies do not move it.
pub const METERED_PERCENTILE: f64 = 0.99;

/// Exposure (a linear scale) that maps the log-average luminance of the image's visible pixels
/// to 18 % grey, the photographer's "middle grey"; 1 for a black image. A real lens at f/5.6
/// passes far less light than a pinhole model would suggest, so a fixed scale would give black
/// or white images.
///
/// Visible means within [`METERED_STOPS`] of the bright end ([`METERED_PERCENTILE`] of the
/// lit pixels). A pixel that received no light has no logarithm and never counted; one that
/// received a trace of it must not count either. A lens's flare leaves a few ghost samples in a
/// black sky and beyond a fisheye's image circle, thousands of times dimmer than the scene, and
/// counted in the log-average those pulled it down by 4–9 stops: the default render's floor and
/// cones came out white (4.6 stops too bright; the fisheye 9.6, a Cornell box 7.8).
///
/// The bright end is read off a histogram of the luminances' `f32` bits (eight bins a stop):
/// two passes over the pixels and no copy of them.
pub fn auto_exposure(pixels: &[[f32; 3]]) -> f32 {
    // Positive finite floats order like their bits; the top 12 bits of a positive float are
    // its exponent and 3 bits of mantissa, an eighth of a stop.
    const BIN_SHIFT: u32 = 20;
    let lit = || {
        pixels
            .iter()
            .map(|&p| luminance(p))
            .filter(|l| *l > 0.0 && l.is_finite())
    };
    let mut histogram = vec![0u64; (f32::MAX.to_bits() >> BIN_SHIFT) as usize + 1];
    let mut count = 0u64;
    for l in lit() {
        histogram[(l.to_bits() >> BIN_SHIFT) as usize] += 1;
        count += 1;
    }
    if count == 0 {
        return 1.0;
    }
    let rank = (METERED_PERCENTILE * count as f64).ceil() as u64;
    let mut below = 0;
    let bright_bin = histogram
        .iter()
        .position(|&n| {
            below += n;
            below >= rank
        })
        .unwrap_or(histogram.len() - 1);
    let bright_end = f32::from_bits((bright_bin as u32) << BIN_SHIFT);
    let floor = bright_end * 2f32.powi(-METERED_STOPS);
    let (mut sum_log, mut metered) = (0.0f64, 0usize);
    for l in lit().filter(|&l| l >= floor) {
        sum_log += f64::from(l).ln();
        metered += 1;
    }
    let log_average = (sum_log / metered as f64).exp();
    (0.18 / log_average) as f32
}

/// sRGB opto-electronic transfer function, linear [0, 1] → encoded [0, 1].
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB pixels of `pixels` × `exposure`, clipped.
pub fn to_srgb8(pixels: &[[f32; 3]], exposure: f32) -> Vec<u8> {
    pixels
        .iter()
        .flat_map(|p| p.map(|c| (linear_to_srgb(c * exposure) * 255.0 + 0.5) as u8))
        .collect()
}

/// Writes `image`'s means as an sRGB PNG scaled by `exposure`.
pub fn write_png(path: &Path, image: &Image, exposure: f32) -> anyhow::Result<()> {
    write_image(path, image, ImageFormat::Png, Tone::exposure(exposure))
}

/// Writes `image`'s means as linear, un-tonemapped RGB float EXR.
pub fn write_exr(path: &Path, image: &Image) -> anyhow::Result<()> {
    write_image(path, image, ImageFormat::Exr, Tone::exposure(1.0))
}

/// Writes `image`'s means in `format`: 8-bit formats tone-mapped by `tone`, float formats
/// linear. `-` is standard output.
pub fn write_image(
    path: &Path,
    image: &Image,
    format: ImageFormat,
    tone: Tone,
) -> anyhow::Result<()> {
    write_output(path, |bytes| encode_image(bytes, image, format, tone))
}

/// True when both paths name one existing file (through links, `..` and the like): an output
/// must never be written over one of the inputs.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// What an output path names on disk, and so how it is written.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Target {
    /// A regular file or nothing yet (at the end of any symbolic links): written to a
    /// temporary file beside it, then renamed over it.
    File(PathBuf),
    /// A FIFO or a character device: opened and written in place.
    InPlace(PathBuf),
}

/// Symbolic links followed before giving up, as the kernel's own limit (`ELOOP`).
const MAX_LINKS: usize = 40;

/// Follows `path` through symbolic links to what they finally name (which need not exist).
fn resolve_links(path: &Path) -> anyhow::Result<PathBuf> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let target = std::fs::read_link(&current)
                    .with_context(|| format!("{}: cannot read the link", path.display()))?;
                current = match current.parent() {
                    Some(parent) if target.is_relative() => parent.join(target),
                    _ => target,
                };
            }
            _ => return Ok(current),
        }
    }
    bail!(
        "{}: too many levels of symbolic links; give the output file itself",
        path.display()
    )
}

/// Decides how `path` is written, refusing what must never be written over.
fn target(path: &Path) -> anyhow::Result<Target> {
    // `metadata` follows every link, /proc's `/dev/stdout → /proc/self/fd/1 → pipe:[…]`
    // included, which a path cannot spell.
    let meta = match std::fs::metadata(path) {
        Ok(meta) => meta,
        // Nothing there yet, or a link to nothing yet: the file it names will be created.
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok(Target::File(resolve_links(path)?));
        }
        Err(e) => {
            return Err(e).with_context(|| format!("{}: cannot write output", path.display()));
        }
    };
    let kind = meta.file_type();
    if kind.is_file() {
        let file = path
            .canonicalize()
            .with_context(|| format!("{}: cannot write output", path.display()))?;
        return Ok(Target::File(file));
    }
    if kind.is_dir() {
        bail!(
            "{}: is a directory; give a file name for the output",
            path.display()
        );
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() || kind.is_char_device() {
            return Ok(Target::InPlace(path.to_path_buf()));
        }
        let what = if kind.is_block_device() {
            "a block device"
        } else if kind.is_socket() {
            "a socket"
        } else {
            "not a regular file"
        };
        bail!(
            "{}: is {what}; realcam writes outputs to regular files (or, in place, to a FIFO or a character device such as /dev/null), never over {what}",
            path.display()
        );
    }
    #[cfg(not(unix))]
    bail!(
        "{}: is not a regular file; give a file name for the output",
        path.display()
    )
}

/// Checks before a long render that `path` can be written: a file's folder exists and is
/// writable; a FIFO or device is writable. Writes nothing.
pub fn check_writable(path: &Path) -> anyhow::Result<()> {
    if is_stdout(path) {
        return Ok(());
    }
    match target(path)? {
        Target::File(file) => {
            let (probe, _) = create_temp(&file)
                .with_context(|| format!("{}: cannot write here", path.display()))?;
            let _ = std::fs::remove_file(&probe);
        }
        Target::InPlace(special) => {
            // Opening a FIFO would wait for a reader: ask for permission instead.
            if !may_write(&special) {
                bail!("{}: cannot write here: permission denied", path.display());
            }
        }
    }
    Ok(())
}

/// Refuses to send binary image data to standard output when it is a terminal.
pub fn check_not_terminal(option: &str, path: &Path) -> anyhow::Result<()> {
    if is_stdout(path) && std::io::stdout().is_terminal() {
        bail!(
            "{option} -: standard output is a terminal, and an image there would be binary garbage; redirect it (`> file`, `| program`) or give a file name"
        );
    }
    Ok(())
}

#[cfg(unix)]
fn may_write(path: &Path) -> bool {
    use std::os::unix::ffi::OsStrExt;
    let Ok(name) = std::ffi::CString::new(path.as_os_str().as_bytes()) else {
        return false;
    };
    // SAFETY: `name` is a valid NUL-terminated string that outlives the call.
    unsafe { libc::access(name.as_ptr(), libc::W_OK) == 0 }
}

#[cfg(not(unix))]
fn may_write(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.permissions().readonly())
}

/// Encodes into memory, then writes to `path` ([`write_atomically`]) or, for `-`, to standard
/// output.
pub fn write_output(
    path: &Path,
    encode: impl FnOnce(&mut Vec<u8>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    if !is_stdout(path) {
        return write_atomically(path, encode);
    }
    let mut bytes = Vec::new();
    encode(&mut bytes).context("standard output: cannot encode the output")?;
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(&bytes)
        .and_then(|()| stdout.flush())
        .context("standard output: cannot write the output")
}

/// Encodes into memory, then puts the bytes at `path` as the module docs say: atomically
/// for a regular file (through symbolic links), in place for a FIFO or a character device.
pub fn write_atomically(
    path: &Path,
    encode: impl FnOnce(&mut Vec<u8>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let target = target(path)?;
    let mut bytes = Vec::new();
    encode(&mut bytes).with_context(|| format!("{}: cannot encode the output", path.display()))?;
    let written = match &target {
        Target::File(file) => replace_file(file, &bytes),
        Target::InPlace(special) => std::fs::OpenOptions::new()
            .write(true)
            .open(special)
            .and_then(|mut sink| {
                sink.write_all(&bytes)?;
                sink.flush()
            }),
    };
    written.with_context(|| format!("{}: cannot write output", path.display()))
}

/// Writes `bytes` to a new temporary file beside `file` and renames it over `file`, keeping an
/// existing file's permissions.
fn replace_file(file: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let (temp, mut handle) = create_temp(file)?;
    let result = (|| {
        if let Ok(meta) = std::fs::metadata(file) {
            handle.set_permissions(meta.permissions())?;
        }
        handle.write_all(bytes)?;
        handle.sync_all()?;
        drop(handle);
        std::fs::rename(&temp, file)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
}

/// A new, empty temporary file beside `path` (`.<name>.<pid>.<n>.tmp`), never an existing one.
fn create_temp(path: &Path) -> std::io::Result<(PathBuf, std::fs::File)> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let mut attempt = 0;
    loop {
        let temp = path.with_file_name(format!(".{name}.{}.{attempt}.tmp", std::process::id()));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp)
        {
            Ok(file) => return Ok((temp, file)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 100 => {
                attempt += 1;
            }
            Err(e) => return Err(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_pixels() -> Image {
        Image {
            width: 2,
            height: 1,
            sums: vec![[1.0; 3], [0.5; 3]],
            samples: 1,
        }
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        names
    }

    #[cfg(unix)]
    fn mkfifo(path: &Path) {
        let status = std::process::Command::new("mkfifo")
            .arg(path)
            .status()
            .unwrap();
        assert!(status.success());
    }

    #[test]
    fn srgb_curve_matches_the_standard() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        // 18 % grey encodes to about 46 % (118/255).
        assert!((linear_to_srgb(0.18) * 255.0 - 117.6).abs() < 1.0);
    }

    #[test]
    fn auto_exposure_maps_uniform_image_to_middle_grey() {
        let pixels = vec![[0.02f32; 3]; 100];
        let k = auto_exposure(&pixels);
        assert!((luminance(pixels[0]) * k - 0.18).abs() < 1e-5);
    }

    #[test]
    fn auto_exposure_of_a_black_image_is_one() {
        assert_eq!(auto_exposure(&[[0.0; 3]; 10]), 1.0);
        assert_eq!(auto_exposure(&[[-1.0, 0.0, 0.0], [f32::NAN; 3]]), 1.0);
        assert_eq!(auto_exposure(&[]), 1.0);
    }

    /// Half the frame a lit grey at luminance 1, half black but for a trace of light in some
    /// pixels (a lens's flare in a night sky, 2⁻¹⁴ to 2⁻²⁰ of the grey): the exposure is the
    /// grey's alone, 0.18, as without the trace. Before the metering window the trace pulled the
    /// log-average down by 8 stops.
    #[test]
    fn a_trace_of_light_in_the_black_does_not_move_the_exposure() {
        let grey = [1.0f32; 3];
        let clean: Vec<[f32; 3]> = (0..1000)
            .map(|i| if i < 500 { grey } else { [0.0; 3] })
            .collect();
        let traced: Vec<[f32; 3]> = (0..1000)
            .map(|i| match i {
                0..500 => grey,
                _ if i % 3 == 0 => [2f32.powi(-14 - (i % 7)); 3],
                _ => [0.0; 3],
            })
            .collect();
        assert!((auto_exposure(&clean) - 0.18).abs() < 1e-6);
        assert!((auto_exposure(&traced) - 0.18).abs() < 1e-6);
    }

    /// Dim parts of the scene within the window still count: a quarter of the frame at
    /// luminance 1, the rest at 2⁻⁴ (4 stops down) and 2⁻⁹ (9 stops): the log-average is the
    /// geometric mean of all of them, 2^(−(0.5·4 + 0.25·9)) = 2^−4.25.
    #[test]
    fn dim_parts_within_the_window_count() {
        let pixels: Vec<[f32; 3]> = (0..1000)
            .map(|i| match i % 4 {
                0 => [1.0; 3],
                1 | 2 => [2f32.powi(-4); 3],
                _ => [2f32.powi(-9); 3],
            })
            .collect();
        let expected = 0.18 / 2f64.powf(-4.25);
        assert!((f64::from(auto_exposure(&pixels)) / expected - 1.0).abs() < 1e-5);
    }

    /// A firefly or two (under 1 % of the pixels) does not set the bright end: a pixel 20
    /// stops above a grey frame leaves the grey's exposure (it is itself metered, so the
    /// log-average moves by its 20 stops ÷ 1000 pixels).
    #[test]
    fn a_firefly_does_not_set_the_bright_end() {
        let mut pixels = vec![[1.0f32; 3]; 1000];
        pixels[7] = [2f32.powi(20); 3];
        let expected = 0.18 / 2f64.powf(20.0 / 1000.0);
        assert!((f64::from(auto_exposure(&pixels)) / expected - 1.0).abs() < 1e-5);
    }

    #[test]
    fn atomic_write_leaves_no_temp_and_replaces() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        write_png(&path, &two_pixels(), 1.0).unwrap();
        write_png(&path, &two_pixels(), 0.5).unwrap();
        assert_eq!(names(dir.path()), ["a.png"]);
        let decoded = image::open(&path).unwrap().to_rgb8();
        assert_eq!(decoded.get_pixel(0, 0).0, [188, 188, 188]);
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_written_through_and_stays_a_link() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.txt");
        std::fs::write(&real, b"old").unwrap();
        std::fs::set_permissions(&real, std::os::unix::fs::PermissionsExt::from_mode(0o640))
            .unwrap();
        let link = dir.path().join("link.txt");
        std::os::unix::fs::symlink("real.txt", &link).unwrap();
        write_atomically(&link, |w| {
            w.extend_from_slice(b"new");
            Ok(())
        })
        .unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        let mode = std::os::unix::fs::PermissionsExt::mode(
            &std::fs::metadata(&real).unwrap().permissions(),
        );
        assert_eq!(mode & 0o777, 0o640, "the file keeps its permissions");
        // A dangling link gets its target created, as a shell's `>` would.
        let dangling = dir.path().join("dangling.txt");
        std::os::unix::fs::symlink("made.txt", &dangling).unwrap();
        write_atomically(&dangling, |w| {
            w.extend_from_slice(b"made");
            Ok(())
        })
        .unwrap();
        assert_eq!(std::fs::read(dir.path().join("made.txt")).unwrap(), b"made");
        assert_eq!(
            names(dir.path()),
            ["dangling.txt", "link.txt", "made.txt", "real.txt"]
        );
        // A loop of links is refused, not followed forever.
        std::os::unix::fs::symlink("loop-b", dir.path().join("loop-a")).unwrap();
        std::os::unix::fs::symlink("loop-a", dir.path().join("loop-b")).unwrap();
        let message = format!(
            "{:#}",
            write_atomically(&dir.path().join("loop-a"), |_| Ok(())).unwrap_err()
        );
        assert!(
            message.contains("loop-a") && message.contains("symbolic links"),
            "{message}"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_written_in_place_and_stays_a_fifo() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe.png");
        mkfifo(&fifo);
        check_writable(&fifo).unwrap();
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        write_png(&fifo, &two_pixels(), 0.5).unwrap();
        let bytes = reader.join().unwrap();
        let decoded = image::load_from_memory(&bytes).unwrap().to_rgb8();
        assert_eq!(decoded.get_pixel(0, 0).0, [188, 188, 188]);
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
        assert_eq!(names(dir.path()), ["pipe.png"], "no temporary file");
    }

    #[cfg(unix)]
    #[test]
    fn a_reader_that_goes_away_is_a_write_error() {
        use std::io::Read;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe.bin");
        mkfifo(&fifo);
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || {
                let mut file = std::fs::File::open(fifo).unwrap();
                let mut first = [0u8; 1];
                file.read_exact(&mut first).unwrap();
            })
        };
        // Far more than any pipe buffer holds: the writer is still writing when the reader
        // closes its end.
        let result = write_atomically(&fifo, |w| {
            w.resize(16 << 20, 7);
            Ok(())
        });
        reader.join().unwrap();
        let message = format!("{:#}", result.unwrap_err());
        assert!(
            message.contains("pipe.bin") && message.contains("cannot write output"),
            "{message}"
        );
    }

    #[cfg(unix)]
    #[test]
    fn sockets_and_directories_are_refused() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let socket = dir.path().join("s.png");
        let _listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        for path in [&socket, &dir.path().to_path_buf()] {
            let check = format!("{:#}", check_writable(path).unwrap_err());
            let write = format!("{:#}", write_png(path, &two_pixels(), 1.0).unwrap_err());
            for message in [check, write] {
                assert!(
                    message.contains("a socket") || message.contains("a directory"),
                    "{message}"
                );
            }
        }
        assert!(
            std::fs::symlink_metadata(&socket)
                .unwrap()
                .file_type()
                .is_socket()
        );
    }
}
