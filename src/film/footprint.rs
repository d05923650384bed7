//! The memory a render run takes for its images, estimated before anything is allocated, so
//! that a run too large for this machine is refused at once with the numbers, instead of
//! taking all the memory there is. It depends on the image size and the number of frames,
//! never on the sample count: passes reuse the same tiles and batches.

use super::contact_sheet;
use crate::memory::{self, gigabytes};

/// Peak memory per image pixel while rendering a frame and writing it: the tiles' sums
/// (12 B), the pass stages' SoA batches (camera rays, lens weights, hits, radiance: about
/// 125 B), then the gathered image, its means and the encoded outputs. Rounded up from
/// measurements (see BENCHMARKS.md, "memory"): 2048² and 4096² renders with PNG and EXR
/// outputs peak at 160–170 B a pixel over the process's base.
pub const BYTES_PER_PIXEL: u64 = 200;

/// The process before any film: scene, BVH of the bundled scene, thread stacks, code.
const BASE_BYTES: u64 = 64 << 20;

/// Lines under each contact-sheet thumbnail (lens; focal length and stop; focus).
pub const CAPTION_LINES: u32 = 3;

/// What a run renders, as far as memory goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunSize {
    pub width: u32,
    pub height: u32,
    /// Frames in the run (lenses × focus frames × stop frames).
    pub frames: usize,
    pub contact_sheet: bool,
}

impl RunSize {
    /// Bytes for the film and outputs of one frame (frames reuse them).
    pub fn film_bytes(&self) -> u64 {
        BASE_BYTES + self.width as u64 * self.height as u64 * BYTES_PER_PIXEL
    }

    /// Bytes for the contact sheet, if the run makes one.
    pub fn contact_sheet_bytes(&self) -> u64 {
        if self.contact_sheet {
            contact_sheet::estimated_bytes(self.frames, self.width, self.height, CAPTION_LINES)
        } else {
            0
        }
    }

    pub fn bytes(&self) -> u64 {
        self.film_bytes() + self.contact_sheet_bytes()
    }

    /// Refuses the run if it needs more than `available` bytes (when known).
    pub fn check_within(&self, available: Option<u64>) -> anyhow::Result<()> {
        let mut what = format!(
            "a {}×{} render ({} B a pixel for the film and its outputs",
            self.width, self.height, BYTES_PER_PIXEL
        );
        if self.contact_sheet {
            what += &format!(
                ", {} for the contact sheet of {} frames",
                gigabytes(self.contact_sheet_bytes()),
                self.frames
            );
        }
        what += ")";
        memory::check_within(
            &what,
            self.bytes(),
            available,
            "render fewer pixels (--width, --height) or fewer frames, or on a machine (or with a memory limit) with more memory",
        )
    }

    /// Refuses the run if it needs more memory than this process can have.
    pub fn check(&self) -> anyhow::Result<()> {
        self.check_within(memory::available_memory())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_follows_pixels_and_frames_and_refuses_with_the_numbers() {
        let small = RunSize {
            width: 512,
            height: 512,
            frames: 1,
            contact_sheet: false,
        };
        let largest = RunSize {
            width: 16_384,
            height: 16_384,
            ..small
        };
        assert_eq!(
            largest.film_bytes() - small.film_bytes(),
            (16_384 * 16_384 - 512 * 512) * BYTES_PER_PIXEL
        );
        assert!(largest.check_within(Some(64 << 30)).is_ok());
        let message = largest.check_within(Some(8 << 30)).unwrap_err().to_string();
        assert!(
            message.contains("16384×16384")
                && message.contains("53.8 GB")
                && message.contains("only 8.6 GB")
                && message.contains("--width"),
            "{message}"
        );
        let sheet = RunSize {
            frames: 10_000,
            contact_sheet: true,
            ..small
        };
        assert!(sheet.contact_sheet_bytes() > 10_000 * 320 * 320 * 3);
        let message = sheet.check_within(Some(1 << 30)).unwrap_err().to_string();
        assert!(
            message.contains("contact sheet of 10000 frames"),
            "{message}"
        );
    }
}
