//! The lenses a live session may be asked for by name: the bundled library, the files named on
//! its command line, and the files under its lens folder. A name from a browser is looked up
//! here and nowhere else: absolute paths, `..` and links that lead out of the folder are refused
//! before anything is opened.

use std::path::{Component, Path, PathBuf};

use crate::lens::Prescription;
use crate::lens::io::ReadOptions;
use crate::lens::io::bundled::{BUNDLED, read_lens};

/// Where a lens of the library comes from.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LensOrigin {
    Bundled,
    CommandLine,
    LensDir,
}

/// One lens the session offers.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct LensEntry {
    /// What the browser sends to pick it.
    pub name: String,
    pub origin: LensOrigin,
}

/// File extensions of lens prescriptions (pbrt tables, realcam's TOML, Zemax).
const LENS_EXTENSIONS: [&str; 3] = ["dat", "toml", "zmx"];
/// How deep and how many files a lens folder is listed (a folder is browsed, not crawled).
const MAX_DEPTH: usize = 4;
const MAX_LISTED: usize = 2000;
/// Longest lens name accepted from a request.
const MAX_NAME: usize = 512;

/// The lenses a session may load.
#[derive(Clone, Debug)]
pub struct LensLibrary {
    /// `--lens` arguments exactly as given (bundled names or files).
    command_line: Vec<String>,
    /// `--lens-dir`, canonical.
    dir: Option<PathBuf>,
    /// How lens files are read (`--lens-format`, `--glass`).
    reading: ReadOptions,
}

impl LensLibrary {
    /// `command_line`: the `--lens` arguments; `dir`: `--lens-dir`, which must be a folder.
    pub fn new(
        command_line: Vec<String>,
        dir: Option<&Path>,
        reading: ReadOptions,
    ) -> anyhow::Result<LensLibrary> {
        let dir = match dir {
            Some(dir) => {
                let canonical = dir.canonicalize().map_err(|e| {
                    anyhow::anyhow!("--lens-dir {}: cannot open: {e}", dir.display())
                })?;
                if !canonical.is_dir() {
                    anyhow::bail!("--lens-dir {}: is not a folder", dir.display());
                }
                Some(canonical)
            }
            None => None,
        };
        Ok(LensLibrary {
            command_line,
            dir,
            reading,
        })
    }

    /// Offers `spec` as if it had been named on the command line (the scene's own lens hint).
    pub fn trust(&mut self, spec: &str) {
        if !self.command_line.iter().any(|given| given == spec) {
            self.command_line.push(spec.to_string());
        }
    }

    /// Every lens on offer: command-line files first, then the lens folder's, then the bundled.
    pub fn entries(&self) -> Vec<LensEntry> {
        let mut entries: Vec<LensEntry> = self
            .command_line
            .iter()
            .map(|name| LensEntry {
                name: name.clone(),
                origin: LensOrigin::CommandLine,
            })
            .collect();
        if let Some(dir) = &self.dir {
            let mut found = Vec::new();
            list_lens_files(dir, dir, 0, &mut found);
            found.sort();
            entries.extend(found.into_iter().map(|name| LensEntry {
                name,
                origin: LensOrigin::LensDir,
            }));
        }
        entries.extend(BUNDLED.iter().map(|b| LensEntry {
            name: b.name.to_string(),
            origin: LensOrigin::Bundled,
        }));
        entries
    }

    /// The prescription a request names, and the path or name `realcam render --lens` would
    /// take for it; an error naming the refusal otherwise.
    pub fn load(&self, name: &str) -> Result<(Prescription, String), String> {
        if name.is_empty() || name.len() > MAX_NAME || name.contains('\0') {
            return Err("a lens name must be 1 to 512 characters".into());
        }
        if self.command_line.iter().any(|given| given == name) {
            return read_lens(name, &self.reading)
                .map(|p| (p, name.to_string()))
                .map_err(|e| e.to_string());
        }
        if let Some(bundled) = BUNDLED.iter().find(|b| b.name == name) {
            return bundled
                .read(&self.reading)
                .map(|p| (p, name.to_string()))
                .map_err(|e| e.to_string());
        }
        let Some(dir) = &self.dir else {
            return Err(format!(
                "lens '{name}': not a bundled lens nor one named on the command line (serve a folder of lens files with --lens-dir)"
            ));
        };
        let path = self.inside_dir(dir, name)?;
        Prescription::read(&path, &self.reading)
            .map(|p| (p, path.display().to_string()))
            .map_err(|e| e.to_string())
    }

    /// `dir/name` when `name` is a relative path that stays inside `dir` (links resolved, never
    /// opened) and names a lens file there.
    fn inside_dir(&self, dir: &Path, name: &str) -> Result<PathBuf, String> {
        let relative = Path::new(name);
        let refused = |why: &str| Err(format!("lens '{name}': refused: {why}"));
        if relative.is_absolute() || name.starts_with('/') || name.starts_with('\\') {
            return refused("absolute paths are not served; name a file under --lens-dir");
        }
        if relative
            .components()
            .any(|c| !matches!(c, Component::Normal(_)))
        {
            return refused("`..` and `.` are not allowed in lens names");
        }
        let joined = dir.join(relative);
        // Resolving links reads them, it does not open the file they lead to.
        let Ok(real) = joined.canonicalize() else {
            return Err(format!(
                "lens '{name}': no such lens under --lens-dir, and not a bundled lens"
            ));
        };
        if !real.starts_with(dir) {
            return refused("it is a link leading out of --lens-dir");
        }
        if !real.is_file() {
            return refused("not a file");
        }
        Ok(joined)
    }
}

/// Lens files under `dir`, as paths relative to `root` with `/` separators; links are listed
/// only when they stay inside `root`.
fn list_lens_files(root: &Path, dir: &Path, depth: usize, found: &mut Vec<String>) {
    if depth > MAX_DEPTH || found.len() >= MAX_LISTED {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        if found.len() >= MAX_LISTED {
            return;
        }
        let path = entry.path();
        let Ok(real) = path.canonicalize() else {
            continue;
        };
        if !real.starts_with(root) {
            continue;
        }
        if real.is_dir() {
            // A link to a folder inside the root would list that folder twice.
            if entry.file_type().is_ok_and(|t| t.is_dir()) {
                list_lens_files(root, &path, depth + 1, found);
            }
        } else if LENS_EXTENSIONS
            .iter()
            .any(|e| crate::lens::io::extension(&path) == *e)
            && let Ok(relative) = path.strip_prefix(root)
        {
            let parts: Vec<String> = relative
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            found.push(parts.join("/"));
        }
    }
}
