//! The lenses that ship inside the binary, so `--lens dgauss.50mm` works from any folder: the
//! classic `.dat` tables of pbrt and Kolb, and the library of real designs in realcam's lens
//! format (`lenses/` in the repository; sources and licences in `lenses/README.md`).

use std::path::{Path, PathBuf};

use super::prescription::{LensFormat, Prescription, PrescriptionError};

/// A lens built into the binary.
#[derive(Clone, Copy, Debug)]
pub struct BundledLens {
    /// What `--lens` calls it, e.g. `dgauss.50mm`.
    pub name: &'static str,
    /// Its file in `lenses/` (the extension gives the format).
    pub file: &'static str,
    pub text: &'static str,
}

impl BundledLens {
    /// Parses the lens (`format` overrides a `.dat` table's layout detection).
    pub fn load(&self, format: Option<LensFormat>) -> Result<Prescription, PrescriptionError> {
        Prescription::parse(
            self.text,
            &PathBuf::from(format!("lenses/{}", self.file)),
            format,
        )
    }

    /// True for the classic `.dat` tables (pbrt and Kolb).
    pub fn is_table(&self) -> bool {
        self.file.ends_with(".dat")
    }
}

macro_rules! bundled {
    ($($name:literal => $file:literal),* $(,)?) => {
        &[$(BundledLens {
            name: $name,
            file: $file,
            text: include_str!(concat!("../../lenses/", $file)),
        }),*]
    };
}

/// Every bundled lens, classic tables first.
pub const BUNDLED: &[BundledLens] = bundled![
    "dgauss.50mm" => "dgauss.50mm.dat",
    "wide.22mm" => "wide.22mm.dat",
    "telephoto.250mm" => "telephoto.250mm.dat",
    "fisheye.10mm" => "fisheye.10mm.dat",
    "dgauss" => "dgauss.dat",
    "wide" => "wide.dat",
    "telephoto" => "telephoto.dat",
    "fisheye" => "fisheye.dat",
];

/// The lens `realcam render` uses when none is given.
pub const DEFAULT_LENS: &str = "dgauss.50mm";

/// The bundled lens called `name` (with or without its file extension or a `lenses/` prefix).
pub fn find_bundled(name: &str) -> Option<&'static BundledLens> {
    let name = Path::new(name)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    BUNDLED.iter().find(|b| b.name == name || b.file == name)
}

/// Loads `spec`: a file path if one exists there, else a bundled lens name.
pub fn load_lens(
    spec: &str,
    format: Option<LensFormat>,
) -> Result<Prescription, PrescriptionError> {
    let path = Path::new(spec);
    if path.exists() {
        return Prescription::load(path, format);
    }
    match find_bundled(spec) {
        Some(bundled) => bundled.load(format),
        None => Err(PrescriptionError {
            file: path.to_path_buf(),
            line: None,
            message: format!(
                "no such lens file, and not a bundled lens (bundled: {}; `realcam lenses` lists them)",
                BUNDLED
                    .iter()
                    .map(|b| b.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bundled_lens_loads_and_matches_its_file() {
        for bundled in BUNDLED {
            let embedded = load_lens(bundled.name, None).unwrap();
            let file = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("lenses")
                .join(bundled.file);
            let on_disk = Prescription::load(&file, None).unwrap();
            assert_eq!(embedded.rows, on_disk.rows, "{}", bundled.name);
            assert_eq!(embedded.info, on_disk.info, "{}", bundled.name);
        }
        assert!(
            load_lens("no-such-lens", None)
                .unwrap_err()
                .to_string()
                .contains("bundled")
        );
    }
}
