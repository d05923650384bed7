//! `realcam glass` from the outside: the text and JSON a user and a script see, and errors.

use crate::support;

use support::cli::realcam_texts;

/// `realcam glass ARGS`: exit code, standard output and error.
fn realcam(args: &[&str]) -> (i32, String, String) {
    realcam_texts(&[&["glass"], args].concat(), None)
}

fn json(args: &[&str]) -> serde_json::Value {
    let (code, stdout, stderr) = realcam(args);
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).unwrap()
}

#[test]
fn a_catalogue_glass_in_text() {
    let (code, stdout, stderr) = realcam(&["n-bk7"]);
    assert_eq!(code, 0, "{stderr}");
    // Schott's N-BK7 data sheet: n_F 1.52238, n_d 1.51680, n_C 1.51432, V_d 64.17.
    for expected in [
        "N-BK7 (Schott)",
        "1.522376",
        "1.516800",
        "1.514322",
        "V_d 64.17",
        "valid 300–2500 nm",
        "status standard",
    ] {
        assert!(stdout.contains(expected), "missing {expected}:\n{stdout}");
    }
}

#[test]
fn a_catalogue_glass_in_json() {
    let v = json(&["NBK7", "--json", "--wavelength", "400,1000"]);
    assert_eq!(v["label"], "N-BK7 (Schott)");
    assert_eq!(v["v_d"], 64.17);
    assert_eq!(v["valid_range_nm"], serde_json::json!([300.0, 2500.0]));
    let n = |line: &str| v["index"][line]["n"].as_f64().unwrap();
    assert!((n("F") - 1.52238).abs() < 1e-5 && (n("C") - 1.51432).abs() < 1e-5);
    assert!((n("d") - 1.5168).abs() < 1e-6);
    assert_eq!(v["wavelengths"].as_array().unwrap().len(), 2);
    assert_eq!(v["wavelengths"][1]["in_valid_range"], true);
    assert_eq!(v["formula"]["refractiveindex_info_formula"], 2);
}

#[test]
fn a_shared_name_says_how_it_was_resolved() {
    let (code, stdout, _) = realcam(&["F5"]);
    assert_eq!(code, 0);
    assert!(stdout.starts_with("F5 (Schott)"), "{stdout}");
    assert!(
        stdout.contains("also in the catalogue of Hikari"),
        "{stdout}"
    );
    assert!(stdout.contains("maker priority Schott, Ohara, Hoya, Hikari, CDGM, Sumita"));
    let cdgm = json(&["cdgm:f5", "--json"]);
    assert_eq!(cdgm["maker"], "CDGM");
    assert_eq!(cdgm["also_at"].as_array().unwrap().len(), 0);
}

#[test]
fn nearest_glasses() {
    let v = json(&["--near", "1.5168,64.17", "--count", "3", "--json"]);
    let glasses = v["glasses"].as_array().unwrap();
    assert_eq!(glasses.len(), 3);
    assert_eq!(glasses[0]["label"], "N-BK7 (Schott)");
    assert_eq!(glasses[0]["distance"], 0.0);
    let ohara = json(&["--near", "1.7725,49.6", "--maker", "ohara", "--json"]);
    let glasses = ohara["glasses"].as_array().unwrap();
    assert_eq!(glasses.len(), 10);
    assert!(glasses.iter().all(|g| g["maker"] == "Ohara"));
    let (code, stdout, _) = realcam(&["--near", "1.62"]);
    assert_eq!(code, 0);
    assert!(
        stdout.contains("V_d ignored") && stdout.contains("F2 (Schott)"),
        "{stdout}"
    );
    // Every row gives n_d to 5 decimals and V_d to 2, whatever the maker published (Hikari's
    // J-F2 has V_d 36.396775 in the catalogue, Schott's F2 36.37).
    let (code, stdout, _) = realcam(&["--near", "1.62,36.4", "--count", "5"]);
    assert_eq!(code, 0);
    let rows: Vec<&str> = stdout
        .lines()
        .filter(|line| line.contains(" (") && line.contains(')'))
        .collect();
    assert_eq!(rows.len(), 5, "{stdout}");
    for row in rows {
        let numbers: Vec<&str> = row.split(')').nth(1).unwrap().split_whitespace().collect();
        let decimals = |text: &str| text.split('.').nth(1).map_or(0, str::len);
        assert_eq!(
            (decimals(numbers[0]), decimals(numbers[1])),
            (5, 2),
            "{row}"
        );
    }
}

#[test]
fn a_model_glass_keeps_its_n_d_and_v_d() {
    let v = json(&["1.62,36.4", "--json"]);
    let n = |line: &str| v["index"][line]["n"].as_f64().unwrap();
    assert_eq!(n("d"), 1.62);
    assert!(((n("d") - 1.0) / (n("F") - n("C")) - 36.4).abs() < 1e-9);
    assert_eq!(v["warning"], serde_json::Value::Null);
    let (code, _, stderr) = realcam(&["2.0,80"]);
    assert_eq!(code, 0);
    assert!(
        stderr.contains("warning:") && stderr.contains("extrapolation"),
        "{stderr}"
    );
}

#[test]
fn the_list_covers_the_catalogue() {
    assert_eq!(json(&["--list", "--json"]).as_array().unwrap().len(), 1610);
    let (code, stdout, _) = realcam(&["--list", "--maker", "SCHOTT"]);
    assert_eq!(code, 0);
    assert!(stdout.trim_end().ends_with("157 glasses"), "{stdout}");
}

#[test]
fn bad_requests_fail_with_a_clear_message() {
    for (args, expected) in [
        (
            &["XYZ"][..],
            "unknown glass 'XYZ'; nearest catalogue names: ",
        ),
        (&["acme:N-BK7"], "unknown glass maker 'acme'"),
        (&["--near", "1.5,x"], "'x' is not a number"),
        (&["--near", "0.9,30"], "not a glass's refractive index"),
        (&["--near", "1.5,60,3"], "is not N_D or N_D,V_D"),
        (&["1.5"], "a model glass needs n_d and V_d"),
        (
            &["--list", "--maker", "acme"],
            "--maker 'acme' is not in the catalogue",
        ),
        (
            &["N-BK7", "--maker", "schott"],
            "--maker applies to --near and --list",
        ),
        (
            &["N-BK7", "--wavelength", "-5"],
            "is not a positive number of nanometres",
        ),
        (
            &["N-BK7", "--wavelength", "50"],
            "no physical refractive index at 50 nm",
        ),
        (
            &["--near", "1.5,60", "--wavelength", "500"],
            "--wavelength applies to one glass",
        ),
    ] {
        let (code, stdout, stderr) = realcam(args);
        assert_ne!(code, 0, "{args:?}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
    let (code, _, _) = realcam(&[]);
    assert_eq!(code, 2, "no glass, no --near, no --list: a usage error");
}

#[test]
fn readme_mentions_every_option() {
    let (code, help, _) = realcam(&["--help"]);
    assert_eq!(code, 0);
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let section = readme
        .split("## Optical glass")
        .nth(1)
        .expect("README has an Optical glass section");
    let options: Vec<&str> = help
        .split_whitespace()
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(|w| w.trim_end_matches(|c: char| !c.is_ascii_alphanumeric()))
        .filter(|w| *w != "--help")
        .collect();
    assert!(options.len() >= 6, "{options:?}");
    for option in options {
        assert!(
            section.contains(&format!("`{option}")),
            "README lacks {option}"
        );
    }
}
