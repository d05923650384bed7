//! From a `.zmx` file's bytes to its text, numbers and lengths: the encodings OpticStudio
//! writes, its number syntax and its length units.

/// Text of a `.zmx` file: UTF-16 (little- or big-endian, with or without a byte-order mark:
/// what OpticStudio writes), UTF-8 (with or without a mark), or Latin-1.
pub(super) fn decode(bytes: &[u8]) -> Result<String, String> {
    let utf16 = |body: &[u8], little: bool| -> Result<String, String> {
        if !body.len().is_multiple_of(2) {
            return Err("is UTF-16 with an odd number of bytes: the file is truncated".into());
        }
        let units: Vec<u16> = body
            .chunks_exact(2)
            .map(|p| {
                if little {
                    u16::from_le_bytes([p[0], p[1]])
                } else {
                    u16::from_be_bytes([p[0], p[1]])
                }
            })
            .collect();
        String::from_utf16(&units).map_err(|_| "is not valid UTF-16 text".to_string())
    };
    match bytes {
        [0xFF, 0xFE, rest @ ..] => utf16(rest, true),
        [0xFE, 0xFF, rest @ ..] => utf16(rest, false),
        [0xEF, 0xBB, 0xBF, rest @ ..] => {
            String::from_utf8(rest.to_vec()).map_err(|_| "is not valid UTF-8 text".into())
        }
        // UTF-16 without a mark: ASCII keywords leave every other byte zero.
        [a, 0, b, 0, ..] if *a != 0 && *b != 0 => utf16(bytes, true),
        [0, a, 0, b, ..] if *a != 0 && *b != 0 => utf16(bytes, false),
        _ => Ok(match String::from_utf8(bytes.to_vec()) {
            Ok(text) => text,
            // Latin-1: every byte is the code point of the same number.
            Err(_) => bytes.iter().map(|&b| b as char).collect(),
        }),
    }
}

/// A number as Zemax writes it (`7.0E-002`, `0.`, `INFINITY`).
pub(super) fn number(token: &str) -> Option<f64> {
    match token.to_ascii_uppercase().as_str() {
        "INFINITY" | "INF" => Some(f64::INFINITY),
        "-INFINITY" | "-INF" => Some(f64::NEG_INFINITY),
        _ => token.parse::<f64>().ok().filter(|v| !v.is_nan()),
    }
}

/// Millimetres per file unit for a `UNIT` name (`None`: a unit realcam does not know).
pub(super) fn unit_scale(unit: &str) -> Option<f64> {
    Some(match unit {
        "MM" => 1.0,
        "CM" => 10.0,
        "IN" | "INCH" | "INCHES" => 25.4,
        "METER" | "METERS" | "M" => 1000.0,
        _ => return None,
    })
}
