//! The lenses that ship inside the binary, so `--lens dgauss.50mm` works from any folder.

use std::path::{Path, PathBuf};

use super::prescription::{LensFormat, Prescription, PrescriptionError};

/// (name, prescription text) of every bundled lens (`lenses/` in the repository).
pub const BUNDLED: &[(&str, &str)] = &[
    ("dgauss.50mm", include_str!("../../lenses/dgauss.50mm.dat")),
    ("wide.22mm", include_str!("../../lenses/wide.22mm.dat")),
    (
        "telephoto.250mm",
        include_str!("../../lenses/telephoto.250mm.dat"),
    ),
    (
        "fisheye.10mm",
        include_str!("../../lenses/fisheye.10mm.dat"),
    ),
    ("dgauss", include_str!("../../lenses/dgauss.dat")),
    ("wide", include_str!("../../lenses/wide.dat")),
    ("telephoto", include_str!("../../lenses/telephoto.dat")),
    ("fisheye", include_str!("../../lenses/fisheye.dat")),
];

/// The lens `realcam render` uses when none is given.
pub const DEFAULT_LENS: &str = "dgauss.50mm";

/// Loads `spec`: a file path if one exists there, else a bundled lens name (with or without
/// `.dat`, with or without a `lenses/` prefix).
pub fn load_lens(
    spec: &str,
    format: Option<LensFormat>,
) -> Result<Prescription, PrescriptionError> {
    let path = Path::new(spec);
    if path.exists() {
        return Prescription::load(path, format);
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = name.trim_end_matches(".dat");
    match BUNDLED.iter().find(|(bundled, _)| *bundled == name) {
        Some((bundled, text)) => Prescription::parse(
            text,
            &PathBuf::from(format!("lenses/{bundled}.dat")),
            format,
        ),
        None => Err(PrescriptionError {
            file: path.to_path_buf(),
            line: None,
            message: format!(
                "no such lens file, and not a bundled lens (bundled: {})",
                BUNDLED
                    .iter()
                    .map(|(n, _)| *n)
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
        for (name, _) in BUNDLED {
            let embedded = load_lens(name, None).unwrap();
            let file = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("lenses")
                .join(format!("{name}.dat"));
            let on_disk = Prescription::load(&file, None).unwrap();
            assert_eq!(embedded.rows, on_disk.rows, "{name}");
        }
        assert!(
            load_lens("no-such-lens", None)
                .unwrap_err()
                .to_string()
                .contains("bundled")
        );
    }
}
