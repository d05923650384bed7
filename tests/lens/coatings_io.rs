//! Per-surface coatings in lens files: realcam's `.toml` `coating` key in each of its forms,
//! written back by `--export`, and Zemax's `COAT` names; the expected layers are computed here
//! from the thin-film definitions (a quarter wave of index n at λ is λ/(4n) thick, a half wave
//! λ/(2n)), not through realcam's helpers.

use std::path::{Path, PathBuf};

use realcam::lens::Prescription;
use realcam::lens::coating::{Coating, Layer};
use realcam::lens::io::export::export_text;

/// The stop, then a singlet of index 1.5 cemented to one of 1.7: surface 1 is the stop in
/// air, surface 2 air→1.5, surface 3 (cemented) 1.5→1.7, surface 4 1.7→air. `#1` … `#4` are
/// where each surface's extra keys go.
const LENS: &str = r#"
name = "coated-doublet"
surfaces = [
  { stop = true, thickness = 2, diameter = 10 #1 },
  { radius = 50, thickness = 5, glass = { n = 1.5 }, diameter = 20 #2 },
  { radius = -40, thickness = 2, glass = { n = 1.7 }, diameter = 20 #3 },
  { radius = -200, thickness = 40, diameter = 20 #4 },
]
"#;

/// `LENS` with `coatings[k]` (a `coating = …` value, or "" for none) on surface k + 1.
fn lens_text(coatings: [&str; 4]) -> String {
    let mut text = LENS.to_string();
    for (k, coating) in coatings.iter().enumerate() {
        let key = if coating.is_empty() {
            String::new()
        } else {
            format!(", coating = {coating}")
        };
        text = text.replace(&format!(" #{}", k + 1), &key);
    }
    text
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn layer(index: f64, thickness_nm: f64) -> Layer {
    Layer {
        index,
        thickness_nm,
    }
}

/// Layers equal to `expected` to rounding (the file's arithmetic may group differently).
fn assert_layers(coating: Option<&Coating>, expected: &[Layer], what: &str) {
    let Some(Coating::Layers(layers)) = coating else {
        panic!("{what}: {coating:?} is not layers");
    };
    assert_eq!(layers.len(), expected.len(), "{what}: {layers:?}");
    for (a, b) in layers.iter().zip(expected) {
        assert_eq!(a.index, b.index, "{what}: {layers:?}");
        assert!(
            (a.thickness_nm - b.thickness_nm).abs() < 1e-9,
            "{what}: {layers:?} vs {expected:?}"
        );
    }
}

/// Every form of the `coating` key reads to the coating it describes, layers from the scene
/// side; surfaces without the key get the lens-wide default (`None`).
#[test]
fn each_toml_coating_form_loads_to_its_coating() {
    let dir = tempfile::tempdir().unwrap();
    let text = lens_text([
        "",
        r#""single""#,
        "{ layers = [ { index = 1.38, thickness_nm = 99.6 }, { index = 2.15, quarter_wave_nm = 550 }, { index = 1.6, half_wave_nm = 500.0 } ] }",
        r#""multi""#,
    ]);
    let lens = Prescription::load(&write(dir.path(), "a.toml", &text), None).unwrap();
    assert_eq!(lens.coatings.len(), 4);
    // MgF2 (n = 1.38), a quarter wave at 550 nm: 550 / (4 · 1.38) nm.
    assert_eq!(lens.coating(0), None);
    assert_layers(lens.coating(1), &[layer(1.38, 550.0 / 5.52)], "single");
    assert_layers(
        lens.coating(2),
        &[
            layer(1.38, 99.6),
            layer(2.15, 550.0 / 8.6),
            layer(1.6, 500.0 / 3.2),
        ],
        "layers",
    );
    // Multi on glass (1.7) → air: the air-side stack 1.38 (λ/4), 2.15 (λ/2), 1.38·√1.7 (λ/4),
    // listed from the scene side, which is the glass side here: reversed.
    let inner = 1.38 * 1.7f64.sqrt();
    assert_layers(
        lens.coating(3),
        &[
            layer(inner, 550.0 / (4.0 * inner)),
            layer(2.15, 550.0 / 4.3),
            layer(1.38, 550.0 / 5.52),
        ],
        "multi, glass to air",
    );

    let text = lens_text([
        r#""ideal""#,
        r#""none""#,
        "",
        "{ measured = [[400, 0.02], [500, 0.004], [700.5, 0.01]] }",
    ]);
    let lens = Prescription::load(&write(dir.path(), "b.toml", &text), None).unwrap();
    assert_eq!(
        lens.coatings,
        vec![
            Some(Coating::Ideal),
            Some(Coating::None),
            None,
            Some(Coating::Measured(vec![
                (400.0, 0.02),
                (500.0, 0.004),
                (700.5, 0.01)
            ])),
        ]
    );
    // Multi from the air side: 1.38 outermost, the inner layer matched to the glass, 1.5.
    let text = lens_text(["", r#""multi""#, "", ""]);
    let lens = Prescription::load(&write(dir.path(), "c.toml", &text), None).unwrap();
    let inner = 1.38 * 1.5f64.sqrt();
    assert_layers(
        lens.coating(1),
        &[
            layer(1.38, 550.0 / 5.52),
            layer(2.15, 550.0 / 4.3),
            layer(inner, 550.0 / (4.0 * inner)),
        ],
        "multi, air to glass",
    );
    // A file that gives no coating has none to report.
    let lens = Prescription::load(&write(dir.path(), "d.toml", &lens_text([""; 4])), None).unwrap();
    assert!(lens.coatings.is_empty());
    assert!((0..4).all(|i| lens.coating(i).is_none()));
}

/// toml → load → export → load gives the same coatings, and the written file is a fixed point;
/// a `.dat` export keeps them as comments and reads back without them.
#[test]
fn coatings_round_trip_through_export() {
    let dir = tempfile::tempdir().unwrap();
    let text = lens_text([
        r#""ideal""#,
        r#""multi""#,
        "{ layers = [ { index = 1.38, thickness_nm = 99.6 }, { index = 2.15, quarter_wave_nm = 550 } ] }",
        "{ measured = [[400, 0.02], [700, 0.01]] }",
    ]);
    let first = Prescription::load(&write(dir.path(), "lens.toml", &text), None).unwrap();
    let exported = export_text(&first, Path::new("out.toml")).unwrap();
    assert!(exported.contains("thickness_nm"), "{exported}");
    assert!(!exported.contains("quarter_wave_nm"), "{exported}");
    let second = Prescription::load(&write(dir.path(), "out.toml", &exported), None).unwrap();
    assert_eq!(second.coatings, first.coatings, "{exported}");
    assert_eq!(
        export_text(&second, Path::new("out.toml")).unwrap(),
        exported
    );

    // "none" survives too (a bare surface is not the default).
    let text = lens_text(["", r#""none""#, "", ""]);
    let bare = Prescription::load(&write(dir.path(), "bare.toml", &text), None).unwrap();
    let exported = export_text(&bare, Path::new("out.toml")).unwrap();
    assert!(exported.contains(r#"coating = "none""#), "{exported}");
    let back = Prescription::load(&write(dir.path(), "bare-out.toml", &exported), None).unwrap();
    assert_eq!(back.coatings, vec![None, Some(Coating::None), None, None]);

    // A .dat table cannot hold coatings: they are written as comments, not lost silently.
    let text = lens_text(["", r#""single""#, "", ""]);
    let single = Prescription::load(&write(dir.path(), "single.toml", &text), None).unwrap();
    let dat = export_text(&single, Path::new("out.dat")).unwrap();
    assert!(
        dat.contains("#   surface 2: coating = { layers = [{ index = 1.38, thickness_nm ="),
        "{dat}"
    );
    let back = Prescription::load(&write(dir.path(), "out.dat", &dat), None).unwrap();
    assert!(back.coatings.is_empty());
    assert_eq!(back.rows.len(), single.rows.len());
}

/// The lens of `tests/lens/zemax.rs`'s refusal cases: SURF 1 air → N-BK7 (the stop), SURF 2
/// N-BK7 → air, `#1`/`#2` where each surface's `COAT` goes.
const ZMX: &str = "UNIT MM\nENPD 10\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0.02\n  DISZ 5\n  GLAS N-BK7 0 0 1.5 64\n  DIAM 12\n#1\nSURF 2\n  CURV -0.02\n  DISZ 40\n  DIAM 12\n#2\nSURF 3\n  COAT AR\n  DISZ 0\n";

fn zemax(dir: &Path, name: &str, first: &str, second: &str) -> Prescription {
    let text = ZMX.replace("#1", first).replace("#2", second);
    Prescription::load(&write(dir, name, &text), None).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// `COAT` names map to realcam's coatings as the sample `COATING.DAT` defines them; the image
/// surface's coating is not the lens's.
#[test]
fn zemax_coat_names_map_to_coatings() {
    let dir = tempfile::tempdir().unwrap();
    let lens = zemax(dir.path(), "ar.zmx", "  COAT AR", "  COAT I.99");
    assert_layers(lens.coating(0), &[layer(1.38, 550.0 / 5.52)], "AR");
    // I.99: 99 % of the intensity transmitted, 1 % reflected.
    let Some(Coating::Measured(curve)) = lens.coating(1) else {
        panic!("I.99: {:?}", lens.coating(1));
    };
    assert_eq!(curve.len(), 1);
    assert_eq!(curve[0].0, 550.0);
    assert!((curve[0].1 - 0.01).abs() < 1e-12, "{curve:?}");
    assert!(lens.warnings.is_empty(), "{:?}", lens.warnings);

    // HEAR1 and HEAR2: the multi-coating, from the air side on SURF 1 and from the glass on
    // SURF 2 (N-BK7's index at the d line).
    let lens = zemax(dir.path(), "hear.zmx", "  COAT HEAR1", "  COAT HEAR2");
    let n = lens.rows[0].base.index;
    assert!((n - 1.5168).abs() < 1e-3, "N-BK7 n_d {n}");
    let inner = 1.38 * n.sqrt();
    let from_air = [
        layer(1.38, 550.0 / 5.52),
        layer(2.15, 550.0 / 4.3),
        layer(inner, 550.0 / (4.0 * inner)),
    ];
    assert_layers(lens.coating(0), &from_air, "HEAR1");
    let mut from_glass = from_air;
    from_glass.reverse();
    assert_layers(lens.coating(1), &from_glass, "HEAR2");

    // I.0 reflects everything; no name, NONE and no COAT line leave the default.
    let lens = zemax(dir.path(), "i0.zmx", "  COAT I.0", "  COAT");
    assert_eq!(
        lens.coating(0),
        Some(&Coating::Measured(vec![(550.0, 1.0)]))
    );
    assert_eq!(lens.coating(1), None);
    let lens = zemax(dir.path(), "none.zmx", "  COAT NONE", "");
    assert!(lens.coatings.is_empty());
    assert!(lens.warnings.is_empty(), "{:?}", lens.warnings);
}

/// A coating name realcam does not know leaves the lens-wide default on its surfaces, with a
/// warning naming the file, the coating and the surfaces.
#[test]
fn an_unknown_zemax_coating_is_a_warning_naming_it_and_its_surfaces() {
    let dir = tempfile::tempdir().unwrap();
    let lens = zemax(dir.path(), "war.zmx", "  COAT WAR", "  COAT WAR");
    assert!(lens.coatings.is_empty());
    assert_eq!(lens.warnings.len(), 1, "{:?}", lens.warnings);
    let warning = &lens.warnings[0];
    for part in ["war.zmx", "COAT WAR", "SURF 1, 2", "lens-wide default"] {
        assert!(warning.contains(part), "'{part}' not in: {warning}");
    }
    let lens = zemax(dir.path(), "mixed.zmx", "  COAT AR", "  COAT MYCOAT");
    assert!(lens.coating(0).is_some());
    assert_eq!(lens.coating(1), None);
    assert_eq!(lens.warnings.len(), 1, "{:?}", lens.warnings);
    assert!(
        lens.warnings[0].contains("COAT MYCOAT on SURF 2"),
        "{:?}",
        lens.warnings
    );
    // A Zemax lens's coatings export to the .toml and read back the same.
    let lens = zemax(dir.path(), "export.zmx", "  COAT HEAR1", "  COAT I.95");
    let text = export_text(&lens, Path::new("out.toml")).unwrap();
    let back = Prescription::load(&write(dir.path(), "out.toml", &text), None).unwrap();
    assert_eq!(back.coatings, lens.coatings, "{text}");
}

/// Each malformed coating is refused with the file, the line, the surface and the problem.
#[test]
fn a_bad_toml_coating_is_refused_naming_its_surface_and_problem() {
    let cases: [(&str, usize, &str, &[&str]); 14] = [
        (
            "unknown word",
            2,
            r#""mgf2""#,
            &["\"mgf2\" is not a coating", "single"],
        ),
        (
            "named model on a cemented surface",
            3,
            r#""single""#,
            &["glass on both sides", "give its layers"],
        ),
        ("a number", 4, "3", &["an integer 3 is not a coating"]),
        (
            "an array",
            2,
            "[1.38, 99.6]",
            &["an array is not a coating"],
        ),
        ("unknown key", 2, "{ layer = [] }", &["unknown key 'layer'"]),
        (
            "both",
            2,
            "{ layers = [], measured = [[550, 0.01]] }",
            &["both layers and measured"],
        ),
        ("empty table", 2, "{}", &["an empty table"]),
        (
            "two thicknesses",
            4,
            "{ layers = [ { index = 1.38, thickness_nm = 99.6, quarter_wave_nm = 550 } ] }",
            &["layer 1", "thickness_nm and quarter_wave_nm"],
        ),
        (
            "no thickness",
            4,
            "{ layers = [ { index = 1.38, thickness_nm = 99 }, { index = 2.1 } ] }",
            &["layer 2", "no thickness"],
        ),
        (
            "index below 1",
            2,
            "{ layers = [ { index = 0.5, thickness_nm = 99.6 } ] }",
            &["layer 1", "index 0.5"],
        ),
        (
            "negative thickness",
            2,
            "{ layers = [ { index = 1.38, thickness_nm = -5 } ] }",
            &["layer 1", "thickness -5"],
        ),
        (
            "index as text",
            2,
            r#"{ layers = [ { index = "MgF2", thickness_nm = 99.6 } ] }"#,
            &["layer 1", "index must be a number", "MgF2"],
        ),
        (
            "reflectance above 1",
            2,
            "{ measured = [[400, 0.02], [500, 1.5]] }",
            &["point 2", "reflectance 1.5"],
        ),
        (
            "decreasing wavelengths",
            2,
            "{ measured = [[500, 0.02], [400, 0.01]] }",
            &["point 2", "must increase"],
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (name, surface, coating, expected) in cases {
        let mut coatings = [""; 4];
        coatings[surface - 1] = coating;
        let text = lens_text(coatings);
        let path = write(
            dir.path(),
            &format!("{}.toml", name.replace(' ', "-")),
            &text,
        );
        let error = Prescription::load(&path, None).expect_err(name).to_string();
        // file:line: surface N: coating: …, the line that surface's.
        let line = text.lines().position(|l| l.contains("coating =")).unwrap() + 1;
        let located = format!("{}:{line}: surface {surface}: coating: ", path.display());
        assert!(error.starts_with(&located), "{name}: {error}");
        for part in expected {
            assert!(error.contains(part), "{name}: '{part}' not in: {error}");
        }
    }
    // Measured points that are not [nm, reflectance] pairs.
    for bad in [
        "{ measured = [[400, 0.02, 1]] }",
        "{ measured = [400, 0.02] }",
        r#"{ measured = [["400", 0.02]] }"#,
        "{ measured = 0.02 }",
    ] {
        let text = lens_text(["", bad, "", ""]);
        let path = write(dir.path(), "measured.toml", &text);
        let error = Prescription::load(&path, None).expect_err(bad).to_string();
        assert!(error.contains("surface 2: coating: "), "{bad}: {error}");
        assert!(error.contains("[nm, reflectance]"), "{bad}: {error}");
    }
}
