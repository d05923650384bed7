//! Writing a lens in another format: realcam's own (`.toml`, everything realcam represents)
//! or a pbrt `.dat` table (spheres, planes and a plane stop only; glass in the fifth column;
//! the surfaces' coatings in comments, which no reader reads back).

use std::fmt::Write;
use std::path::Path;

use super::extension;
use super::toml::{write_coating, write_lens_file};
use crate::glass::Glass;
use crate::lens::prescription::{Prescription, SurfaceKind};

/// The formats a lens is exported in, as messages name them.
const EXPORT_FORMATS: &str = ".toml (realcam's lens format) or .dat (a pbrt table)";

/// The text of `prescription` in the format `path`'s extension names.
pub fn export_text(prescription: &Prescription, path: &Path) -> Result<String, String> {
    match extension(path).as_str() {
        "toml" => Ok(write_lens_file(prescription)),
        "dat" => write_dat(prescription),
        _ if path.is_dir() => Err(format!(
            "{}: is a directory; give a file name ending in {EXPORT_FORMATS}",
            path.display()
        )),
        "" => Err(format!(
            "{}: has no extension to choose the format by; name it {EXPORT_FORMATS}",
            path.display()
        )),
        other => Err(format!(
            "{}: cannot export a lens as '.{other}': use {EXPORT_FORMATS}",
            path.display()
        )),
    }
}

/// A pbrt-v3/v4 `.dat` table (thickness after each surface; radius 0 for the stop). Refuses
/// what the format cannot say: aspheres, a stop on a refracting surface, zoom positions and
/// focus groups. Coatings the lens gives its surfaces, which the format cannot say either but
/// which change no ray's path, are kept as comments (as `.toml` would write them), so that
/// they are not lost without a word; read back, the table's surfaces get the lens-wide default.
pub fn write_dat(prescription: &Prescription) -> Result<String, String> {
    if !prescription.spacings.is_empty() {
        return Err(
            "the lens has zoom positions or focus groups: a pbrt .dat table holds fixed spacings only; export to .toml instead"
                .into(),
        );
    }
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# {} — exported by realcam",
        prescription
            .info
            .title
            .as_deref()
            .unwrap_or(&prescription.name)
    );
    if let Some(source) = &prescription.info.source {
        let _ = writeln!(out, "# source: {source}");
    }
    let coated: Vec<usize> = (0..prescription.rows.len())
        .filter(|&i| prescription.coating(i).is_some())
        .collect();
    if !coated.is_empty() {
        let _ = writeln!(
            out,
            "# coatings (a .dat table cannot hold them: read back, every surface gets the lens-wide default; export to .toml to keep them):"
        );
        for i in coated {
            if let Some(coating) = prescription.coating(i) {
                let _ = writeln!(
                    out,
                    "#   surface {}: coating = {}",
                    i + 1,
                    write_coating(coating)
                );
            }
        }
    }
    let _ = writeln!(
        out,
        "# radius  thickness  index  aperture  [glass: V_d or MAKER:NAME]   (mm; thickness after each surface)"
    );
    for (i, row) in prescription.rows.iter().enumerate() {
        let n = i + 1;
        if row.kind() == SurfaceKind::Aspheric {
            return Err(format!(
                "surface {n} is aspheric (conic {}, {} polynomial terms): a pbrt .dat table holds spheres only; export to .toml instead",
                row.asphere.conic,
                row.asphere.order()
            ));
        }
        if row.base.stop && row.curvature() != 0.0 {
            return Err(format!(
                "the stop is on a curved surface (surface {n}): a pbrt .dat table's stop is a plane of its own; export to .toml instead"
            ));
        }
        let radius = match row.kind() {
            SurfaceKind::Stop => "0".to_string(),
            SurfaceKind::Flat => "inf".to_string(),
            _ => format!("{:?}", row.base.radius),
        };
        let glass = match row.glass {
            None => String::new(),
            Some(Glass::Model { v_d, .. }) => format!("  {v_d:?}"),
            Some(Glass::Catalogue(id)) => {
                let g = id.get();
                if g.name.chars().any(char::is_whitespace) {
                    return Err(format!(
                        "surface {n}: glass '{}' has a space in its name, which a .dat column cannot hold",
                        g.name
                    ));
                }
                format!("  {}:{}", g.maker.name().to_ascii_uppercase(), g.name)
            }
        };
        let _ = writeln!(
            out,
            "{radius}  {:?}  {:?}  {:?}{glass}",
            row.base.thickness, row.base.index, row.base.aperture
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::io::bundled::load_lens;

    #[test]
    fn an_export_path_without_a_format_says_what_is_wrong() {
        let lens = load_lens("dgauss.50mm", None).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let folder = export_text(&lens, dir.path()).unwrap_err();
        assert!(folder.contains("is a directory"), "{folder}");
        assert!(folder.contains(".toml"), "{folder}");
        let bare = export_text(&lens, &dir.path().join("mylens")).unwrap_err();
        assert!(bare.contains("has no extension"), "{bare}");
        let odd = export_text(&lens, Path::new("lens.txt")).unwrap_err();
        assert!(odd.contains("cannot export a lens as '.txt'"), "{odd}");
        assert!(export_text(&lens, Path::new("lens.toml")).is_ok());
    }
}
