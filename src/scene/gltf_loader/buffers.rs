//! glTF buffers and buffer views: the raw bytes behind accessors and embedded images.

use std::borrow::Cow;
use std::path::Path;

use anyhow::{Context, Result, bail};
use gltf::json::Root;

use super::uri;

/// The bytes of every buffer of a document, by glTF buffer index. The GLB `BIN` chunk is
/// borrowed from the file's bytes rather than copied.
pub(super) struct Buffers<'a>(Vec<Cow<'a, [u8]>>);

impl<'a> Buffers<'a> {
    /// Reads every buffer: the GLB `BIN` chunk (`blob`) for a buffer without a URI, files and
    /// data URIs otherwise. Each must hold at least its declared `byteLength`.
    pub(super) fn load(
        root: &Root,
        blob: Option<&'a [u8]>,
        base_dir: Option<&Path>,
    ) -> Result<Buffers<'a>> {
        let mut blob = blob;
        let mut buffers = Vec::with_capacity(root.buffers.len());
        for (index, buffer) in root.buffers.iter().enumerate() {
            let declared = buffer.byte_length.0;
            let data = match &buffer.uri {
                // Bytes of a file past byteLength are never used: they are not read.
                Some(uri) => Cow::Owned(
                    uri::read_uri(uri, base_dir, Some(declared))
                        .with_context(|| format!("buffer {index} ({})", uri::describe(uri)))?,
                ),
                None => match blob.take() {
                    Some(blob) => Cow::Borrowed(blob),
                    None => bail!(
                        "buffer {index} has no uri, so it must be the GLB BIN chunk, but the file has none (or it is already used by another buffer); the file is corrupt"
                    ),
                },
            };
            if (data.len() as u64) < declared {
                let source = buffer
                    .uri
                    .as_deref()
                    .map_or("the GLB BIN chunk".to_string(), uri::describe);
                bail!(
                    "buffer {index} ({source}) has {} bytes but the glTF declares byteLength {declared}: the data is truncated or belongs to another file; re-export the scene",
                    data.len()
                );
            }
            buffers.push(data);
        }
        Ok(Buffers(buffers))
    }

    /// The bytes of buffer view `view`, checked to lie inside its buffer.
    pub(super) fn view(&self, root: &Root, view: usize) -> Result<&[u8]> {
        let Some(json) = root.buffer_views.get(view) else {
            bail!("buffer view {view} does not exist");
        };
        let buffer = json.buffer.value();
        let Some(data) = self.0.get(buffer) else {
            bail!("buffer view {view} refers to buffer {buffer}, which does not exist");
        };
        let start = json.byte_offset.map_or(0, |offset| offset.0);
        let length = json.byte_length.0;
        let range = usize::try_from(start)
            .ok()
            .zip(usize::try_from(length).ok())
            .and_then(|(start, length)| Some(start..start.checked_add(length)?))
            .filter(|range| range.end <= data.len());
        match range {
            Some(range) => Ok(&data[range]),
            None => bail!(
                "buffer view {view} covers bytes {start}..{} of buffer {buffer}, which has only {} bytes; the file is corrupt",
                start.saturating_add(length),
                data.len()
            ),
        }
    }
}
