//! Lens files: reading them into a [`Prescription`] and writing one out.
//!
//! Every format reads into the model of [`crate::lens::prescription`] and validates through
//! [`Prescription::from_rows`]; the model never refers back to a format. [`Prescription::load`]
//! and [`Prescription::parse`] pick the reader by the file's extension (or, for Zemax, its
//! content):
//!
//! | format | reader |
//! |---|---|
//! | pbrt/Kolb `.dat` tables | [`dat`] |
//! | realcam's `.toml` | [`toml`] (also written by [`export`]) |
//! | Zemax `.zmx` | [`zemax`] |
//!
//! [`bundled`] holds the lenses built into the binary.

pub mod bundled;
pub mod dat;
pub mod export;
pub mod toml;
pub mod zemax;

use std::io::Read;
use std::path::Path;

use self::zemax::MAX_ZEMAX_BYTES;
use super::prescription::{LensFormat, Prescription, PrescriptionError};

/// Prescription files larger than this are refused before reading: the largest real lens
/// prescriptions have a few dozen rows.
pub const MAX_FILE_BYTES: u64 = 1 << 20;

// The readers are inherent methods so every caller keeps asking the model type for a lens;
// they live here so that the model depends on no file format.
impl Prescription {
    /// Reads and validates a prescription file; `format` overrides layout detection.
    pub fn load(
        path: &Path,
        format: Option<LensFormat>,
    ) -> Result<Prescription, PrescriptionError> {
        let error = |message: String| PrescriptionError {
            file: path.to_path_buf(),
            line: None,
            message,
        };
        let cannot_read = |e: std::io::Error| error(format!("cannot read lens file: {e}"));
        let file = std::fs::File::open(path).map_err(cannot_read)?;
        if file.metadata().map_err(cannot_read)?.is_dir() {
            return Err(error("is a directory, not a lens file".into()));
        }
        // Read through a limit rather than trusting the size: a device such as /dev/zero
        // reports 0 bytes and never ends.
        let mut bytes = Vec::new();
        file.take(MAX_ZEMAX_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(cannot_read)?;
        // Zemax files (often UTF-16, whatever their name) have their own decoding and limit.
        if extension(path) == "zmx" || zemax::looks_like_zemax(&bytes) {
            if bytes.len() as u64 > MAX_ZEMAX_BYTES {
                return Err(error(format!(
                    "is more than {MAX_ZEMAX_BYTES} bytes: too large for a Zemax lens file"
                )));
            }
            return zemax::read_zemax(&bytes, path);
        }
        if bytes.len() as u64 > MAX_FILE_BYTES {
            return Err(error(format!(
                "is more than {MAX_FILE_BYTES} bytes; a lens file is a small text table (a .dat of rows 'radius thickness index aperture', a realcam .toml or a Zemax .zmx)"
            )));
        }
        let text = String::from_utf8(bytes).map_err(|_| {
            error("is not a text file (invalid UTF-8); expected a .dat table of rows 'radius thickness index aperture', a realcam .toml or a Zemax .zmx".into())
        })?;
        Prescription::parse(&text, path, format)
    }

    /// Parses lens-file text; `source` names it in errors, gives the lens its name, and by its
    /// extension picks the format (`.toml`: realcam's own, `.zmx`: Zemax, else rows of a
    /// pbrt/Kolb `.dat` table, whose layout `format` overrides).
    pub fn parse(
        text: &str,
        source: &Path,
        format: Option<LensFormat>,
    ) -> Result<Prescription, PrescriptionError> {
        match extension(source).as_str() {
            "toml" => toml::read_lens_file(text, source),
            "zmx" => zemax::read_zemax(text.as_bytes(), source),
            _ if looks_like_json(text) => Err(PrescriptionError {
                file: source.to_path_buf(),
                line: None,
                message: JSON_LENS_FILE.into(),
            }),
            _ => dat::parse_dat(text, source, format),
        }
    }
}

/// Why a JSON lens file is refused, and what to do instead.
const JSON_LENS_FILE: &str = "is a JSON lens file (as DeepLens and lentil write them), which realcam does not read: \
     write the lens as a realcam .toml (lenses/README.md gives the format; `realcam lens FILE --export OUT.toml` \
     converts any lens file realcam reads), a pbrt .dat table or a Zemax .zmx";

/// Text that opens with `{` or `[`, as no `.dat` table does: some other program's JSON lens,
/// which the `.dat` parser would refuse for its first character alone.
fn looks_like_json(text: &str) -> bool {
    text.trim_start().starts_with(['{', '['])
}

/// A path's extension, lower case ("" when it has none).
pub fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// A text as it may be shown in a message: at most 60 characters, control characters escaped
/// (binary garbage must not scramble the user's terminal).
pub fn shorten(s: &str) -> String {
    const MAX: usize = 60;
    let shown: String = s.chars().take(MAX).flat_map(|c| c.escape_debug()).collect();
    if s.chars().count() <= MAX {
        shown
    } else {
        format!("{shown}…")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_json_lens_file_is_refused_for_what_it_is() {
        let deeplens = "{\n  \"info\": \"a cellphone lens\",\n  \"surfaces\": []\n}\n";
        for name in ["phone.json", "phone.dat", "phone"] {
            let error = Prescription::parse(deeplens, Path::new(name), None).unwrap_err();
            let message = error.to_string();
            assert!(message.contains("JSON lens file"), "{message}");
            assert!(message.contains("--export"), "{message}");
            assert!(!message.contains("found"), "{message}");
        }
    }
}
