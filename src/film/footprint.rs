//! The memory a render run takes for its images, estimated before anything is allocated, so
//! that a run too large for this machine is refused at once with the numbers, instead of
//! taking all the memory there is. It depends on the image size and the number of frames,
//! never on the sample count: passes reuse the same tiles and batches.

use super::contact_sheet;
use crate::memory::{self, gigabytes};

/// Peak memory per image pixel while rendering a frame and writing it without dispersion:
/// the tiles' sums (12 B), the pass stages' SoA batches (camera rays, lens weights, hits,
/// radiance: about 125 B), then the gathered image, its means and the encoded outputs.
/// Rounded up from measurements (see BENCHMARKS.md, "memory"): 2048² and 4096² renders with
/// PNG and EXR outputs peak at 160–170 B a pixel over the process's base.
pub const BYTES_PER_PIXEL: u64 = 200;

/// What a spectral camera adds per pixel: the hero's wavelength, its factor and the film
/// filter's spread (40 B), and per further wavelength its own arrays and backward trace
/// (64 B). Rounded up from 2048² renders (`--spp 1 --max-depth 1`, PNG and EXR): 204, 272,
/// 328 and 605 B a pixel with 1, 2, 3 and 8 wavelengths, against 174 without dispersion.
/// Since the camera's working arrays are kept per thread instead of per tile (2026-11-27,
/// mimalloc): 171, 212 and 298 B with 1, 3 and 8 wavelengths, 155 without; the estimates stay,
/// with that much more room. Since the heroes that pass the lens are kept from GenerateRays to
/// LandCompanions (2026-11-28), several wavelengths take about 35 B a pixel more (the default
/// scene at 2048², three wavelengths: a peak of 991 against 843 MB).
const SPECTRAL_BYTES_PER_PIXEL: u64 = 40;
const BYTES_PER_EXTRA_WAVELENGTH: u64 = 64;

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
    /// Wavelengths per camera sample; 0 without dispersion.
    pub wavelengths: u32,
}

impl RunSize {
    /// Peak bytes a pixel of the film takes (see [`BYTES_PER_PIXEL`]).
    pub fn bytes_per_pixel(&self) -> u64 {
        match self.wavelengths {
            0 => BYTES_PER_PIXEL,
            n => {
                BYTES_PER_PIXEL
                    + SPECTRAL_BYTES_PER_PIXEL
                    + u64::from(n - 1) * BYTES_PER_EXTRA_WAVELENGTH
            }
        }
    }

    /// Bytes for the film and outputs of one frame (frames reuse them).
    pub fn film_bytes(&self) -> u64 {
        BASE_BYTES + self.width as u64 * self.height as u64 * self.bytes_per_pixel()
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
            self.width,
            self.height,
            self.bytes_per_pixel()
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
            wavelengths: 0,
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
        // A spectral camera's arrays grow with its wavelengths: 3 of them 2.6 GB at 4096².
        let spectral = RunSize {
            width: 4096,
            height: 4096,
            wavelengths: 3,
            ..small
        };
        assert_eq!(spectral.bytes_per_pixel(), 368);
        assert_eq!(
            RunSize {
                wavelengths: 1,
                ..spectral
            }
            .bytes_per_pixel(),
            240
        );
        let message = spectral
            .check_within(Some(4 << 30))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("368 B a pixel") && message.contains("6.2 GB"),
            "{message}"
        );
        assert!(
            RunSize {
                wavelengths: 0,
                ..spectral
            }
            .check_within(Some(4 << 30))
            .is_ok()
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
