//! Ground-truth scene description: per-face materials and emitters (`scene_gt.json`).
//!
//! Materials follow the metallic workflow of FIPT (method §2): base colour `a`, roughness σ,
//! metallic `m`; kd and ks by [`crate::reflectance::metallic_workflow`]. Emitters are opaque, double-sided,
//! reflect nothing and have constant radiance.
//!
//! Parameters may vary in space through procedural [`Texture`]s evaluated at world positions,
//! so no UV coordinates are needed. The Mitsuba `studio` scene's `scene_parts.json` is imported
//! by [`SceneMaterials::from_scene_parts`].
use crate::color::Rgb;
use crate::emitter::EmitSide;
use crate::error::{CoreError, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A value that may vary in space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Texture {
    /// Grey constant.
    Scalar(f32),
    /// RGB constant.
    Rgb([f32; 3]),
    /// A procedural pattern.
    Pattern(Pattern),
}

/// Procedural patterns, evaluated at a world position `p` through planar coordinates
/// `(s, t) = ((p − origin)·u_axis, (p − origin)·v_axis)` (the axes carry the scale).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Pattern {
    /// Mitsuba's checkerboard rule: `color0` where `frac(s) > 0.5` equals `frac(t) > 0.5`.
    Checker {
        color0: [f32; 3],
        color1: [f32; 3],
        origin: [f32; 3],
        u_axis: [f32; 3],
        v_axis: [f32; 3],
    },
    /// Bands along `s`: `color0` where `frac(s) < duty`, else `color1`.
    Stripes {
        color0: [f32; 3],
        color1: [f32; 3],
        origin: [f32; 3],
        u_axis: [f32; 3],
        duty: f32,
    },
}

impl Texture {
    /// Value at world position `p`.
    pub fn eval(&self, p: Vec3) -> Rgb {
        match self {
            Texture::Scalar(v) => Vec3::splat(*v),
            Texture::Rgb(c) => Vec3::from_array(*c),
            Texture::Pattern(Pattern::Checker {
                color0,
                color1,
                origin,
                u_axis,
                v_axis,
            }) => {
                let d = p - Vec3::from_array(*origin);
                let s = d.dot(Vec3::from_array(*u_axis));
                let t = d.dot(Vec3::from_array(*v_axis));
                let ms = s - s.floor() > 0.5;
                let mt = t - t.floor() > 0.5;
                Vec3::from_array(if ms == mt { *color0 } else { *color1 })
            }
            Texture::Pattern(Pattern::Stripes {
                color0,
                color1,
                origin,
                u_axis,
                duty,
            }) => {
                let s = (p - Vec3::from_array(*origin)).dot(Vec3::from_array(*u_axis));
                Vec3::from_array(if s - s.floor() < *duty {
                    *color0
                } else {
                    *color1
                })
            }
        }
    }

    /// Whether the texture is a constant.
    pub fn is_constant(&self) -> bool {
        !matches!(self, Texture::Pattern(_))
    }
}

/// One material of the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialDesc {
    /// FIPT's metallic-workflow BRDF.
    Principled {
        name: String,
        base_color: Texture,
        /// σ ∈ [0.02, 1]; GGX α = σ².
        roughness: Texture,
        /// m ∈ [0, 1].
        metallic: Texture,
    },
    /// An opaque, black emitter of constant radiance, on both sides unless `one_sided` (then
    /// only towards the side its triangles' winding faces, as Mitsuba's area lights).
    Emitter {
        name: String,
        radiance: [f32; 3],
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        one_sided: bool,
    },
}

impl MaterialDesc {
    pub fn name(&self) -> &str {
        match self {
            MaterialDesc::Principled { name, .. } | MaterialDesc::Emitter { name, .. } => name,
        }
    }
    pub fn is_emitter(&self) -> bool {
        matches!(self, MaterialDesc::Emitter { .. })
    }
    /// The side an emitter emits from (both for reflecting materials, which emit nothing).
    pub fn emit_side(&self) -> EmitSide {
        match self {
            MaterialDesc::Emitter {
                one_sided: true, ..
            } => EmitSide::Front,
            _ => EmitSide::Both,
        }
    }
}

/// Material parameters at a surface point (what the ground-truth maps store).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SurfacePoint {
    pub kd: Rgb,
    pub ks: Rgb,
    pub roughness: f32,
    pub metallic: f32,
    pub emission: Rgb,
}

impl SurfacePoint {
    /// `a′ = kd + ks` (the simple albedo proxy written to `albedo/`).
    pub fn albedo(&self) -> Rgb {
        self.kd + self.ks
    }
}

pub use crate::reflectance::MIN_ROUGHNESS;

/// A contiguous range of faces `[start, end)` sharing a material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaceRange {
    pub start: u32,
    pub end: u32,
    pub material: u32,
}

/// Per-face materials of a mesh: the content of `scene_gt.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneMaterials {
    /// Format version (1).
    pub version: u32,
    pub materials: Vec<MaterialDesc>,
    /// Face ranges in the mesh's file order; every face must be covered exactly once.
    pub faces: Vec<FaceRange>,
    /// Free-form note (what generated it).
    #[serde(default)]
    pub note: String,
}

impl SceneMaterials {
    /// Per-face material index for a mesh of `num_faces` faces; checks coverage.
    pub fn face_table(&self, num_faces: usize, path: &Path) -> Result<Vec<u32>> {
        let mut table = vec![u32::MAX; num_faces];
        for r in &self.faces {
            if r.end as usize > num_faces || r.start > r.end {
                return Err(CoreError::invalid(
                    path,
                    format!("face range [{}, {}) is outside the mesh's {num_faces} faces: is this the right mesh?", r.start, r.end),
                ));
            }
            if r.material as usize >= self.materials.len() {
                return Err(CoreError::invalid(
                    path,
                    format!(
                        "face range [{}, {}) names material {} of {}",
                        r.start,
                        r.end,
                        r.material,
                        self.materials.len()
                    ),
                ));
            }
            for f in r.start..r.end {
                if table[f as usize] != u32::MAX {
                    return Err(CoreError::invalid(
                        path,
                        format!("face {f} is listed twice"),
                    ));
                }
                table[f as usize] = r.material;
            }
        }
        if let Some(f) = table.iter().position(|&m| m == u32::MAX) {
            let missing = table.iter().filter(|&&m| m == u32::MAX).count();
            return Err(CoreError::invalid(path, format!("{missing} faces have no material (first: face {f}); the table must cover every face of the mesh")));
        }
        Ok(table)
    }

    /// Material parameters of material `m` at world position `p`.
    pub fn eval(&self, m: u32, p: Vec3) -> SurfacePoint {
        match &self.materials[m as usize] {
            MaterialDesc::Principled {
                base_color,
                roughness,
                metallic,
                ..
            } => {
                let a = base_color.eval(p).clamp(Vec3::ZERO, Vec3::ONE);
                let mtl = metallic.eval(p).x.clamp(0.0, 1.0);
                let (kd, ks) = crate::reflectance::metallic_workflow(a, mtl);
                SurfacePoint {
                    kd,
                    ks,
                    roughness: roughness.eval(p).x.clamp(MIN_ROUGHNESS, 1.0),
                    metallic: mtl,
                    emission: Vec3::ZERO,
                }
            }
            MaterialDesc::Emitter { radiance, .. } => SurfacePoint {
                kd: Vec3::ZERO,
                ks: Vec3::ZERO,
                roughness: 1.0,
                metallic: 0.0,
                emission: Vec3::from_array(*radiance),
            },
        }
    }

    /// Reads `scene_gt.json`.
    pub fn read(path: &Path) -> Result<Self> {
        let s: SceneMaterials = crate::fsutil::read_json(path)?;
        if s.version != 1 {
            return Err(CoreError::invalid(
                path,
                format!(
                    "unsupported version {} (this fipt reads version 1)",
                    s.version
                ),
            ));
        }
        Ok(s)
    }

    /// The material table of scene folder `scene`: `fipt synth`'s `scene_gt.json`, else the
    /// Mitsuba rooms' `scene_parts.json` (a scene holds one of them); None without either.
    pub fn file_in(scene: &Path) -> Option<std::path::PathBuf> {
        ["scene_gt.json", "scene_parts.json"]
            .map(|f| scene.join(f))
            .into_iter()
            .find(|p| p.is_file())
    }

    /// Reads either fipt's `scene_gt.json` or a Mitsuba-style `scene_parts.json` (detected by
    /// its `objects` key).
    pub fn read_any(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| CoreError::io(path, e))?;
        let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| CoreError::Json {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        if v.get("objects").is_some() {
            Self::from_scene_parts(&v, path)
        } else {
            Self::read(path)
        }
    }

    /// Imports a `scene_parts.json` table (objects with face ranges, `principled` or `emitter`).
    /// Base colour, roughness and metallic are each a number, an RGB triple or a checker
    /// (`color0`/`color1` numbers or triples), defined on the object's bounding box: u along +x,
    /// v along −z (the floor quad's uv in the studio scene), scaled by `uv_scale`. Anything
    /// else is an error naming the object.
    pub fn from_scene_parts(v: &serde_json::Value, path: &Path) -> Result<Self> {
        let rd = PartsReader { path };
        let bad = |m: String| CoreError::invalid(path, m);
        let objects = v["objects"]
            .as_array()
            .ok_or_else(|| bad("`objects` is not a list".into()))?;
        // Emitters are one-sided where the table's conventions say so (Mitsuba's area lights).
        let one_sided = v["gt_conventions"]["emitters"]
            .as_str()
            .is_some_and(|s| s.contains("one-sided"));
        let mut materials = Vec::new();
        let mut faces = Vec::new();
        for (i, o) in objects.iter().enumerate() {
            let name = o["name"].as_str().unwrap_or("object").to_string();
            let start = o["face_start"]
                .as_u64()
                .ok_or_else(|| bad(format!("object {i} has no face_start")))?
                as u32;
            let end = o["face_end"]
                .as_u64()
                .ok_or_else(|| bad(format!("object {i} has no face_end")))?
                as u32;
            let mat = match o["type"].as_str() {
                Some("emitter") => MaterialDesc::Emitter {
                    name,
                    radiance: rd.arr3(&o["radiance"], "radiance")?,
                    one_sided,
                },
                Some("principled") => MaterialDesc::Principled {
                    base_color: rd.param(o, "base_color", None)?,
                    roughness: rd.param(o, "roughness", Some(1.0))?,
                    metallic: rd.param(o, "metallic", Some(0.0))?,
                    name,
                },
                other => return Err(bad(format!("object {name}: unknown type {other:?}"))),
            };
            faces.push(FaceRange {
                start,
                end,
                material: materials.len() as u32,
            });
            materials.push(mat);
        }
        Ok(SceneMaterials {
            version: 1,
            materials,
            faces,
            note: format!("imported from {}", path.display()),
        })
    }
}

/// Reads the values of a `scene_parts.json` table, errors naming its file.
struct PartsReader<'a> {
    path: &'a Path,
}

impl PartsReader<'_> {
    fn bad(&self, m: String) -> CoreError {
        CoreError::invalid(self.path, m)
    }

    fn arr3(&self, x: &serde_json::Value, what: &str) -> Result<[f32; 3]> {
        let a = x
            .as_array()
            .filter(|a| a.len() == 3)
            .ok_or_else(|| self.bad(format!("{what} is not a 3-vector")))?;
        let mut out = [0.0; 3];
        for (o, e) in out.iter_mut().zip(a) {
            *o = e
                .as_f64()
                .ok_or_else(|| self.bad(format!("{what} holds a non-number")))?
                as f32;
        }
        Ok(out)
    }

    /// A colour or a scalar: a number stands for its grey.
    fn value(&self, x: &serde_json::Value, what: &str) -> Result<[f32; 3]> {
        match x.as_f64() {
            Some(v) => Ok([v as f32; 3]),
            None => self.arr3(x, what),
        }
    }

    /// A parameter: a constant, or a checker over the object's bounding box. A missing
    /// parameter takes `default`, or is an error where there is none.
    fn param(&self, o: &serde_json::Value, key: &str, default: Option<f32>) -> Result<Texture> {
        let x = &o[key];
        let what = format!("object {}: {key}", o["name"].as_str().unwrap_or("?"));
        if x.is_null() {
            return default
                .map(Texture::Scalar)
                .ok_or_else(|| self.bad(format!("{what} is missing")));
        }
        if let Some(v) = x.as_f64() {
            return Ok(Texture::Scalar(v as f32));
        }
        if x.is_array() {
            return Ok(Texture::Rgb(self.arr3(x, &what)?));
        }
        if x["type"].as_str() != Some("checker") {
            return Err(self.bad(format!(
                "{what} is {x}: expected a number, an RGB triple or a checker"
            )));
        }
        let lo = self.arr3(&o["bbox"][0], &format!("{what}: the object's bbox[0]"))?;
        let hi = self.arr3(&o["bbox"][1], &format!("{what}: the object's bbox[1]"))?;
        let scale = |i: usize| x["uv_scale"][i].as_f64().map(|v| v as f32);
        let (Some(su), Some(sv)) = (scale(0), scale(1)) else {
            return Err(self.bad(format!(
                "{what}: a checker needs uv_scale = [u, v] (numbers)"
            )));
        };
        let ex = (hi[0] - lo[0]).max(1e-9);
        let ez = (hi[2] - lo[2]).max(1e-9);
        Ok(Texture::Pattern(Pattern::Checker {
            color0: self.value(&x["color0"], &format!("{what}.color0"))?,
            color1: self.value(&x["color1"], &format!("{what}.color1"))?,
            origin: [lo[0], lo[1], hi[2]],
            u_axis: [su / ex, 0.0, 0.0],
            v_axis: [0.0, 0.0, -sv / ez],
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metallic_workflow_and_json_round_trip() {
        let s = SceneMaterials {
            version: 1,
            materials: vec![
                MaterialDesc::Principled {
                    name: "gold".into(),
                    base_color: Texture::Rgb([1.0, 0.8, 0.2]),
                    roughness: Texture::Scalar(0.001),
                    metallic: Texture::Scalar(1.0),
                },
                MaterialDesc::Emitter {
                    name: "lamp".into(),
                    radiance: [5.0, 4.0, 3.0],
                    one_sided: true,
                },
                MaterialDesc::Principled {
                    name: "floor".into(),
                    base_color: Texture::Pattern(Pattern::Checker {
                        color0: [1.0, 0.0, 0.0],
                        color1: [0.0, 1.0, 0.0],
                        origin: [0.0; 3],
                        u_axis: [1.0, 0.0, 0.0],
                        v_axis: [0.0, 0.0, 1.0],
                    }),
                    roughness: Texture::Scalar(0.5),
                    metallic: Texture::Scalar(0.0),
                },
            ],
            faces: vec![
                FaceRange {
                    start: 0,
                    end: 2,
                    material: 0,
                },
                FaceRange {
                    start: 2,
                    end: 3,
                    material: 1,
                },
                FaceRange {
                    start: 3,
                    end: 4,
                    material: 2,
                },
            ],
            note: String::new(),
        };
        let text = serde_json::to_string(&s).unwrap();
        let back: SceneMaterials = serde_json::from_str(&text).unwrap();
        assert_eq!(s, back);
        let g = s.eval(0, Vec3::ZERO);
        assert_eq!(g.kd, Vec3::ZERO);
        assert_eq!(g.ks, Vec3::new(1.0, 0.8, 0.2));
        assert_eq!(
            g.roughness, MIN_ROUGHNESS,
            "roughness is clamped to the model's range"
        );
        let e = s.eval(1, Vec3::ZERO);
        assert_eq!(e.emission, Vec3::new(5.0, 4.0, 3.0));
        assert_eq!(
            s.eval(2, Vec3::new(0.25, 0.0, 0.25)).kd,
            Vec3::new(1.0, 0.0, 0.0)
        );
        assert_eq!(
            s.eval(2, Vec3::new(0.75, 0.0, 0.25)).kd,
            Vec3::new(0.0, 1.0, 0.0)
        );
        assert!((s.eval(2, Vec3::ZERO).ks - Vec3::splat(0.04)).length() < 1e-7);
        assert_eq!(s.face_table(4, Path::new("t")).unwrap(), vec![0, 0, 1, 2]);
        let err = s
            .face_table(5, Path::new("t.json"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("1 faces have no material"), "{err}");
        assert!(s.face_table(3, Path::new("t.json")).is_err());
    }

    #[test]
    fn scene_parts_checkers_drive_base_colour_roughness_and_metallic() {
        // A 2 m × 2 m tile field: 2 × 2 checks, metal gold where color0, black dielectric else.
        let parts = serde_json::json!({"objects": [{
            "name": "tray", "type": "principled", "face_start": 0, "face_end": 2,
            "bbox": [[0.0, 0.0, 0.0], [2.0, 0.1, 2.0]],
            "base_color": {"type": "checker", "color0": [1.0, 0.8, 0.3], "color1": [0.05, 0.05, 0.05], "uv_scale": [2.0, 2.0]},
            "roughness": {"type": "checker", "color0": 0.25, "color1": 0.6, "uv_scale": [2.0, 2.0]},
            "metallic": {"type": "checker", "color0": 1.0, "color1": 0.0, "uv_scale": [2.0, 2.0]}
        }]});
        let s = SceneMaterials::from_scene_parts(&parts, Path::new("p.json")).unwrap();
        // u = x / 2, v = (2 − z) / 2; color0 where frac(2u) > 0.5 equals frac(2v) > 0.5.
        let gold = s.eval(0, Vec3::new(0.75, 0.1, 0.25));
        let black = s.eval(0, Vec3::new(0.25, 0.1, 0.25));
        assert_eq!((gold.roughness, black.roughness), (0.25, 0.6));
        assert_eq!((gold.metallic, black.metallic), (1.0, 0.0));
        assert_eq!(gold.kd, Vec3::ZERO);
        assert_eq!(gold.ks, Vec3::new(1.0, 0.8, 0.3));
        assert!((black.kd - Vec3::splat(0.05)).length() < 1e-7);
        let bad = serde_json::json!({"objects": [{
            "name": "floor", "type": "principled", "face_start": 0, "face_end": 2,
            "base_color": 0.5, "roughness": {"type": "noise"}
        }]});
        let err = SceneMaterials::from_scene_parts(&bad, Path::new("p.json"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("p.json") && err.contains("floor: roughness"),
            "{err}"
        );
        let bare = serde_json::json!({"objects": [{
            "name": "wall", "type": "principled", "face_start": 0, "face_end": 2
        }]});
        let err = SceneMaterials::from_scene_parts(&bare, Path::new("p.json"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("wall: base_color is missing"), "{err}");
        let unscaled = serde_json::json!({"objects": [{
            "name": "rug", "type": "principled", "face_start": 0, "face_end": 2,
            "bbox": [[0.0, 0.0, 0.0], [2.0, 0.1, 2.0]],
            "base_color": {"type": "checker", "color0": 0.2, "color1": 0.8, "uv_scale": []}
        }]});
        let err = SceneMaterials::from_scene_parts(&unscaled, Path::new("p.json"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("rug: base_color: a checker needs uv_scale"),
            "{err}"
        );
    }

    #[test]
    fn unknown_keys_are_rejected() {
        let bad = r#"{"version":1,"materials":[{"type":"emitter","name":"l","radiance":[1,1,1],"power":3}],"faces":[]}"#;
        let err = serde_json::from_str::<SceneMaterials>(bad)
            .unwrap_err()
            .to_string();
        assert!(err.contains("power"), "{err}");
    }
}
