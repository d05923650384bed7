//! Finding catalogue glasses: by name (tolerant of the makers' spellings) and by position on
//! the glass map (n_d, V_d).
//!
//! # Names
//!
//! A name matches when it equals a catalogue name after [`normalized_name`]: case, hyphens,
//! spaces, underscores, dots and brackets are ignored, so `N-BK7`, `NBK7`, `n-bk7` and `n_bk7`
//! are one glass, as are `S-LAH66` and `SLAH66`, or Sumita's `K-VC89(M)` and `KVC89M`. No two
//! catalogue names collide under this rule (checked when the catalogue is parsed).
//!
//! A maker can be named explicitly, as `MAKER:NAME` (`hoya:BAF10`, Zemax-style) or as
//! `NAME (MAKER)` (what [`Glass::label`](super::Glass::label) prints). Otherwise a name that
//! several makers use resolves by the **default maker priority** Schott, Ohara, Hoya, Hikari,
//! CDGM, Sumita (see [`Maker`] for why), or by the caller's order with
//! [`Catalogue::find_preferring`] (a Zemax file's GCAT line).
//!
//! Names are never rewritten beyond that: an old glass is not swapped for its successor (BK7 is
//! not N-BK7), and moulding suffixes (Zemax's `_MOLD` style) are not mapped onto annealed
//! glass, because moulding lowers the index (Sumita's `(M)` entries sit 0.0011–0.0078 below
//! their annealed glass); an unknown name's error lists the nearest spellings instead.
//!
//! # The glass map
//!
//! [`Catalogue::nearest`] ranks glasses by distance on the (n_d, V_d) map in **glass-code
//! units**: d = √((1000·Δn_d)² + (10·ΔV_d)²), so one unit is one step in the last digit of
//! either half of the six-digit glass code (517642: n_d 1.517, V_d 64.2). The two steps weigh
//! about the same optically: Δn_d = 0.001 changes a lens's power by 0.001/(n_d − 1) ≈ 0.17 %,
//! ΔV_d = 0.1 its chromatic power by 0.1/V_d ≈ 0.2 % (at n_d 1.6, V_d 50).

use std::fmt;

use super::GlassId;
use super::catalogue::{Catalogue, Maker};

/// How many spelling suggestions an unknown name's error lists.
const SUGGESTIONS: usize = 5;

/// A name reduced to what tells glasses apart: ASCII letters (upper-cased) and digits.
pub fn normalized_name(name: &str) -> String {
    name.chars()
        .filter(char::is_ascii_alphanumeric)
        .map(|c| c.to_ascii_uppercase())
        .collect()
}

/// Distance on the glass map in glass-code units (see the module docs).
pub fn glass_map_distance(n_d: f64, v_d: f64, other_n_d: f64, other_v_d: f64) -> f64 {
    (1000.0 * (n_d - other_n_d)).hypot(10.0 * (v_d - other_v_d))
}

/// Why a glass name did not resolve.
#[derive(Clone, Debug, PartialEq)]
pub enum GlassLookupError {
    /// The name is empty (or only a maker).
    Empty { query: String },
    /// `MAKER:NAME` or `NAME (MAKER)` with a maker the catalogue does not have.
    UnknownMaker { query: String, maker: String },
    /// No catalogue glass has this name; `suggestions` are the nearest names by spelling.
    Unknown {
        name: String,
        suggestions: Vec<String>,
        /// Why a likely intended glass was not taken (e.g. a moulding suffix).
        note: Option<String>,
    },
    /// The name exists, but not at the maker asked for; `makers` have it.
    NotAtMaker {
        name: String,
        maker: Maker,
        makers: Vec<Maker>,
    },
}

impl fmt::Display for GlassLookupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GlassLookupError::Empty { query } => write!(f, "no glass name in '{query}'"),
            GlassLookupError::UnknownMaker { query, maker } => write!(
                f,
                "unknown glass maker '{maker}' in '{query}'; the catalogue's makers are {}",
                Maker::priority_list()
            ),
            GlassLookupError::Unknown {
                name,
                suggestions,
                note,
            } => {
                write!(
                    f,
                    "unknown glass '{name}'; nearest catalogue names: {}",
                    suggestions.join(", ")
                )?;
                if let Some(note) = note {
                    write!(f, " ({note})")?;
                }
                Ok(())
            }
            GlassLookupError::NotAtMaker {
                name,
                maker,
                makers,
            } => write!(
                f,
                "{maker}'s catalogue has no glass '{name}'; {} {} it",
                makers
                    .iter()
                    .map(|m| m.name())
                    .collect::<Vec<_>>()
                    .join(", "),
                if makers.len() == 1 { "has" } else { "have" }
            ),
        }
    }
}

impl std::error::Error for GlassLookupError {}

/// A name as asked for: the glass name and an explicit maker, if one was given.
struct Query<'a> {
    name: &'a str,
    maker: Option<Maker>,
}

fn parse_query(text: &str) -> Result<Query<'_>, GlassLookupError> {
    let text = text.trim();
    let query = if let Some((maker, name)) = text.split_once(':') {
        let Some(parsed) = Maker::parse(maker) else {
            return Err(GlassLookupError::UnknownMaker {
                query: text.into(),
                maker: maker.trim().into(),
            });
        };
        Query {
            name: name.trim(),
            maker: Some(parsed),
        }
    } else if let Some((name, maker)) = text
        .strip_suffix(')')
        .and_then(|t| t.rsplit_once(" ("))
        .and_then(|(name, maker)| Maker::parse(maker).map(|m| (name, m)))
    {
        // "N-BK7 (Schott)"; "K-VC89(M)" has no maker in its brackets and stays a name.
        Query {
            name: name.trim(),
            maker: Some(maker),
        }
    } else {
        Query {
            name: text,
            maker: None,
        }
    };
    if normalized_name(query.name).is_empty() {
        return Err(GlassLookupError::Empty { query: text.into() });
    }
    Ok(query)
}

impl Catalogue {
    /// The glass called `name` (see the module docs for the spellings accepted); a name
    /// several makers use resolves by the default maker priority.
    pub fn find(&self, name: &str) -> Result<GlassId, GlassLookupError> {
        self.find_preferring(name, &[])
    }

    /// As [`find`](Self::find), but a name several makers use resolves to the first of
    /// `makers` that has it (then the default priority): a Zemax file's `GCAT SCHOTT OHARA`.
    /// Maker names are case-insensitive; names the catalogue does not have (Zemax's `MISC`,
    /// `INFRARED`, …) are skipped. An explicit `MAKER:NAME` overrides `makers`.
    pub fn find_preferring(
        &self,
        name: &str,
        makers: &[&str],
    ) -> Result<GlassId, GlassLookupError> {
        let query = parse_query(name)?;
        let entries = self.find_all_parsed(&query)?;
        let preferred = makers.iter().filter_map(|m| Maker::parse(m));
        Ok(preferred
            .flat_map(|m| entries.iter().find(|id| self.get(**id).maker == m))
            .next()
            .copied()
            .unwrap_or(entries[0]))
    }

    /// Every entry with this name, in the default maker priority (one entry when the name
    /// gives a maker). The first is what [`find`](Self::find) returns; more than one means the
    /// name alone was ambiguous.
    pub fn find_all(&self, name: &str) -> Result<Vec<GlassId>, GlassLookupError> {
        self.find_all_parsed(&parse_query(name)?)
    }

    fn find_all_parsed(&self, query: &Query) -> Result<Vec<GlassId>, GlassLookupError> {
        let entries = self.entries_named(&normalized_name(query.name));
        if entries.is_empty() {
            return Err(self.unknown(query.name));
        }
        match query.maker {
            None => Ok(entries.to_vec()),
            Some(maker) => match entries.iter().find(|id| self.get(**id).maker == maker) {
                Some(id) => Ok(vec![*id]),
                None => Err(GlassLookupError::NotAtMaker {
                    name: self.get(entries[0]).name.into(),
                    maker,
                    makers: entries.iter().map(|id| self.get(*id).maker).collect(),
                }),
            },
        }
    }

    fn unknown(&self, name: &str) -> GlassLookupError {
        let key = normalized_name(name);
        let mut ranked: Vec<(usize, bool, usize, &str)> = self
            .names()
            .map(|(other, ids)| {
                let contains = other.contains(&key) || key.contains(other);
                (
                    edit_distance(&key, other),
                    !contains,
                    key.len().abs_diff(other.len()),
                    self.get(ids[0]).name,
                )
            })
            .collect();
        ranked.sort_unstable();
        let note = key
            .strip_suffix("MOLD")
            .or_else(|| key.strip_suffix("MOLDED"))
            .map(|base| {
                let base = self
                    .entries_named(base)
                    .first()
                    .map(|id| format!("; the catalogue has {}", self.get(*id).name))
                    .unwrap_or_default();
                format!(
                    "moulded-glass names are not mapped onto annealed glass: moulding lowers the \
                     index, by 0.001–0.008 in Sumita's (M) data{base}"
                )
            });
        GlassLookupError::Unknown {
            name: name.trim().into(),
            suggestions: ranked
                .into_iter()
                .take(SUGGESTIONS)
                .map(|r| r.3.to_string())
                .collect(),
            note,
        }
    }

    /// The `count` glasses nearest to (n_d, V_d) on the glass map, nearest first, with their
    /// distance in glass-code units (see the module docs). Ties keep the maker priority.
    pub fn nearest(&self, n_d: f64, v_d: f64, count: usize) -> Vec<(GlassId, f64)> {
        self.ranked(count, |g| glass_map_distance(n_d, v_d, g.n_d, g.v_d))
    }

    /// The `count` glasses whose n_d is nearest to `n_d`, with |Δn_d| in glass-code units
    /// (1000·|Δn_d|): for prescriptions that give an index but no Abbe number.
    pub fn nearest_n_d(&self, n_d: f64, count: usize) -> Vec<(GlassId, f64)> {
        self.ranked(count, |g| 1000.0 * (g.n_d - n_d).abs())
    }

    fn ranked(
        &self,
        count: usize,
        distance: impl Fn(&super::CatalogueGlass) -> f64,
    ) -> Vec<(GlassId, f64)> {
        let mut all: Vec<(GlassId, f64)> = self.iter().map(|(id, g)| (id, distance(g))).collect();
        all.sort_by(|a, b| {
            a.1.total_cmp(&b.1)
                .then_with(|| self.get(a.0).maker.cmp(&self.get(b.0).maker))
                .then_with(|| self.get(a.0).name.cmp(self.get(b.0).name))
        });
        all.truncate(count);
        all
    }
}

/// Levenshtein distance (insertions, deletions, substitutions) between two ASCII strings.
fn edit_distance(a: &str, b: &str) -> usize {
    let b = b.as_bytes();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.bytes().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distance_counts_single_edits() {
        assert_eq!(edit_distance("NBK7", "NBK7"), 0);
        assert_eq!(edit_distance("BK7", "NBK7"), 1);
        assert_eq!(edit_distance("NBK7", "PBK7"), 1);
        assert_eq!(edit_distance("SF6", "SF66"), 1);
        assert_eq!(edit_distance("", "ABC"), 3);
        assert_eq!(edit_distance("KITTEN", "SITTING"), 3);
    }

    #[test]
    fn normalisation_keeps_letters_and_digits_only() {
        assert_eq!(normalized_name(" n-bk7 "), "NBK7");
        assert_eq!(normalized_name("K-CaFK95(M)"), "KCAFK95M");
        assert_eq!(normalized_name("S_LAH66"), "SLAH66");
    }

    #[test]
    fn glass_map_distance_is_in_glass_code_steps() {
        assert!((glass_map_distance(1.517, 64.2, 1.518, 64.2) - 1.0).abs() < 1e-9);
        assert!((glass_map_distance(1.517, 64.2, 1.517, 64.1) - 1.0).abs() < 1e-9);
        assert!((glass_map_distance(1.517, 64.2, 1.520, 64.6) - 5.0).abs() < 1e-9);
    }
}
