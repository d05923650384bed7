//! `realcam lens` from the outside: JSON keys, ray tracing over stdin, diagrams, bad files.

use crate::support;

use support::cli::realcam_texts as realcam;

#[test]
fn json_has_the_documented_keys_and_values() {
    let (code, stdout, stderr) = realcam(
        &[
            "lens",
            "lenses/wide.22mm.dat",
            "--json",
            "--focus-distance",
            "1",
        ],
        None,
    );
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    for key in [
        "focal_length_mm",
        "back_focal_length_mm",
        "front_focal_length_mm",
        "principal_planes_mm",
        "entrance_pupil",
        "exit_pupil",
        "f_number",
        "total_track_mm",
        "film_distance_mm",
        "surfaces",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert!((v["focal_length_mm"].as_f64().unwrap() - 22.024).abs() < 0.01);
    // pbrt's thick-lens focus for wide.22mm at 1 m.
    assert!((v["film_distance_mm"].as_f64().unwrap() - 14.831).abs() < 0.0015);
    assert!(v["entrance_pupil"]["z_mm"].is_number() && v["exit_pupil"]["diameter_mm"].is_number());
    assert_eq!(v["surfaces"].as_array().unwrap().len(), 13);
}

#[test]
fn trace_reads_rays_and_reports_blocks() {
    let rays =
        r#"[{"origin":[0,2,-10],"direction":[0,0,1]},{"origin":[0,14,-10],"direction":[0,0,1]}]"#;
    let (code, stdout, stderr) = realcam(&["lens", "dgauss.50mm", "--trace"], Some(rays));
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let first = &v[0];
    let d: Vec<f64> = first["direction"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 1.0).abs() < 1e-12);
    assert!(
        d[1] < 0.0,
        "a converging lens bends a ray above the axis down"
    );
    assert_eq!(v[1]["blocked"], "aperture");
    assert_eq!(v[1]["surface"], 0);

    let (code, _, stderr) = realcam(&["lens", "dgauss.50mm", "--trace"], Some("not json"));
    assert_ne!(code, 0);
    assert!(stderr.contains("stdin"), "{stderr}");
}

#[test]
fn diagram_is_an_svg_with_the_lens_and_rays() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.svg");
    let (code, _, stderr) = realcam(
        &["lens", "fisheye.10mm", "--diagram", path.to_str().unwrap()],
        None,
    );
    assert_eq!(code, 0, "{stderr}");
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.matches("<polygon").count() >= 6, "glass elements");
    assert!(svg.matches("<polyline").count() >= 20, "ray fans");
}

#[test]
fn bad_lens_files_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("empty.dat", "", "no surfaces", None),
        (
            "cols.dat",
            "50 5 1.5 20\n0 5 0\n-50 0 1 20\n",
            "expected 4 columns",
            Some(2),
        ),
        (
            "ambiguous.dat",
            "50 5 1.5 20\n0 5 0 10\n-50 3 1 20\n",
            "--lens-format",
            None,
        ),
        (
            "binary.dat",
            "\u{0}\u{1}\u{2}garbage\u{7f}",
            "expected 4 columns",
            Some(1),
        ),
        (
            "nan.dat",
            "50 5 1.5 nan\n0 5 0 10\n-50 0 1 20\n",
            "aperture 'nan' is not a number",
            Some(1),
        ),
    ];
    for (name, text, expect, line) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let (code, stdout, stderr) = realcam(&["lens", path.to_str().unwrap()], None);
        assert_eq!(code, 1, "{name}: {stderr}");
        assert!(stdout.is_empty());
        assert!(
            stderr.contains(name) && stderr.contains(expect),
            "{name}: {stderr}"
        );
        if let Some(line) = line {
            assert!(
                stderr.contains(&format!("{name}:{line}:")),
                "{name}: {stderr}"
            );
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            !stderr.chars().any(|c| c.is_control() && c != '\n'),
            "raw control characters: {stderr:?}"
        );
    }
    let (code, _, stderr) = realcam(&["lens", "telephoto.250mm", "--focus-distance", "1"], None);
    assert_eq!(code, 1);
    assert!(stderr.contains("closest"), "{stderr}");
    let (code, _, stderr) = realcam(&["lens", "dgauss.50mm", "--focus-distance", "-3"], None);
    assert_ne!(code, 0);
    assert!(stderr.contains("focus-distance"), "{stderr}");
}
