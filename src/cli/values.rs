//! Parsing option values: vectors and whole numbers, with realcam's own messages.
//!
//! Numeric and vector options take values that start with `-` (clap would otherwise read
//! `--up -0.04,1,0` as a flag `-0`): vectors are declared `allow_hyphen_values`, numbers
//! `allow_negative_numbers`, and a value out of range is refused here or by the command's
//! checks, in realcam's words, naming the range.

use std::fmt::Display;

use glam::Vec3;

/// `X,Y,Z`: three finite numbers, any sign.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    finite_numbers::<f32, 3>(s, "X,Y,Z", "three").map(Vec3::from_array)
}

/// `X,Y`: two finite numbers, any sign (a shift in mm, a tilt in degrees).
pub fn parse_pair(s: &str) -> Result<[f64; 2], String> {
    finite_numbers::<f64, 2>(s, "X,Y", "two")
}

/// `N` finite numbers separated by commas; `form` (`X,Y,Z`) and `count` (`three`) name them
/// in the messages.
fn finite_numbers<T, const N: usize>(s: &str, form: &str, count: &str) -> Result<[T; N], String>
where
    T: std::str::FromStr + Copy + Into<f64>,
{
    let parts: Vec<T> = s
        .split(',')
        .map(|p| p.trim().parse::<T>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not {form}"))?;
    match <[T; N]>::try_from(parts) {
        Ok(values) if values.iter().all(|&v| v.into().is_finite()) => Ok(values),
        _ => Err(format!("'{s}' is not {count} finite numbers {form}")),
    }
}

/// `X,Y`: a pixel, two whole numbers ≥ 0 ((0,0) is the image's top-left pixel).
pub fn parse_pixel(s: &str) -> Result<[u32; 2], String> {
    let bad =
        || format!("'{s}' is not a pixel X,Y: two whole numbers from 0, (0,0) at the top left");
    let parts: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    match parts[..] {
        [x, y] => Ok([x, y]),
        _ => Err(bad()),
    }
}

/// A number (`inf` and `nan` included: the command's checks say where they make no sense).
pub fn number<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))
}

/// A parser of whole numbers of type `T` for an option whose meaningful values are
/// `min..=max`. It refuses what is not a whole number or does not fit `T` (a negative count,
/// say), naming the range; values that fit `T` but lie outside the range are left to the
/// command's own checks, which say why.
pub fn whole<T>(
    min: impl Display,
    max: impl Display,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: TryFrom<i128>,
{
    let range = format!("a whole number from {min} to {max}");
    move |s: &str| {
        let value: i128 = s
            .trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a whole number; expected {range}"))?;
        T::try_from(value).map_err(|_| format!("{value} is out of range; expected {range}"))
    }
}

/// A parser of whole numbers that must lie in `min..=max`, refusing others in realcam's words.
pub fn whole_within<T>(
    min: i128,
    max: i128,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: TryFrom<i128>,
{
    let parse = whole::<i128>(min, max);
    move |s: &str| {
        let value = parse(s)?;
        if !(min..=max).contains(&value) {
            return Err(format!(
                "{value} is out of range; expected a whole number from {min} to {max}"
            ));
        }
        T::try_from(value).map_err(|_| format!("{value} is out of range"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_take_any_sign() {
        assert_eq!(
            parse_vec3("-0.041,0.998,-0.032").unwrap(),
            Vec3::new(-0.041, 0.998, -0.032)
        );
        assert_eq!(parse_vec3(" -3, 1 ,2").unwrap(), Vec3::new(-3.0, 1.0, 2.0));
        for bad in ["1,2", "1,2,3,4", "a,b,c", "nan,0,0", "1,inf,0", ""] {
            assert!(parse_vec3(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn numbers_are_parsed_with_realcam_words() {
        assert_eq!(number::<f64>("-2.5"), Ok(-2.5));
        assert_eq!(number::<f64>("inf"), Ok(f64::INFINITY));
        assert_eq!(
            number::<f32>("-1,2,3").unwrap_err(),
            "'-1,2,3' is not a number"
        );
    }

    #[test]
    fn whole_numbers_outside_their_type_are_refused_naming_the_range() {
        let spp = whole::<u32>(1, 16_777_216);
        assert_eq!(spp("64"), Ok(64));
        assert_eq!(spp("0"), Ok(0), "left to the command's check");
        assert_eq!(
            spp("-3").unwrap_err(),
            "-3 is out of range; expected a whole number from 1 to 16777216"
        );
        assert!(spp("4294967296").unwrap_err().contains("out of range"));
        assert!(
            spp("2.5")
                .unwrap_err()
                .contains("'2.5' is not a whole number")
        );
        let count = whole_within::<u32>(1, 10_000);
        assert_eq!(count("10000"), Ok(10_000));
        assert!(count("0").unwrap_err().contains("from 1 to 10000"));
        assert!(count("-1").unwrap_err().contains("-1 is out of range"));
        let seed = whole::<u64>(0, u64::MAX);
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        assert!(
            seed("-1")
                .unwrap_err()
                .contains("from 0 to 18446744073709551615")
        );
    }
}
