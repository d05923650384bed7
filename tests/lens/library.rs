//! The library of real designs (`lenses/*.toml`, built into the binary): each design's optics,
//! computed by realcam, against the numbers its source publishes; and `realcam lenses`.
//!
//! The published numbers below are copied from the sources (patents as quoted by DeepLens and
//! lentil, the makers' marked values, the Zemax file's targets, the patent tables of the zoom and
//! focus-group designs), not from realcam: see each lens file's `notes` and lenses/README.md for
//! where each comes from.

use crate::support;

use support::cli::realcam_texts;

use std::path::Path;

use realcam::lens::clear_aperture::widest_stop;
use realcam::lens::field::field_angle;
use realcam::lens::first_order::FirstOrder;
use realcam::lens::io::bundled::{BUNDLED, BundledLens, load_lens};
use realcam::lens::report::LensReport;
use realcam::lens::settings::LensSettings;
use realcam::lens::trace::{Ray, Travel, normalize, trace};
use realcam::lens::{LensSystem, Prescription, SurfaceRow};

/// How closely a computed focal length must meet the published one, and why.
#[derive(Clone, Copy, Debug)]
enum Basis {
    /// A maker's marked focal length. Marked values are nominal, rounded to the customary series
    /// (…, 16, 24, 35, 40, 50, 70, 85, 100, …), and a patent example is one design for the
    /// product, not the product itself: 5 %. Conversion errors are far larger (a semi-aperture
    /// read as a radius, inches for mm, a coefficient order) or show in the other checks.
    Marketed,
    /// The focal length a patent (or a design file) states for the very prescription
    /// converted, normalised (f = 1 or 100) or to three figures: its tables, rounded to 3–5
    /// significant digits, reproduce it to far better than 1 %.
    Patent,
}

impl Basis {
    fn tolerance(self) -> f64 {
        match self {
            Basis::Marketed => 0.05,
            Basis::Patent => 0.01,
        }
    }
}

struct Published {
    name: &'static str,
    focal_length_mm: Option<(f64, Basis)>,
    f_number: Option<f64>,
}

const fn marketed(name: &'static str, focal: f64, f_number: f64) -> Published {
    Published {
        name,
        focal_length_mm: Some((focal, Basis::Marketed)),
        f_number: Some(f_number),
    }
}

const fn patent(name: &'static str, focal: f64, f_number: Option<f64>) -> Published {
    Published {
        name,
        focal_length_mm: Some((focal, Basis::Patent)),
        f_number,
    }
}

/// Every design in the library with what its source publishes.
const LIBRARY: &[Published] = &[
    marketed("canon-ef-35mm-f2", 35.0, 2.0),
    marketed("canon-ef-40mm-f2.8", 40.0, 2.8),
    marketed("canon-ef-50mm-f1.8", 50.0, 1.8),
    marketed("canon-ef-85mm-f1.8", 85.0, 1.8),
    marketed("canon-ef-100mm-f2.8-macro", 100.0, 2.8),
    marketed("canon-rf-16mm-f2.8", 16.0, 2.8),
    marketed("canon-rf-24mm-f1.8-macro", 24.0, 1.8),
    marketed("canon-rf-50mm-f1.8", 50.0, 1.8),
    marketed("sigma-70mm-f2.8-macro", 70.0, 2.8),
    marketed("yongnuo-50mm-f1.8", 50.0, 1.8),
    // The design's nominal 50 mm f/4 (DeepLens names no source).
    patent("cooke-triplet-50mm-f4", 50.0, Some(4.0)),
    // DeepLens's own designs publish a field of view, checked below.
    Published {
        name: "deeplens-phone-68deg",
        focal_length_mm: None,
        f_number: None,
    },
    Published {
        name: "deeplens-phone-80deg",
        focal_length_mm: None,
        f_number: None,
    },
    // lentil's focal-length-mm-patent; f-numbers quoted from the patents in lentil's notes.
    patent("angenieux-double-gauss-1953", 100.0, None),
    patent("meyer-primoplan-1936", 100.0, None),
    patent("nikon-retrofocus-wide-1971", 100.0, Some(2.8)),
    patent("kodak-petzval-1948", 100.0, None),
    patent("zeiss-biotar-1927", 100.0, None),
    patent("asahi-takumar-1969", 100.0, None),
    patent("asahi-takumar-1970", 100.0, Some(2.0)),
    // lentil's 6.0 mm contradicts its own prescription (see its notes): checked below instead.
    Published {
        name: "aspheric-fisheye",
        focal_length_mm: None,
        f_number: None,
    },
    // Patents normalised to f = 1, scaled to the products' 16 mm and 35 mm.
    patent("minolta-fisheye-16mm-f2.8", 16.0, Some(2.8)),
    patent("canon-35mm-f1.8", 35.0, Some(1.8)),
    // The Zemax file's EFLY target and FNUM.
    patent("rudolph-double-gauss", 49.4, Some(4.5)),
    // Typed from patent tables (lenses/tools/make_patent_lenses.py), at infinity focus: US
    // 2018/0031811 A1 Table 4 (f = 587.80 mm, FNO 4.08); WO 2021/085655 A1 Table 6 (f = 84 mm,
    // F/1.47).
    patent("nikon-af-s-600mm-f4e-fl-if", 587.80, Some(4.08)),
    patent("samyang-af-85mm-f1.4-if", 84.0, Some(1.47)),
    // The zooms as their surfaces are written, at the position whose stop opens widest: US
    // 5,899,585 Table 1's wide end (f = 28.98 mm, F/3.46); JP 2013-140404 A Numerical Example 1's
    // middle position (f = 135.00 mm, Fno 4.67). Every position is checked below.
    patent("canon-ef-28-80mm-f3.5-5.6-zoom", 28.98, Some(3.46)),
    patent("canon-ef-70-300mm-f4-5.6-zoom", 135.0, Some(4.67)),
];

fn library() -> impl Iterator<Item = &'static BundledLens> {
    BUNDLED.iter().filter(|b| !b.is_table())
}

fn load(name: &str) -> (Prescription, LensSystem, FirstOrder) {
    let prescription = load_lens(name, None).unwrap_or_else(|e| panic!("{name}: {e}"));
    let system = LensSystem::new(&prescription.rows, None);
    let first_order = FirstOrder::compute(&system).unwrap_or_else(|e| panic!("{name}: {e}"));
    (prescription, system, first_order)
}

#[test]
fn every_design_is_bundled_with_its_source_and_licence() {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("lenses");
    let mut on_disk: Vec<String> = std::fs::read_dir(&folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".toml"))
        .collect();
    on_disk.sort();
    let mut bundled: Vec<String> = library().map(|b| b.file.to_string()).collect();
    bundled.sort();
    assert_eq!(
        on_disk, bundled,
        "every lenses/*.toml is bundled, and only those"
    );
    let mut named: Vec<&str> = LIBRARY.iter().map(|p| p.name).collect();
    named.sort();
    let mut names: Vec<&str> = library().map(|b| b.name).collect();
    names.sort();
    assert_eq!(
        named, names,
        "every bundled design has its published figures here"
    );
    for lens in library() {
        assert_eq!(format!("{}.toml", lens.name), lens.file);
        let (p, _, _) = load(lens.name);
        assert_eq!(p.name, lens.name);
        let info = &p.info;
        for (what, value) in [
            ("title", &info.title),
            ("source", &info.source),
            ("notes", &info.notes),
        ] {
            assert!(
                value.as_deref().is_some_and(|v| v.len() > 10),
                "{}: no {what}",
                lens.name
            );
        }
        let source = info.source.as_deref().unwrap();
        assert!(
            source.contains(" @ ") && source.contains(" : "),
            "{}: the source names the repository, commit and path: {source}",
            lens.name
        );
        let licence_file = match info.licence.as_deref() {
            Some("Apache-2.0") => "DeepLens-Apache-2.0.txt",
            Some("MIT") => "lentil-MIT.txt",
            Some("BSD-3-Clause") => "ray-optics-BSD-3-Clause.txt",
            // Numbers typed from patent tables; the file says why no licence applies.
            Some("none (facts from patent tables)") => "patent-facts.txt",
            other => panic!("{}: licence {other:?}", lens.name),
        };
        assert!(
            folder.join("licenses").join(licence_file).is_file(),
            "{licence_file}"
        );
        assert!(
            info.film_diagonal_mm.is_some_and(|d| d > 1.0),
            "{}: no image format",
            lens.name
        );
        assert!(
            info.film_distance_mm.is_some(),
            "{}: no design image distance",
            lens.name
        );
    }
}

#[test]
fn focal_lengths_and_f_numbers_match_the_published_ones() {
    for published in LIBRARY {
        let name = published.name;
        let (p, _, fo) = load(name);
        // The file's nominal fields are the same published numbers.
        assert_eq!(
            p.info.focal_length_mm,
            published.focal_length_mm.map(|f| f.0),
            "{name}"
        );
        assert_eq!(p.info.f_number, published.f_number, "{name}");
        if let Some((focal, basis)) = published.focal_length_mm {
            let error = fo.focal_length / focal - 1.0;
            assert!(
                error.abs() < basis.tolerance(),
                "{name}: focal length {:.3} mm, published {focal} mm ({basis:?}: {:.1} %)",
                fo.focal_length,
                100.0 * error
            );
        }
        // The converter sized each stop for the published f-number with its own paraxial
        // trace (lenses/tools/make_library.py); realcam's entrance pupil must agree.
        if let Some(f_number) = published.f_number {
            assert!(
                (fo.f_number / f_number - 1.0).abs() < 1e-3,
                "{name}: f/{:.4}, published f/{f_number}",
                fo.f_number
            );
        }
    }
}

/// Height on the film (at the design's image distance) of the chief ray entering at `angle`
/// (radians) through the centre of a stop on the front vertex, traced scene to film; `None`
/// if a clear aperture stops it.
fn chief_ray_height(p: &Prescription, system: &LensSystem, angle: f64) -> Option<f64> {
    assert_eq!(system.stop, 0, "{}: the stop is the first surface", p.name);
    let ray = Ray {
        origin: [0.0, -angle.tan(), -1.0],
        direction: normalize([0.0, angle.sin(), angle.cos()]),
    };
    let out = trace(&system.f64s, ray, Travel::SceneToFilm).ok()?;
    let film_z = system.rear_z() + p.info.film_distance_mm.unwrap();
    let t = (film_z - out.origin[2]) / out.direction[2];
    Some(out.origin[1] + t * out.direction[1])
}

/// The real half-field angle (degrees) whose chief ray reaches `height` on the film.
fn half_field_reaching(p: &Prescription, system: &LensSystem, height: f64) -> f64 {
    let mut lo = 0.0f64;
    let mut hi = loop {
        let next = lo + 0.1f64.to_radians();
        let h = chief_ray_height(p, system, next)
            .unwrap_or_else(|| panic!("{}: blocked before reaching {height} mm", p.name));
        if h >= height {
            break next;
        }
        lo = next;
    };
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if chief_ray_height(p, system, mid).unwrap() < height {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).to_degrees()
}

/// DeepLens's phone designs publish their field of view on their own sensor (the name, and for
/// the 80° design its foclen and fnum, which DeepLens defines from that field: foclen = sensor
/// radius / tan(half field), fnum = foclen / entrance-pupil diameter).
#[test]
fn phone_lenses_see_their_published_fields() {
    // cellphone68deg.json: r_sensor 3.565 mm; named for 68°.
    let (p, system, _) = load("deeplens-phone-68deg");
    assert_eq!(p.info.film_diagonal_mm, Some(7.13));
    let field = 2.0 * half_field_reaching(&p, &system, 3.565);
    assert!((field - 68.0).abs() < 1.0, "68° design: {field:.2}°");

    // cellphone80deg.json: r_sensor 3.83 mm, foclen 4.3458705, fnum 1.9935185 ("80deg FoV,
    // F/2.0"). DeepLens defines foclen as r_sensor / tan(half field), which puts the sensor
    // corner at atan(3.83 / 4.3458705) = 41.39°, the 82.8° its name rounds to 80°. Its half
    // field averages the directions of a fan of rays from the sensor corner across the rear
    // element (its calc_fov), where this follows the chief ray; in a phone lens at the edge of
    // the field that fan spreads over about a degree, so the two agree to half a degree.
    let (p, system, fo) = load("deeplens-phone-80deg");
    assert_eq!(p.info.film_diagonal_mm, Some(7.66));
    let half = half_field_reaching(&p, &system, 3.83);
    let deeplens_half = (3.83f64 / 4.345_870_5).atan().to_degrees();
    assert!(
        (half - deeplens_half).abs() < 0.5,
        "80° design: half field {half:.3}°, DeepLens {deeplens_half:.3}°"
    );
    // DeepLens's fnum is its foclen over the entrance pupil: the pupil is its stop, 2.18 mm
    // across (a radius read as a diameter would show here).
    let deeplens_pupil = 4.345_870_5 / 1.993_518_5;
    assert!(
        (fo.entrance_pupil.diameter_mm - deeplens_pupil).abs() < 1e-5,
        "{}",
        fo.entrance_pupil.diameter_mm
    );
    // The paraxial focal length differs from DeepLens's: the lens has strong barrel distortion.
    assert!(
        fo.focal_length > 4.9 && fo.focal_length < 5.3,
        "{}",
        fo.focal_length
    );
}

/// lentil's aspheric fisheye: its listed focal length (6.0 mm) is contradicted by its own
/// prescription, but the prescription is self-consistent: the designer put the image plane
/// (14.0 mm behind the cover glass, in lentil's data and its source .fx file) at the paraxial
/// focus, and the lens sees a hemisphere (the .fx file: "181 degree fov").
#[test]
fn the_aspheric_fisheye_focuses_where_its_designer_put_the_film() {
    let (p, system, fo) = load("aspheric-fisheye");
    assert_eq!(p.info.film_distance_mm, Some(14.0));
    // A designer's image plane sits at the best focus, within a few depths of focus (at f/2,
    // ±2·N·c ≈ 0.02 mm for a 5 µm spot) of the paraxial one.
    assert!(
        (fo.back_focal_length - 14.0).abs() < 0.05,
        "{}",
        fo.back_focal_length
    );
    // The widest chief ray: scan the film out past the image circle's edge. The clear
    // apertures of the front element, lentil's housing radii (trimmed where the element's
    // surfaces would cross), limit the widest field: allow 2° below the design's 181°.
    let widest = (0..=1600)
        .filter_map(|k| field_angle(&system, fo.back_focal_length, 0.01 * k as f64))
        .fold(0.0f64, f64::max);
    assert!(
        2.0 * widest.to_degrees() > 179.0,
        "{}",
        2.0 * widest.to_degrees()
    );
    assert_eq!(p.rows.iter().filter(|r| r.asphere.order() > 0).count(), 4);
}

/// lentil's own ray tracer found, for each design, the largest iris radius whose axial beam no
/// housing clips (`max-fstop-aperture-radius`, "unscaled", in lenses.json @ 1492e9dc); where a
/// housing, not the iris, limits it, realcam's real-ray search of the same limit
/// ([`widest_stop`]) must find the same diameter. lentil traces at 550 nm in f32, stepping
/// the entering height by 1/1000 of the front housing radius: 0.3 %.
#[test]
fn the_widest_unclipped_stop_agrees_with_lentils_ray_trace() {
    for (name, lentil_radius, scale) in [
        ("meyer-primoplan-1936", 23.368_825_585_717_612, 1.0),
        ("asahi-takumar-1969", 25.422_512_243_860_86, 1.0),
        ("asahi-takumar-1970", 27.724_794_114_629_262, 1.0),
        ("canon-35mm-f1.8", 0.185_174_635_616_521_2, 35.0),
    ] {
        let (p, system, _) = load(name);
        let widest = widest_stop(&p.rows, system.stop, &vec![false; p.rows.len()]).unwrap();
        let lentil = 2.0 * lentil_radius * scale;
        assert!(
            (widest / lentil - 1.0).abs() < 3e-3,
            "{name}: realcam {widest:.4} mm, lentil {lentil:.4} mm"
        );
    }
}

/// The Zemax design as realcam's own `.zmx` reader reads it (tests/data/zmx, the same file the
/// converter read) and the library's conversion are the same lens: the converter's paraxial
/// stop sizing for the file's FNUM agrees with the reader's, and leaving out the file's dummy
/// front plane changes nothing.
#[test]
fn rudolph_double_gauss_is_its_zemax_file() {
    let (library, _, converted) = load("rudolph-double-gauss");
    let zmx = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/zmx/US00583336-2-scaled.zmx");
    let direct = Prescription::load(&zmx, None).unwrap();
    let direct_fo = FirstOrder::compute(&LensSystem::new(&direct.rows, None)).unwrap();
    assert!((converted.focal_length - direct_fo.focal_length).abs() < 1e-9);
    // The converter took the glasses' n_d to five decimals (Schott's data sheets).
    assert!(
        (converted.f_number / direct_fo.f_number - 1.0).abs() < 1e-4,
        "{} vs {}",
        converted.f_number,
        direct_fo.f_number
    );
    assert_eq!(library.rows.len() + 1, direct.rows.len());
    for (a, b) in library.rows.iter().zip(&direct.rows[1..]) {
        assert!((a.curvature() - b.curvature()).abs() < 1e-12);
        assert!((a.base.index - b.base.index).abs() < 1e-12);
        assert_eq!(a.base.stop, b.base.stop);
    }
}

/// A zoom lens's positions as its patent tabulates them.
struct PatentZoom {
    name: &'static str,
    /// The surfaces (numbered from 1, the stop counted) after which the gaps change.
    surfaces: &'static [usize],
    /// Per position: focal length (mm), F-number, the gaps after `surfaces` (mm), and the back
    /// focus (last surface to image, mm) where the patent prints it.
    positions: &'static [(f64, f64, &'static [f64], Option<f64>)],
}

const PATENT_ZOOMS: &[PatentZoom] = &[
    // US 5,899,585, Numerical Example 1 (Table 1): f = 28.98, 50.00, 77.08; FNo 3.46, 4.51, 5.88;
    // D8, D17 (the stop is the patent's surface 11). No back focus is printed.
    PatentZoom {
        name: "canon-ef-28-80mm-f3.5-5.6-zoom",
        surfaces: &[8, 17],
        positions: &[
            (28.98, 3.46, &[32.88, 3.01], None),
            (50.00, 4.51, &[11.61, 17.95], None),
            (77.08, 5.88, &[1.31, 37.21], None),
        ],
    },
    // JP 2013-140404 A, Numerical Example 1: f = 72.20, 135.00, 290.00; Fno 4.20, 4.67, 5.86;
    // D5, D10, D16 (after the stop, surface 16), D19, D26; BF 46.74, 47.82, 57.41.
    PatentZoom {
        name: "canon-ef-70-300mm-f4-5.6-zoom",
        surfaces: &[5, 10, 16, 19, 26],
        positions: &[
            (72.20, 4.20, &[2.78, 26.47, 6.01, 16.39, 11.97], Some(46.74)),
            (
                135.00,
                4.67,
                &[32.18, 14.15, 24.56, 10.16, 10.82],
                Some(47.82),
            ),
            (290.00, 5.86, &[56.78, 1.28, 44.99, 2.60, 1.30], Some(57.41)),
        ],
    },
];

/// `realcam lens`'s report of `name` at `zoom_position` (1-based; `None`: as written), focused
/// at `metres` from the film.
fn report_at(name: &str, zoom_position: Option<usize>, metres: f64) -> anyhow::Result<LensReport> {
    let lens = load_lens(name, None).unwrap_or_else(|e| panic!("{name}: {e}"));
    LensReport::derive(
        lens,
        &LensSettings {
            zoom_position,
            focus_distance: Some(metres),
            ..LensSettings::default()
        },
    )
}

/// Each zoom position has the focal length and f-number its patent states for it, with the
/// patent's gaps, and where the patent prints the back focus, the film where it says.
#[test]
fn zoom_positions_have_their_patents_focal_lengths_and_f_numbers() {
    for zoom in PATENT_ZOOMS {
        let name = zoom.name;
        let all = report_at(name, None, f64::INFINITY).unwrap();
        assert_eq!(all.zoom_positions.len(), zoom.positions.len(), "{name}");
        let spacings = &all.prescription.spacings;
        for (k, &(focal, f_number, gaps, back_focus)) in zoom.positions.iter().enumerate() {
            let at = report_at(name, Some(k + 1), f64::INFINITY).unwrap();
            let fo = &at.geometry.first_order;
            // The focal length a patent states for its own table: 1 % (Basis::Patent).
            for computed in [fo.focal_length, all.zoom_positions[k].focal_length_mm] {
                assert!(
                    (computed / focal - 1.0).abs() < Basis::Patent.tolerance(),
                    "{name} position {}: focal length {computed:.3} mm, the patent's {focal} mm",
                    k + 1
                );
            }
            // The stop of each position is sized for its F-number (make_patent_lenses.py's
            // paraxial trace); realcam's entrance pupil must agree.
            for computed in [fo.f_number, all.zoom_positions[k].f_number] {
                assert!(
                    (computed / f_number - 1.0).abs() < 1e-3,
                    "{name} position {}: f/{computed:.4}, the patent's F/{f_number}",
                    k + 1
                );
            }
            assert_eq!(spacings.zoom[k].focal_length_mm, Some(focal), "{name}");
            let rows = &at.geometry.system.rows;
            for (&surface, &gap) in zoom.surfaces.iter().zip(gaps) {
                assert!(
                    (rows[surface - 1].base.thickness - gap).abs() < 1e-9,
                    "{name} position {}: gap after surface {surface}",
                    k + 1
                );
            }
            // The patent's back focus is printed to 0.01 mm from gaps printed to 0.01 mm; over
            // a 290 mm focal length those reproduce it to 0.06 mm.
            if let Some(back_focus) = back_focus {
                assert!(
                    (at.film_distance - back_focus).abs() < 0.1,
                    "{name} position {}: film {:.4} mm behind the lens, the patent's BF {back_focus} mm",
                    k + 1,
                    at.film_distance
                );
            }
        }
    }
}

/// A prime that focuses by moving groups, as its patent tabulates them.
struct PatentFocus {
    name: &'static str,
    /// The closest focus, object to image, metres.
    close_m: f64,
    /// The surfaces (numbered from 1) after which the gaps change, and the gaps at infinity and
    /// at the closest focus (mm).
    surfaces: &'static [usize],
    infinity: &'static [f64],
    close: &'static [f64],
    /// The back focus (last surface to image, in air, without the patent's filter plate) at
    /// infinity and at the closest focus, mm.
    back_focus: (f64, f64),
    /// At the closest focus: the object's distance in front of surface 1 (mm) and the
    /// magnification (unsigned).
    object_mm: f64,
    magnification: f64,
}

const PATENT_FOCUS: &[PatentFocus] = &[
    // US 2018/0031811 A1, Example 4 (Table 4): d11, d14 at infinity and at the close state, the
    // object d0 = 3930.900 mm before surface 1 with TL = 469.10 mm (4.400 m object to image),
    // beta = -0.145; air-converted BF 82.26 mm (the image plane is fixed: the focus group keeps it).
    PatentFocus {
        name: "nikon-af-s-600mm-f4e-fl-if",
        close_m: 4.4,
        surfaces: &[11, 14],
        infinity: &[17.545, 45.385],
        close: &[33.104, 29.826],
        back_focus: (82.26, 82.26),
        object_mm: 3930.9,
        magnification: 0.145,
    },
    // WO 2021/085655 A1, Example 3 (Tables 5-6): D1, D2 at infinity and at 0.90 m (the object
    // D0 = 784 mm before surface 1); BF "in Air" 16.854 and 17.045 mm; close-focus magnification
    // 0.1128.
    PatentFocus {
        name: "samyang-af-85mm-f1.4-if",
        close_m: 0.9,
        surfaces: &[7, 9],
        infinity: &[1.94373, 9.91877],
        close: &[6.99684, 4.86565],
        back_focus: (16.854, 17.045),
        object_mm: 784.0,
        magnification: 0.1128,
    },
];

/// The distance in front of the first surface of the object `metres` from the film (`film` mm
/// behind the last of `rows`), and the paraxial magnification: a y-nu trace written out here, the
/// ray's reduced angle in object space over its angle in image space.
fn object_and_magnification(rows: &[SurfaceRow], film: f64, metres: f64) -> (f64, f64) {
    let span: f64 = rows[..rows.len() - 1]
        .iter()
        .map(|r| r.base.thickness)
        .sum();
    let object = metres * 1000.0 - span - film;
    let u = 1e-3;
    let (mut y, mut nu, mut n) = (object * u, u, 1.0);
    for (i, row) in rows.iter().enumerate() {
        let n_after = row.base.index;
        nu -= y * (n_after - n) * row.curvature();
        n = n_after;
        if i + 1 < rows.len() {
            y += row.base.thickness * nu / n;
        }
    }
    // The image: where the ray crosses the axis, `film` mm on if the lens is focused there.
    assert!(
        ((-y / nu) - film).abs() < 1e-6 * film,
        "the image is {} mm behind the lens, the film {film} mm",
        -y / nu
    );
    (object, u / nu)
}

/// Focused at its patent's closest distance, a focus-group prime has the patent's close-focus
/// gaps, puts the film where the patent's back focus says (the image on the film), and has the
/// patent's object distance and magnification; at infinity, the patent's infinity gaps and back
/// focus; closer than the close focus is refused.
#[test]
fn focus_group_primes_focus_as_their_patents_tabulate() {
    for lens in PATENT_FOCUS {
        let name = lens.name;
        for (metres, gaps, back_focus) in [
            (f64::INFINITY, lens.infinity, lens.back_focus.0),
            (lens.close_m, lens.close, lens.back_focus.1),
        ] {
            let at = report_at(name, None, metres).unwrap();
            assert_eq!(at.to_json()["closest_focus_m"], lens.close_m, "{name}");
            let rows = &at.geometry.system.rows;
            for (&surface, &gap) in lens.surfaces.iter().zip(gaps) {
                assert!(
                    (rows[surface - 1].base.thickness - gap).abs() < 1e-9,
                    "{name} at {metres} m: gap after surface {surface} is {}, the patent's {gap}",
                    rows[surface - 1].base.thickness
                );
            }
            // The patents print the back focus to 0.01 and 0.001 mm, from radii rounded to 3-4
            // decimals: the paraxial image of their tables lies within 0.03 mm of it.
            assert!(
                (at.film_distance - back_focus).abs() < 0.03,
                "{name} at {metres} m: film {:.4} mm behind the lens, the patent's {back_focus} mm",
                at.film_distance
            );
            if metres.is_finite() {
                let (object, beta) = object_and_magnification(rows, at.film_distance, metres);
                let beta = beta.abs();
                // The patents' filter plates, left out here, make their object-to-image distance
                // 0.5 and 0.85 mm longer than it is without them.
                assert!(
                    (object - lens.object_mm).abs() < 1.0,
                    "{name}: the object {object:.3} mm before surface 1, the patent's {}",
                    lens.object_mm
                );
                assert!(
                    (beta - lens.magnification).abs() < 1e-3,
                    "{name}: magnification {beta:.5} at {metres} m, the patent's {}",
                    lens.magnification
                );
            }
        }
        let e = report_at(name, None, 0.95 * lens.close_m)
            .err()
            .unwrap_or_else(|| panic!("{name} focused closer than its close focus"))
            .to_string();
        assert!(
            e.contains("closer than this lens focuses")
                && e.contains(&format!("{} m", lens.close_m)),
            "{name}: {e}"
        );
    }
}

#[test]
fn lenses_command_lists_every_bundled_lens() {
    let (code, stdout, stderr) = realcam_texts(&["lenses"], None);
    assert_eq!(code, 0, "{stderr}");
    for lens in BUNDLED {
        assert!(
            stdout
                .lines()
                .any(|l| l.starts_with(&format!("{} ", lens.name))),
            "{} missing:\n{stdout}",
            lens.name
        );
    }
    // Computed and published focal lengths side by side where they differ.
    let line = stdout
        .lines()
        .find(|l| l.starts_with("canon-ef-35mm-f2 "))
        .unwrap();
    assert!(
        line.contains("35.5 mm (35 mm)") && line.contains("1992"),
        "{line}"
    );
    assert!(line.contains("JP 1992-015611 Example 1"), "{line}");
    // The field-of-view column says which frame it is for: full frame, not the render's
    // default 35 mm diagonal.
    assert!(
        stdout.lines().next().unwrap().contains("FoV on 36×24"),
        "{stdout}"
    );
    assert!(stdout.contains("43.3 mm diagonal"), "{stdout}");
}

/// A zoom's entry in `realcam lenses` gives each zoom position (the patent's focal lengths and
/// F-numbers: US 5,899,585, Numerical Example 1) and its table row the range; a fixed lens
/// has none.
#[test]
fn lenses_gives_a_zoom_its_positions_and_range() {
    let (code, stdout, stderr) = realcam_texts(&["lenses", "--json", "28-80"], None);
    assert_eq!(code, 0, "{stderr}");
    let entries: Vec<serde_json::Value> = serde_json::from_str(&stdout).unwrap();
    let positions = entries[0]["zoom_positions"].as_array().unwrap();
    assert_eq!(positions.len(), 3);
    for (position, (focal, f_number)) in
        positions
            .iter()
            .zip([(28.98, 3.46), (50.00, 4.51), (77.08, 5.88)])
    {
        let f = position["focal_length_mm"].as_f64().unwrap();
        assert!((f / focal - 1.0).abs() < 0.01, "{f} vs {focal}");
        let n = position["f_number"].as_f64().unwrap();
        assert!((n - f_number).abs() < 0.01, "{n} vs {f_number}");
        assert!(position["field_of_view_deg"].as_f64().unwrap() > 0.0);
    }
    let (_, table, _) = realcam_texts(&["lenses", "28-80"], None);
    assert!(
        table.contains("29.0–77.0 mm") && table.contains("f/3.46–5.88"),
        "{table}"
    );
    let (_, stdout, _) = realcam_texts(&["lenses", "--json", "dgauss.50mm"], None);
    let fixed: Vec<serde_json::Value> = serde_json::from_str(&stdout).unwrap();
    assert_eq!(fixed[0]["zoom_positions"], serde_json::json!([]));
}

#[test]
fn lenses_json_has_every_figure() {
    let (code, stdout, stderr) = realcam_texts(&["lenses", "--json"], None);
    assert_eq!(code, 0, "{stderr}");
    let entries: Vec<serde_json::Value> = serde_json::from_str(&stdout).unwrap();
    assert_eq!(entries.len(), BUNDLED.len());
    for (entry, lens) in entries.iter().zip(BUNDLED) {
        assert_eq!(entry["name"], lens.name);
        let (_, _, fo) = load(lens.name);
        assert!((entry["focal_length_mm"].as_f64().unwrap() - fo.focal_length).abs() < 1e-9);
        assert!((entry["f_number"].as_f64().unwrap() - fo.f_number).abs() < 1e-9);
        let full_frame = &entry["full_frame"];
        assert!((full_frame["film_diagonal_mm"].as_f64().unwrap() - 43.2666).abs() < 1e-3);
        // Either the frame is covered, or the image circle is smaller than it.
        match full_frame["field_of_view_deg"].as_f64() {
            Some(fov) => assert!(fov > 0.0 && fov < 200.0, "{}", lens.name),
            None => {
                let d = full_frame["image_circle"]["diameter_mm"].as_f64().unwrap();
                assert!(d > 0.0 && d < 43.27, "{}: {d}", lens.name);
            }
        }
        for key in ["elements", "aspheric_surfaces"] {
            assert!(entry[key].is_u64(), "{}: {key}", lens.name);
        }
    }
    let phone = entries
        .iter()
        .find(|e| e["name"] == "deeplens-phone-80deg")
        .unwrap();
    assert_eq!(phone["aspheric_surfaces"], 12);
    assert_eq!(phone["elements"], 6);
    assert_eq!(phone["licence"], "Apache-2.0");
    // A small-format lens: its own 7.66 mm sensor, and only an image circle on 35 mm film.
    assert_eq!(phone["design_format"]["film_diagonal_mm"], 7.66);
    assert!(phone["full_frame"]["field_of_view_deg"].is_null());
    // On a distortion-free long-focus lens the real field of view is the paraxial one.
    let tele = entries
        .iter()
        .find(|e| e["name"] == "canon-ef-100mm-f2.8-macro")
        .unwrap();
    let fov = tele["full_frame"]["field_of_view_deg"].as_f64().unwrap();
    let paraxial = 2.0 * (43.2666f64 / 2.0 / tele["focal_length_mm"].as_f64().unwrap()).atan();
    assert!((fov - paraxial.to_degrees()).abs() < 0.3, "{fov}");
}

#[test]
fn lenses_filter_and_its_errors() {
    let (code, stdout, _) = realcam_texts(&["lenses", "fisheye"], None);
    assert_eq!(code, 0);
    let names: Vec<&str> = stdout
        .lines()
        .skip(1)
        .take_while(|l| !l.is_empty())
        .map(|l| l.split_whitespace().next().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "fisheye.10mm",
            "fisheye",
            "aspheric-fisheye",
            "minolta-fisheye-16mm-f2.8"
        ]
    );
    let (code, stdout, stderr) = realcam_texts(&["lenses", "no-such-maker"], None);
    assert_ne!(code, 0);
    assert!(stdout.is_empty());
    assert!(stderr.contains("no-such-maker"), "{stderr}");
    let (code, _, stderr) = realcam_texts(&["lenses", "--no-such-option"], None);
    assert_eq!(code, 2, "{stderr}");
}

#[test]
fn readme_documents_every_option_of_realcam_lenses() {
    let (code, help, _) = realcam_texts(&["lenses", "--help"], None);
    assert_eq!(code, 0);
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let section = readme
        .split("## The lens library")
        .nth(1)
        .expect("README has a lens library section");
    assert!(section.contains("`FILTER`") && help.contains("[FILTER]"));
    let options: Vec<&str> = help
        .split_whitespace()
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(|w| w.trim_end_matches(|c: char| !c.is_ascii_alphanumeric()))
        .filter(|w| *w != "--help")
        .collect();
    assert!(!options.is_empty());
    for option in options {
        assert!(
            section.contains(&format!("`{option}")),
            "README lacks {option}"
        );
    }
}
