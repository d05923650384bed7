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
use std::str::FromStr;

use self::zemax::MAX_ZEMAX_BYTES;
use super::prescription::{LensFormat, Prescription, PrescriptionError};
use crate::glass::{Glass, catalogue, looks_numeric};

/// Prescription files larger than this are refused before reading: the largest real lens
/// prescriptions have a few dozen rows.
pub const MAX_FILE_BYTES: u64 = 1 << 20;

/// What a lens file may leave open, given to its reader: the layout of a `.dat` table's
/// thickness column, and glasses to read in place of names the file gives.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadOptions {
    /// Layout of a `.dat` table's thickness column, when it cannot be detected.
    pub format: Option<LensFormat>,
    /// `--glass NAME=GLASS`: a Zemax file's glass `NAME` read as `GLASS`.
    pub glasses: Vec<GlassSubstitute>,
}

impl ReadOptions {
    /// Only the `.dat` layout.
    pub fn format(format: Option<LensFormat>) -> ReadOptions {
        ReadOptions {
            format,
            glasses: Vec::new(),
        }
    }
}

/// A glass a lens file names, read as another (`--glass NAME=GLASS`): the way round a name
/// realcam's catalogue lacks (a maker's moulded or newest glass), or a melt to try instead.
#[derive(Clone, Debug, PartialEq)]
pub struct GlassSubstitute {
    name: String,
    pub glass: Glass,
}

impl GlassSubstitute {
    /// Whether this substitute stands in for the file's glass `name` (case-insensitive, as
    /// Zemax names are).
    pub fn replaces(&self, name: &str) -> bool {
        self.name.eq_ignore_ascii_case(name)
    }

    pub fn name(&self) -> &str {
        &self.name
    }
}

impl FromStr for GlassSubstitute {
    type Err = String;

    /// `NAME=GLASS`, where GLASS is a catalogue glass (`S-TIM28`, `ohara:S-TIM28`) or a model
    /// glass `N_D,V_D`.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let Some((name, glass)) = text.split_once('=') else {
            return Err(format!(
                "'{text}' is not NAME=GLASS (e.g. L-TIM28_MOLD=S-TIM28, or NAME=1.69,31.1)"
            ));
        };
        let (name, glass) = (name.trim(), glass.trim());
        if name.is_empty() || glass.is_empty() {
            return Err(format!(
                "'{text}': give both the file's glass name and the glass to read it as"
            ));
        }
        let glass = if looks_numeric(glass) {
            let numbers: Vec<Option<f64>> = glass
                .split(',')
                .map(|t| t.trim().parse::<f64>().ok())
                .collect();
            let [Some(n_d), Some(v_d)] = numbers[..] else {
                return Err(format!(
                    "'{glass}': a model glass is N_D,V_D (e.g. 1.69,31.1)"
                ));
            };
            Glass::model(n_d, v_d).map_err(|e| format!("'{glass}': {e}"))?
        } else {
            Glass::Catalogue(
                catalogue()
                    .find(glass)
                    .map_err(|e| format!("'{glass}': {e}"))?,
            )
        };
        Ok(GlassSubstitute {
            name: name.to_string(),
            glass,
        })
    }
}

// The readers are inherent methods so every caller keeps asking the model type for a lens;
// they live here so that the model depends on no file format.
impl Prescription {
    /// Reads and validates a prescription file; `format` overrides layout detection.
    pub fn load(
        path: &Path,
        format: Option<LensFormat>,
    ) -> Result<Prescription, PrescriptionError> {
        Prescription::read(path, &ReadOptions::format(format))
    }

    /// Reads and validates a prescription file as `options` say.
    pub fn read(path: &Path, options: &ReadOptions) -> Result<Prescription, PrescriptionError> {
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
            return zemax::read_zemax(&bytes, path, &options.glasses);
        }
        if bytes.len() as u64 > MAX_FILE_BYTES {
            return Err(error(format!(
                "is more than {MAX_FILE_BYTES} bytes; a lens file is a small text table (a .dat of rows 'radius thickness index aperture', a realcam .toml or a Zemax .zmx)"
            )));
        }
        let text = String::from_utf8(bytes).map_err(|_| {
            error("is not a text file (invalid UTF-8); expected a .dat table of rows 'radius thickness index aperture', a realcam .toml or a Zemax .zmx".into())
        })?;
        Prescription::parse_with(&text, path, options)
    }

    /// Parses lens-file text; `source` names it in errors, gives the lens its name, and by its
    /// extension picks the format (`.toml`: realcam's own, `.zmx`: Zemax, else rows of a
    /// pbrt/Kolb `.dat` table, whose layout `format` overrides).
    pub fn parse(
        text: &str,
        source: &Path,
        format: Option<LensFormat>,
    ) -> Result<Prescription, PrescriptionError> {
        Prescription::parse_with(text, source, &ReadOptions::format(format))
    }

    /// As [`parse`](Self::parse), with all of `options`.
    pub fn parse_with(
        text: &str,
        source: &Path,
        options: &ReadOptions,
    ) -> Result<Prescription, PrescriptionError> {
        let format = options.format;
        let extension = extension(source);
        if extension == "zmx" {
            return zemax::read_zemax(text.as_bytes(), source, &options.glasses);
        }
        let mut prescription = match extension.as_str() {
            "toml" => toml::read_lens_file(text, source),
            _ if looks_like_json(text) => Err(PrescriptionError {
                file: source.to_path_buf(),
                line: None,
                message: JSON_LENS_FILE.into(),
            }),
            _ => dat::parse_dat(text, source, format),
        }?;
        if !options.glasses.is_empty() {
            prescription.warnings.push(
                "--glass renames the glasses of Zemax files; this lens file names its glasses itself, so it is read as it stands".into(),
            );
        }
        Ok(prescription)
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
