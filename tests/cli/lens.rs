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

/// `realcam ARGS | head -1`: reads the first line of standard output, closes the pipe, and
/// returns how the run ended and its standard error.
fn first_line_then_close(args: &[&str], input: &str) -> (std::process::ExitStatus, String) {
    use std::io::{BufRead, Write};
    let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut child = support::cli::command(manifest, args)
        .stdin(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_string();
    let feeder = std::thread::spawn(move || {
        // The run may end before it reads everything: a refused write here is no failure.
        let _ = stdin.write_all(input.as_bytes());
    });
    let mut stdout = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    assert!(!line.is_empty(), "{args:?} printed nothing");
    drop(stdout);
    feeder.join().unwrap();
    let output = child.wait_with_output().unwrap();
    (output.status, support::cli::stderr(&output))
}

/// A reader that leaves early (`| head -1`) ends the printing commands quietly, as it ends
/// Unix tools: success or SIGPIPE, never a panic about a broken pipe (exit 101).
#[test]
fn a_closed_pipe_ends_the_printing_commands_quietly() {
    use std::os::unix::process::ExitStatusExt;
    // 4000 rays traced: pretty JSON far longer than a pipe buffers (64 KiB).
    let rays = format!(
        "[{}]",
        vec![r#"{"origin":[0,2,-10],"direction":[0,0,1]}"#; 4000].join(",")
    );
    let runs: [(&[&str], &str); 5] = [
        (&["lens", "canon-ef-85mm-f1.8", "--json"], ""),
        (&["lens", "dgauss.50mm"], ""),
        (&["lenses", "--json"], ""),
        (&["lenses"], ""),
        (&["lens", "dgauss.50mm", "--trace"], &rays),
    ];
    for (args, input) in runs {
        let (status, stderr) = first_line_then_close(args, input);
        assert!(
            status.success() || status.signal() == Some(libc::SIGPIPE),
            "{args:?}: {status:?}\n{stderr}"
        );
        for message in ["panicked", "Broken pipe", "error"] {
            assert!(!stderr.contains(message), "{args:?}: {stderr}");
        }
    }
}

/// The diagram is SVG: a name with another extension is refused before anything is derived
/// or written, naming the path and the format it writes; `.svg` (any case) is written.
#[test]
fn diagram_names_other_than_svg_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["x.png", "x.jpg", "diagram"] {
        let path = dir.path().join(name);
        let (code, _, stderr) = realcam(
            &["lens", "dgauss.50mm", "--diagram", path.to_str().unwrap()],
            None,
        );
        assert_eq!(code, 1, "{name}: {stderr}");
        assert!(stderr.contains(path.to_str().unwrap()), "{stderr}");
        assert!(stderr.contains(".svg"), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!path.exists(), "{name} written");
    }
    // `-` would mix the SVG into the summary on standard output: refused, no file named `-`.
    let (code, stdout, stderr) = realcam(&["lens", "dgauss.50mm", "--diagram", "-"], None);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("--diagram -") && stderr.contains(".svg"),
        "{stderr}"
    );
    assert!(stdout.is_empty(), "{stdout}");
    let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    assert!(!manifest.join("-").exists(), "a file named -");
    let path = dir.path().join("X.SVG");
    let (code, _, stderr) = realcam(
        &["lens", "dgauss.50mm", "--diagram", path.to_str().unwrap()],
        None,
    );
    assert_eq!(code, 0, "{stderr}");
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.starts_with("<svg"), "{svg}");
}

/// `realcam lens` lists a zoom's positions, reports any one of them with `--zoom-position`,
/// and exports them; `realcam render` renders each position.
#[test]
fn zoom_positions_are_reported_exported_and_rendered() {
    use support::cli::{ok, realcam as run, refused};
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zoom.toml"), crate::support::TWO_GROUP_ZOOM).unwrap();
    let json = |args: &[&str]| json_of(dir.path(), args);
    let all = json(&["lens", "zoom.toml", "--json"]);
    let positions = all["zoom_positions"].as_array().unwrap().clone();
    assert_eq!(positions.len(), 3);
    let focal = |v: &serde_json::Value| v["focal_length_mm"].as_f64().unwrap();
    assert!(
        focal(&positions[0]) < focal(&positions[1]) && focal(&positions[1]) < focal(&positions[2])
    );
    for (k, position) in positions.iter().enumerate() {
        let n = (k + 1).to_string();
        let one = json(&["lens", "zoom.toml", "--json", "--zoom-position", &n]);
        assert!((focal(&one) - focal(position)).abs() < 1e-9, "position {n}");
        assert_eq!(one["f_number"], position["f_number"], "position {n}");
        assert_eq!(
            one["field_of_view_deg"], position["field_of_view_deg"],
            "position {n}"
        );
    }
    ok(&run(
        dir.path(),
        &["lens", "zoom.toml", "--export", "again.toml"],
    ));
    assert_eq!(
        json(&["lens", "again.toml", "--json"])["zoom_positions"],
        all["zoom_positions"]
    );
    refused(
        &run(dir.path(), &["lens", "zoom.toml", "--export", "zoom.dat"]),
        &["zoom positions", ".toml"],
    );
    refused(
        &run(dir.path(), &["lens", "zoom.toml", "--zoom-position", "4"]),
        &["zoom position 4", "1 to 3"],
    );

    let small = [
        "render",
        "--spp",
        "1",
        "--width",
        "16",
        "--height",
        "16",
        "--focus-distance",
        "3",
    ];
    for (n, out) in [("1", "wide.png"), ("3", "long.png")] {
        let mut args = small.to_vec();
        args.extend(["--lens", "zoom.toml", "--zoom-position", n, "--out", out]);
        ok(&run(dir.path(), &args));
    }
    let (wide, long) = (
        std::fs::read(dir.path().join("wide.png")).unwrap(),
        std::fs::read(dir.path().join("long.png")).unwrap(),
    );
    assert_ne!(wide, long, "the two zoom positions frame the scene alike");
    let mut fixed = small.to_vec();
    fixed.extend([
        "--lens",
        "dgauss.50mm",
        "--zoom-position",
        "2",
        "--out",
        "x.png",
    ]);
    refused(
        &run(dir.path(), &fixed),
        &["zoom position 2", "fixed spacings"],
    );
}

/// `--coating`: the transmission on the axis at the d line against figures computed here from
/// the lens's own indices — Fresnel's ((a − b)/(a + b))² for a bare or cemented surface, and
/// for a single quarter wave of MgF₂ (1.38 at 550 nm) the Airy sum of its two reflections,
/// r = (r₁ + r₂e^{−2iδ}) / (1 + r₁r₂e^{−2iδ}), δ = (π/2)(550/λ) — and T-number = N/√T.
#[test]
fn transmission_and_t_number_follow_fresnel_and_the_airy_formula() {
    let report = |coating: &str| {
        let (code, stdout, stderr) = realcam(
            &["lens", "dgauss.50mm", "--json", "--coating", coating],
            None,
        );
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str::<serde_json::Value>(&stdout).unwrap()
    };
    let d_line = 587.5618;
    let airy = |n_glass: f64| {
        let n_c = 1.38;
        let r1 = (1.0 - n_c) / (1.0 + n_c);
        let r2 = (n_c - n_glass) / (n_c + n_glass);
        let phase = -2.0 * (std::f64::consts::FRAC_PI_2 * 550.0 / d_line);
        let (c, s) = (phase.cos(), phase.sin());
        // (r1 + r2 e^{iφ}) / (1 + r1 r2 e^{iφ}), φ = −2δ.
        let (num_re, num_im) = (r1 + r2 * c, r2 * s);
        let (den_re, den_im) = (1.0 + r1 * r2 * c, r1 * r2 * s);
        (num_re * num_re + num_im * num_im) / (den_re * den_re + den_im * den_im)
    };
    let mut transmissions = Vec::new();
    for coating in ["none", "single"] {
        let v = report(coating);
        let indices: Vec<f64> = v["surfaces"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["index"].as_f64().unwrap())
            .collect();
        let (mut expected, mut before, mut air_glass, mut cemented) = (1.0, 1.0, 0, 0);
        for &after in &indices {
            if before != after {
                let air = |n: f64| n == 1.0;
                let r = if coating == "single" && air(before) != air(after) {
                    airy(if air(before) { after } else { before })
                } else {
                    ((before - after) / (before + after)).powi(2)
                };
                expected *= 1.0 - r;
                if air(before) != air(after) {
                    air_glass += 1;
                } else {
                    cemented += 1;
                }
            }
            before = after;
        }
        // The issue's count: 10 surfaces where the index changes, 2 of them cemented.
        assert_eq!((air_glass, cemented), (8, 2));
        let t = v["transmission"].as_f64().unwrap();
        assert!((t - expected).abs() < 1e-9, "{coating}: {t} vs {expected}");
        let n = v["f_number"].as_f64().unwrap();
        let t_number = v["t_number"].as_f64().unwrap();
        assert!((t_number - n / expected.sqrt()).abs() < 1e-9, "{coating}");
        assert_eq!(v["coating"], coating);
        transmissions.push(t);
    }
    // Bare, the eight air–glass surfaces of n ≈ 1.6–1.7 lose 41 %; one coat gets back most.
    assert!(
        (0.58..0.60).contains(&transmissions[0]),
        "{transmissions:?}"
    );
    assert!(transmissions[1] > 0.95, "{transmissions:?}");
    let multi = report("multi")["transmission"].as_f64().unwrap();
    assert!(multi > transmissions[1], "{multi}");
    let (code, _, stderr) = realcam(&["lens", "dgauss.50mm", "--coating", "mgf2"], None);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("unknown coating 'mgf2': use none, single, multi or ideal"),
        "{stderr}"
    );
}

/// `ghosts` in `realcam lens --json`: with bare glass, every pair of the surfaces where the
/// index changes (C(10, 2) = 45 for dgauss.50mm), each as strong as the product of the two
/// surfaces' Fresnel reflectances computed here, and focused where a paraxial y–nu trace of its
/// unfolded path (written here: a reflection turns the index's sign, n'u' = nu − yc(n' − n) at
/// every surface) brings a ray from a distant point on the axis; none with `--coating ideal`.
#[test]
fn ghosts_are_the_pairs_of_reflecting_surfaces_with_their_strength_and_paraxial_focus() {
    let report = |coating: &str| {
        let (code, stdout, stderr) = realcam(
            &["lens", "dgauss.50mm", "--coating", coating, "--json"],
            None,
        );
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str::<serde_json::Value>(&stdout).unwrap()
    };
    let v = report("none");
    let surfaces = v["surfaces"].as_array().unwrap();
    let field = |k: usize, name: &str| surfaces[k][name].as_f64().unwrap();
    let count = surfaces.len();
    let after: Vec<f64> = (0..count).map(|k| field(k, "index")).collect();
    let before = |k: usize| if k == 0 { 1.0 } else { after[k - 1] };
    let fresnel = |k: usize| ((after[k] - before(k)) / (after[k] + before(k))).powi(2);
    let reflecting: Vec<usize> = (0..count).filter(|&k| fresnel(k) > 0.0).collect();
    assert_eq!(reflecting.len(), 10);
    let ghosts = v["ghosts"].as_array().unwrap();
    assert_eq!(ghosts.len(), 45);
    let film_z = field(count - 1, "z_mm") + v["film_distance_mm"].as_f64().unwrap();
    for ghost in ghosts {
        let pair: Vec<usize> = ghost["surfaces"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_u64().unwrap() as usize)
            .collect();
        let (a, b) = (pair[0], pair[1]);
        assert!(a < b && reflecting.contains(&a) && reflecting.contains(&b));
        let strength = ghost["strength"].as_f64().unwrap();
        let expected = fresnel(a) * fresnel(b);
        assert!(
            (strength - expected).abs() < 1e-9 * expected.max(1e-6),
            "{pair:?}"
        );

        // From the scene: 0 … b, reflect, b−1 … a, reflect, a+1 … the last surface.
        let mut path: Vec<(usize, bool)> = (0..b).map(|k| (k, false)).collect();
        path.push((b, true));
        path.extend((a + 1..b).rev().map(|k| (k, false)));
        path.push((a, true));
        path.extend((a + 1..count).map(|k| (k, false)));
        let (mut y, mut u, mut n) = (1e-3, 0.0f64, 1.0f64);
        let mut z = field(0, "z_mm");
        for (k, reflect) in path {
            let z_k = field(k, "z_mm");
            y += u * (z_k - z);
            z = z_k;
            let next = if reflect {
                -n
            } else if n > 0.0 {
                after[k]
            } else {
                -before(k)
            };
            let c = field(k, "curvature_per_mm");
            u = (n * u - y * c * (next - n)) / next;
            n = next;
        }
        let crossing = z - y / u;
        let focus = ghost["focus_from_film_mm"].as_f64().unwrap();
        let paraxial = crossing - film_z;
        assert!(
            (focus - paraxial).abs() < 1e-3 + 1e-4 * paraxial.abs(),
            "{pair:?}: {focus} vs paraxial {paraxial}"
        );
    }
    assert!(report("ideal")["ghosts"].as_array().unwrap().is_empty());
}

/// `--diagram --ghost A,B` draws the on-axis bundle along that ghost path (in purple, most of
/// it passing for the ghost that focuses on the film); a pair that is not a ghost, a lossless
/// lens and a malformed pair are refused in words.
#[test]
fn the_diagram_draws_a_ghost_path_and_refuses_pairs_that_are_not_ghosts() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("ghost.svg");
    let svg_arg = svg.to_str().unwrap();
    let (code, _, stderr) = realcam(
        &[
            "lens",
            "dgauss.50mm",
            "--diagram",
            svg_arg,
            "--ghost",
            "9,1",
        ],
        None,
    );
    assert_eq!(code, 0, "{stderr}");
    let text = std::fs::read_to_string(&svg).unwrap();
    let ghost_rays: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("<polyline") && l.contains("#8e44ad"))
        .collect();
    assert!(ghost_rays.len() >= 5, "{ghost_rays:?}");
    let passing = ghost_rays
        .iter()
        .filter(|l| !l.contains("dasharray"))
        .count();
    assert!(passing * 2 > ghost_rays.len(), "{ghost_rays:?}");
    assert!(text.contains("reflected by surfaces 1 and 9"));
    for (args, expected) in [
        (
            vec!["--ghost", "1,5"],
            "--ghost 1,5: not a ghost of dgauss.50mm",
        ),
        (
            vec!["--ghost", "1,9", "--coating", "ideal"],
            "has no ghosts with ideal coating",
        ),
        (vec!["--ghost", "1"], "two surface numbers A,B"),
        (vec!["--ghost", "-1,2"], "two surface numbers A,B"),
    ] {
        let mut full = vec!["lens", "dgauss.50mm", "--diagram", svg_arg];
        full.extend(args);
        let (code, _, stderr) = realcam(&full, None);
        assert_ne!(code, 0);
        assert!(stderr.contains(expected), "{stderr}");
    }
}

/// `--zoom FOCAL_MM`: the zoom position whose focal length that is (its paraxial one within
/// 2 %, computed here by reading each position's `--zoom-position` report, or its published
/// one), the same report and render as `--zoom-position N`; a focal length between positions,
/// `--zoom` on a fixed lens, and both options at once are refused in words.
#[test]
fn zoom_by_focal_length_picks_the_position_of_that_focal_length() {
    use support::cli::{realcam as run, refused};
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zoom.toml"), crate::support::TWO_GROUP_ZOOM).unwrap();
    let json = |args: &[&str]| json_of(dir.path(), args);
    for n in ["1", "2", "3"] {
        let by_position = json(&["lens", "zoom.toml", "--json", "--zoom-position", n]);
        let f = by_position["focal_length_mm"].as_f64().unwrap();
        // A focal length 1 % off the paraxial one still names the position.
        let named = format!("{}", f * 1.01);
        let by_focal_length = json(&["lens", "zoom.toml", "--json", "--zoom", &named]);
        assert_eq!(
            by_focal_length["focal_length_mm"], by_position["focal_length_mm"],
            "position {n}"
        );
    }
    // The published figure of position 3 (100 mm) names it too.
    let published = json(&["lens", "zoom.toml", "--json", "--zoom", "100"]);
    let third = json(&["lens", "zoom.toml", "--json", "--zoom-position", "3"]);
    assert_eq!(published["focal_length_mm"], third["focal_length_mm"]);
    refused(
        &run(dir.path(), &["lens", "zoom.toml", "--zoom", "70"]),
        &[
            "--zoom 70 mm",
            "design's positions only",
            "--zoom-position N",
        ],
    );
    refused(
        &run(dir.path(), &["lens", "dgauss.50mm", "--zoom", "50"]),
        &["--zoom 50 mm", "fixed spacings"],
    );
    refused(
        &run(dir.path(), &["lens", "zoom.toml", "--zoom", "-5"]),
        &["--zoom must be a positive number"],
    );
    let both = run(
        dir.path(),
        &["lens", "zoom.toml", "--zoom", "100", "--zoom-position", "3"],
    );
    assert!(!both.status.success());
}

/// Breathing in `zoom_positions`: each position's field of view focused at infinity and at its
/// closest focus is what `--zoom-position N --focus-distance D` reports for that focus, and a
/// unit-focused lens (this zoom moves no group with focus) narrows its view as it focuses
/// closer (the lens moves away from the film).
#[test]
fn zoom_positions_give_the_field_of_view_at_infinity_and_at_close_focus() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zoom.toml"), crate::support::TWO_GROUP_ZOOM).unwrap();
    let json = |args: &[&str]| json_of(dir.path(), args);
    let all = json(&["lens", "zoom.toml", "--json"]);
    let positions = all["zoom_positions"].as_array().unwrap().clone();
    let first = &positions[0];
    let (infinity, close) = (
        first["field_of_view_infinity_deg"].as_f64().unwrap(),
        first["field_of_view_close_deg"].as_f64().unwrap(),
    );
    assert!(close < infinity, "{first}");
    for (k, position) in positions.iter().enumerate() {
        let n = (k + 1).to_string();
        let close_m = position["close_focus_m"].as_f64().unwrap().to_string();
        for (distance, key) in [
            ("inf", "field_of_view_infinity_deg"),
            (close_m.as_str(), "field_of_view_close_deg"),
        ] {
            let one = json(&[
                "lens",
                "zoom.toml",
                "--json",
                "--zoom-position",
                &n,
                "--focus-distance",
                distance,
            ]);
            assert_eq!(
                one["field_of_view_deg"], position[key],
                "position {n} at {distance}"
            );
        }
    }
}

/// `realcam ARGS` in `dir`, which must succeed, its standard output as JSON.
fn json_of(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let output = support::cli::realcam(dir, args);
    support::cli::ok(&output);
    serde_json::from_slice(&output.stdout).unwrap()
}

/// The group-motion rows of a `--diagram`: per setting, each group's first and last vertex
/// measured from the film (the bars' data attributes), keyed by (group, setting).
fn group_rows(svg: &str) -> std::collections::BTreeMap<(String, usize), (f64, f64)> {
    let attribute = |tag: &str, name: &str| -> String {
        let start = tag.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
        tag[start..][..tag[start..].find('"').unwrap()].to_string()
    };
    svg.lines()
        .filter(|l| l.contains("data-group="))
        .map(|tag| {
            (
                (
                    attribute(tag, "data-group"),
                    attribute(tag, "data-setting").parse().unwrap(),
                ),
                (
                    attribute(tag, "data-from-film-mm").parse().unwrap(),
                    attribute(tag, "data-to-film-mm").parse().unwrap(),
                ),
            )
        })
        .collect()
}

/// A zoom's diagram shows its groups at every zoom position against a fixed film, each placed
/// by the position's gaps and its paraxial back focus (a y–nu trace written in the test
/// support): the front group's first vertex stands 3 + gap + 2 + 4 mm + BFD in front of the
/// film, the rear group (stop and second element) 2 + 4 mm + BFD. A focus-group lens gets a row
/// at infinity and at close focus, its groups parted by exactly the focus gap's travel.
#[test]
fn the_diagram_shows_the_groups_at_each_setting() {
    let dir = tempfile::tempdir().unwrap();
    // `lens` written as NAME.toml, its diagram drawn: the SVG text.
    let diagram = |name: &str, lens: &str| {
        let lens_path = dir.path().join(format!("{name}.toml"));
        let svg_path = dir.path().join(format!("{name}.svg"));
        std::fs::write(&lens_path, lens).unwrap();
        let (code, _, stderr) = realcam(
            &[
                "lens",
                lens_path.to_str().unwrap(),
                "--diagram",
                svg_path.to_str().unwrap(),
            ],
            None,
        );
        assert_eq!(code, 0, "{stderr}");
        std::fs::read_to_string(&svg_path).unwrap()
    };
    let svg = diagram("zoom", support::TWO_GROUP_ZOOM);
    let rows = group_rows(&svg);
    assert_eq!(rows.len(), 6, "two groups at three positions: {rows:?}");
    for (setting, gap) in [(1, 20.0), (2, 50.0), (3, 90.0)] {
        let bfd = support::two_group_zoom_paraxial(gap).1;
        let g1 = rows[&("G1".to_string(), setting)];
        let g2 = rows[&("G2".to_string(), setting)];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-5;
        assert!(close(g1.0, -(3.0 + gap + 6.0 + bfd)), "{g1:?} at gap {gap}");
        assert!(close(g1.1, -(gap + 6.0 + bfd)), "{g1:?}");
        assert!(close(g2.0, -(6.0 + bfd)) && close(g2.1, -bfd), "{g2:?}");
    }
    assert!(svg.contains("zoom 2 (56 mm)"), "position labels");

    // The same two groups, focused by the gap between them (20 mm at infinity, 14 at 0.5 m).
    let focusing = support::TWO_GROUP_ZOOM
        .split("[zoom]")
        .next()
        .unwrap()
        .to_string()
        + "[focus]\nclose_focus_m = 0.5\nsurfaces = [2]\ninfinity = [20.0]\nclose = [14.0]\n";
    let svg = diagram("focus", &focusing);
    let rows = group_rows(&svg);
    assert_eq!(rows.len(), 4, "{rows:?}");
    let parting = |setting: usize| {
        rows[&("G2".to_string(), setting)].0 - rows[&("G1".to_string(), setting)].1
    };
    assert!((parting(1) - 20.0).abs() < 1e-5 && (parting(2) - 14.0).abs() < 1e-5);
    assert!(svg.contains("close focus 0.5 m") && svg.contains("focused at infinity"));
}
