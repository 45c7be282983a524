//! The lowest layer of fipt-rs, re-exported by `fipt-core` at the same paths
//! (`fipt_core::image::Image`, `fipt_core::CoreError`, …):
//!
//! * [`error::CoreError`]: the one error of reading, validating and writing fipt data;
//! * [`fsutil`]: atomic writes (temp file, then rename), content hashes; [`chaos`]: the fault
//!   injection the kill tests drive;
//! * [`color`]: the sRGB curves and luminance; [`image::Image`]: linear RGB images with EXR
//!   (f32/half, channels by name), PNG and JPEG I/O;
//! * [`exif`]: exposures from the photos' EXIF; [`capture`]: 8-bit views' response, clipping and
//!   `capture.json`.
pub mod capture;
pub mod chaos;
pub mod color;
pub mod error;
pub mod exif;
pub mod fsutil;
pub mod image;
/// Temporary folders for tests (this crate's and `fipt-dataset`'s).
#[doc(hidden)]
pub mod test_temp;

pub use error::{CoreError, Result};
