//! The built-in glass catalogue: `assets/glass/glass-catalog-all.csv` (CC0, from the
//! refractiveindex.info database), compiled into the binary and parsed once, on first use.

use std::collections::HashMap;
use std::fmt;
use std::ops::RangeInclusive;
use std::sync::OnceLock;

use super::formula::DispersionFormula;
use super::lookup::normalized_name;
use super::{FRAUNHOFER_C_NM, FRAUNHOFER_D_NM, FRAUNHOFER_F_NM, GlassId, abbe_number};

const CATALOGUE_CSV: &str = include_str!("../../assets/glass/glass-catalog-all.csv");

/// The column header the parser expects (the file's first line).
const HEADER: &str = "glass,catalog,formula,coefficients,wl_range_um,n_d,V_d,n_d_calc,V_d_calc,status,glass_code,source_path";

/// A glass maker in the catalogue.
///
/// The declaration order is the **default maker priority** that resolves a name several
/// makers use (28 names do, e.g. F5 at Schott, Hikari and CDGM): Schott, Ohara, Hoya, Hikari,
/// CDGM, Sumita. Schott first because the shared names are Schott's classic names (F2, SF5,
/// BAF10, LAF2…) and Schott's glass is what they mean in older prescriptions; Hikari and Hoya
/// use them for equivalents of Schott's glass, while CDGM's F1–F5 and BAF4 are different glasses
/// under the same names (CDGM F5: n_d 1.62435; Schott and Hikari F5: 1.60342), so CDGM comes
/// after them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Maker {
    Schott,
    Ohara,
    Hoya,
    Hikari,
    Cdgm,
    Sumita,
}

impl Maker {
    /// Every maker, in the default priority order.
    pub const ALL: [Maker; 6] = [
        Maker::Schott,
        Maker::Ohara,
        Maker::Hoya,
        Maker::Hikari,
        Maker::Cdgm,
        Maker::Sumita,
    ];

    /// "Schott", "Ohara", "Hoya", "Hikari", "CDGM", "Sumita".
    pub fn name(self) -> &'static str {
        match self {
            Maker::Schott => "Schott",
            Maker::Ohara => "Ohara",
            Maker::Hoya => "Hoya",
            Maker::Hikari => "Hikari",
            Maker::Cdgm => "CDGM",
            Maker::Sumita => "Sumita",
        }
    }

    /// A maker's name in any case ("SCHOTT", "schott", "Cdgm"), as Zemax's GCAT lines and
    /// the catalogue spell them.
    pub fn parse(text: &str) -> Option<Maker> {
        let text = text.trim();
        Maker::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(text))
    }

    /// The makers' names joined for messages: "Schott, Ohara, Hoya, Hikari, CDGM, Sumita".
    pub fn priority_list() -> String {
        Maker::ALL.map(Maker::name).join(", ")
    }
}

impl fmt::Display for Maker {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The maker's availability class, where the source gives one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlassStatus {
    Preferred,
    Standard,
    Special,
    /// The source gives no status (760 entries, including all of CDGM's and Sumita's).
    Unlisted,
}

impl GlassStatus {
    pub fn name(self) -> &'static str {
        match self {
            GlassStatus::Preferred => "preferred",
            GlassStatus::Standard => "standard",
            GlassStatus::Special => "special",
            GlassStatus::Unlisted => "not listed",
        }
    }
}

/// One glass of the catalogue.
#[derive(Clone, Debug, PartialEq)]
pub struct CatalogueGlass {
    /// The maker's name, as the catalogue spells it (e.g. "N-BK7", "K-CaFK95(M)").
    pub name: &'static str,
    pub maker: Maker,
    pub formula: DispersionFormula,
    /// Where the formula is valid, µm (the maker's fit range).
    pub valid_range_um: (f64, f64),
    /// n_d as published; for Schott LF7, the one entry without one, its formula's.
    pub n_d: f64,
    /// V_d as published; for Schott LF7, its formula's.
    pub v_d: f64,
    /// Whether `n_d` and `v_d` are the catalogue's published values (false only for LF7).
    pub published_n_d_v_d: bool,
    pub status: GlassStatus,
    /// The glass code (6 digits n_d·V_d; Schott appends the density), where given.
    pub glass_code: Option<&'static str>,
    /// The refractiveindex.info database file the entry came from.
    pub source: &'static str,
}

impl CatalogueGlass {
    /// Refractive index at `wavelength_nm` (air, nm) from the maker's formula; extrapolated
    /// outside [`valid_range_nm`](Self::valid_range_nm).
    pub fn index(&self, wavelength_nm: f64) -> f64 {
        self.formula.index_um(wavelength_nm * 1e-3)
    }

    /// Where the formula is valid, nm.
    pub fn valid_range_nm(&self) -> RangeInclusive<f64> {
        self.valid_range_um.0 * 1e3..=self.valid_range_um.1 * 1e3
    }

    /// Whether the formula is valid at `wavelength_nm`.
    pub fn covers(&self, wavelength_nm: f64) -> bool {
        // The ranges are given to 4–6 digits in µm; allow their rounding.
        let (lo, hi) = self.valid_range_um;
        let um = wavelength_nm * 1e-3;
        um >= lo - 5e-7 && um <= hi + 5e-7
    }

    /// n_d evaluated from the formula (the published `n_d` agrees within 3.8e-5).
    pub fn formula_n_d(&self) -> f64 {
        self.index(FRAUNHOFER_D_NM)
    }

    /// V_d evaluated from the formula at the F, d and C lines.
    pub fn formula_v_d(&self) -> f64 {
        abbe_number(
            self.index(FRAUNHOFER_D_NM),
            self.index(FRAUNHOFER_F_NM),
            self.index(FRAUNHOFER_C_NM),
        )
    }

    /// "N-BK7 (Schott)".
    pub fn label(&self) -> String {
        format!("{} ({})", self.name, self.maker.name())
    }
}

/// The parsed catalogue: every glass, and an index from normalised names to entries.
#[derive(Debug)]
pub struct Catalogue {
    glasses: Vec<CatalogueGlass>,
    /// Normalised name (see [`normalized_name`]) → entries with that name, in the default
    /// maker priority.
    by_name: HashMap<String, Vec<GlassId>>,
}

/// The built-in catalogue, parsed on first use (about a millisecond) and shared thereafter.
pub fn catalogue() -> &'static Catalogue {
    static CATALOGUE: OnceLock<Catalogue> = OnceLock::new();
    CATALOGUE.get_or_init(|| {
        Catalogue::parse(CATALOGUE_CSV)
            .unwrap_or_else(|e| panic!("the built-in glass catalogue is malformed: {e}"))
    })
}

impl Catalogue {
    /// Parses the catalogue CSV (the format of `assets/glass/glass-catalog-all.csv`).
    pub fn parse(csv: &'static str) -> Result<Catalogue, String> {
        let mut lines = csv.lines().enumerate();
        match lines.next() {
            Some((_, header)) if header.trim_end() == HEADER => {}
            _ => return Err(format!("line 1: expected the header `{HEADER}`")),
        }
        let mut glasses = Vec::new();
        for (i, line) in lines {
            if line.trim().is_empty() {
                continue;
            }
            let glass = parse_row(line).map_err(|e| format!("line {}: {e}", i + 1))?;
            glasses.push(glass);
        }
        if glasses.len() > usize::from(u16::MAX) {
            return Err(format!("{} glasses do not fit a GlassId", glasses.len()));
        }
        let mut by_name: HashMap<String, Vec<GlassId>> = HashMap::new();
        for (i, glass) in glasses.iter().enumerate() {
            by_name
                .entry(normalized_name(glass.name))
                .or_default()
                .push(GlassId(i as u16));
        }
        for ids in by_name.values_mut() {
            ids.sort_by_key(|id| glasses[id.index()].maker);
            // One key, one name: makers may share a name, but two names that differ only in
            // punctuation would make a tolerant look-up pick between different glasses.
            for pair in ids.windows(2) {
                let (a, b) = (&glasses[pair[0].index()], &glasses[pair[1].index()]);
                if a.maker == b.maker || !a.name.eq_ignore_ascii_case(b.name) {
                    return Err(format!(
                        "'{}' ({}) and '{}' ({}) differ only in case or punctuation",
                        a.name,
                        a.maker.name(),
                        b.name,
                        b.maker.name()
                    ));
                }
            }
        }
        Ok(Catalogue { glasses, by_name })
    }

    /// Every glass, in file order (sorted by maker file, then name).
    pub fn glasses(&self) -> &[CatalogueGlass] {
        &self.glasses
    }

    /// Every glass with its id.
    pub fn iter(&self) -> impl Iterator<Item = (GlassId, &CatalogueGlass)> {
        self.glasses
            .iter()
            .enumerate()
            .map(|(i, g)| (GlassId(i as u16), g))
    }

    pub fn len(&self) -> usize {
        self.glasses.len()
    }

    pub fn is_empty(&self) -> bool {
        self.glasses.is_empty()
    }

    /// The entry for `id`.
    pub fn get(&self, id: GlassId) -> &CatalogueGlass {
        &self.glasses[id.index()]
    }

    /// Entries whose normalised name is `key`, in default maker priority.
    pub(crate) fn entries_named(&self, key: &str) -> &[GlassId] {
        self.by_name.get(key).map_or(&[], Vec::as_slice)
    }

    /// Every distinct normalised name with its entries.
    pub(crate) fn names(&self) -> impl Iterator<Item = (&str, &[GlassId])> {
        self.by_name.iter().map(|(k, v)| (k.as_str(), v.as_slice()))
    }
}

fn parse_row(line: &'static str) -> Result<CatalogueGlass, String> {
    let fields: Vec<&'static str> = line.trim_end_matches('\r').split(',').collect();
    let [
        name,
        maker,
        formula,
        coefficients,
        range,
        n_d,
        v_d,
        _n_d_calc,
        _v_d_calc,
        status,
        glass_code,
        source,
    ] = fields[..]
    else {
        return Err(format!("expected 12 fields, found {}", fields.len()));
    };
    if name.is_empty() {
        return Err("empty glass name".into());
    }
    let maker = Maker::parse(maker).ok_or_else(|| format!("{name}: unknown maker '{maker}'"))?;
    let formula_number: u32 = formula
        .parse()
        .map_err(|_| format!("{name}: formula '{formula}' is not a number"))?;
    let coefficients = numbers(coefficients).map_err(|e| format!("{name}: coefficients: {e}"))?;
    let formula = DispersionFormula::from_refractiveindex_info(formula_number, &coefficients)
        .map_err(|e| format!("{name}: {e}"))?;
    let valid_range_um = match numbers(range).map_err(|e| format!("{name}: range: {e}"))?[..] {
        [lo, hi] if 0.0 < lo && lo < hi => (lo, hi),
        _ => {
            return Err(format!(
                "{name}: wavelength range '{range}' is not `min max`"
            ));
        }
    };
    let optional = |text: &str, what: &str| -> Result<Option<f64>, String> {
        if text.is_empty() {
            Ok(None)
        } else {
            text.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Some)
                .ok_or_else(|| format!("{name}: {what} '{text}' is not a number"))
        }
    };
    let status = match status {
        "preferred" => GlassStatus::Preferred,
        "standard" => GlassStatus::Standard,
        "special" => GlassStatus::Special,
        "" => GlassStatus::Unlisted,
        other => return Err(format!("{name}: unknown status '{other}'")),
    };
    let mut glass = CatalogueGlass {
        name,
        maker,
        formula,
        valid_range_um,
        n_d: f64::NAN,
        v_d: f64::NAN,
        published_n_d_v_d: false,
        status,
        glass_code: Some(glass_code).filter(|c| !c.is_empty()),
        source,
    };
    match (optional(n_d, "n_d")?, optional(v_d, "V_d")?) {
        (Some(n_d), Some(v_d)) => {
            glass.n_d = n_d;
            glass.v_d = v_d;
            glass.published_n_d_v_d = true;
        }
        (None, None) => {
            glass.n_d = glass.formula_n_d();
            glass.v_d = glass.formula_v_d();
        }
        _ => return Err(format!("{name}: n_d and V_d must be given together")),
    }
    if !(glass.n_d > 1.0 && glass.v_d > 0.0) {
        return Err(format!(
            "{name}: n_d {} and V_d {} are not a glass's",
            glass.n_d, glass.v_d
        ));
    }
    Ok(glass)
}

fn numbers(text: &str) -> Result<Vec<f64>, String> {
    text.split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("'{t}' is not a number"))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn malformed_rows_name_the_line_and_the_problem() {
        let header = format!("{HEADER}\n");
        let good = "N-BK7,SCHOTT,2,0 1.03961212 0.00600069867 0.231792344 0.0200179144 1.01046945 103.560653,0.3 2.5,1.5168,64.17,1.5168,64.167,standard,517642.251,database/data/specs/schott/optical/N-BK7.yml";
        let leak = |s: String| -> &'static str { Box::leak(s.into_boxed_str()) };
        assert_eq!(
            Catalogue::parse(leak(format!("{header}{good}\n")))
                .unwrap()
                .len(),
            1
        );
        for (bad, expected) in [
            (good.replace("SCHOTT", "ACME"), "unknown maker 'ACME'"),
            (good.replace(",2,0 ", ",7,0 "), "formula 7 is not supported"),
            (good.replace("0.3 2.5", "0.3"), "is not `min max`"),
            (good.replace("1.5168,64.17,", "1.5168,,"), "given together"),
            (
                good.replace("1.5168,64.17,", "x,64.17,"),
                "n_d 'x' is not a number",
            ),
            (good.replace(",standard,", ",rare,"), "unknown status"),
            (good.replace(",0.3 2.5,", ","), "expected 12 fields"),
        ] {
            let err = Catalogue::parse(leak(format!("{header}{bad}\n"))).unwrap_err();
            assert!(err.starts_with("line 2: "), "{err}");
            assert!(err.contains(expected), "{err}");
        }
        let twice = leak(format!(
            "{header}{good}\n{}\n",
            good.replace("N-BK7,", "NBK7,")
        ));
        assert!(
            Catalogue::parse(twice)
                .unwrap_err()
                .contains("differ only in case or punctuation")
        );
        let across_makers = leak(format!(
            "{header}{good}\n{}\n",
            good.replace("N-BK7,SCHOTT", "NBK7,HOYA")
        ));
        assert!(Catalogue::parse(across_makers).is_err());
        let same_name = leak(format!(
            "{header}{good}\n{}\n",
            good.replace("SCHOTT", "HOYA")
        ));
        assert_eq!(Catalogue::parse(same_name).unwrap().len(), 2);
        assert!(Catalogue::parse("glass,maker\n").is_err());
    }

    #[test]
    fn makers_parse_in_any_case_and_keep_the_priority_order() {
        assert_eq!(Maker::parse("SCHOTT"), Some(Maker::Schott));
        assert_eq!(Maker::parse("cdgm"), Some(Maker::Cdgm));
        assert_eq!(Maker::parse(" Hikari "), Some(Maker::Hikari));
        assert_eq!(Maker::parse("MISC"), None);
        assert_eq!(
            Maker::priority_list(),
            "Schott, Ohara, Hoya, Hikari, CDGM, Sumita"
        );
    }
}
