//! glTF URIs: embedded `data:` URIs and files relative to the glTF file.

use std::fs::Metadata;
use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};

/// Where a URI's bytes live.
#[derive(Debug, PartialEq)]
enum UriTarget<'a> {
    /// Base64 payload of a `data:…;base64,` URI.
    Base64(&'a str),
    File(PathBuf),
}

/// Reads the bytes a glTF `uri` names, at most `limit` of a file. Relative paths are resolved
/// against `base_dir`, the directory of the glTF file (`None` when the glTF came from memory).
pub(super) fn read_uri(uri: &str, base_dir: Option<&Path>, limit: Option<u64>) -> Result<Vec<u8>> {
    match parse(uri, base_dir)? {
        UriTarget::Base64(payload) => decode_base64(payload).context("corrupt data URI"),
        UriTarget::File(path) => read_file(&path, limit).with_context(|| {
            format!(
                "cannot read {} (files a glTF refers to must be at that path relative to it)",
                path.display()
            )
        }),
    }
}

/// Reads at most `limit` bytes of the file at `path`. A directory or a device (`/dev/zero`,
/// `/dev/urandom`: endless) is refused rather than read until memory runs out; a named pipe is
/// read to its end, as a user piping a scene in expects.
pub(super) fn read_file(path: &Path, limit: Option<u64>) -> std::io::Result<Vec<u8>> {
    let file = std::fs::File::open(path)?;
    let metadata = file.metadata()?;
    if metadata.is_dir() {
        return Err(std::io::Error::other("it is a directory, not a file"));
    }
    if is_device(&metadata) {
        return Err(std::io::Error::other("it is a device, not a file"));
    }
    let mut bytes = Vec::with_capacity(metadata.len().min(limit.unwrap_or(u64::MAX)) as usize);
    file.take(limit.unwrap_or(u64::MAX))
        .read_to_end(&mut bytes)?;
    Ok(bytes)
}

#[cfg(unix)]
fn is_device(metadata: &Metadata) -> bool {
    use std::os::unix::fs::FileTypeExt;
    let kind = metadata.file_type();
    kind.is_char_device() || kind.is_block_device() || kind.is_socket()
}

#[cfg(not(unix))]
fn is_device(_: &Metadata) -> bool {
    false
}

/// A short form of a URI for messages: data URIs can be megabytes long.
pub(super) fn describe(uri: &str) -> String {
    const SHOWN: usize = 40;
    if let Some(data) = uri.strip_prefix("data:") {
        let media_type = data.split([';', ',']).next().unwrap_or("");
        format!("embedded data URI ({media_type}, {} bytes)", uri.len())
    } else if uri.chars().count() > SHOWN {
        format!("'{}…'", uri.chars().take(SHOWN).collect::<String>())
    } else {
        format!("'{uri}'")
    }
}

fn parse<'a>(uri: &'a str, base_dir: Option<&Path>) -> Result<UriTarget<'a>> {
    if let Some(data) = uri.strip_prefix("data:") {
        let Some((header, payload)) = data.split_once(',') else {
            bail!("malformed data URI (no ',' before the payload)");
        };
        if !header.ends_with(";base64") {
            bail!("data URI is not base64-encoded; re-export the file with base64 data URIs");
        }
        return Ok(UriTarget::Base64(payload));
    }
    if let Some(path) = uri
        .strip_prefix("file://")
        .or_else(|| uri.strip_prefix("file:"))
    {
        return Ok(UriTarget::File(PathBuf::from(percent_decode(path)?)));
    }
    if has_scheme(uri) {
        bail!(
            "URI scheme of {} is not supported; download the file and refer to it by a relative path",
            describe(uri)
        );
    }
    let relative = percent_decode(uri)?;
    let base_dir = base_dir.ok_or_else(|| {
        anyhow!("refers to the external file '{relative}', but the scene was loaded from memory without a base directory; embed the data in a .glb")
    })?;
    Ok(UriTarget::File(base_dir.join(relative)))
}

/// RFC 3986: `scheme ":"` where the scheme starts with a letter and holds letters, digits,
/// `+`, `-` and `.`. A single letter is taken as a Windows drive (`C:`), not a scheme.
fn has_scheme(uri: &str) -> bool {
    let Some((scheme, _)) = uri.split_once(':') else {
        return false;
    };
    scheme.len() > 1
        && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
}

/// Decodes `%XX` escapes (glTF URIs are RFC 3986 URI references). A `%` not followed by two
/// hex digits is kept as it is.
fn percent_decode(text: &str) -> Result<String> {
    let bytes = text.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let escaped = match (bytes[i], bytes.get(i + 1), bytes.get(i + 2)) {
            (b'%', Some(&high), Some(&low)) => hex_value(high).zip(hex_value(low)),
            _ => None,
        };
        match escaped {
            Some((high, low)) => {
                decoded.push(high << 4 | low);
                i += 3;
            }
            None => {
                decoded.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8(decoded).map_err(|_| anyhow!("URI '{text}' decodes to invalid UTF-8"))
}

fn hex_value(digit: u8) -> Option<u8> {
    (digit as char).to_digit(16).map(|value| value as u8)
}

/// Decodes standard (RFC 4648 §4) base64, also accepting the URL-safe alphabet (§5).
/// Padding is optional; ASCII whitespace is skipped.
fn decode_base64(text: &str) -> Result<Vec<u8>> {
    let mut decoded = Vec::with_capacity(text.len() / 4 * 3 + 2);
    let mut accumulator: u32 = 0;
    let mut bits = 0;
    for (offset, byte) in text.bytes().enumerate() {
        let value = match byte {
            b'A'..=b'Z' => byte - b'A',
            b'a'..=b'z' => byte - b'a' + 26,
            b'0'..=b'9' => byte - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            _ if byte.is_ascii_whitespace() => continue,
            _ => bail!(
                "invalid base64 character {:?} at offset {offset}",
                byte as char
            ),
        };
        accumulator = (accumulator << 6) | u32::from(value);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            decoded.push((accumulator >> bits) as u8);
            accumulator &= (1 << bits) - 1;
        }
    }
    Ok(decoded)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_known_vectors() {
        // RFC 4648 §10.
        for (encoded, plain) in [
            ("", ""),
            ("Zg==", "f"),
            ("Zm8=", "fo"),
            ("Zm9v", "foo"),
            ("Zm9vYg==", "foob"),
            ("Zm9vYmE=", "fooba"),
            ("Zm9vYmFy", "foobar"),
            ("Zm9vYmE", "fooba"),
        ] {
            assert_eq!(
                decode_base64(encoded).unwrap(),
                plain.as_bytes(),
                "{encoded}"
            );
        }
        assert_eq!(
            decode_base64("+/-_").unwrap(),
            decode_base64("+/+/").unwrap()
        );
        assert!(decode_base64("Zm9v!").is_err());
    }

    #[test]
    fn data_uri() {
        let bytes = read_uri("data:application/octet-stream;base64,AAEC", None, None).unwrap();
        assert_eq!(bytes, [0, 1, 2]);
        assert!(read_uri("data:text/plain,hello", None, None).is_err());
        assert!(read_uri("data:nocomma", None, None).is_err());
    }

    #[test]
    fn relative_and_file_uris() {
        let base = Path::new("/scenes/duck");
        assert_eq!(
            parse("textures/my%20duck.png", Some(base)).unwrap(),
            UriTarget::File(PathBuf::from("/scenes/duck/textures/my duck.png"))
        );
        assert_eq!(
            parse("file:///tmp/a.bin", Some(base)).unwrap(),
            UriTarget::File(PathBuf::from("/tmp/a.bin"))
        );
        assert_eq!(
            parse("C:/data/a.bin", Some(base)).unwrap(),
            UriTarget::File(base.join("C:/data/a.bin"))
        );
        assert!(parse("https://example.com/a.bin", Some(base)).is_err());
        assert!(
            parse("a.bin", None)
                .unwrap_err()
                .to_string()
                .contains("a.bin")
        );
        assert!(parse("bad%FF.bin", Some(base)).is_err());
        assert_eq!(percent_decode("100%").unwrap(), "100%");
    }

    #[test]
    fn long_uris_are_shortened_in_messages() {
        let data = format!("data:image/png;base64,{}", "A".repeat(1000));
        assert_eq!(describe(&data), "embedded data URI (image/png, 1022 bytes)");
        assert!(describe(&"x".repeat(100)).chars().count() < 50);
    }
}
