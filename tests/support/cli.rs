//! Running the `realcam` binary from the tests: the command, its output, and what success and
//! a clear refusal look like.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// `realcam ARGS` in `dir`, standard input closed, standard output and error captured.
pub fn command(dir: &Path, args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_realcam"));
    command
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    command
}

/// Runs `realcam ARGS` in `dir` to the end.
pub fn realcam(dir: &Path, args: &[&str]) -> Output {
    command(dir, args).output().unwrap()
}

/// Runs `realcam ARGS` in the package's folder (where `lenses/…` names resolve) with `input`
/// on standard input: the exit code (−1 when a signal ended it), standard output and error.
pub fn realcam_texts(args: &[&str], input: Option<&str>) -> (i32, String, String) {
    let mut child = command(Path::new(env!("CARGO_MANIFEST_DIR")), args)
        .stdin(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(input.unwrap_or("").as_bytes()).unwrap();
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr(&out),
    )
}

pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Asserts that the run succeeded; its standard error.
pub fn ok(output: &Output) -> String {
    let text = stderr(output);
    assert!(output.status.success(), "{text}");
    text
}

/// Asserts a clear refusal of a value the run checked: exit 1, an `error: ` line holding every
/// phrase, no panic.
pub fn refused(output: &Output, phrases: &[&str]) {
    refused_with(1, output, phrases);
}

/// Asserts a refusal by the option parser (a value out of an option's range, a missing
/// companion option): exit 2, an `error: ` line holding every phrase, no panic.
pub fn refused_by_parser(output: &Output, phrases: &[&str]) {
    refused_with(2, output, phrases);
}

fn refused_with(code: i32, output: &Output, phrases: &[&str]) {
    let text = stderr(output);
    assert_eq!(output.status.code(), Some(code), "{text}");
    assert!(text.contains("error: "), "{text}");
    for phrase in phrases {
        assert!(text.contains(phrase), "missing {phrase:?}: {text}");
    }
    assert!(!text.contains("panicked"), "{text}");
}
