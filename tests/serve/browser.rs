//! The page of `realcam serve` in a real browser: headless Chromium, driven over the DevTools
//! protocol on a pipe (`--remote-debugging-pipe`), loads the page, picks another lens in the
//! lens picker, types a focus distance, clicks the image to focus, sets diaphragm blades and a
//! film shift, and sees the image change each time; a refused lens puts the picker back. Skipped, saying so, when no Chromium is installed — unless
//! `REALCAM_REQUIRE_CHROMIUM=1` (CI: `.ci/run` installs Debian's `chromium`).

use crate::live_server;

use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::{FromRawFd, RawFd};
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use live_server::{SMALL, Served};
use serde_json::{Value, json};

fn find_chromium() -> Option<PathBuf> {
    let candidates = [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ];
    let path = std::env::var_os("PATH")?;
    candidates.iter().find_map(|name| {
        std::env::split_paths(&path)
            .map(|dir| dir.join(name))
            .find(|p| p.is_file())
    })
}

/// Chromium or, when there is none, `None` after saying the test is skipped.
fn chromium_or_skip(test: &str) -> Option<PathBuf> {
    let found = find_chromium();
    if found.is_none() {
        assert!(
            std::env::var_os("REALCAM_REQUIRE_CHROMIUM").is_none(),
            "REALCAM_REQUIRE_CHROMIUM is set but no chromium is on PATH"
        );
        eprintln!(
            "SKIPPED {test}: no headless Chromium found (install Debian's `chromium`; .ci/run does)"
        );
    }
    found
}

/// A headless Chromium spoken to over the DevTools pipe.
struct Browser {
    child: Child,
    to_browser: File,
    from_browser: File,
    next_id: u64,
    session: Option<String>,
    _profile: tempfile::TempDir,
}

fn pipe() -> (RawFd, RawFd) {
    let mut fds = [0; 2];
    assert_eq!(unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) }, 0);
    (fds[0], fds[1])
}

impl Browser {
    fn launch(chromium: &PathBuf, width: u32, height: u32) -> Browser {
        let profile = tempfile::tempdir().unwrap();
        let (chrome_reads, we_write) = pipe();
        let (we_read, chrome_writes) = pipe();
        let mut command = Command::new(chromium);
        command
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                "--hide-scrollbars",
                "--remote-debugging-pipe",
                &format!("--window-size={width},{height}"),
                &format!("--user-data-dir={}", profile.path().display()),
                "about:blank",
            ])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        // The protocol's pipe is fd 3 (commands in) and fd 4 (answers out); dup2 leaves them
        // open across exec, the O_CLOEXEC originals close.
        unsafe {
            command.pre_exec(move || {
                // Copies above 9 first: a pipe end may itself be fd 3 or 4, and dup2 onto
                // itself would keep its close-on-exec flag.
                let (reads, writes) = (
                    libc::fcntl(chrome_reads, libc::F_DUPFD, 10),
                    libc::fcntl(chrome_writes, libc::F_DUPFD, 10),
                );
                if reads < 0 || writes < 0 || libc::dup2(reads, 3) < 0 || libc::dup2(writes, 4) < 0
                {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = command.spawn().expect("chromium starts");
        unsafe {
            libc::close(chrome_reads);
            libc::close(chrome_writes);
        }
        Browser {
            child,
            to_browser: unsafe { File::from_raw_fd(we_write) },
            from_browser: unsafe { File::from_raw_fd(we_read) },
            next_id: 0,
            session: None,
            _profile: profile,
        }
    }

    /// Sends a command and waits for its answer (events in between are skipped).
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.try_call(method, params)
            .unwrap_or_else(|error| panic!("{method}: {error}"))
    }

    fn try_call(&mut self, method: &str, params: Value) -> Result<Value, Value> {
        self.next_id += 1;
        let mut message = json!({ "id": self.next_id, "method": method, "params": params });
        if let Some(session) = &self.session {
            message["sessionId"] = json!(session);
        }
        let mut bytes = message.to_string().into_bytes();
        bytes.push(0);
        self.to_browser
            .write_all(&bytes)
            .expect("chromium takes commands");
        loop {
            let answer = self.receive();
            if answer["id"] == self.next_id {
                if let Some(error) = answer.get("error") {
                    return Err(error.clone());
                }
                return Ok(answer["result"].clone());
            }
        }
    }

    fn receive(&mut self) -> Value {
        let mut bytes = Vec::new();
        let mut byte = [0u8; 1];
        loop {
            let n = self.from_browser.read(&mut byte).expect("chromium answers");
            assert!(n == 1, "chromium closed the protocol pipe");
            if byte[0] == 0 {
                return serde_json::from_slice(&bytes).expect("a JSON message");
            }
            bytes.push(byte[0]);
        }
    }

    /// Opens `url` in a new page and attaches to it.
    fn open(&mut self, url: &str) {
        let target = self.call("Target.createTarget", json!({ "url": url }));
        let attached = self.call(
            "Target.attachToTarget",
            json!({ "targetId": target["targetId"], "flatten": true }),
        );
        self.session = Some(attached["sessionId"].as_str().unwrap().to_string());
    }

    /// Waits until the page's script has loaded the state from the server.
    fn wait_for_page(&mut self) {
        for _ in 0..300 {
            let ready = self.try_call(
                "Runtime.evaluate",
                json!({ "expression": "typeof state !== 'undefined' && state !== null", "returnByValue": true }),
            );
            if ready.is_ok_and(|r| r["result"]["value"] == true) {
                return;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        panic!("the page never loaded its state");
    }

    /// Evaluates `expression` (a promise is awaited) in the page.
    fn evaluate(&mut self, expression: &str) -> Value {
        let result = self.call(
            "Runtime.evaluate",
            json!({ "expression": expression, "awaitPromise": true, "returnByValue": true }),
        );
        if let Some(exception) = result.get("exceptionDetails") {
            panic!("the page's script failed: {exception}");
        }
        result["result"]["value"].clone()
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Helpers run in the page: wait for a condition, read the shown image's pixels.
const HELPERS: &str = r#"
window.until = (cond, what) => new Promise((resolve, reject) => {
  const t0 = Date.now();
  const tick = () => {
    let v = false;
    try { v = cond(); } catch (e) {}
    if (v) resolve(v);
    else if (Date.now() - t0 > 60000) reject(new Error("timed out waiting for " + what));
    else setTimeout(tick, 50);
  };
  tick();
});
// The render finished and the page shows its final image.
window.settled = (what) => until(() => state && state.spp_done === state.spp_target
  && document.getElementById("image").src.endsWith("g=" + state.generation)
  && document.getElementById("image").complete, what);
window.pixels = () => {
  const img = document.getElementById("image");
  const canvas = document.createElement("canvas");
  canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
  const g = canvas.getContext("2d");
  g.drawImage(img, 0, 0);
  return Array.from(g.getImageData(0, 0, canvas.width, canvas.height).data).join(",");
};
true
"#;

/// `realcam serve ARGS` with its page loaded in a `width` × `height` window and the test
/// helpers ([`HELPERS`]) in place.
fn open_page(chromium: &PathBuf, args: &[&str], width: u32, height: u32) -> (Served, Browser) {
    let served = Served::start(args);
    let mut browser = Browser::launch(chromium, width, height);
    browser.open(&served.url());
    browser.wait_for_page();
    assert_eq!(browser.evaluate(HELPERS), json!(true));
    (served, browser)
}

#[test]
fn the_page_changes_lens_and_focus_and_shows_the_new_image() {
    let Some(chromium) =
        chromium_or_skip("the_page_changes_lens_and_focus_and_shows_the_new_image")
    else {
        return;
    };
    let (served, mut browser) = open_page(&chromium, SMALL, 1400, 860);

    let outcome = browser.evaluate(
        r##"(async () => {
          await settled("the first render");
          const first = pixels();
          const options = Array.from(document.getElementById("lens").options).map((o) => o.value);
          const lens = document.getElementById("lens");
          lens.value = "wide.22mm";
          lens.dispatchEvent(new Event("change"));
          await until(() => state.lens === "wide.22mm", "the lens change");
          await settled("the render through wide.22mm");
          const afterLens = pixels();
          const focus = document.getElementById("focus_distance");
          focus.value = "0.5";
          focus.dispatchEvent(new Event("change"));
          await until(() => state.focus_distance === 0.5, "the focus change");
          await settled("the render focused at 0.5 m");
          const afterFocus = pixels();
          const img = document.getElementById("image");
          const box = img.getBoundingClientRect();
          img.dispatchEvent(new MouseEvent("click", { bubbles: true,
            clientX: box.left + box.width / 2, clientY: box.top + box.height / 2 }));
          await until(() => state.focus_distance !== 0.5, "click to focus");
          await settled("the render focused by a click");
          const afterClick = pixels();
          const blades = document.getElementById("blades");
          blades.value = "5";
          blades.dispatchEvent(new Event("change"));
          await until(() => state.blades === 5, "the blades change");
          await settled("the render through five blades");
          const afterBlades = pixels();
          const shiftX = document.getElementById("shift_x");
          shiftX.value = "1";
          shiftX.dispatchEvent(new Event("change"));
          await until(() => state.shift && state.shift[0] === 1, "the shift change");
          await settled("the shifted render");
          const afterShift = pixels();
          const wavelengths = document.getElementById("wavelengths");
          const wavelengthsShown = wavelengths.value;
          wavelengths.value = "1";
          wavelengths.dispatchEvent(new Event("change"));
          await until(() => state.wavelengths === 1, "the wavelengths change");
          await settled("the render with one wavelength per sample");
          const afterWavelengths = pixels();
          const coating = document.getElementById("coating");
          const coatingShown = coating.value;
          coating.value = "none";
          coating.dispatchEvent(new Event("change"));
          await until(() => state.coating === "none", "the coating change");
          await settled("the render through bare glass");
          const afterCoating = pixels();
          const diagram = document.querySelector("#diagram svg") !== null;
          const numbers = document.getElementById("first-order").textContent;
          return { options: options.length, lensChanged: first !== afterLens,
            focusChanged: afterLens !== afterFocus, clickChanged: afterFocus !== afterClick,
            bladesChanged: afterClick !== afterBlades, shiftChanged: afterBlades !== afterShift,
            wavelengthsShown, wavelengthsChanged: afterShift !== afterWavelengths,
            filterShown: document.getElementById("filter").value,
            coatingShown, coatingChanged: afterWavelengths !== afterCoating,
            diaphragmShown: document.getElementById("first-order").textContent.includes("5 blades"),
            focus: state.focus_distance, diagram, numbers,
            message: document.getElementById("message").textContent };
        })()"##,
    );
    assert!(outcome["options"].as_u64().unwrap() > 10, "{outcome}");
    assert_eq!(outcome["lensChanged"], true, "{outcome}");
    assert_eq!(outcome["focusChanged"], true, "{outcome}");
    assert_eq!(outcome["clickChanged"], true, "{outcome}");
    assert_eq!(outcome["bladesChanged"], true, "{outcome}");
    assert_eq!(outcome["shiftChanged"], true, "{outcome}");
    assert_eq!(
        outcome["wavelengthsShown"],
        realcam::lens::hero_wavelengths::DEFAULT_WAVELENGTHS.to_string(),
        "{outcome}"
    );
    assert_eq!(outcome["filterShown"], "tent", "{outcome}");
    assert_eq!(outcome["wavelengthsChanged"], true, "{outcome}");
    // The page shows the file's coatings until one is chosen; bare glass loses more light.
    assert_eq!(outcome["coatingShown"], "", "{outcome}");
    assert_eq!(outcome["coatingChanged"], true, "{outcome}");
    assert_eq!(outcome["diaphragmShown"], true, "{outcome}");
    assert_eq!(outcome["diagram"], true, "{outcome}");
    assert!(
        outcome["numbers"].as_str().unwrap().contains("wide.22mm"),
        "{outcome}"
    );
    assert_eq!(outcome["message"], "", "{outcome}");
    // The server saw the same: one scene load and BVH build.
    let stats = served.get("/api/stats").json();
    assert_eq!(
        (stats["bvh_builds"].as_u64(), stats["scene_loads"].as_u64()),
        (Some(1), Some(1))
    );
}

/// A refused lens at a narrow width: the picker goes back to the lens the image shows, and the
/// error is in sight while the picker is (the controls then sit below the image).
#[test]
fn a_refused_lens_puts_the_picker_back_and_the_error_in_sight() {
    let Some(chromium) =
        chromium_or_skip("a_refused_lens_puts_the_picker_back_and_the_error_in_sight")
    else {
        return;
    };
    let (_served, mut browser) = open_page(&chromium, SMALL, 800, 900);
    let outcome = browser.evaluate(
        r##"(async () => {
          await settled("the first render");
          const focus = document.getElementById("focus_distance");
          focus.value = "0.3";
          focus.dispatchEvent(new Event("change"));
          await until(() => state.focus_distance === 0.3, "the focus change");
          await settled("the render focused at 0.3 m");
          const shown = state.lens;
          const lens = document.getElementById("lens");
          lens.scrollIntoView();
          lens.value = "telephoto.250mm";
          lens.dispatchEvent(new Event("change"));
          const message = document.getElementById("message");
          await until(() => message.textContent !== "", "the refusal");
          await until(() => lens.value === shown, "the picker going back");
          const box = message.getBoundingClientRect();
          return { shown, picked: lens.value, stateLens: state.lens, text: message.textContent,
            inView: box.height > 0 && box.top >= 0 && box.bottom <= window.innerHeight,
            narrow: window.innerWidth <= 800, scrolled: window.scrollY > 0 };
        })()"##,
    );
    assert_eq!(outcome["narrow"], true, "{outcome}");
    assert_eq!(outcome["scrolled"], true, "{outcome}");
    assert_eq!(outcome["picked"], outcome["shown"], "{outcome}");
    assert_eq!(outcome["stateLens"], outcome["shown"], "{outcome}");
    assert!(
        outcome["text"]
            .as_str()
            .unwrap()
            .contains("closest this lens can focus"),
        "{outcome}"
    );
    assert_eq!(outcome["inView"], true, "{outcome}");
}

/// Takes README's screenshot: `REALCAM_SCREENSHOT=docs/serve.png cargo test --release --test serve
/// browser::readme_screenshot -- --ignored`.
#[test]
#[ignore = "writes the README screenshot when REALCAM_SCREENSHOT names the file"]
fn readme_screenshot() {
    let Some(path) = std::env::var_os("REALCAM_SCREENSHOT") else {
        return;
    };
    let chromium = find_chromium().expect("chromium");
    let (_served, mut browser) = open_page(
        &chromium,
        &["--spp", "32", "--f-number", "2", "--blades", "6"],
        1500,
        1010,
    );
    browser.evaluate(
        r#"(async () => {
          await settled("the render");
          const img = document.getElementById("image");
          const box = img.getBoundingClientRect();
          img.dispatchEvent(new MouseEvent("click", { bubbles: true,
            clientX: box.left + box.width * 0.3, clientY: box.top + box.height * 0.62 }));
          await until(() => state.spp_done === 0, "the click");
          await settled("the refocused render");
          await new Promise((r) => setTimeout(r, 500));
          return true;
        })()"#,
    );
    let shot = browser.call("Page.captureScreenshot", json!({ "format": "png" }));
    let png = decode_base64(shot["data"].as_str().unwrap());
    std::fs::write(&path, png).unwrap();
}

fn decode_base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let digits: Vec<u8> = text.bytes().filter(|&c| c != b'=').map(value).collect();
    digits
        .chunks(4)
        .flat_map(|chunk| {
            let bits = chunk
                .iter()
                .enumerate()
                .fold(0u32, |acc, (i, &d)| acc | (d as u32) << (18 - 6 * i));
            let bytes = bits.to_be_bytes();
            bytes[1..chunk.len()].to_vec()
        })
        .collect()
}
