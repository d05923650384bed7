//! A live session's settings, kept as `realcam render` arguments: a change from the API is
//! parsed by the very option parser of the command line (the same ranges, the same messages),
//! and the settings always have an equivalent `realcam render` command line.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde_json::{Map, Value, json};

use crate::job::spec::JobSpec;

/// Reads `realcam render` arguments (without the command name) into a job spec, refusing a bad
/// value with the command line's own message. The front end that starts a live session passes
/// its parser in: the settings are that command line's options, which only it knows how to read.
pub type SpecParser = Arc<dyn Fn(&[String]) -> Result<JobSpec, String> + Send + Sync>;

/// Options a live session changes without reloading the scene or rebuilding its BVH, by their
/// names in the API (`realcam render`'s long options without dashes, `-` as `_`).
pub const LIVE_OPTIONS: [&str; 26] = [
    "lens",
    "focus_distance",
    "film_distance",
    "focus_mode",
    "f_number",
    "aperture",
    "blades",
    "blade_rotation",
    "blade_curvature",
    "film_diagonal",
    "shift",
    "tilt",
    "pupil_sampling",
    "dispersion",
    "wavelengths",
    "filter",
    "coating",
    "flare",
    "zoom_position",
    "zoom",
    "width",
    "height",
    "spp",
    "seed",
    "max_depth",
    "exposure",
];

/// Settings that take whole numbers (the rest of the numeric ones take any number).
const WHOLE: [&str; 8] = [
    "width",
    "height",
    "spp",
    "seed",
    "max_depth",
    "blades",
    "wavelengths",
    "zoom_position",
];
/// Settings that take two numbers (`[x, y]` in JSON, `X,Y` on the command line).
const PAIRS: [&str; 2] = ["shift", "tilt"];
/// Settings that take words.
const WORDS: [&str; 7] = [
    "lens",
    "focus_mode",
    "pupil_sampling",
    "dispersion",
    "filter",
    "coating",
    "flare",
];
/// Pairs of settings of which one replaces the other.
const EITHER: [(&str, &str); 3] = [
    ("focus_distance", "film_distance"),
    ("f_number", "aperture"),
    ("zoom_position", "zoom"),
];
/// Settings that only qualify another: removing it removes them.
const QUALIFIERS: [(&str, [&str; 2]); 1] = [("blades", ["blade_rotation", "blade_curvature"])];
/// What the live session's state adds beside the settings: a client may send a state back.
pub const READ_ONLY: [&str; 10] = [
    "warning",
    "revision",
    "spp_done",
    "spp_target",
    "generation",
    "lens_info",
    "out",
    "exr",
    "command",
    "error",
];

/// The settings of a live session.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveSettings {
    /// `realcam render` arguments the session keeps as they were given (scene, camera, …).
    fixed: Vec<String>,
    /// The live options' values as command-line text; absent when not given.
    values: BTreeMap<&'static str, String>,
}

impl LiveSettings {
    /// `fixed`: the rest of the `realcam render` command line.
    pub fn new(fixed: Vec<String>) -> LiveSettings {
        LiveSettings {
            fixed,
            values: BTreeMap::new(),
        }
    }

    /// Settings from `realcam render` arguments (already accepted by its parser): the live
    /// options are taken out of them (the last of a repeated one wins, the first `--lens`), the rest kept as given.
    pub fn from_arguments(argv: &[String]) -> LiveSettings {
        let mut settings = LiveSettings::new(Vec::new());
        let mut words = argv.iter();
        while let Some(word) = words.next() {
            let (name, inline) = match word.strip_prefix("--") {
                Some(option) => match option.split_once('=') {
                    Some((name, value)) => (name.replace('-', "_"), Some(value.to_string())),
                    None => (option.replace('-', "_"), None),
                },
                None => (String::new(), None),
            };
            if LIVE_OPTIONS.contains(&name.as_str()) {
                // The first --lens is the one shown; the others are offered on the page.
                if let Some(value) = inline.or_else(|| words.next().cloned())
                    && (name != "lens" || settings.get("lens").is_none())
                {
                    settings.set(&name, value);
                }
            } else {
                settings.fixed.push(word.clone());
            }
        }
        settings
    }

    /// Sets a live option from text (as on the command line).
    pub fn set(&mut self, name: &str, value: impl Into<String>) {
        if let Some(name) = LIVE_OPTIONS.iter().find(|o| **o == name) {
            self.values.insert(name, value.into());
        }
    }

    /// Takes `--name VALUE` (or `--name=VALUE`) out of the kept arguments; `name` as in the
    /// API (`_` for `-`).
    pub fn remove_fixed(&mut self, name: &str) {
        let option = format!("--{}", name.replace('_', "-"));
        let mut kept = Vec::with_capacity(self.fixed.len());
        let mut words = std::mem::take(&mut self.fixed).into_iter();
        while let Some(word) = words.next() {
            if word == option {
                words.next();
            } else if !word.starts_with(&format!("{option}=")) {
                kept.push(word);
            }
        }
        self.fixed = kept;
    }

    pub fn unset(&mut self, name: &str) {
        self.values.remove(name);
    }

    pub fn get(&self, name: &str) -> Option<&str> {
        self.values.get(name).map(String::as_str)
    }

    /// The `realcam render` arguments (without the command name).
    pub fn arguments(&self) -> Vec<String> {
        let mut argv = self.fixed.clone();
        for (name, value) in &self.values {
            argv.push(format!("--{}", name.replace('_', "-")));
            argv.push(value.clone());
        }
        argv
    }

    /// The arguments read by `parser`, as `realcam render` reads them.
    pub fn parse(&self, parser: &SpecParser) -> Result<JobSpec, String> {
        parser(&self.arguments())
    }

    /// These settings with the changes of a JSON object (`null` removes a setting; one of
    /// `focus_distance`/`film_distance` or `f_number`/`aperture` replaces the other).
    pub fn changed(&self, changes: &Value) -> Result<LiveSettings, String> {
        let Value::Object(changes) = changes else {
            return Err("the settings must be a JSON object, e.g. {\"f_number\": 4}".into());
        };
        let mut next = self.clone();
        for (name, value) in changes {
            if READ_ONLY.contains(&name.as_str()) {
                continue;
            }
            if !LIVE_OPTIONS.contains(&name.as_str()) {
                return Err(format!(
                    "unknown setting '{name}'; the settings are {}",
                    LIVE_OPTIONS.join(", ")
                ));
            }
            let text = match value {
                Value::Null => {
                    next.unset(name);
                    for (qualified, qualifiers) in QUALIFIERS {
                        if name == qualified {
                            qualifiers.iter().for_each(|q| next.unset(q));
                        }
                    }
                    continue;
                }
                Value::Array(pair) if PAIRS.contains(&name.as_str()) => match pair.as_slice() {
                    [Value::Number(x), Value::Number(y)] => format!("{x},{y}"),
                    _ => {
                        return Err(format!(
                            "{name}: expected [x, y] (two numbers), got {value}"
                        ));
                    }
                },
                Value::Number(n)
                    if !WORDS.contains(&name.as_str()) && !PAIRS.contains(&name.as_str()) =>
                {
                    whole_number_text(n).unwrap_or_else(|| n.to_string())
                }
                // The command line's own text is welcome too ("4", "inf" — JSON has no
                // infinity — or "1.5,-2" for a pair): the option parser checks it.
                Value::String(s) => s.clone(),
                _ => {
                    let expected = if WORDS.contains(&name.as_str()) {
                        "a string"
                    } else if PAIRS.contains(&name.as_str()) {
                        "[x, y] (two numbers)"
                    } else {
                        "a number"
                    };
                    return Err(format!("{name}: expected {expected}, got {value}"));
                }
            };
            if text.len() > 1024 {
                return Err(format!("{name}: value too long"));
            }
            // A value is never an option of its own (it goes to the parser as the next word).
            if text.starts_with("--") {
                return Err(format!("{name}: {text:?} is not a value"));
            }
            next.set(name, text);
            for (a, b) in EITHER {
                if name == a {
                    next.unset(b);
                } else if name == b {
                    next.unset(a);
                }
            }
        }
        for (a, b) in EITHER {
            if changes.contains_key(a)
                && changes.contains_key(b)
                && !changes[a].is_null()
                && !changes[b].is_null()
            {
                return Err(format!("give {a} or {b}, not both"));
            }
        }
        Ok(next)
    }

    /// The settings as JSON: every live option by name, `null` when not given.
    pub fn to_json(&self) -> Map<String, Value> {
        LIVE_OPTIONS
            .iter()
            .map(|name| {
                let value = match self.values.get(name) {
                    None => Value::Null,
                    Some(text) if WORDS.contains(name) => json!(text),
                    Some(text) if PAIRS.contains(name) => text
                        .split(',')
                        .map(|v| v.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
                        .collect::<Option<Vec<f64>>>()
                        .map_or_else(|| json!(text), |pair| json!(pair)),
                    Some(text) if WHOLE.contains(name) => text
                        .parse::<u64>()
                        .map_or_else(|_| json!(text), |v| json!(v)),
                    Some(text) => text
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .map_or_else(|| json!(text), |v| json!(v)),
                };
                (name.to_string(), value)
            })
            .collect()
    }

    /// `realcam render …` with these settings, quoted for a POSIX shell.
    pub fn command_line(&self, extra: &[String]) -> String {
        std::iter::once("realcam render".to_string())
            .chain(self.arguments().iter().chain(extra).map(|a| shell_quote(a)))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// A JSON number with no fractional part as the command line writes it (`1e9` and
/// `1000000000.0` as `1000000000`), so that a whole-number setting is judged by its range,
/// not refused as "not a whole number".
fn whole_number_text(n: &serde_json::Number) -> Option<String> {
    if n.is_f64() {
        let value = n.as_f64()?;
        (value.fract() == 0.0 && value.abs() < 1e18).then(|| format!("{}", value as i64))
    } else {
        None
    }
}

/// `a` as one word of a POSIX shell command.
fn shell_quote(a: &str) -> String {
    let plain = !a.is_empty()
        && a.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./,:=+@%".contains(c));
    if plain {
        a.to_string()
    } else {
        format!("'{}'", a.replace('\'', "'\\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changes_replace_their_alternatives_and_give_the_command_line() {
        let mut settings = LiveSettings::new(vec![]);
        settings.set("lens", "dgauss.50mm");
        settings.set("focus_distance", "3");
        let next = settings
            .changed(&json!({"film_distance": 40.5, "f_number": 4}))
            .unwrap();
        assert_eq!(next.get("focus_distance"), None);
        assert_eq!(
            next.command_line(&[]),
            "realcam render --f-number 4 --film-distance 40.5 --lens dgauss.50mm"
        );
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
        for bad in [
            json!({"no_such": 1}),
            json!({"lens": 3}),
            json!([1, 2]),
            json!({"f_number": 2, "aperture": 3}),
            json!({"lens": "--out=/tmp/elsewhere.png"}),
            json!({"focus_mode": "--spp"}),
        ] {
            assert!(settings.changed(&bad).is_err(), "{bad} was accepted");
        }
    }

    #[test]
    fn pairs_are_json_arrays_and_blades_take_their_qualifiers_along() {
        let settings = LiveSettings::from_arguments(&[
            "--shift".into(),
            "-2,0.5".into(),
            "--blades".into(),
            "7".into(),
            "--blade-curvature".into(),
            "0.3".into(),
            "--focus-on".into(),
            "3,4".into(),
        ]);
        let state = settings.to_json();
        assert_eq!(state["shift"], json!([-2.0, 0.5]));
        assert_eq!(
            (state["blades"].clone(), state["blade_curvature"].clone()),
            (json!(7), json!(0.3))
        );
        let tilted = settings.changed(&json!({"tilt": [1.5, -3]})).unwrap();
        assert_eq!(tilted.to_json()["tilt"], json!([1.5, -3.0]));
        for bad in [
            json!({"tilt": [1]}),
            json!({"tilt": [1, "a"]}),
            json!({"tilt": 2}),
            json!({"blades": [6, 1]}),
        ] {
            assert!(settings.changed(&bad).is_err(), "{bad} was accepted");
        }
        let round = settings.changed(&json!({"blades": null})).unwrap();
        assert_eq!(
            (round.get("blades"), round.get("blade_curvature")),
            (None, None)
        );
        let mut unfocused = settings.clone();
        unfocused.remove_fixed("focus_on");
        assert!(
            !unfocused
                .arguments()
                .iter()
                .any(|a| a.contains("focus-on") || a == "3,4")
        );
        assert!(settings.arguments().contains(&"--focus-on".to_string()));
    }
}
