//! Sizing the aperture stop: by diameter, or by the f-number a user asks for.

use super::first_order::FirstOrder;
use super::prescription::MIN_APERTURE_MM;
use super::system::LensSystem;

/// How wide the stop is opened.
#[derive(bevy_ecs::component::Component, Clone, Copy, Debug, PartialEq, Default)]
pub enum ApertureSetting {
    /// The stop row's own diameter (its maximum).
    #[default]
    Full,
    /// Stop diameter in mm.
    Diameter(f64),
    /// The real f-number N = EFL / entrance-pupil diameter. pbrt and appleseed divide the
    /// focal length by N and use that as the *stop* diameter, which is wrong whenever the
    /// elements in front of the stop magnify it (they usually do).
    FNumber(f64),
}

/// The stop diameter for `setting`, clamped to what the stop row allows, with a warning when
/// it had to be clamped. `full` is the lens with its stop at the row's diameter.
/// `open_fraction` is the area of the diaphragm's opening over its circle's (1 for a round
/// stop): an f-number sizes the circle so the opening has the area of the f-number's circle.
pub fn stop_diameter(
    setting: ApertureSetting,
    full: &LensSystem,
    full_first_order: &FirstOrder,
    open_fraction: f64,
) -> Result<(f64, Option<String>), String> {
    let maximum = full.stop_diameter();
    let requested = match setting {
        ApertureSetting::Full => return Ok((maximum, None)),
        ApertureSetting::Diameter(d) => {
            if !(d.is_finite() && d > 0.0) {
                return Err(format!(
                    "aperture diameter {d} mm must be a positive number"
                ));
            }
            d
        }
        ApertureSetting::FNumber(n) => {
            if !(n.is_finite() && n > 0.0) {
                return Err(format!("f-number {n} must be a positive number"));
            }
            // The entrance pupil scales linearly with the stop: EP = stop × (EP/stop at full).
            let pupil_per_stop = full_first_order.entrance_pupil.diameter_mm / maximum;
            let circle = full_first_order.focal_length / n / pupil_per_stop;
            if open_fraction == 1.0 {
                circle
            } else {
                circle / open_fraction.sqrt()
            }
        }
    };
    // A stop narrower than a wavelength of light is beyond geometric optics (diffraction
    // would spread its light over the whole film), as a lens file's sub-micrometre aperture is.
    if requested < MIN_APERTURE_MM {
        let smallest = match setting {
            ApertureSetting::FNumber(n) => {
                format!("f/{:.0}", (n * requested / MIN_APERTURE_MM).floor())
            }
            _ => format!("{MIN_APERTURE_MM} mm"),
        };
        return Err(format!(
            "a stop of {requested:.2e} mm is narrower than a micrometre, below the wavelength of light, where rays no longer describe it; the smallest stop realcam traces through this lens is {smallest}"
        ));
    }
    if requested > maximum {
        let widest = full_first_order.f_number;
        let warning = format!(
            "requested stop of {requested:.3} mm is wider than this lens's stop ({maximum:.3} mm, f/{widest:.2}); using {maximum:.3} mm"
        );
        return Ok((maximum, Some(warning)));
    }
    Ok((requested, None))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::io::bundled::load_lens;

    /// The f-number scales the stop as 1/N, so the smallest stop (1 µm) is reached at
    /// N = N₀ · d₀ / 1 µm from any (N₀, d₀) of the lens: the refusal names that f-number, and
    /// it is accepted while a hair smaller is not.
    #[test]
    fn stops_below_a_micrometre_are_refused_naming_the_smallest() {
        let lens = load_lens("dgauss.50mm", None).unwrap();
        let system = LensSystem::new(&lens.rows, None);
        let first_order = FirstOrder::compute(&system).unwrap();
        let (at_f16, _) =
            stop_diameter(ApertureSetting::FNumber(16.0), &system, &first_order, 1.0).unwrap();
        let limit = 16.0 * at_f16 / MIN_APERTURE_MM;
        assert!(
            stop_diameter(
                ApertureSetting::FNumber(limit * 0.999),
                &system,
                &first_order,
                1.0
            )
            .is_ok()
        );
        let refusal = stop_diameter(
            ApertureSetting::FNumber(limit * 10.0),
            &system,
            &first_order,
            1.0,
        )
        .unwrap_err();
        assert!(refusal.contains("narrower than a micrometre"), "{refusal}");
        assert!(
            refusal.contains(&format!("f/{:.0}", limit.floor())),
            "{refusal} (f/{limit})"
        );
        let diameter =
            stop_diameter(ApertureSetting::Diameter(5e-4), &system, &first_order, 1.0).unwrap_err();
        assert!(diameter.contains("0.001 mm"), "{diameter}");
    }
}
