//! Infers catalogue glasses for a lens table that gives only n_d (pbrt's `.dat` lenses), and
//! prints the table with the glass in the fifth column.
//!
//! For each glass element the candidates are the catalogue glasses within ±0.0005 of the
//! table's n_d (the tables give three decimals), from the first maker in realcam's default
//! priority (Schott, Ohara, Hoya, Hikari, CDGM, Sumita) that has any. A positive element gets
//! the candidate with the highest Abbe number and a negative one the lowest: an achromatised
//! design pairs low-dispersion crowns in its converging elements with flints in its diverging
//! ones; among glasses of that Abbe number, the maker's regular glass (standard or preferred
//! status, the plain name over special variants). This is a guess from n_d and the element's sign, not the designer's glass; the lens
//! files and `lenses/README.md` say so.
//!
//! `cargo run --release --example infer_lens_glass -- lenses/wide.22mm.dat`

use realcam::glass::{Glass, catalogue};
use realcam::lens::Prescription;

fn main() -> anyhow::Result<()> {
    let path = std::env::args()
        .nth(1)
        .ok_or_else(|| anyhow::anyhow!("usage: infer_lens_glass LENS.dat"))?;
    let lens = Prescription::load(std::path::Path::new(&path), None)?;
    let rows = &lens.rows;
    for (i, row) in rows.iter().enumerate() {
        if row.base.index <= 1.0 {
            println!(
                "{:>10} {:>8} {:>7} {:>7}",
                row.base.radius, row.base.thickness, row.base.index, row.base.aperture
            );
            continue;
        }
        let next = &rows[i + 1];
        // Thin-lens power of the element between this surface and the next.
        let power = (row.base.index - 1.0) * (row.curvature() - next.curvature());
        let within: Vec<_> = catalogue()
            .iter()
            .filter(|(_, g)| (g.n_d - row.base.index).abs() <= 5e-4)
            .collect();
        let maker = realcam::glass::Maker::ALL
            .into_iter()
            .find(|m| within.iter().any(|(_, g)| g.maker == *m))
            .ok_or_else(|| {
                anyhow::anyhow!("no catalogue glass within 0.0005 of n_d {}", row.base.index)
            })?;
        let candidates: Vec<_> = within
            .into_iter()
            .filter(|(_, g)| g.maker == maker)
            .collect();
        let signed_v = |v: f64| if power > 0.0 { v } else { -v };
        let extreme = candidates
            .iter()
            .map(|(_, g)| signed_v(g.v_d))
            .fold(f64::MIN, f64::max);
        // Among glasses of (nearly) that V_d, the maker's regular glass: its current
        // standard or preferred type, and the plain name over special variants (HT, HTi, ultra).
        let (id, glass) = candidates
            .into_iter()
            .filter(|(_, g)| extreme - signed_v(g.v_d) < 0.05)
            .min_by_key(|(_, g)| {
                let regular = matches!(
                    g.status,
                    realcam::glass::GlassStatus::Standard | realcam::glass::GlassStatus::Preferred
                );
                (!regular, g.name.len())
            })
            .expect("the maker has candidates");
        eprintln!(
            "surface {i}: n {} {} element → {} (n_d {}, V_d {})",
            row.base.index,
            if power > 0.0 { "positive" } else { "negative" },
            Glass::Catalogue(id).label(),
            glass.n_d,
            glass.v_d
        );
        println!(
            "{:>10} {:>8} {:>7} {:>7}  {}:{}",
            row.base.radius,
            row.base.thickness,
            row.base.index,
            row.base.aperture,
            glass.maker.name().to_ascii_uppercase(),
            glass.name
        );
    }
    Ok(())
}
