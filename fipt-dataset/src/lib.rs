//! Cameras and scenes, re-exported by `fipt-core` at the same paths
//! (`fipt_core::dataset::Dataset`, `fipt_core::camera::Camera`, …):
//!
//! * [`camera::Camera`]: pinhole cameras in both pose conventions users have (Mitsuba
//!   `transforms.json`, OpenCV `cam.txt` + `K_list.txt`), pixel-centre rays, lens models
//!   ([`distortion`]);
//! * [`dataset::Dataset`]: the reference scene layouts and the capture layouts
//!   ([`capture_layout`]: COLMAP in [`colmap`], nerfstudio in [`nerfstudio`]), opened with
//!   validation that names the file and the fix; [`camera_files`] writes them.
pub mod camera;
pub mod camera_files;
pub mod capture_layout;
pub mod colmap;
pub mod dataset;
pub mod distortion;
mod inputs;
pub mod nerfstudio;

#[cfg(test)]
use fipt_data::test_temp;
use fipt_data::{capture, color, error, exif, fsutil, image};
