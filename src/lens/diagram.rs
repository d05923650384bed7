//! The lens cross-section as SVG: elements, stop, film, axis, and traced ray fans (on axis
//! and at the edge of the field), blocked rays dashed. Drawn in the meridional (y–z) plane of
//! the lens frame, scene on the left. A zoom or focus-group lens gets its groups' motion
//! underneath ([`super::group_motion`]): a row per setting, the film fixed on the right.

use std::fmt::Write;

use super::field::field_edge;
use super::first_order::FirstOrder;
use super::ghost::{ghost_steps, trace_ghost_path};
use super::group_motion::GroupMotion;
use super::prescription::sag;
use super::report::LensReport;
use super::system::LensSystem;
use super::trace::{Ray, Travel, normalize, trace_path};
use crate::glass::{FRAUNHOFER_C_NM, FRAUNHOFER_D_NM, FRAUNHOFER_F_NM};

const WIDTH: f64 = 1000.0;
const RAYS_PER_FAN: usize = 11;

struct View {
    z0: f64,
    y_max: f64,
    scale: f64,
    height: f64,
}

impl View {
    fn x(&self, z: f64) -> f64 {
        20.0 + (z - self.z0) * self.scale
    }

    fn y(&self, y: f64) -> f64 {
        self.height / 2.0 - y * self.scale
    }

    fn point(&self, z: f64, y: f64) -> String {
        format!("{:.2},{:.2}", self.x(z), self.y(y))
    }
}

/// SVG text of the cross-section of the lens `report` describes, at its settings, with the
/// groups' motion of a zoom or focus-group lens and (`ghost`) a ghost path.
pub fn draw_report_diagram(report: &LensReport, ghost: Option<[usize; 2]>) -> String {
    draw_diagram_with(
        &report.geometry.system,
        report.film_distance,
        report.film_diagonal,
        &report.prescription.name,
        ghost,
        GroupMotion::of(&report.prescription).as_ref(),
    )
}

/// Height of one row of the group-motion strip, px.
const MOTION_ROW: f64 = 30.0;

/// [`draw_diagram`], with `ghost` the on-axis bundle along the ghost path of that pair of
/// surfaces too (see [`super::ghost`]), and `motion` the groups of a zoom or focus-group lens
/// at each of its settings.
fn draw_diagram_with(
    system: &LensSystem,
    film_distance: f64,
    film_diagonal: f64,
    title: &str,
    ghost: Option<[usize; 2]>,
    motion: Option<&GroupMotion>,
) -> String {
    let s = &system.f64s;
    let film_z = system.rear_z() + film_distance;
    let max_aperture = system
        .rows
        .iter()
        .map(|r| r.base.aperture / 2.0)
        .fold(0.0, f64::max);
    let y_max = max_aperture.max(film_diagonal / 2.0) * 1.15;
    // Room in front for the longest setting of a lens whose groups move (its rows are drawn
    // against this film plane).
    let front = motion
        .iter()
        .flat_map(|m| &m.states)
        .map(|s| film_z + s.from_film_mm[0])
        .fold(0.0, f64::min);
    let lead = (0.3 * film_z).max(max_aperture) - front;
    let z0 = -lead;
    let scale = (WIDTH - 40.0) / (film_z + film_distance.max(5.0) * 0.1 + lead);
    let view = View {
        z0,
        y_max,
        scale,
        height: 2.0 * y_max * scale + 60.0,
    };
    // A ghost's caption takes a line of its own; the groups' motion its rows and a caption.
    let caption = if ghost.is_some() { 16.0 } else { 0.0 }
        + motion.map_or(0.0, |m| MOTION_ROW * m.states.len() as f64 + 24.0);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{:.0}" viewBox="0 0 {WIDTH} {:.0}" font-family="sans-serif" font-size="13">"#,
        view.height + 20.0 + caption,
        view.height + 20.0 + caption
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(svg, r#"<text x="20" y="18">{}</text>"#, escape(title));

    // Glass between a surface and the next where the medium is not air.
    for i in 0..system.surface_count().saturating_sub(1) {
        if s.index_back[i] <= 1.0 {
            continue;
        }
        let (front, back) = (&system.rows[i], &system.rows[i + 1]);
        let mut points = Vec::new();
        for k in 0..=24 {
            let h = -front.base.aperture / 2.0 + front.base.aperture * k as f64 / 24.0;
            points.push(view.point(s.vertex_z[i] + sag(front, h), h));
        }
        for k in 0..=24 {
            let h = back.base.aperture / 2.0 - back.base.aperture * k as f64 / 24.0;
            points.push(view.point(s.vertex_z[i + 1] + sag(back, h), h));
        }
        let _ = writeln!(
            svg,
            r##"<polygon points="{}" fill="#cfe3f5" stroke="#3a6b99" stroke-width="1"/>"##,
            points.join(" ")
        );
    }
    // Bare surfaces (air on both sides never happens in practice, but draw every profile).
    for (i, row) in system.rows.iter().enumerate() {
        if row.is_stop() {
            let a = row.base.aperture / 2.0;
            let outer = max_aperture * 1.08;
            let x = view.x(s.vertex_z[i]);
            for (y0, y1) in [(a, outer), (-a, -outer)] {
                let _ = writeln!(
                    svg,
                    r#"<line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}" stroke="black" stroke-width="3"/>"#,
                    view.y(y0),
                    view.y(y1)
                );
            }
            continue;
        }
        let points: Vec<String> = (0..=24)
            .map(|k| {
                let h = -row.base.aperture / 2.0 + row.base.aperture * k as f64 / 24.0;
                view.point(s.vertex_z[i] + sag(row, h), h)
            })
            .collect();
        let _ = writeln!(
            svg,
            r##"<polyline points="{}" fill="none" stroke="#3a6b99" stroke-width="1"/>"##,
            points.join(" ")
        );
    }
    // Axis and film.
    let _ = writeln!(
        svg,
        r##"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="#888" stroke-dasharray="8 4"/>"##,
        view.x(z0),
        view.y(0.0),
        view.x(film_z + 2.0),
        view.y(0.0)
    );
    let half_film = film_diagonal / 2.0;
    let _ = writeln!(
        svg,
        r##"<line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}" stroke="#222" stroke-width="2"/><text x="{x:.2}" y="{:.2}" text-anchor="middle">film</text>"##,
        view.y(half_film),
        view.y(-half_film),
        view.y(-half_film) + 16.0,
        x = view.x(film_z)
    );

    // A lens with glass data gets its fans at the F, d and C lines in their colours (the colour
    // errors show as fans that part); one without, the on-axis fan green and the corner red.
    let edge = field_edge(system, film_distance, half_film);
    let field = edge.map_or(0.0, |(_, angle)| angle);
    if system.is_dispersive() {
        for (nm, colour) in [
            (FRAUNHOFER_F_NM, "#1f4fd8"),
            (FRAUNHOFER_D_NM, "#c99700"),
            (FRAUNHOFER_C_NM, "#d0202a"),
        ] {
            let at = system.at_wavelength(nm);
            draw_fans(&mut svg, &view, &at, film_z, z0, edge, [colour, colour]);
        }
        let _ = writeln!(
            svg,
            r##"<text x="20" y="{:.0}" fill="#444">on-axis and film-corner ({:.1}° off axis) bundles at <tspan fill="#1f4fd8">F 486 nm</tspan>, <tspan fill="#c99700">d 588 nm</tspan>, <tspan fill="#d0202a">C 656 nm</tspan>; dashed: blocked</text>"##,
            view.height + 12.0,
            field.to_degrees()
        );
    } else {
        draw_fans(
            &mut svg,
            &view,
            system,
            film_z,
            z0,
            edge,
            ["#1b7f3b", "#c0392b"],
        );
        let _ = writeln!(
            svg,
            r##"<text x="20" y="{:.0}" fill="#444">green: on-axis bundle; red: film-corner bundle ({:.1}° off axis); dashed: blocked</text>"##,
            view.height + 12.0,
            field.to_degrees()
        );
    }
    if let Some(pair) = ghost {
        draw_ghost(&mut svg, &view, system, film_z, z0, pair);
        let _ = writeln!(
            svg,
            r##"<text x="20" y="{:.0}" fill="#8e44ad">purple: the on-axis bundle reflected by surfaces {} and {} (a ghost)</text>"##,
            view.height + 26.0,
            pair[0],
            pair[1]
        );
    }
    if let Some(motion) = motion {
        let top = view.height + 20.0 + if ghost.is_some() { 16.0 } else { 0.0 };
        draw_motion(&mut svg, &view, film_z, motion, top);
    }
    svg.push_str("</svg>\n");
    svg
}

/// The groups' motion below the cross-section, from `top` (px): per setting a row with each
/// group as a bar from its first to its last vertex (moving groups orange, fixed ones blue),
/// the stop as a tick, the film plane of the cross-section above as the common reference, and
/// each group's front vertex joined from row to row. Each bar carries its group, setting and
/// distance from the film as data attributes.
fn draw_motion(svg: &mut String, view: &View, film_z: f64, motion: &GroupMotion, top: f64) {
    // A group "moves" when it shifts by more than a line's width at any scale, 0.05 mm: a
    // patent's rounded gaps leave a fixed group a few micrometres off its paraxial film plane.
    let moves = |g: &super::group_motion::Group| {
        let first = &motion.states[0].from_film_mm;
        motion.states.iter().any(|s| {
            (s.from_film_mm[g.first] - first[g.first]).abs() > 0.05
                || (s.from_film_mm[g.last] - first[g.last]).abs() > 0.05
        })
    };
    let _ = writeln!(
        svg,
        r##"<text x="20" y="{:.0}" fill="#444">groups at each setting, against a fixed film (right): <tspan fill="#d35400">moving</tspan>, <tspan fill="#3a6b99">fixed</tspan>; black tick: the stop</text>"##,
        top + 14.0
    );
    let row_y = |i: usize| top + 24.0 + MOTION_ROW * i as f64 + MOTION_ROW * 0.6;
    let x = |from_film: f64| view.x(film_z + from_film);
    for (g_index, group) in motion.groups.iter().enumerate() {
        let colour = if moves(group) { "#d35400" } else { "#3a6b99" };
        let fronts: Vec<String> = motion
            .states
            .iter()
            .enumerate()
            .map(|(i, s)| format!("{:.2},{:.2}", x(s.from_film_mm[group.first]), row_y(i)))
            .collect();
        if fronts.len() > 1 {
            let _ = writeln!(
                svg,
                r##"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="1" stroke-dasharray="3 2"/>"##,
                fronts.join(" ")
            );
        }
        for (i, state) in motion.states.iter().enumerate() {
            let (from, to) = (
                state.from_film_mm[group.first],
                state.from_film_mm[group.last],
            );
            let _ = writeln!(
                svg,
                r##"<rect x="{:.2}" y="{:.2}" width="{:.2}" height="8" fill="{colour}" data-group="G{}" data-setting="{}" data-from-film-mm="{from:.6}" data-to-film-mm="{to:.6}"/>"##,
                x(from),
                row_y(i) - 4.0,
                (x(to) - x(from)).max(2.0),
                g_index + 1,
                i + 1
            );
            if i == 0 {
                let _ = writeln!(
                    svg,
                    r##"<text x="{:.2}" y="{:.2}" font-size="11" fill="{colour}">G{}</text>"##,
                    x(from),
                    row_y(i) - 6.0,
                    g_index + 1
                );
            }
        }
    }
    for (i, state) in motion.states.iter().enumerate() {
        let _ = writeln!(
            svg,
            r##"<text x="20" y="{:.2}" font-size="11" fill="#444">{}</text>"##,
            row_y(i) - 8.0,
            escape(&state.label)
        );
        if let Some(stop) = motion.stop {
            let at = x(state.from_film_mm[stop]);
            let _ = writeln!(
                svg,
                r#"<line x1="{at:.2}" y1="{:.2}" x2="{at:.2}" y2="{:.2}" stroke="black" stroke-width="2"/>"#,
                row_y(i) - 7.0,
                row_y(i) + 7.0
            );
        }
    }
    let film = x(0.0);
    let _ = writeln!(
        svg,
        r##"<line x1="{film:.2}" y1="{:.2}" x2="{film:.2}" y2="{:.2}" stroke="#222" stroke-width="2"/>"##,
        row_y(0) - 10.0,
        row_y(motion.states.len() - 1) + 10.0
    );
}

/// The on-axis bundle from infinity along the ghost path of `pair`, to the film plane.
fn draw_ghost(
    svg: &mut String,
    view: &View,
    system: &LensSystem,
    film_z: f64,
    z0: f64,
    pair: [usize; 2],
) {
    let s = &system.f64s;
    let steps = ghost_steps(s.len(), pair, true);
    let index = |i: usize| (s.index_front[i], s.index_back[i]);
    let pupil_radius = FirstOrder::compute(system).map_or(system.front_semi_aperture(), |fo| {
        fo.entrance_pupil.diameter_mm / 2.0
    });
    for k in 0..RAYS_PER_FAN {
        let height = pupil_radius * (2.0 * k as f64 / (RAYS_PER_FAN - 1) as f64 - 1.0);
        let mut path = vec![(z0, height)];
        let ray = Ray {
            origin: [0.0, height, z0],
            direction: [0.0, 0.0, 1.0],
        };
        let result = trace_ghost_path(
            s,
            ray,
            &steps,
            index,
            |_, _| 0.0,
            |p| path.push((p[2], p[1])),
        );
        if let Some((out, _)) = result {
            let t = (film_z - out.origin[2]) / out.direction[2];
            path.push((film_z, out.origin[1] + t * out.direction[1]));
        }
        draw_ray(svg, view, &path, "#8e44ad", result.is_some());
    }
}

/// The on-axis fan and the fan from the film point at the field edge (`edge`: its height and
/// angle), traced through `system`, in `colours` [on axis, edge].
fn draw_fans(
    svg: &mut String,
    view: &View,
    system: &LensSystem,
    film_z: f64,
    z0: f64,
    edge: Option<(f64, f64)>,
    colours: [&str; 2],
) {
    let s = &system.f64s;
    // On axis: a parallel bundle from infinity filling the entrance pupil (a little over, so
    // the clipping shows). At the field edge: rays from the film point back out through the
    // rear element, which finds the real pupil however strongly it is aberrated (a fisheye's).
    let pupil_radius = FirstOrder::compute(system).map_or(system.front_semi_aperture(), |fo| {
        fo.entrance_pupil.diameter_mm / 2.0
    });
    for k in 0..RAYS_PER_FAN {
        let height = 1.15 * pupil_radius * (2.0 * k as f64 / (RAYS_PER_FAN - 1) as f64 - 1.0);
        let origin = [0.0, height, z0];
        let mut path = vec![(z0, height)];
        let result = trace_path(
            s,
            Ray {
                origin,
                direction: [0.0, 0.0, 1.0],
            },
            Travel::SceneToFilm,
            true,
            |_, p| path.push((p[2], p[1])),
        );
        if let Ok(out) = result {
            let t = (film_z - out.origin[2]) / out.direction[2];
            path.push((film_z, out.origin[1] + t * out.direction[1]));
        }
        draw_ray(svg, view, &path, colours[0], result.is_ok());
    }
    if let Some((height, _)) = edge {
        let rear = 1.5 * system.rear_semi_aperture();
        let from = [0.0, -height, film_z];
        let towards = |aim: f64| Ray {
            origin: from,
            direction: normalize([0.0, aim + height, system.rear_z() - film_z]),
        };
        let passing: Vec<f64> = (0..=400)
            .map(|k| -rear + 2.0 * rear * k as f64 / 400.0)
            .filter(|&aim| {
                trace_path(s, towards(aim), Travel::FilmToScene, true, |_, _| {}).is_ok()
            })
            .collect();
        if let (Some(&low), Some(&high)) = (passing.first(), passing.last()) {
            let margin = 0.1 * (high - low);
            for k in 0..RAYS_PER_FAN {
                let aim = low - margin
                    + (high - low + 2.0 * margin) * k as f64 / (RAYS_PER_FAN - 1) as f64;
                let mut path = vec![(film_z, -height)];
                let result = trace_path(s, towards(aim), Travel::FilmToScene, true, |_, p| {
                    path.push((p[2], p[1]))
                });
                if let Ok(out) = result {
                    let t = (z0 - out.origin[2]) / out.direction[2];
                    path.push((z0, out.origin[1] + t * out.direction[1]));
                }
                draw_ray(svg, view, &path, colours[1], result.is_ok());
            }
        }
    }
}

/// A ray path as a polyline, dashed when the ray was blocked.
fn draw_ray(svg: &mut String, view: &View, path: &[(f64, f64)], colour: &str, passed: bool) {
    let dashed = if passed {
        ""
    } else {
        r#" stroke-dasharray="4 3" opacity="0.6""#
    };
    let points: Vec<String> = path
        .iter()
        .map(|&(z, y)| view.point(z, y.clamp(-view.y_max, view.y_max)))
        .collect();
    let _ = writeln!(
        svg,
        r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="0.8"{dashed}/>"#,
        points.join(" ")
    );
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
