//! # fipt-core
//!
//! The plain data and the contracts of fipt-rs, shared by every other crate. The data layers
//! below it are crates of their own, re-exported here at the same paths: `fipt-data` (the
//! error, atomic files, colour, images, EXIF, captures' response) and `fipt-dataset`
//! (cameras, lenses, the scene layouts):
//!
//! * [`image::Image`]: linear RGB images with EXR (f32/half, channels by name) and sRGB PNG I/O;
//! * [`camera::Camera`]: pinhole cameras in both pose conventions users have
//!   (Mitsuba `transforms.json`, OpenCV `cam.txt` + `K_list.txt`), pixel-centre rays;
//! * [`dataset::Dataset`]: the reference scene layouts, opened with validation that names the
//!   file and the fix;
//! * [`materials::SceneMaterials`]: ground-truth per-face materials and emitters
//!   (`scene_gt.json`, or a Mitsuba `scene_parts.json`);
//! * [`brdf::Brdf`]: the BRDF contract (eval includes cos θi);
//! * [`reflectance::ReflectanceModel`]: the reflectance models (FIPT, principled) and every
//!   formula they decide: metallic workflow, masking, diffuse lobe, the factorised image;
//! * [`emitter::EmitterExtractor`]: which triangles emit, grouped into lights;
//! * [`field::MaterialField`]: the BRDF field and emission mask contract;
//! * [`trainer::FieldTrainer`]: fits a field to a [`training_set::TrainingSet`] (FIPT's
//!   training rounds call it; the hash-grid trainer of `fipt-neural` is the built-in one);
//! * [`fit::MaterialFitter`]: a method that fits a field to the views (FIPT's rounds are one, registered as `fipt`);
//! * [`shading`]: the factorised shading model, [`shading::RayQuery`] and the
//!   [`shading::ShadingBaker`] and [`shading::ShadingRefiner`] contracts;
//! * [`rng::Pcg32`], [`disjoint::DisjointSets`], [`metrics`], atomic file writing in
//!   [`fsutil`], the output folder's lock in [`lock`].
//!
//! ```
//! use fipt_core::camera::Camera;
//! use glam::Vec3;
//! let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, 64, 48);
//! let (origin, dir) = cam.pixel_center_ray(32, 24);
//! assert_eq!(origin, Vec3::ZERO);
//! assert!(dir.z > 0.99);
//! ```
pub mod brdf;
pub use fipt_data::capture;
pub use fipt_data::chaos;
pub use fipt_data::color;
pub use fipt_dataset::camera;
pub use fipt_dataset::camera_files;
pub use fipt_dataset::capture_layout;
pub use fipt_dataset::colmap;
pub mod cube;
pub mod disjoint;
pub use fipt_dataset::dataset;
pub use fipt_dataset::distortion;
pub mod emitter;
pub use fipt_data::error;
pub use fipt_data::exif;
pub mod external_model;
pub mod field;
pub mod fit;
pub mod hash;
pub mod parted;
pub use fipt_data::fsutil;
pub use fipt_data::image;
pub mod lock;
pub mod materials;
pub mod memory;
pub mod metrics;
pub use fipt_dataset::nerfstudio;
pub mod presets;
pub mod range;
pub mod reflectance;
pub mod rng;
pub mod shading;
pub mod trainer;
pub mod training_set;
pub mod view_stats;

pub use error::{CoreError, Result};
