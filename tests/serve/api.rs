//! `realcam serve`'s JSON API over loopback: every endpoint, live changes that reload nothing,
//! bad requests that leave the render running, the lens path rules, click to focus, Save and
//! Ctrl-C.

use crate::live_server;

use std::process::Command;
use std::time::Duration;

use live_server::{SMALL, Served};
use serde_json::{Value, json};

fn png_size(bytes: &[u8]) -> (u32, u32) {
    let image = image::load_from_memory_with_format(bytes, image::ImageFormat::Png).expect("a PNG");
    (image.width(), image.height())
}

/// What `realcam lens … --json` prints for the lens and settings of `state`.
fn lens_cli_json(state: &Value) -> Value {
    let mut command = Command::new(env!("CARGO_BIN_EXE_realcam"));
    command.args(["lens", state["lens"].as_str().unwrap(), "--json"]);
    for name in [
        "focus_distance",
        "film_distance",
        "f_number",
        "aperture",
        "film_diagonal",
        "focus_mode",
        "pupil_sampling",
    ] {
        match &state[name] {
            Value::Null => {}
            Value::String(s) => {
                command.args([format!("--{}", name.replace('_', "-")), s.clone()]);
            }
            v => {
                command.args([format!("--{}", name.replace('_', "-")), v.to_string()]);
            }
        }
    }
    let out = command.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn every_endpoint_answers_over_loopback() {
    let served = Served::start(SMALL);
    // The state is whole from the moment the URL is printed (it was once published by the
    // render thread after the server had started answering).
    let first = served.state();
    for name in ["lens", "film_diagonal", "spp_target", "command", "revision"] {
        assert!(!first[name].is_null(), "{name} missing at start: {first}");
    }
    let page = served.get("/");
    assert_eq!(page.status, 200);
    let html = String::from_utf8(page.body).unwrap();
    assert!(html.contains("<img id=\"image\"") && html.contains("/app.js"));
    for (path, kind) in [("/app.js", "javascript"), ("/style.css", "css")] {
        let reply = served.get(path);
        assert_eq!(reply.status, 200, "{path}");
        assert!(reply.header("content-type").unwrap().contains(kind));
    }

    let state = served.wait_until_done();
    for name in [
        "lens",
        "focus_distance",
        "film_distance",
        "f_number",
        "aperture",
        "film_diagonal",
        "width",
        "height",
        "spp",
        "seed",
        "max_depth",
    ] {
        assert!(state.get(name).is_some(), "state lacks {name}: {state}");
    }
    assert_eq!(state["spp_target"], 4);
    assert_eq!(state["spp_done"], 4);
    assert_eq!(
        (state["width"].as_u64(), state["height"].as_u64()),
        (Some(64), Some(64))
    );

    let stats = served.get("/api/stats").json();
    assert_eq!(stats["bvh_builds"], 1);
    assert_eq!(stats["scene_loads"], 1);
    assert_eq!(stats["spp_done"], 4);
    assert!(
        stats["samples_per_second"].as_f64().unwrap() > 0.0,
        "{stats}"
    );

    let image = served.get("/api/image.png");
    assert_eq!(image.status, 200);
    assert_eq!(image.header("content-type"), Some("image/png"));
    assert_eq!(png_size(&image.body), (64, 64));

    let svg = served.get("/api/lens.svg");
    assert_eq!(svg.header("content-type"), Some("image/svg+xml"));
    let svg = String::from_utf8(svg.body).unwrap();
    assert!(svg.contains("<svg") && svg.contains("</svg>"));

    // Exactly what the command line prints for the same lens and settings.
    let lens = served.get("/api/lens.json").json();
    assert_eq!(lens, lens_cli_json(&state));

    let lenses = served.get("/api/lenses").json();
    let list = lenses["lenses"].as_array().unwrap();
    assert!(list.len() >= realcam::lens::io::bundled::BUNDLED.len());
    assert!(
        list.iter()
            .any(|l| l["name"] == "wide.22mm" && l["origin"] == "bundled")
    );
    assert_eq!(lenses["current"], state["lens"]);

    // The push channel announces each new image.
    let mut stream = std::net::TcpStream::connect(&served.address).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    use std::io::{Read, Write};
    write!(stream, "GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
    // Every publication has a larger revision, so a client can order answers that cross.
    let revision_before = served.state()["revision"].as_u64().unwrap();
    let changed = served.post("/api/settings", &json!({"seed": 7}));
    assert_eq!(changed.status, 200);
    let revision_changed = changed.json()["revision"].as_u64().unwrap();
    assert!(revision_changed > revision_before);
    let mut seen = String::new();
    let mut buffer = [0u8; 4096];
    // An event ends with a blank line; it may arrive over several reads.
    let whole_event = |seen: &str| {
        seen.find("event: image")
            .is_some_and(|at| seen[at..].contains("\n\n"))
    };
    while !whole_event(&seen) {
        let n = stream
            .read(&mut buffer)
            .expect("an event before the timeout");
        assert!(n > 0, "the event stream closed: {seen}");
        seen.push_str(&String::from_utf8_lossy(&buffer[..n]));
    }
    assert!(seen.starts_with("HTTP/1.1 200") && seen.contains("text/event-stream"));
    assert!(seen.contains("\"generation\""), "{seen}");
    // Whole events only: a read may end inside the one after the image (CI, 2026-11-27: a
    // `data:` line cut mid-string).
    let whole = &seen[..seen.rfind("\n\n").unwrap_or(0)];
    let revisions: Vec<u64> = whole
        .lines()
        .filter_map(|line| line.strip_prefix("data: "))
        .map(|data| {
            serde_json::from_str::<Value>(data).unwrap()["revision"]
                .as_u64()
                .unwrap()
        })
        .collect();
    assert!(revisions.windows(2).all(|w| w[0] < w[1]), "{seen}");
    let finished = served.wait_until_done();
    assert!(finished["revision"].as_u64().unwrap() > revision_changed);
}

#[test]
fn changes_are_live_and_reload_nothing() {
    let served = Served::start(SMALL);
    served.wait_until_done();
    let before = served.get("/api/image.png").body;

    let state = served.post("/api/settings", &json!({"f_number": 4})).json();
    assert_eq!(state["f_number"], 4.0);
    assert_eq!(state["aperture"], Value::Null, "f_number replaces aperture");
    // The real f-number (EFL / entrance-pupil diameter) is what was asked for.
    let real = state["lens_info"]["f_number"].as_f64().unwrap();
    assert!((real - 4.0).abs() < 1e-3 * 4.0, "f/{real}");

    let state = served
        .post(
            "/api/settings",
            &json!({"lens": "wide.22mm", "focus_distance": 2.0}),
        )
        .json();
    assert_eq!(state["lens"], "wide.22mm");
    assert_eq!(state["film_distance"], Value::Null);
    let far = served
        .post("/api/settings", &json!({"focus_distance": 50.0}))
        .json();
    let (near_mm, far_mm) = (
        state["lens_info"]["film_distance_mm"].as_f64().unwrap(),
        far["lens_info"]["film_distance_mm"].as_f64().unwrap(),
    );
    // A nearer object images farther behind the lens.
    assert!(near_mm > far_mm, "{near_mm} ≤ {far_mm}");
    // The film's filter is live too, the tent by default.
    assert_eq!(far["filter"], "tent");
    let boxed = served
        .post("/api/settings", &json!({"filter": "box"}))
        .json();
    assert_eq!(boxed["filter"], "box");
    assert!(
        boxed["command"].as_str().unwrap().contains("--filter box"),
        "{boxed}"
    );
    let done = served.wait_until_done();
    assert_eq!(done["lens"], "wide.22mm");
    let after = served.get("/api/image.png").body;
    assert_ne!(before, after, "the image did not change");

    let stats = served.get("/api/stats").json();
    assert_eq!(stats["bvh_builds"], 1, "{stats}");
    assert_eq!(stats["scene_loads"], 1, "{stats}");
    assert_eq!(stats["settings_changes"], 4, "{stats}");
}

#[test]
fn a_swapped_in_lens_renders_on_its_own_film_unless_one_is_set() {
    let served = Served::start(SMALL);
    // The default scene's camera names a 70 mm film for its lens, which names none.
    assert_eq!(served.wait_until_done()["film_diagonal"], 70.0);
    // A phone lens's sensor, from its lens file.
    served.post("/api/settings", &json!({"lens": "deeplens-phone-80deg"}));
    let phone = served.wait_until_done();
    assert_eq!(phone["film_diagonal"], 7.66, "{phone}");
    assert!(
        !phone["command"]
            .as_str()
            .unwrap()
            .contains("--film-diagonal"),
        "{phone}"
    );
    // A film the user sets stays through a swap.
    served.post("/api/settings", &json!({"film_diagonal": 24}));
    served.post("/api/settings", &json!({"lens": "cooke-triplet-50mm-f4"}));
    let set = served.wait_until_done();
    assert_eq!(set["film_diagonal"], 24.0, "{set}");
    assert!(
        set["command"]
            .as_str()
            .unwrap()
            .contains("--film-diagonal 24")
    );
}

#[test]
fn bad_requests_get_an_error_and_the_render_goes_on() {
    let served = Served::start(SMALL);
    let start = served.wait_until_done();
    for (body, why) in [
        (&b"{not json"[..], "not valid JSON"),
        (b"[1, 2]", "JSON object"),
        (b"", "JSON object"),
        (br#"{"no_such_setting": 1}"#, "unknown setting"),
        (br#"{"f_number": "fast"}"#, "'fast' is not a number"),
        (br#"{"f_number": [4]}"#, "expected a number"),
        (br#"{"f_number": -2}"#, "f-number"),
        (br#"{"spp": 0}"#, "spp"),
        (br#"{"spp": 1.5}"#, "whole number"),
        (br#"{"width": 100000}"#, "width"),
        (br#"{"focus_distance": 0.0001}"#, ""),
        (br#"{"f_number": 4, "aperture": 3}"#, "not both"),
        (br#"{"lens": "no-such-lens"}"#, "no-such-lens"),
        (br#"{"focus_mode": "sharpest"}"#, "sharpest"),
        (br#"{"filter": "mitchell"}"#, "unknown filter 'mitchell'"),
    ] {
        let reply = served.request("POST", "/api/settings", &[], body);
        let text = String::from_utf8_lossy(body);
        assert_eq!(
            reply.status,
            400,
            "{text}: {}",
            String::from_utf8_lossy(&reply.body)
        );
        let error = reply.json()["error"].as_str().unwrap().to_string();
        assert!(error.contains(why), "{text}: {error}");
    }
    // The settings are as they were.
    let state = served.state();
    for name in [
        "lens",
        "f_number",
        "aperture",
        "focus_distance",
        "film_distance",
        "spp",
    ] {
        assert_eq!(state[name], start[name], "{name}");
    }

    let too_big = vec![b' '; 70_000];
    assert_eq!(
        served
            .request("POST", "/api/settings", &[], &too_big)
            .status,
        413
    );
    let mut huge_header = b"GET /api/state HTTP/1.1\r\nX-Junk: ".to_vec();
    huge_header.extend(std::iter::repeat_n(b'a', 20_000));
    huge_header.extend(b"\r\n\r\n");
    assert_eq!(served.raw(&huge_header).status, 431);
    assert_eq!(served.raw(b"garbage\r\n\r\n").status, 400);
    assert_eq!(
        served
            .raw(b"GET / HTTP/1.1\r\nContent-Length: x\r\n\r\n")
            .status,
        400
    );
    assert_eq!(
        served
            .raw(b"POST /api/settings HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n")
            .status,
        501
    );
    assert_eq!(served.get("/api/nothing").status, 404);
    assert_eq!(served.get("/../../etc/passwd").status, 404);
    assert_eq!(served.request("DELETE", "/api/state", &[], b"").status, 405);
    assert_eq!(served.get("/api/settings").status, 405);
    assert_eq!(served.post("/api/image.png", &json!({})).status, 405);
    // Another site's page may not drive the server through the user's browser.
    let cross = served.request(
        "POST",
        "/api/settings",
        &[("Origin", "http://evil.example")],
        br#"{"f_number": 8}"#,
    );
    assert_eq!(cross.status, 403);
    // A client that sends nothing and hangs up, and one that stops mid-body.
    drop(std::net::TcpStream::connect(&served.address).unwrap());
    let short = served.raw(b"POST /api/settings HTTP/1.1\r\nContent-Length: 100\r\n\r\n{");
    assert_eq!(short.status, 400);

    // Still rendering: a good change goes through and the render finishes again.
    assert_eq!(
        served
            .post("/api/settings", &json!({"f_number": 5.6}))
            .status,
        200
    );
    let state = served.wait_until_done();
    assert_eq!(state["f_number"], 5.6);
    let stats = served.get("/api/stats").json();
    assert_eq!(
        (stats["bvh_builds"].as_u64(), stats["scene_loads"].as_u64()),
        (Some(1), Some(1))
    );
}

#[test]
fn lens_names_follow_the_path_rules() {
    let root = tempfile::tempdir().unwrap();
    let lenses = root.path().join("lenses");
    std::fs::create_dir_all(lenses.join("primes")).unwrap();
    let dgauss = realcam::lens::io::bundled::find_bundled("dgauss.50mm")
        .unwrap()
        .text;
    let wide = realcam::lens::io::bundled::find_bundled("wide.22mm")
        .unwrap()
        .text;
    std::fs::write(lenses.join("mine.dat"), dgauss).unwrap();
    std::fs::write(lenses.join("primes/wide.dat"), wide).unwrap();
    // Outside the folder: a lens file, and a FIFO that would hang whoever opened it.
    std::fs::write(root.path().join("outside.dat"), dgauss).unwrap();
    let fifo = root.path().join("fifo.dat");
    let fifo_c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(fifo_c.as_ptr(), 0o600) }, 0);
    std::os::unix::fs::symlink(root.path().join("outside.dat"), lenses.join("escape.dat")).unwrap();
    std::os::unix::fs::symlink(&fifo, lenses.join("fifo-link.dat")).unwrap();
    std::os::unix::fs::symlink("mine.dat", lenses.join("alias.dat")).unwrap();
    let command_line = root.path().join("given.dat");
    std::fs::write(&command_line, wide).unwrap();

    let dir = tempfile::tempdir_in(root.path()).unwrap();
    let mut args = SMALL.to_vec();
    let (lens_dir, given) = (
        lenses.to_str().unwrap().to_string(),
        command_line.to_str().unwrap().to_string(),
    );
    args.extend(["--lens-dir", &lens_dir, "--lens", &given]);
    let served = Served::start_in(dir, &args);

    let listed: Vec<Value> = served.get("/api/lenses").json()["lenses"]
        .as_array()
        .unwrap()
        .clone();
    let names: Vec<&str> = listed.iter().map(|l| l["name"].as_str().unwrap()).collect();
    for expected in [
        "mine.dat",
        "primes/wide.dat",
        "alias.dat",
        given.as_str(),
        "dgauss.50mm",
    ] {
        assert!(names.contains(&expected), "{expected} not in {names:?}");
    }
    for hidden in ["escape.dat", "fifo-link.dat"] {
        assert!(!names.contains(&hidden), "{hidden} listed: {names:?}");
    }

    for good in [
        "mine.dat",
        "primes/wide.dat",
        "alias.dat",
        given.as_str(),
        "telephoto.250mm",
    ] {
        let reply = served.post("/api/settings", &json!({ "lens": good }));
        assert_eq!(
            reply.status,
            200,
            "{good}: {}",
            String::from_utf8_lossy(&reply.body)
        );
        assert_eq!(reply.json()["lens"], good);
    }
    let outside = root.path().join("outside.dat");
    let refusals = [
        (outside.to_str().unwrap(), "absolute"),
        (fifo.to_str().unwrap(), "absolute"),
        ("../outside.dat", ".."),
        ("../fifo.dat", ".."),
        ("primes/../mine.dat", ".."),
        ("./mine.dat", ".."),
        ("escape.dat", "link"),
        ("fifo-link.dat", "link"),
        ("nothing.dat", "no such lens"),
        ("given.dat", "no such lens"),
    ];
    for (name, why) in refusals {
        let started = std::time::Instant::now();
        let reply = served.post("/api/settings", &json!({ "lens": name }));
        assert_eq!(reply.status, 400, "{name} was accepted");
        let error = reply.json()["error"].as_str().unwrap().to_string();
        assert!(error.contains(why), "{name}: {error}");
        assert!(started.elapsed() < Duration::from_secs(10), "{name} hung");
    }
    assert_eq!(served.state()["lens"], "telephoto.250mm");
}

#[test]
fn click_to_focus_traces_the_real_lens_to_the_scene() {
    let served = Served::start(SMALL);
    // The distance along the axis to what the image centre shows, by a plain ray from the
    // camera (the library's autofocus): the on-axis ray through the lens runs along the axis.
    let arguments: Vec<String> = SMALL.iter().map(|s| s.to_string()).collect();
    let spec = realcam::cli::render::parse_render_arguments(&arguments).unwrap();
    let formats = realcam::job::outputs::validate(&spec).unwrap();
    let mut job = realcam::job::Job::prepare(&spec, formats).unwrap();
    let wfc = job.world_from_camera;
    let realcam::lens::elements::FocusSetting::Distance { metres: axial, .. } =
        realcam::job::setup::autofocus(&mut job.renderer, wfc)
    else {
        panic!("autofocus gives a distance")
    };

    let state = served.post("/api/focus", &json!({"x": 32, "y": 32})).json();
    let focused = state["focus_distance"].as_f64().unwrap();
    assert!(
        (focused - axial).abs() < 0.01 * axial,
        "{focused} m vs {axial} m"
    );
    assert_eq!(state["film_distance"], Value::Null);

    let corner = served.post("/api/focus", &json!({"x": 2, "y": 60})).json();
    assert_ne!(corner["focus_distance"], state["focus_distance"]);
    for bad in [
        json!({"x": -5, "y": 3}),
        json!({"x": 1e9, "y": 3}),
        json!({"x": "a"}),
        json!({}),
    ] {
        let reply = served.post("/api/focus", &bad);
        assert_eq!(reply.status, 400, "{bad}");
        assert!(reply.json()["error"].is_string());
    }
}

#[test]
fn save_writes_what_the_command_line_it_shows_renders() {
    let served = Served::start(SMALL);
    served.post(
        "/api/settings",
        &json!({"lens": "wide.22mm", "f_number": 8}),
    );
    served.wait_until_done();
    // Paths in the request are not the server's to take.
    let evil = served.path().join("elsewhere.png");
    let saved = served
        .post("/api/save", &json!({"out": evil.to_str().unwrap()}))
        .json();
    assert!(!evil.exists());
    assert_eq!(saved["out"], "render.png");
    assert_eq!(saved["exr"], "render.exr");
    assert_eq!(saved["spp"], 4);
    let png = std::fs::read(served.path().join("render.png")).unwrap();
    let exr = std::fs::read(served.path().join("render.exr")).unwrap();

    let command = saved["command"].as_str().unwrap();
    assert!(command.contains("--lens wide.22mm") && command.contains("--f-number 8"));
    let elsewhere = render_command_line(command);
    assert_eq!(
        std::fs::read(elsewhere.path().join("render.png")).unwrap(),
        png
    );
    assert_eq!(
        std::fs::read(elsewhere.path().join("render.exr")).unwrap(),
        exr
    );
}

/// Runs a `realcam render …` command line the server showed (plain words, no quoting) in a
/// new folder, which it returns.
fn render_command_line(command: &str) -> tempfile::TempDir {
    let words: Vec<&str> = command.split(' ').collect();
    assert_eq!(&words[..2], ["realcam", "render"], "{command}");
    let folder = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(&words[1..])
        .current_dir(folder.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{command}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    folder
}

#[test]
fn blades_shift_and_tilt_change_live_and_stay_through_a_lens_swap() {
    let served = Served::start(SMALL);
    let unmoved = served.wait_until_done();
    let plain_png = served.get("/api/image.png").body;

    let state = served
        .post(
            "/api/settings",
            &json!({"shift": [1.5, -0.5], "tilt": [2, 0], "blades": 6, "blade_rotation": 15, "film_diagonal": 24}),
        )
        .json();
    assert_eq!(state["shift"], json!([1.5, -0.5]), "{state}");
    assert_eq!(state["tilt"], json!([2.0, 0.0]), "{state}");
    assert_eq!(
        (state["blades"].as_u64(), state["blade_rotation"].as_f64()),
        (Some(6), Some(15.0))
    );
    let diaphragm = served.get("/api/lens.json").json()["diaphragm"].clone();
    assert!(
        (diaphragm["open_fraction"].as_f64().unwrap()
            - 3.0 * 3f64.sqrt() / (2.0 * std::f64::consts::PI))
            .abs()
            < 1e-9,
        "six straight blades open a regular hexagon: 3√3/2π of the circle; {diaphragm}"
    );

    // A tilt that darkens a real part of what the untilted film has light on, a tilt past 60°,
    // a malformed pair: refused, the settings stay.
    for (bad, says) in [
        (
            json!({"film_diagonal": 70, "tilt": [40, 0]}),
            "beyond what this lens can cover",
        ),
        (json!({"tilt": [75, 0]}), "tilt"),
        (json!({"shift": [1e308, 0]}), "between −1000 and 1000"),
        (json!({"shift": [1]}), "shift"),
        (json!({"shift": "1,two"}), "shift"),
        (json!({"blade_curvature": 2}), "curvature"),
    ] {
        let reply = served.post("/api/settings", &bad);
        assert_eq!(reply.status, 400, "{bad}");
        let error = reply.json()["error"].as_str().unwrap().to_string();
        assert!(error.contains(says), "{bad}: {error}");
    }
    assert_eq!(served.state()["shift"], json!([1.5, -0.5]));

    // The new lens takes the same diaphragm and movements.
    served.post("/api/settings", &json!({"lens": "wide.22mm"}));
    let swapped = served.wait_until_done();
    assert_eq!(swapped["lens"], "wide.22mm");
    assert_eq!(swapped["shift"], json!([1.5, -0.5]));
    let swapped_diaphragm = served.get("/api/lens.json").json()["diaphragm"].clone();
    for field in ["shape", "open_fraction"] {
        assert_eq!(swapped_diaphragm[field], diaphragm[field]);
    }
    let command = swapped["command"].as_str().unwrap();
    for option in [
        "--shift 1.5,-0.5",
        "--tilt 2,0",
        "--blades 6",
        "--blade-rotation 15",
    ] {
        assert!(command.contains(option), "{option} missing: {command}");
    }
    // What the page shows is what that command renders: the swap kept them on the lens.
    let shown = served.get("/api/image.png").body;
    let rendered = render_command_line(command);
    assert_eq!(
        std::fs::read(rendered.path().join("render.png")).unwrap(),
        shown
    );

    // Taking the blades away takes their rotation too; taking the movements away restores the
    // unmoved picture.
    let state = served
        .post(
            "/api/settings",
            &json!({"blades": null, "shift": null, "tilt": null, "lens": unmoved["lens"],
                "film_diagonal": unmoved["film_diagonal"]}),
        )
        .json();
    assert_eq!(
        (state["blades"].clone(), state["blade_rotation"].clone()),
        (Value::Null, Value::Null)
    );
    served.wait_until_done();
    assert_eq!(served.get("/api/image.png").body, plain_png);
}

/// The default scene's 70 mm film is larger than dgauss.50mm covers: the state warns of it from
/// the start, and a tilt that loses nothing more is accepted with the same warning (it was once
/// refused, blamed on the tilt).
#[test]
fn a_film_larger_than_the_lens_covers_warns_tilted_or_not() {
    let served = Served::start(SMALL);
    let start = served.wait_until_done();
    let warning = start["warning"].as_str().unwrap_or_default();
    assert!(
        warning.contains("larger than the lens covers") && warning.contains("image circle"),
        "{start}"
    );
    for tilt in [json!([0.01, 0]), json!([8, 0])] {
        let reply = served.post("/api/settings", &json!({ "tilt": tilt }));
        assert_eq!(
            reply.status,
            200,
            "{tilt}: {}",
            String::from_utf8_lossy(&reply.body)
        );
        assert_eq!(reply.json()["warning"], start["warning"], "{tilt}");
    }
}

/// A refused lens leaves everything on the lens shown: the state (from which the page sets its
/// picker after every answer), `/api/lenses`' `current`, the lens report and the image.
#[test]
fn a_refused_lens_leaves_the_state_on_the_lens_shown() {
    let served = Served::start(SMALL);
    served.wait_until_done();
    // Nearer than telephoto.250mm can focus (dgauss.50mm can).
    let near = served.post("/api/settings", &json!({"focus_distance": 0.3}));
    assert_eq!(near.status, 200, "{}", String::from_utf8_lossy(&near.body));
    let before = served.wait_until_done();
    let image = served.get("/api/image.png").body;
    let refused = served.post("/api/settings", &json!({"lens": "telephoto.250mm"}));
    assert_eq!(refused.status, 400);
    let error = refused.json()["error"].as_str().unwrap().to_string();
    assert!(
        error.contains("telephoto.250mm") && error.contains("closest this lens can focus"),
        "{error}"
    );
    let after = served.state();
    for name in ["lens", "focus_distance", "generation", "lens_info"] {
        assert_eq!(after[name], before[name], "{name}");
    }
    let lenses = served.get("/api/lenses").json();
    assert_eq!(lenses["current"], before["lens"]);
    // The page can put its picker back: the lens shown is one of the picker's options.
    assert!(
        lenses["lenses"]
            .as_array()
            .unwrap()
            .iter()
            .any(|l| l["name"] == after["lens"]),
        "{lenses}"
    );
    assert_eq!(served.get("/api/lens.json").json(), lens_cli_json(&after));
    assert_eq!(served.get("/api/image.png").body, image);
}

#[test]
fn focus_on_at_start_is_the_focus_render_finds() {
    let pixel = "20,40";
    let served = Served::start(&[SMALL, &["--focus-on", pixel]].concat());
    let state = served.state();
    assert_eq!(state["film_distance"], Value::Null);
    let command = state["command"].as_str().unwrap();
    assert!(!command.contains("--focus-on"), "{command}");

    let argv: Vec<&str> = ["render", "--focus-on", pixel, "--stats", "stats.json"]
        .into_iter()
        .chain(SMALL.iter().copied())
        .collect();
    let folder = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(&argv)
        .current_dir(folder.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: Value =
        serde_json::from_slice(&std::fs::read(folder.path().join("stats.json")).unwrap()).unwrap();
    let expected = stats["frames"][0]["focus_distance_m"]
        .as_f64()
        .unwrap_or_else(|| panic!("{stats}"));
    let focused = state["focus_distance"].as_f64().unwrap();
    assert!(
        (focused - expected).abs() < 1e-9 * expected,
        "{focused} m vs {expected} m"
    );
}

#[test]
fn ctrl_c_stops_the_server_cleanly() {
    let served = Served::start(SMALL);
    served.post("/api/settings", &json!({"spp": 100000}));
    served.wait_for("rendering", |s| s["spp_done"].as_u64() > Some(0));
    let (status, stderr) = served.interrupt();
    assert!(status.success(), "{status}: {stderr}");
    assert!(stderr.contains("stopped"), "{stderr}");
}

#[test]
fn serve_refuses_batch_options_and_bad_addresses() {
    for (args, why) in [
        (&["--focus-sweep", "1:2:3"][..], "--focus-sweep"),
        (&["--out", "-"], "--out -"),
        (&["--lens-dir", "/no/such/folder"], "--lens-dir"),
        (&["--listen", "not-an-address"], "--listen"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_realcam"))
            .arg("serve")
            .args(args)
            .args(["--port", "0"])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(why), "{args:?}: {stderr}");
    }
}

/// `realcam serve | head -0`: nobody reads the printed address, and the lab serves on and stops
/// cleanly on Ctrl-C instead of panicking at that print.
#[test]
fn a_closed_standard_output_does_not_stop_the_lab() {
    use std::io::Read;
    use std::process::Stdio;
    use std::time::Instant;

    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .arg("serve")
        .args(["--port", "0"])
        .args(SMALL)
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away before the address is printed
    let mut stderr = child.stderr.take().unwrap();
    let mut said = String::new();
    let start = Instant::now();
    let mut buffer = [0u8; 4096];
    while !said.contains("serving the live lens lab") {
        assert!(start.elapsed() < Duration::from_secs(60), "{said}");
        match stderr.read(&mut buffer).unwrap() {
            0 => break,
            n => said.push_str(&String::from_utf8_lossy(&buffer[..n])),
        }
    }
    assert!(said.contains("serving the live lens lab"), "{said}");
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let status = child.wait().unwrap();
    stderr.read_to_string(&mut said).unwrap();
    assert!(status.success(), "{status}: {said}");
    assert!(!said.contains("panicked"), "{said}");
}

#[test]
fn the_live_lab_renders_on_the_gpu_and_swaps_lenses_there() {
    if realcam::gpu::GpuContext::for_tests().is_none() {
        return;
    }
    let args: Vec<&str> = SMALL.iter().copied().chain(["--device", "gpu"]).collect();
    let served = Served::start(&args);
    let first = served.wait_until_done();
    assert!(
        first["command"].as_str().unwrap().contains("--device gpu"),
        "{first}"
    );
    let before = served.get("/api/image.png").body;
    // A focus pull and a lens swap on the GPU: the lens buffer is rewritten, nothing reloads.
    served.post("/api/settings", &json!({"focus_distance": 1.5}));
    served.post("/api/settings", &json!({"lens": "wide.22mm"}));
    let done = served.wait_until_done();
    assert_eq!(done["lens"], "wide.22mm");
    let after = served.get("/api/image.png");
    assert_eq!(after.status, 200);
    assert_eq!(png_size(&after.body), (64, 64));
    assert_ne!(before, after.body, "the image did not change");
    let stats = served.get("/api/stats").json();
    assert_eq!(stats["device"], "gpu", "{stats}");
    assert_eq!(stats["bvh_builds"], 1, "{stats}");
    assert_eq!(stats["scene_loads"], 1, "{stats}");
    assert!(
        stats["samples_per_second"].as_f64().unwrap() > 0.0,
        "{stats}"
    );
}

/// The zoom ring: a zoom lens's positions are in the state's `lens_info` (with their published
/// focal lengths), `zoom_position` moves its groups live (the focal length follows, nothing is
/// reloaded), a position the lens lacks is refused with 400 in words, and `null` returns to the
/// lens as written.
#[test]
fn the_zoom_ring_moves_a_zoom_lens_live() {
    let dir = tempfile::tempdir().unwrap();
    let lens = dir.path().join("test-zoom.toml");
    std::fs::write(&lens, crate::support::TWO_GROUP_ZOOM).unwrap();
    let mut args = SMALL.to_vec();
    let path = lens.to_str().unwrap().to_string();
    args.extend(["--lens", &path]);
    let served = Served::start_in(dir, &args);
    let first = served.wait_until_done();
    let positions = first["lens_info"]["zoom_positions"]
        .as_array()
        .unwrap()
        .clone();
    assert_eq!(positions.len(), 3, "{first}");
    assert_eq!(positions[2]["position"], 3);
    assert_eq!(positions[2]["focal_length_mm"], 100.0);
    let written = first["lens_info"]["focal_length_mm"].as_f64().unwrap();
    let mut focal_lengths = Vec::new();
    for position in 1..=3 {
        let reply = served.post("/api/settings", &json!({ "zoom_position": position }));
        assert_eq!(reply.status, 200, "{}", reply.json());
        let state = served.wait_until_done();
        assert_eq!(state["zoom_position"], position);
        focal_lengths.push(state["lens_info"]["focal_length_mm"].as_f64().unwrap());
    }
    // The groups part, the focal length grows (39, 56, 100 mm nominal).
    assert!(
        focal_lengths.windows(2).all(|w| w[1] > w[0] * 1.2),
        "{focal_lengths:?}"
    );
    assert!(
        (focal_lengths[0] - written).abs() < 1e-9,
        "{focal_lengths:?} vs {written}"
    );
    let refused = served.post("/api/settings", &json!({ "zoom_position": 4 }));
    assert_eq!(refused.status, 400);
    assert!(
        refused.json().to_string().contains("zoom position 4"),
        "{}",
        refused.json()
    );
    let back = served.post("/api/settings", &json!({ "zoom_position": null }));
    assert_eq!(back.status, 200);
    let state = served.wait_until_done();
    assert_eq!(state["zoom_position"], Value::Null);
    assert!((state["lens_info"]["focal_length_mm"].as_f64().unwrap() - written).abs() < 1e-9);
    let stats = served.get("/api/stats").json();
    assert_eq!(stats["scene_loads"].as_u64(), Some(1), "{stats}");
}
