//! Zemax OpticStudio `.zmx` files (sequential mode): decoding, parsing, units, and the
//! conversion to a [`Prescription`].
//!
//! A `.zmx` file is a list of keyword lines. Global ones set the system (`UNIT`, the system
//! aperture `FNUM`/`ENPD`/`FLOA`, the glass catalogues `GCAT`, the fields `FTYP`/`XFLN`/
//! `YFLN`); `SURF n` opens the block of surface n, whose lines give its `TYPE`, `CURV`
//! (1/radius), `DISZ` (thickness to the next surface), `GLAS` (the medium after it), `DIAM`
//! (its **semi**-diameter), `CONI` (conic constant), `PARM i` (an even asphere's r^(2i)
//! coefficient), `STOP`, `COAT` (its coating, by its name in `COATING.DAT`: `AR`, `HEAR1`,
//! `HEAR2` and the ideal `I.<transmission>` are read, other names warned of), and apertures
//! such as `CLAP`. Surface 0 is the object, the last one
//! the image; the surfaces between are the lens. The image distance (the last lens surface's
//! `DISZ`) is the design's film distance.
//!
//! Everything is converted to millimetres in realcam's lens frame. What realcam cannot
//! represent (mirrors, coordinate breaks, tilted or decentred surfaces and apertures,
//! non-rotationally-symmetric or diffractive surfaces, multi-configuration operands other than
//! the thicknesses and the system aperture, unknown glass names) is refused, naming the file, the `SURF` number and what it is: never misread.
//!
//! A multi-configuration file (`MNUM n active`, then the editor's rows such as
//! `THIC surface configuration value …`) is a zoom: each configuration a zoom position
//! (`configurations`), the `SURF` blocks the active one.
//!
//! Four steps, a module each: `decode` (bytes to text; numbers and units), `parse` (the
//! keyword lines into the system and its `SURF` blocks, in file units), `convert` (the
//! refusals, then the rows in millimetres, the stop and clear apertures, validation) and
//! `configurations` (the zoom positions).

mod configurations;
mod convert;
mod decode;
mod parse;

use std::path::Path;

use super::GlassSubstitute;
use crate::lens::prescription::{Prescription, PrescriptionError};

/// Zemax files larger than this are refused before reading (real ones, merit functions and
/// tolerances included, are well below; UTF-16 doubles them).
pub const MAX_ZEMAX_BYTES: u64 = 16 << 20;

/// Reads a `.zmx` file's bytes (any of its encodings) into a validated prescription.
pub fn read_zemax(
    bytes: &[u8],
    source: &Path,
    substitutes: &[GlassSubstitute],
) -> Result<Prescription, PrescriptionError> {
    let error = |line: Option<usize>, message: String| PrescriptionError {
        file: source.to_path_buf(),
        line,
        message,
    };
    let text = decode::decode(bytes).map_err(|m| error(None, m))?;
    let (system, surfaces) = parse::parse(&text).map_err(|(line, m)| error(line, m))?;
    convert::convert(&system, &surfaces, source, substitutes)
}

/// True when `bytes` look like a Zemax file (its keywords, in any of its encodings): lets a
/// `.zmx` saved under another name load too.
pub fn looks_like_zemax(bytes: &[u8]) -> bool {
    let Ok(text) = decode::decode(&bytes[..bytes.len().min(4096)]) else {
        return false;
    };
    text.lines()
        .take(40)
        .any(|l| l.starts_with("VERS ") || l.starts_with("MODE SEQ") || l.starts_with("SURF 0"))
}
