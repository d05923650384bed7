//! Zemax import and aspheric tracing checked against an independent optical design program
//! (ray-optics 0.9.8, cross-checked by optiland: `tests/data/reference/README.md`), and every
//! shared Zemax file loading or being refused with the right message.

use std::path::{Path, PathBuf};

use realcam::lens::first_order::FirstOrder;
use realcam::lens::trace::{Ray, Travel, trace};
use realcam::lens::{Asphere, LensSystem, Prescription, SurfaceRow};
use serde_json::Value;

fn data(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(path)
}

fn reference() -> Value {
    let text = std::fs::read_to_string(data("reference/rayoptics-reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn entry<'a>(reference: &'a Value, id: &str) -> &'a Value {
    reference["lenses"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["id"] == id)
        .unwrap_or_else(|| panic!("no reference entry {id}"))
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

fn vec3(v: &Value) -> [f64; 3] {
    [f(&v[0]), f(&v[1]), f(&v[2])]
}

fn load(file: &str) -> Prescription {
    Prescription::load(&data(&format!("zmx/{file}")), None)
        .unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// First-order data against the reference's, to `tolerance` relative (mm for positions).
fn assert_paraxial(name: &str, system: &LensSystem, reference: &Value, tolerance: f64) {
    let fo = FirstOrder::compute(system).unwrap();
    let p = &reference["paraxial"];
    let close = |what: &str, ours: f64, theirs: f64| {
        let scale = theirs.abs().max(1.0);
        assert!(
            (ours - theirs).abs() <= tolerance * scale,
            "{name}: {what} {ours} vs {theirs} (reference)"
        );
    };
    close("EFL", fo.focal_length, f(&p["efl"]));
    close("BFL", fo.back_focal_length, f(&p["bfl"]));
    close("front focal point", fo.front_focal_z, f(&p["ffd"]));
    close(
        "entrance pupil z",
        fo.entrance_pupil.z_mm,
        f(&p["entrance_pupil_z"]),
    );
    close(
        "entrance pupil diameter",
        fo.entrance_pupil.diameter_mm,
        f(&p["epd"]),
    );
    close(
        "exit pupil z",
        fo.exit_pupil.z_mm - system.rear_z(),
        f(&p["exit_pupil_z"]),
    );
    close(
        "exit pupil diameter",
        fo.exit_pupil.diameter_mm,
        f(&p["exit_pupil_diameter"]),
    );
    close("f-number", fo.f_number, f(&p["f_number"]));
}

/// Every reference ray traced through `system` leaves the last surface where and as the
/// reference says, to `tolerance` mm (and radians).
fn assert_rays(name: &str, system: &LensSystem, reference: &Value, tolerance: f64) -> usize {
    let mut compared = 0;
    for ray in reference["rays"].as_array().unwrap() {
        let label = ray["label"].as_str().unwrap();
        let start = Ray {
            origin: vec3(&ray["start_point"]),
            direction: vec3(&ray["start_direction"]),
        };
        let out = trace(&system.f64s, start, Travel::SceneToFilm)
            .unwrap_or_else(|e| panic!("{name} {label}: blocked {e:?}"));
        let point = vec3(&ray["last_lens_surface"]["point"]);
        let direction = vec3(&ray["last_lens_surface"]["direction_after"]);
        for k in 0..3 {
            assert!(
                (out.origin[k] - point[k]).abs() < tolerance,
                "{name} {label}: point {:?} vs {point:?}",
                out.origin
            );
            assert!(
                (out.direction[k] - direction[k]).abs() < tolerance,
                "{name} {label}: direction {:?} vs {direction:?}",
                out.direction
            );
        }
        compared += 1;
    }
    compared
}

/// The reference's Zemax files that realcam reads, and the file each was computed from.
const READABLE: [(&str, &str); 4] = [
    ("lens1.zmx", "lens1.zmx"),
    ("US00583336-2-scaled.zmx", "US00583336-2-scaled.zmx"),
    ("US08427765-1.ZMX", "US08427765-1-S-TIM28.zmx"),
    (
        "circular_aperture_example_with_aperture.zmx",
        "circular_aperture_example_with_aperture.zmx",
    ),
];

#[test]
fn zemax_first_order_data_match_the_independent_program() {
    let reference = reference();
    for (id, file) in READABLE {
        let p = load(file);
        let system = LensSystem::new(&p.rows, None);
        // The issue asks for 0.1 %; both programs solve the same equations in f64, but the
        // reference sizes its pupil to its f-number by iteration (its f/4.5 lens reports
        // f/4.49999998): 1e-7.
        assert_paraxial(id, &system, entry(&reference, id), 1e-7);
    }
}

#[test]
fn zemax_real_rays_match_the_independent_program() {
    let reference = reference();
    let mut compared = 0;
    for (id, file) in READABLE {
        let p = load(file);
        let system = LensSystem::new(&p.rows, None);
        compared += assert_rays(id, &system, entry(&reference, id), 1e-9);
    }
    assert_eq!(compared, 44);
}

/// The catalogue indices realcam gives each glass at d equal the reference program's.
#[test]
fn zemax_glasses_resolve_to_the_same_indices() {
    let reference = reference();
    for (id, file) in READABLE {
        let p = load(file);
        for glass in entry(&reference, id)["glasses"].as_array().unwrap() {
            // Rows are the lens surfaces SURF 1.. in order.
            let row = &p.rows[glass["after_surface"].as_u64().unwrap() as usize - 1];
            let theirs = f(&glass["n_d_587.5618"]);
            assert!(
                (row.base.index - theirs).abs() < 1e-6,
                "{id} {}: n_d {} vs {theirs}",
                glass["name"],
                row.base.index
            );
        }
    }
}

/// The DeepLens designs the reference built from their JSON (aspheric phone lenses among
/// them), rebuilt here from the reference's own surface table: tests realcam's asphere
/// intersection, normals and paraxial data against the independent program.
#[test]
fn aspheric_designs_trace_as_the_independent_program_does() {
    let reference = reference();
    for id in [
        "deeplens/cellphone68deg.json",
        "deeplens/cellphone80deg.json",
        "deeplens/rf16mm_f2.8.json",
        "deeplens/rf50mm_f1.8.json",
        "deeplens/ef35mm_f2.0.json",
    ] {
        let lens = entry(&reference, id);
        let index_after = |surface: u64| {
            lens["glasses"]
                .as_array()
                .unwrap()
                .iter()
                .find(|g| g["after_surface"].as_u64() == Some(surface))
                .map_or(1.0, |g| f(&g["n_d_587.5618"]))
        };
        let surfaces = lens["surfaces"].as_array().unwrap();
        let stop = lens["stop_surface"].as_u64().unwrap();
        // The last entry is the image plane.
        let rows: Vec<SurfaceRow> = surfaces[..surfaces.len() - 1]
            .iter()
            .map(|s| {
                let number = s["surface"].as_u64().unwrap();
                let c = f(&s["c"]);
                let mut asphere = Asphere {
                    conic: s["k"].as_f64().unwrap_or(0.0),
                    ..Asphere::NONE
                };
                if let Some(coefficients) = s["poly_coefs_r2_first"].as_array() {
                    for (a, v) in asphere.coefficients.iter_mut().zip(coefficients) {
                        *a = f(v);
                    }
                }
                // No clipping: the reference's rays pass the design's apertures.
                let mut row = SurfaceRow::new(
                    if c == 0.0 { f64::INFINITY } else { 1.0 / c },
                    s["thickness_after"].as_f64().unwrap_or(0.0),
                    index_after(number),
                    f64::INFINITY,
                );
                row.base.stop = number == stop;
                row.asphere = asphere;
                row
            })
            .collect();
        let mut system = LensSystem::new(&rows, None);
        // The stop's size from the reference's entrance pupil.
        let fo = FirstOrder::compute(&system).unwrap();
        let epd = f(&lens["paraxial"]["epd"]);
        let stop_diameter = epd * system.stop_diameter() / fo.entrance_pupil.diameter_mm;
        assert!(stop_diameter.is_finite() || system.stop_diameter().is_infinite());
        let mut sized = rows.clone();
        sized[system.stop].base.aperture = 1.0;
        let unit = FirstOrder::compute(&LensSystem::new(&sized, None)).unwrap();
        sized[system.stop].base.aperture = epd / unit.entrance_pupil.diameter_mm;
        system = LensSystem::new(&sized, None);
        assert_paraxial(id, &system, lens, 1e-9);
        // Strong aspheres in f64: a Newton root to 1e-10 mm along the ray.
        assert_eq!(assert_rays(id, &system, lens, 1e-8), 11, "{id}");
    }
}

#[test]
fn every_shared_zemax_file_loads_or_is_refused_by_name() {
    for file in [
        "lens1.zmx",
        "US00583336-2-scaled.zmx",
        "circular_aperture_example_with_aperture.zmx",
        "US08427765-1-S-TIM28.zmx",
    ] {
        let p = load(file);
        assert!(p.rows.len() >= 7, "{file}");
    }
    let refused: [(&str, &[&str]); 3] = [
        ("HoO-V2C18Ex27.zmx", &["SURF 4", "MIRROR", "mirror"]),
        (
            "zemax_double_gaussian.zmx",
            &["SURF 1", "TYPE PARAXIAL", "ideal paraxial lens"],
        ),
        (
            "US08427765-1.ZMX",
            &[
                "SURF 3",
                "L-TIM28_MOLD",
                "nearest catalogue names",
                "L-TIM28",
            ],
        ),
    ];
    for (file, expected) in refused {
        let e = Prescription::load(&data(&format!("zmx/{file}")), None)
            .expect_err(file)
            .to_string();
        assert!(e.contains(file), "{e}");
        for part in expected {
            assert!(e.contains(part), "{file}: '{part}' not in: {e}");
        }
    }
}

/// The same lens in every encoding OpticStudio and text editors produce reads the same.
#[test]
fn encodings_and_line_endings_read_the_same() {
    let original = std::fs::read(data("zmx/lens1.zmx")).unwrap();
    let text = String::from_utf8(original.clone()).unwrap();
    let crlf = text.replace('\n', "\r\n");
    let with_note = format!("NOTE 0 Entwurf für Prüfung é\n{text}");
    let utf16 = |s: &str, little: bool| -> Vec<u8> {
        let mut bytes = if little {
            vec![0xFF, 0xFE]
        } else {
            vec![0xFE, 0xFF]
        };
        for unit in s.encode_utf16() {
            bytes.extend(if little {
                unit.to_le_bytes()
            } else {
                unit.to_be_bytes()
            });
        }
        bytes
    };
    let latin1: Vec<u8> = with_note.chars().map(|c| c as u32 as u8).collect();
    let mut utf8_bom = vec![0xEF, 0xBB, 0xBF];
    utf8_bom.extend(crlf.as_bytes());
    let variants: Vec<(&str, Vec<u8>)> = vec![
        ("crlf", crlf.as_bytes().to_vec()),
        ("utf-16le", utf16(&crlf, true)),
        ("utf-16be", utf16(&text, false)),
        ("utf-8 with a mark", utf8_bom),
        ("latin-1", latin1),
        ("utf-8", with_note.as_bytes().to_vec()),
    ];
    let expected = load("lens1.zmx").rows;
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in variants {
        let path = dir.path().join(format!("{}.zmx", name.replace(' ', "-")));
        std::fs::write(&path, bytes).unwrap();
        let p = Prescription::load(&path, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        let strip = |rows: &[SurfaceRow]| -> Vec<(f64, f64, f64, f64)> {
            rows.iter()
                .map(|r| {
                    (
                        r.base.radius,
                        r.base.thickness,
                        r.base.index,
                        r.base.aperture,
                    )
                })
                .collect()
        };
        assert_eq!(strip(&p.rows), strip(&expected), "{name}");
    }
}

/// A design written in centimetres, inches or metres is the same lens in millimetres.
#[test]
fn units_convert_to_millimetres() {
    let text = std::fs::read_to_string(data("zmx/US08427765-1-S-TIM28.zmx")).unwrap();
    let expected = load("US08427765-1-S-TIM28.zmx");
    let dir = tempfile::tempdir().unwrap();
    for (unit, scale) in [("CM", 10.0), ("IN", 25.4), ("METER", 1000.0)] {
        // Rewrite every length: curvatures ×scale, distances and semi-diameters ÷scale, the
        // even-asphere coefficient of r^(2i) × scale^(2i−1).
        let mut out = String::new();
        let mut asphere = false;
        for line in text.lines() {
            let mut tokens: Vec<String> = line.split_whitespace().map(String::from).collect();
            let number = |s: &str| s.parse::<f64>().ok();
            match tokens.first().map(String::as_str) {
                Some("SURF") => asphere = false,
                Some("TYPE") => asphere = tokens.get(1).is_some_and(|t| t == "EVENASPH"),
                _ => {}
            }
            match tokens.first().map(String::as_str) {
                Some("UNIT") => tokens[1] = unit.into(),
                Some("CURV") => tokens[1] = format!("{:e}", number(&tokens[1]).unwrap() * scale),
                Some("DISZ") | Some("DIAM") | Some("ENPD") if number(&tokens[1]).is_some() => {
                    tokens[1] = format!("{:e}", number(&tokens[1]).unwrap() / scale)
                }
                Some("PARM") if asphere => {
                    let i: i32 = tokens[1].parse().unwrap();
                    tokens[2] =
                        format!("{:e}", number(&tokens[2]).unwrap() * scale.powi(2 * i - 1));
                }
                _ => {}
            }
            out += &tokens.join(" ");
            out += "\n";
        }
        let path = dir.path().join(format!("lens-{unit}.zmx"));
        std::fs::write(&path, out).unwrap();
        let p = Prescription::load(&path, None).unwrap();
        for (a, b) in p.rows.iter().zip(&expected.rows) {
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * y.abs().max(1.0) || x == y;
            assert!(
                close(a.base.radius, b.base.radius),
                "{unit}: radius {} vs {}",
                a.base.radius,
                b.base.radius
            );
            assert!(close(a.base.thickness, b.base.thickness), "{unit}");
            assert!(close(a.base.aperture, b.base.aperture), "{unit}");
            for (x, y) in a.asphere.coefficients.iter().zip(&b.asphere.coefficients) {
                assert!((x - y).abs() <= 1e-12 * y.abs(), "{unit}: {x} vs {y}");
            }
        }
    }
}

/// What realcam cannot represent is refused, naming the file, the SURF and what it is.
#[test]
fn unrepresentable_zemax_files_are_refused_clearly() {
    const LENS: &str = "UNIT MM\nENPD 10\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0.02\n  DISZ 5\n  GLAS N-BK7 0 0 1.5 64\n  DIAM 12\n#EXTRA\nSURF 2\n  CURV -0.02\n  DISZ 40\n  DIAM 12\nSURF 3\n  DISZ 0\n";
    let cases: [(&str, &str, &[&str]); 12] = [
        (
            "coordbrk",
            "  TYPE COORDBRK",
            &["SURF 1", "COORDBRK", "coordinate break"],
        ),
        (
            "toroidal",
            "  TYPE TOROIDAL",
            &["SURF 1", "TOROIDAL", "toroidal"],
        ),
        ("grating", "  TYPE DGRATING", &["SURF 1", "grating"]),
        (
            "unknown type",
            "  TYPE WIGGLY",
            &["SURF 1", "WIGGLY", "does not know"],
        ),
        ("mirror", "  GLAS MIRROR 0 0 1.5 40", &["SURF 1", "mirror"]),
        ("obscuration", "  OBSC 0 2", &["SURF 1", "obscuration"]),
        ("rectangular", "  SQAP 4 5 0", &["SURF 1", "rectangular"]),
        ("decentred aperture", "  OBDC 1 0", &["SURF 1", "decentred"]),
        ("annular", "  CLAP 2 6 0", &["SURF 1", "annular"]),
        (
            "unknown glass",
            "  GLAS UNOBTAINIUM 0 0 1.5 40",
            &["SURF 1", "UNOBTAINIUM", "nearest catalogue names"],
        ),
        (
            "high asphere term",
            "  TYPE EVENASPH\n  PARM 9 1e-20",
            &["SURF 1", "PARM 9"],
        ),
        (
            "infinite lens thickness",
            "  DISZ INFINITY",
            &["SURF 1", "INFINITY"],
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (name, extra, expected) in cases {
        let path = dir.path().join(format!("{}.zmx", name.replace(' ', "-")));
        std::fs::write(&path, LENS.replace("#EXTRA", extra)).unwrap();
        let e = Prescription::load(&path, None).expect_err(name).to_string();
        assert!(e.starts_with(&path.display().to_string()), "{name}: {e}");
        for part in expected {
            assert!(e.contains(part), "{name}: '{part}' not in: {e}");
        }
    }
    let whole_file_cases = [
        (
            "zoom changing a curvature",
            format!("{LENS}\nMNUM 2 1\nCRVT 1 1 0.02 0 0\nCRVT 1 2 0.03 0 0\n"),
            "multi-configuration operand CRVT",
        ),
        ("non-sequential", format!("MODE NSC\n{LENS}"), "sequential"),
        (
            "no stop size",
            LENS.replace("ENPD 10\n", "")
                .replace("  DIAM 12\n#EXTRA", "#EXTRA"),
            "system aperture",
        ),
        (
            "unknown unit",
            LENS.replace("UNIT MM", "UNIT FURLONG"),
            "FURLONG",
        ),
        (
            "too few surfaces",
            "SURF 0\n  DISZ INFINITY\nSURF 1\n".into(),
            "SURF",
        ),
        ("out of order", LENS.replace("SURF 2", "SURF 7"), "in order"),
        (
            "bad number",
            LENS.replace("CURV 0.02", "CURV zero"),
            "expected a number",
        ),
    ];
    for (name, text, expected) in whole_file_cases {
        let path = dir.path().join(format!("{}.zmx", name.replace(' ', "-")));
        std::fs::write(&path, &text).unwrap();
        let e = Prescription::load(&path, None).expect_err(name).to_string();
        assert!(e.contains(expected), "{name}: '{expected}' not in: {e}");
    }
    // The base lens itself loads (so each case above fails for its own reason).
    let path = dir.path().join("base.zmx");
    std::fs::write(&path, LENS.replace("#EXTRA\n", "")).unwrap();
    Prescription::load(&path, None).unwrap();
    // A truncated UTF-16 file.
    let path = dir.path().join("truncated.zmx");
    std::fs::write(&path, [0xFF, 0xFE, b'S', 0, b'U']).unwrap();
    let e = Prescription::load(&path, None).unwrap_err().to_string();
    assert!(e.contains("truncated"), "{e}");
}

/// A glass realcam's catalogue lacks (Ohara's moulded L-TIM28_MOLD) is read as the glass
/// `--glass NAME=GLASS` names, with the lens otherwise as the file gives it: the same lens as
/// the file edited by hand to name S-TIM28.
#[test]
fn a_glass_the_catalogue_lacks_is_read_as_the_one_given() {
    use realcam::lens::io::{GlassSubstitute, ReadOptions};

    let original = data("zmx/US08427765-1.ZMX");
    let refusal = Prescription::load(&original, None).unwrap_err().to_string();
    assert!(
        refusal.contains("give --glass L-TIM28_MOLD=GLASS"),
        "{refusal}"
    );
    let reading = |substitute: &str| ReadOptions {
        format: None,
        glasses: vec![substitute.parse::<GlassSubstitute>().unwrap()],
    };
    let substituted = Prescription::read(&original, &reading("l-tim28_mold=S-TIM28")).unwrap();
    let edited = load("US08427765-1-S-TIM28.zmx");
    assert_eq!(substituted.rows.len(), edited.rows.len());
    for (a, b) in substituted.rows.iter().zip(&edited.rows) {
        assert!(a.same_optics(b), "{a:?}\nvs\n{b:?}");
        assert_eq!(a.glass, b.glass);
    }
    assert!(
        substituted.warnings.is_empty(),
        "{:?}",
        substituted.warnings
    );
    // A substitute the file has no use for, and one for a lens file that names its own
    // glasses, are said to be unused rather than passing silently.
    let typo = Prescription::read(
        &original,
        &ReadOptions {
            format: None,
            glasses: vec![
                "L-TIM28_MOLD=S-TIM28".parse().unwrap(),
                "L-TIM82_MOLD=S-TIM28".parse().unwrap(),
            ],
        },
    )
    .unwrap();
    assert!(
        typo.warnings
            .iter()
            .any(|w| w.contains("names no glass L-TIM82_MOLD")),
        "{:?}",
        typo.warnings
    );
    let dat = realcam::lens::io::bundled::read_lens("dgauss.50mm", &reading("F5=S-TIM28")).unwrap();
    assert!(
        dat.warnings.iter().any(|w| w.contains("read as it stands")),
        "{:?}",
        dat.warnings
    );
    // A model glass through an n_d and V_d: the surface's index is that n_d.
    let model = Prescription::read(&original, &reading("L-TIM28_MOLD=1.69,31.1")).unwrap();
    assert!(model.rows.iter().any(|r| r.base.index == 1.69));
    // A malformed or unknown substitute is refused naming it.
    for (bad, named) in [
        ("L-TIM28_MOLD", "NAME=GLASS"),
        ("L-TIM28_MOLD=", "give both"),
        ("L-TIM28_MOLD=NO-SUCH-GLASS", "NO-SUCH-GLASS"),
        ("L-TIM28_MOLD=0.5,30", "0.5,30"),
        ("L-TIM28_MOLD=1.69", "a model glass is N_D,V_D"),
    ] {
        let error = bad.parse::<GlassSubstitute>().unwrap_err();
        assert!(error.contains(named), "{bad}: {error}");
    }
    // The command line takes it for `realcam lens` (and `render`, which shares the option).
    let (code, stdout, stderr) = crate::support::cli::realcam_texts(
        &[
            "lens",
            "tests/data/zmx/US08427765-1.ZMX",
            "--glass",
            "L-TIM28_MOLD=S-TIM28",
            "--json",
        ],
        None,
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("S-TIM28"), "{stdout}");
}

/// A designer's file whose clear apertures reach a little past where two surfaces meet loads,
/// the apertures reduced to that circle with a warning: the EF 35 mm f/2's surfaces 8 and 9
/// (radii 45.81 and −46.16 mm, 2 mm apart) meet 9.538 mm
/// from the axis, inside the file's semi-apertures of 10.44 and 10.75 mm.
#[test]
fn a_designers_apertures_that_overlap_by_a_hair_are_reduced_with_a_warning() {
    let p = load("ef35mm_f2.0.zmx");
    let (r8, r9) = (p.rows[7].base, p.rows[8].base);
    // The exact meeting height of the two spheres, solved here by bisection on the sags.
    let sag = |r: f64, h: f64| r.signum() * (r.abs() - (r * r - h * h).sqrt());
    let gap = |h: f64| r8.thickness + sag(r9.radius, h) - sag(r8.radius, h);
    let (mut lo, mut hi) = (5.0, 10.4);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if gap(mid) < 0.0 { hi = mid } else { lo = mid }
    }
    assert!(
        (lo - 9.538).abs() < 1e-3,
        "the surfaces meet {lo} mm from the axis"
    );
    for row in [r8, r9] {
        assert!(
            row.aperture <= 2.0 * lo && row.aperture > 2.0 * lo - 2e-3,
            "aperture ⌀{} is not where the surfaces meet (⌀{})",
            row.aperture,
            2.0 * lo
        );
    }
    assert!(
        p.warnings
            .iter()
            .any(|w| w.contains("surface 9 meets surface 8") && w.contains("reduced to")),
        "{:?}",
        p.warnings
    );
    // Everything else as the file gives it.
    assert!((p.rows[0].base.aperture - 2.0 * 18.031727235645135).abs() < 1e-9);
}
