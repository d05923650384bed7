//! `realcam glass`: what the built-in glass catalogue knows about a glass, which catalogue
//! glasses sit near an (n_d, V_d), and what the n_d/V_d model gives.

use std::fmt::Write as _;
use std::io::Write as _;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::Args;
use serde_json::{Value, json};

use super::values::{number, whole_within};

use crate::glass::model::{self, BuchdahlModel, CHECK_RANGE_NM, catalogue_deviation};
use crate::glass::partial::NORMAL_LINE_G_F;
use crate::glass::{
    CatalogueGlass, FRAUNHOFER_C_NM, FRAUNHOFER_D_NM, FRAUNHOFER_F_NM, GlassId, GlassStatus, Maker,
    SPECTRAL_LINES, abbe_number, catalogue, looks_numeric,
};

#[derive(Args, Debug, Clone)]
pub struct GlassArgs {
    /// A catalogue glass (N-BK7, nbk7, S-LAH66, MAKER:NAME such as cdgm:F5, or "NAME (MAKER)"),
    /// or N_D,V_D for the dispersion model through those two numbers.
    #[arg(value_name = "GLASS", required_unless_present_any = ["near", "list"])]
    pub glass: Option<String>,
    /// List the catalogue glasses nearest to N_D,V_D on the glass map (or to N_D alone).
    #[arg(
        long,
        value_name = "N_D[,V_D]",
        conflicts_with_all = ["glass", "list"],
        allow_hyphen_values = true
    )]
    pub near: Option<String>,
    /// How many glasses --near lists [default: 10].
    #[arg(long, value_name = "K", allow_hyphen_values = true, value_parser = whole_within::<u32>(1, 10_000))]
    pub count: Option<u32>,
    /// List every catalogue glass.
    #[arg(long, conflicts_with = "glass")]
    pub list: bool,
    /// With --near or --list: only this maker's glasses (Schott, Ohara, Hoya, Hikari, CDGM,
    /// Sumita).
    #[arg(long, value_name = "MAKER")]
    pub maker: Option<String>,
    /// Also give n at these wavelengths, nm (repeat the option or separate with commas).
    #[arg(
        long = "wavelength",
        value_name = "NM",
        value_delimiter = ',',
        allow_hyphen_values = true,
        value_parser = number::<f64>
    )]
    pub wavelengths: Vec<f64>,
    /// Print one JSON value instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &GlassArgs) -> anyhow::Result<ExitCode> {
    let maker = args
        .maker
        .as_deref()
        .map(|m| {
            Maker::parse(m).with_context(|| {
                format!(
                    "--maker '{m}' is not in the catalogue; its makers are {}",
                    Maker::priority_list()
                )
            })
        })
        .transpose()?;
    if maker.is_some() && args.near.is_none() && !args.list {
        bail!("--maker applies to --near and --list; to pick one maker's glass write MAKER:NAME");
    }
    if let Some(nm) = args
        .wavelengths
        .iter()
        .find(|nm| !(nm.is_finite() && **nm > 0.0))
    {
        bail!("--wavelength {nm} is not a positive number of nanometres");
    }
    if args.count.is_some() && args.near.is_none() {
        bail!("--count applies to --near");
    }
    if !args.wavelengths.is_empty() && (args.near.is_some() || args.list) {
        bail!("--wavelength applies to one glass (GLASS), not to --near or --list");
    }
    let out = if let Some(near) = &args.near {
        let (n_d, v_d) = parse_numbers(near, "--near")?;
        let listed = nearest(n_d, v_d, maker, args.count.unwrap_or(10) as usize);
        if args.json {
            near_json(n_d, v_d, &listed).to_string()
        } else {
            near_text(n_d, v_d, maker, &listed)
        }
    } else if args.list {
        let glasses: Vec<&CatalogueGlass> = catalogue()
            .glasses()
            .iter()
            .filter(|g| maker.is_none_or(|m| g.maker == m))
            .collect();
        if args.json {
            Value::Array(glasses.iter().map(|g| summary_json(g, None)).collect()).to_string()
        } else {
            list_text(&glasses)
        }
    } else {
        let text = args.glass.as_deref().unwrap_or_default();
        if looks_numeric(text) {
            let (n_d, v_d) = parse_numbers(text, "GLASS")?;
            let Some(v_d) = v_d else {
                bail!(
                    "'{text}': a model glass needs n_d and V_d as N_D,V_D (e.g. 1.62,36.4); \
                     for the glasses nearest to an index use --near {text}"
                );
            };
            model_report(n_d, v_d, &args.wavelengths, args.json)?
        } else {
            glass_report(text, &args.wavelengths, args.json)?
        }
    };
    // `realcam glass --list | head` closes the pipe early: that is not an error.
    let mut stdout = std::io::stdout().lock();
    match writeln!(stdout, "{}", out.trim_end()).and_then(|()| stdout.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(e).context("cannot write to standard output")
        }
        _ => Ok(ExitCode::SUCCESS),
    }
}

/// "N_D" or "N_D,V_D", checked to be a glass's values.
fn parse_numbers(text: &str, what: &str) -> anyhow::Result<(f64, Option<f64>)> {
    let fields: Vec<&str> = text.split(',').map(str::trim).collect();
    let number = |s: &str| -> anyhow::Result<f64> {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .with_context(|| format!("{what} '{text}': '{s}' is not a number"))
    };
    let (n_d, v_d) = match fields[..] {
        [n] => (number(n)?, None),
        [n, v] => (number(n)?, Some(number(v)?)),
        _ => bail!("{what} '{text}' is not N_D or N_D,V_D"),
    };
    model::check_model_values(n_d, v_d.unwrap_or(1.0))
        .with_context(|| format!("{what} '{text}'"))?;
    Ok((n_d, v_d))
}

fn nearest(n_d: f64, v_d: Option<f64>, maker: Option<Maker>, count: usize) -> Vec<(GlassId, f64)> {
    let c = catalogue();
    // Rank the whole catalogue when one maker is asked for, then keep its glasses.
    let pool = if maker.is_some() { c.len() } else { count };
    let ranked = match v_d {
        Some(v_d) => c.nearest(n_d, v_d, pool),
        None => c.nearest_n_d(n_d, pool),
    };
    ranked
        .into_iter()
        .filter(|(id, _)| maker.is_none_or(|m| c.get(*id).maker == m))
        .take(count)
        .collect()
}

fn near_text(
    n_d: f64,
    v_d: Option<f64>,
    maker: Option<Maker>,
    listed: &[(GlassId, f64)],
) -> String {
    let target = match v_d {
        Some(v_d) => format!("n_d {n_d}, V_d {v_d}"),
        None => format!("n_d {n_d}"),
    };
    let whose = maker.map_or(String::new(), |m| format!("{m} "));
    let mut out = format!(
        "{whose}catalogue glasses nearest to {target}\n\
         (distance in glass-code units: 0.001 in n_d or 0.1 in V_d counts 1{})\n\n\
         {:>9}  {:<24} {:>9} {:>10}  {}\n",
        if v_d.is_none() { "; V_d ignored" } else { "" },
        "distance",
        "glass",
        "n_d",
        "V_d",
        "glass code"
    );
    for (id, distance) in listed {
        let g = catalogue().get(*id);
        writeln!(
            out,
            "{distance:>9.2}  {:<24} {:>9.5} {:>10.2}  {}",
            g.label(),
            g.n_d,
            g.v_d,
            g.glass_code.unwrap_or("—")
        )
        .unwrap();
    }
    out
}

fn near_json(n_d: f64, v_d: Option<f64>, listed: &[(GlassId, f64)]) -> Value {
    json!({
        "n_d": n_d,
        "v_d": v_d,
        "glasses": listed.iter().map(|(id, d)| summary_json(catalogue().get(*id), Some(*d))).collect::<Vec<_>>(),
    })
}

fn summary_json(g: &CatalogueGlass, distance: Option<f64>) -> Value {
    let mut v = json!({
        "name": g.name,
        "maker": g.maker.name(),
        "label": g.label(),
        "n_d": g.n_d,
        "v_d": g.v_d,
        "glass_code": g.glass_code,
        "status": (g.status != GlassStatus::Unlisted).then(|| g.status.name()),
    });
    if let Some(d) = distance {
        v["distance"] = json!(d);
    }
    v
}

fn list_text(glasses: &[&CatalogueGlass]) -> String {
    let mut out = format!(
        "{:<16} {:<7} {:>9} {:>10}  {:<11} {}\n",
        "glass", "maker", "n_d", "V_d", "glass code", "status"
    );
    for g in glasses {
        writeln!(
            out,
            "{:<16} {:<7} {:>9.5} {:>10.2}  {:<11} {}",
            g.name,
            g.maker.name(),
            g.n_d,
            g.v_d,
            g.glass_code.unwrap_or("—"),
            g.status.name()
        )
        .unwrap();
    }
    write!(out, "{} glasses", glasses.len()).unwrap();
    out
}

/// n at the extra wavelengths: (nm, n, whether inside the valid range).
fn extra_wavelengths(
    wavelengths: &[f64],
    index: impl Fn(f64) -> f64,
    covers: impl Fn(f64) -> bool,
    what: &str,
) -> anyhow::Result<Vec<(f64, f64, bool)>> {
    wavelengths
        .iter()
        .map(|&nm| {
            let n = index(nm);
            if !(n.is_finite() && n >= 1.0) {
                bail!(
                    "{what} gives no physical refractive index at {nm} nm (n = {n:.4}): the \
                     wavelength is far outside the formula's valid range"
                );
            }
            Ok((nm, n, covers(nm)))
        })
        .collect()
}

fn glass_report(name: &str, wavelengths: &[f64], json: bool) -> anyhow::Result<String> {
    let c = catalogue();
    let all = c.find_all(name)?;
    let g = c.get(all[0]);
    let others: Vec<&CatalogueGlass> = all[1..].iter().map(|id| c.get(*id)).collect();
    let extra = extra_wavelengths(wavelengths, |nm| g.index(nm), |nm| g.covers(nm), &g.label())?;
    let range = g.valid_range_nm();
    let (n_d_formula, v_d_formula) = (g.formula_n_d(), g.formula_v_d());
    let model_off = catalogue_deviation(g);
    if json {
        let mut v = summary_json(g, None);
        v["formula"] = json!({
            "kind": g.formula.kind(),
            "refractiveindex_info_formula": g.formula.refractiveindex_info_number(),
            "coefficients": g.formula.coefficients(),
            "wavelength_unit": "um",
        });
        v["valid_range_nm"] = json!([range.start(), range.end()]);
        v["index"] = lines_json(|nm| g.index(nm));
        v["wavelengths"] = extra_json(&extra);
        v["n_d_v_d_published"] = json!(g.published_n_d_v_d);
        v["n_d_formula"] = json!(n_d_formula);
        v["v_d_formula"] = json!(v_d_formula);
        v["p_g_f"] = json!(g.p_g_f());
        v["delta_p_g_f"] = json!(g.delta_p_g_f());
        v["model_deviation_400_700_nm"] = json!(model_off);
        v["source"] = json!(g.source);
        v["also_at"] = Value::Array(others.iter().map(|o| summary_json(o, None)).collect());
        return Ok(v.to_string());
    }
    let mut out = format!("{}\n", g.label());
    writeln!(
        out,
        "  formula   {} (refractiveindex.info formula {}), valid {}–{} nm, λ in µm:\n            {}",
        g.formula.kind(),
        g.formula.refractiveindex_info_number(),
        range.start(),
        range.end(),
        g.formula
    )
    .unwrap();
    out += &lines_text(|nm| g.index(nm), &extra, &|nm| g.covers(nm));
    let published = if g.published_n_d_v_d {
        "catalogue"
    } else {
        "not published; from the formula"
    };
    writeln!(
        out,
        "  n_d {:.5}, V_d {:.2} ({published}); the formula gives n_d {n_d_formula:.6}, V_d {v_d_formula:.3}",
        g.n_d, g.v_d
    )
    .unwrap();
    writeln!(
        out,
        "  P_g,F {:.4}, ΔP_g,F {:+.4} (from Schott's normal line P_g,F = {} − {}·V_d)",
        g.p_g_f(),
        g.delta_p_g_f(),
        NORMAL_LINE_G_F.0,
        -NORMAL_LINE_G_F.1
    )
    .unwrap();
    let part = if g.covers(CHECK_RANGE_NM.0) && g.covers(CHECK_RANGE_NM.1) {
        ""
    } else {
        " (where the formula is valid)"
    };
    writeln!(
        out,
        "  the n_d/V_d model alone would be within {model_off:.1e} of this formula over {}–{} nm{part}",
        CHECK_RANGE_NM.0, CHECK_RANGE_NM.1
    )
    .unwrap();
    writeln!(
        out,
        "  glass code {}, status {}\n  source: refractiveindex.info {} (CC0)",
        g.glass_code.unwrap_or("—"),
        g.status.name(),
        g.source
    )
    .unwrap();
    if !others.is_empty() {
        let listed: Vec<String> = others
            .iter()
            .map(|o| format!("{} (n_d {:.5}, V_d {:.2})", o.maker, o.n_d, o.v_d))
            .collect();
        writeln!(
            out,
            "  {} is also in the catalogue of {}: a name several makers use resolves by the \
             maker priority {}; name one as MAKER:NAME (e.g. {}:{})",
            g.name,
            listed.join(", "),
            Maker::priority_list(),
            others[0].maker.name().to_uppercase(),
            g.name
        )
        .unwrap();
    }
    Ok(out)
}

fn model_report(n_d: f64, v_d: f64, wavelengths: &[f64], json: bool) -> anyhow::Result<String> {
    let m = BuchdahlModel::new(n_d, v_d);
    let extra = extra_wavelengths(
        wavelengths,
        |nm| m.index(nm),
        |nm| (CHECK_RANGE_NM.0..=CHECK_RANGE_NM.1).contains(&nm),
        "the model",
    )?;
    let near = catalogue().nearest(n_d, v_d, 3);
    let warning = model::domain_warning(n_d, v_d);
    if json {
        return Ok(json!({
            "model": "buchdahl",
            "label": format!("n_d {n_d}, V_d {v_d}"),
            "n_d": n_d,
            "v_d": v_d,
            "nu": m.nu,
            "index": lines_json(|nm| m.index(nm)),
            "wavelengths": extra_json(&extra),
            "fitted_range_nm": [CHECK_RANGE_NM.0, CHECK_RANGE_NM.1],
            "nearest": near.iter().map(|(id, d)| summary_json(catalogue().get(*id), Some(*d))).collect::<Vec<_>>(),
            "warning": warning,
        })
        .to_string());
    }
    let mut out = format!(
        "model glass n_d {n_d}, V_d {v_d}: three-term Buchdahl dispersion fitted to the catalogue\n\
         (exact n_d and n_F − n_C; typically within 1e-4 of a real glass over {}–{} nm, more for\n\
         anomalous-dispersion glasses)\n",
        CHECK_RANGE_NM.0, CHECK_RANGE_NM.1
    );
    out += &lines_text(|nm| m.index(nm), &extra, &|nm| {
        (CHECK_RANGE_NM.0..=CHECK_RANGE_NM.1).contains(&nm)
    });
    let v_check = abbe_number(
        m.index(FRAUNHOFER_D_NM),
        m.index(FRAUNHOFER_F_NM),
        m.index(FRAUNHOFER_C_NM),
    );
    writeln!(
        out,
        "  V_d from these indices {v_check:.4}; Buchdahl ν₁ {:.6}, ν₂ {:.6}, ν₃ {:.6}",
        m.nu[0], m.nu[1], m.nu[2]
    )
    .unwrap();
    let nearest: Vec<String> = near
        .iter()
        .map(|(id, d)| format!("{} at {d:.2}", catalogue().get(*id).label()))
        .collect();
    writeln!(
        out,
        "  nearest catalogue glasses (glass-code units): {}",
        nearest.join(", ")
    )
    .unwrap();
    if let Some(w) = warning {
        eprintln!("warning: {w}");
    }
    Ok(out)
}

fn lines_json(index: impl Fn(f64) -> f64) -> Value {
    SPECTRAL_LINES
        .iter()
        .map(|&(line, nm)| {
            (
                line.to_string(),
                json!({"wavelength_nm": nm, "n": index(nm)}),
            )
        })
        .collect::<serde_json::Map<_, _>>()
        .into()
}

fn extra_json(extra: &[(f64, f64, bool)]) -> Value {
    extra
        .iter()
        .map(|&(nm, n, inside)| json!({"wavelength_nm": nm, "n": n, "in_valid_range": inside}))
        .collect()
}

fn lines_text(
    index: impl Fn(f64) -> f64,
    extra: &[(f64, f64, bool)],
    covers: &dyn Fn(f64) -> bool,
) -> String {
    let mut out = String::from("  line    λ (nm)   n\n");
    for &(line, nm) in &SPECTRAL_LINES {
        let note = if covers(nm) {
            ""
        } else {
            "  (outside the valid range)"
        };
        writeln!(out, "  {line:<4} {nm:>9.4}   {:.6}{note}", index(nm)).unwrap();
    }
    for &(nm, n, inside) in extra {
        let note = if inside {
            ""
        } else {
            "  (outside the valid range: extrapolated)"
        };
        writeln!(out, "  {:<4} {nm:>9.4}   {n:.6}{note}", "").unwrap();
    }
    out
}
