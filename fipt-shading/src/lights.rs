//! Lights added to a scene for relighting (`lights.json`), and what happens to the scene's own
//! emitters.
//!
//! Area lights (spheres, quads, OBJ meshes) become emitting triangles appended to the scene
//! mesh, so the tracer samples them with the scene's emitters (next-event estimation + MIS);
//! point and spot lights are [`DeltaLight`]s, sampled every vertex without MIS (a delta
//! distribution cannot be hit). Units: `radiance` (W·m⁻²·sr⁻¹) for area lights, `intensity`
//! (W·sr⁻¹) for point and spot lights; positions in scene units.
//!
//! A file holds either one light object (as `studio-mitsuba/relight/light.json`) or
//! `{"lights": [...], "emitters": ..., "emitter_overrides": {...}, "comment": ...}`. In a light
//! object, string-valued keys that are no field of any light are notes and ignored (that file
//! carries four); any other unknown key is an error naming it.
use crate::error::{Result, ShadingError};
use fipt_core::color::Rgb;
use fipt_geom::Mesh;
use glam::{EulerRot, Mat3, Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// A placement: scale, then rotation (XYZ Euler angles in degrees), then translation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transform {
    #[serde(default)]
    pub translate: [f32; 3],
    #[serde(default)]
    pub rotate_deg: [f32; 3],
    /// Uniform scale (default 1).
    #[serde(default)]
    pub scale: Option<f32>,
}

impl Transform {
    /// Range checks: a finite translation and rotation, a scale in (0, 1e6].
    pub fn check(&self) -> std::result::Result<(), String> {
        finite3("translate", self.translate)?;
        if !self.rotate_deg.iter().all(|r| r.is_finite()) {
            return Err(format!("`rotate_deg` {:?} is not finite", self.rotate_deg));
        }
        let most = fipt_core::range::MAX_EXTENT;
        match self.scale {
            Some(k) if !(k > 0.0 && k <= most) => {
                Err(format!("`scale` {k} must be in (0, {most:e}]"))
            }
            _ => Ok(()),
        }
    }

    pub fn matrix(&self) -> Mat4 {
        let r = self.rotate_deg.map(f32::to_radians);
        Mat4::from_scale_rotation_translation(
            Vec3::splat(self.scale.unwrap_or(1.0)),
            Quat::from_euler(EulerRot::XYZ, r[0], r[1], r[2]),
            Vec3::from(self.translate),
        )
    }

    /// Applies the placement to a mesh (positions and normals).
    pub fn apply(&self, mesh: &mut Mesh) {
        let m = self.matrix();
        let nm = Mat3::from_mat4(m).inverse().transpose();
        for p in &mut mesh.positions {
            *p = m.transform_point3(*p);
        }
        if let Some(ns) = &mut mesh.normals {
            for n in ns {
                *n = (nm * *n).normalize_or_zero();
            }
        }
    }
}

fn default_subdivisions() -> u32 {
    3
}
fn default_true() -> bool {
    true
}
fn default_cutoff() -> f32 {
    20.0
}

/// One light of `lights.json`, tagged by `"type"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightSpec {
    /// A sphere emitting `radiance` from its outside (an icosphere of 20·4^subdivisions
    /// triangles; 3 gives the 1280 of `studio-mitsuba`'s `light.obj`).
    Sphere {
        center: [f32; 3],
        radius: f32,
        radiance: [f32; 3],
        #[serde(default = "default_subdivisions")]
        subdivisions: u32,
    },
    /// A parallelogram `corner + s·edge1 + t·edge2` emitting towards `edge1 × edge2` (both
    /// ways when `two_sided`).
    Quad {
        corner: [f32; 3],
        edge1: [f32; 3],
        edge2: [f32; 3],
        radiance: [f32; 3],
        #[serde(default)]
        two_sided: bool,
    },
    /// Every triangle of an OBJ / PLY / glTF file (relative to the lights file) emits.
    Mesh {
        file: PathBuf,
        radiance: [f32; 3],
        #[serde(default)]
        transform: Transform,
        #[serde(default = "default_true")]
        two_sided: bool,
    },
    /// An isotropic point light.
    Point {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    /// A spot light: full intensity within `beam_width` degrees of `direction`, falling
    /// smoothly to 0 at `cutoff_angle` (default 20°; `beam_width` defaults to ¾ of it).
    Spot {
        position: [f32; 3],
        direction: [f32; 3],
        intensity: [f32; 3],
        #[serde(default = "default_cutoff")]
        cutoff_angle: f32,
        #[serde(default)]
        beam_width: Option<f32>,
    },
}

/// What happens to the scene's own emitters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EmitterPolicy {
    Keep,
    Off,
    Scale(f32),
}

impl EmitterPolicy {
    /// The factor on the emitted radiance.
    pub fn factor(self) -> f32 {
        match self {
            EmitterPolicy::Keep => 1.0,
            EmitterPolicy::Off => 0.0,
            EmitterPolicy::Scale(k) => k,
        }
    }
}

impl std::str::FromStr for EmitterPolicy {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "keep" => Ok(EmitterPolicy::Keep),
            "off" => Ok(EmitterPolicy::Off),
            _ => match s.strip_prefix("scale=").map(str::parse::<f32>) {
                Some(Ok(k)) if (0.0..=fipt_core::range::MAX_RADIANCE).contains(&k) => {
                    Ok(EmitterPolicy::Scale(k))
                }
                _ => Err(format!(
                    "`{s}`: expected keep, off or scale=K with K in [0, {:e}]",
                    fipt_core::range::MAX_RADIANCE
                )),
            },
        }
    }
}

impl<'de> Deserialize<'de> for EmitterPolicy {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Word(String),
            Scale { scale: f32 },
            Other(serde_json::Value),
        }
        // A file's forms are "keep", "off" and {"scale": K}; the command line's `scale=K` is
        // accepted too, but the message names the file's.
        let file_form = |shown: String| {
            serde::de::Error::custom(format!(
                "{shown}: expected \"keep\", \"off\" or {{\"scale\": K}} with K in [0, {:e}]",
                fipt_core::range::MAX_RADIANCE
            ))
        };
        match Raw::deserialize(d)? {
            Raw::Word(s) => s.parse().map_err(|_| file_form(format!("\"{s}\""))),
            Raw::Scale { scale } => format!("scale={scale}")
                .parse()
                .map_err(|_| file_form(format!("{{\"scale\": {scale}}}"))),
            Raw::Other(v) => Err(file_form(v.to_string())),
        }
    }
}

/// A parsed `lights.json`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightsFile {
    pub lights: Vec<LightSpec>,
    /// The scene's emitters (None: the caller's default).
    pub emitters: Option<EmitterPolicy>,
    /// Per emitter id of `emitters.json`.
    pub overrides: BTreeMap<u32, EmitterPolicy>,
    /// The folder relative paths are resolved against.
    pub dir: PathBuf,
}

const LIGHT_FIELDS: [&str; 16] = [
    "type",
    "center",
    "radius",
    "radiance",
    "subdivisions",
    "corner",
    "edge1",
    "edge2",
    "two_sided",
    "file",
    "transform",
    "position",
    "direction",
    "intensity",
    "cutoff_angle",
    "beam_width",
];

fn invalid(path: &Path, message: impl Into<String>) -> ShadingError {
    ShadingError::Invalid {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

fn parse_light(path: &Path, k: usize, mut v: serde_json::Value) -> Result<LightSpec> {
    if let Some(obj) = v.as_object_mut() {
        obj.retain(|key, val| LIGHT_FIELDS.contains(&key.as_str()) || !val.is_string());
    }
    let spec: LightSpec = serde_json::from_value(v).map_err(|e| {
        invalid(
            path,
            format!("light {k}: {e} (types: sphere, quad, mesh, point, spot; see docs/relighting-and-export.md, section lights.json)"),
        )
    })?;
    spec.check()
        .map_err(|m| invalid(path, format!("light {k}: {m}")))?;
    Ok(spec)
}

impl LightsFile {
    /// The lights whose place (a sphere's centre, a quad's corners, a point or spot light's
    /// position; not a mesh light, whose file is read later) lies outside the box `lo`–`hi`
    /// widened by a tenth of its size: in a closed room they light nothing the cameras see.
    pub fn outside(&self, lo: Vec3, hi: Vec3) -> Vec<usize> {
        let m = 0.1 * (hi - lo);
        let inside = |p: Vec3| p.cmpge(lo - m).all() && p.cmple(hi + m).all();
        (self.lights.iter().enumerate())
            .filter(|(_, l)| {
                let places: Vec<Vec3> = match l {
                    LightSpec::Sphere { center, .. } => vec![Vec3::from(*center)],
                    LightSpec::Quad {
                        corner,
                        edge1,
                        edge2,
                        ..
                    } => {
                        let (c, a, b) =
                            (Vec3::from(*corner), Vec3::from(*edge1), Vec3::from(*edge2));
                        vec![c, c + a, c + b, c + a + b]
                    }
                    LightSpec::Point { position, .. } | LightSpec::Spot { position, .. } => {
                        vec![Vec3::from(*position)]
                    }
                    LightSpec::Mesh { .. } => vec![],
                };
                !places.is_empty() && !places.into_iter().any(inside)
            })
            .map(|(k, _)| k)
            .collect()
    }

    /// Refuses a sphere light that encloses a camera of `origins` (index `k` named): its
    /// outside faces away from the camera, which would see nothing at all.
    pub fn check_cameras(&self, path: &Path, origins: &[Vec3]) -> Result<()> {
        for (i, l) in self.lights.iter().enumerate() {
            if let LightSpec::Sphere { center, radius, .. } = l {
                let inside = origins
                    .iter()
                    .position(|o| o.distance(Vec3::from(*center)) < *radius);
                if let Some(k) = inside {
                    return Err(invalid(
                        path,
                        format!("light {i}: the sphere (radius {radius} m) encloses camera {k}, which would see only its dark inside: make it smaller or move it"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads and checks a lights file.
    pub fn read(path: &Path) -> Result<LightsFile> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| invalid(path, format!("cannot read the lights file: {e}")))?;
        Self::parse(&text, path)
    }

    /// Parses a lights file's text (`path` names it in errors and anchors relative paths).
    pub fn parse(text: &str, path: &Path) -> Result<LightsFile> {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| invalid(path, format!("invalid JSON: {e}")))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let serde_json::Value::Object(mut top) = v else {
            return Err(invalid(
                path,
                "expected a JSON object (one light, or {\"lights\": [...]})",
            ));
        };
        if top.contains_key("type") {
            let spec = parse_light(path, 0, serde_json::Value::Object(top))?;
            return Ok(LightsFile {
                lights: vec![spec],
                dir,
                ..Default::default()
            });
        }
        let mut out = LightsFile {
            dir,
            ..Default::default()
        };
        let lights = top.remove("lights").ok_or_else(|| {
            invalid(
                path,
                "no `lights` array and no `type`: expected one light or {\"lights\": [...]}",
            )
        })?;
        let serde_json::Value::Array(lights) = lights else {
            return Err(invalid(path, "`lights` must be an array"));
        };
        for (k, l) in lights.into_iter().enumerate() {
            out.lights.push(parse_light(path, k, l)?);
        }
        if let Some(e) = top.remove("emitters") {
            out.emitters = Some(
                serde_json::from_value(e).map_err(|e| invalid(path, format!("`emitters`: {e}")))?,
            );
        }
        if let Some(o) = top.remove("emitter_overrides") {
            let map: HashMap<String, EmitterPolicy> = serde_json::from_value(o)
                .map_err(|e| invalid(path, format!("`emitter_overrides`: {e}")))?;
            for (id, p) in map {
                let id: u32 = id.parse().map_err(|_| {
                    invalid(
                        path,
                        format!(
                            "`emitter_overrides`: `{id}` is not an emitter id of emitters.json"
                        ),
                    )
                })?;
                out.overrides.insert(id, p);
            }
        }
        if let Some(key) = top.keys().find(|k| *k != "comment") {
            return Err(invalid(
                path,
                format!(
                    "unknown key `{key}` (expected lights, emitters, emitter_overrides, comment)"
                ),
            ));
        }
        Ok(out)
    }
}

fn finite3(name: &str, v: [f32; 3]) -> std::result::Result<(), String> {
    let most = fipt_core::range::MAX_EXTENT;
    if v.iter().all(|x| x.abs() <= most) {
        Ok(())
    } else {
        Err(format!(
            "`{name}` {v:?} is not finite or beyond ±{most:e} m"
        ))
    }
}

fn nonnegative3(name: &str, v: [f32; 3]) -> std::result::Result<(), String> {
    let most = fipt_core::range::MAX_RADIANCE;
    if v.iter().all(|&x| (0.0..=most).contains(&x)) {
        Ok(())
    } else {
        Err(format!(
            "`{name}` {v:?} is not in [0, {most:e}] (a larger value overflows the tracer's f32)"
        ))
    }
}

impl LightSpec {
    /// Range checks (finite, positive sizes, non-negative radiance).
    pub fn check(&self) -> std::result::Result<(), String> {
        match self {
            LightSpec::Sphere {
                center,
                radius,
                radiance,
                subdivisions,
            } => {
                finite3("center", *center)?;
                nonnegative3("radiance", *radiance)?;
                let most = fipt_core::range::MAX_EXTENT;
                if !(*radius > 0.0 && *radius <= most) {
                    return Err(format!("`radius` {radius} must be in (0, {most:e}] m"));
                }
                if *subdivisions > 6 {
                    return Err(format!(
                        "`subdivisions` {subdivisions} > 6 (81,920 triangles)"
                    ));
                }
            }
            LightSpec::Quad {
                corner,
                edge1,
                edge2,
                radiance,
                ..
            } => {
                finite3("corner", *corner)?;
                finite3("edge1", *edge1)?;
                finite3("edge2", *edge2)?;
                nonnegative3("radiance", *radiance)?;
                let n = Vec3::from(*edge1).cross(Vec3::from(*edge2));
                if !(n.is_finite() && n.length() > 0.0) {
                    return Err("`edge1` and `edge2` span no area".into());
                }
            }
            LightSpec::Mesh {
                radiance,
                transform,
                ..
            } => {
                nonnegative3("radiance", *radiance)?;
                transform.check()?;
            }
            LightSpec::Point {
                position,
                intensity,
            } => {
                finite3("position", *position)?;
                nonnegative3("intensity", *intensity)?;
            }
            LightSpec::Spot {
                position,
                direction,
                intensity,
                cutoff_angle,
                beam_width,
            } => {
                finite3("position", *position)?;
                finite3("direction", *direction)?;
                nonnegative3("intensity", *intensity)?;
                if !(Vec3::from(*direction).length() > 0.0) {
                    return Err("`direction` must be a non-zero vector".into());
                }
                if !(*cutoff_angle > 0.0 && *cutoff_angle <= 90.0) {
                    return Err(format!("`cutoff_angle` {cutoff_angle}° must be in (0, 90]"));
                }
                if let Some(b) = beam_width {
                    if !(*b > 0.0 && b <= cutoff_angle) {
                        return Err(format!(
                            "`beam_width` {b}° must be in (0, cutoff_angle = {cutoff_angle}°]"
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The triangles of an area light, its radiance and whether it emits from both sides
    /// (None for point and spot lights). `dir` anchors a mesh light's relative file.
    pub fn area(&self, dir: &Path) -> Result<Option<(Mesh, Rgb, bool)>> {
        Ok(Some(match self {
            LightSpec::Sphere {
                center,
                radius,
                radiance,
                subdivisions,
            } => (
                icosphere(Vec3::from(*center), *radius, *subdivisions),
                Vec3::from(*radiance),
                false,
            ),
            LightSpec::Quad {
                corner,
                edge1,
                edge2,
                radiance,
                two_sided,
            } => {
                let (c, a, b) = (Vec3::from(*corner), Vec3::from(*edge1), Vec3::from(*edge2));
                let mesh = Mesh::from_triangles(
                    vec![c, c + a, c + a + b, c + b],
                    None,
                    vec![[0, 1, 2], [0, 2, 3]],
                );
                (mesh, Vec3::from(*radiance), *two_sided)
            }
            LightSpec::Mesh {
                file,
                radiance,
                transform,
                two_sided,
            } => {
                let path = dir.join(file);
                if !path.is_file() {
                    return Err(invalid(
                        &path,
                        "mesh light file not found (paths are relative to the lights file)",
                    ));
                }
                let mut mesh = Mesh::load(&path)?;
                if mesh.triangles.is_empty() {
                    return Err(invalid(&path, "mesh light has no triangles"));
                }
                transform.apply(&mut mesh);
                (mesh, Vec3::from(*radiance), *two_sided)
            }
            LightSpec::Point { .. } | LightSpec::Spot { .. } => return Ok(None),
        }))
    }

    /// The delta light of a point or spot light.
    pub fn delta(&self) -> Option<DeltaLight> {
        match self {
            LightSpec::Point {
                position,
                intensity,
            } => Some(DeltaLight {
                position: Vec3::from(*position),
                intensity: Vec3::from(*intensity),
                spot: None,
            }),
            LightSpec::Spot {
                position,
                direction,
                intensity,
                cutoff_angle,
                beam_width,
            } => {
                let beam = beam_width.unwrap_or(0.75 * cutoff_angle);
                Some(DeltaLight {
                    position: Vec3::from(*position),
                    intensity: Vec3::from(*intensity),
                    spot: Some(Spot {
                        axis: Vec3::from(*direction).normalize(),
                        cos_cutoff: cutoff_angle.to_radians().cos(),
                        cos_beam: beam.to_radians().cos(),
                    }),
                })
            }
            _ => None,
        }
    }
}

/// The cone of a spot light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spot {
    pub axis: Vec3,
    pub cos_cutoff: f32,
    pub cos_beam: f32,
}

/// A point or spot light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeltaLight {
    pub position: Vec3,
    /// Radiant intensity on the axis (W·sr⁻¹).
    pub intensity: Rgb,
    pub spot: Option<Spot>,
}

impl DeltaLight {
    /// Intensity towards unit direction `w` (from the light).
    #[inline]
    pub fn intensity_towards(&self, w: Vec3) -> Rgb {
        match self.spot {
            None => self.intensity,
            Some(s) => {
                let c = w.dot(s.axis);
                if c <= s.cos_cutoff {
                    Vec3::ZERO
                } else if c >= s.cos_beam {
                    self.intensity
                } else {
                    let t = (c - s.cos_cutoff) / (s.cos_beam - s.cos_cutoff);
                    self.intensity * (t * t * (3.0 - 2.0 * t))
                }
            }
        }
    }
}

/// A sphere of 20·4^n triangles ([`fipt_geom::shapes::icosphere_mesh`]) wound outwards, with
/// outward vertex normals.
pub fn icosphere(center: Vec3, radius: f32, subdivisions: u32) -> Mesh {
    let mut m = fipt_geom::shapes::icosphere_mesh(center, radius, subdivisions);
    for t in 0..m.triangles.len() {
        let [a, b, c] = m.vertices(t);
        if (b - a).cross(c - a).dot((a + b + c) / 3.0 - center) < 0.0 {
            m.triangles[t].swap(1, 2);
        }
    }
    m.normals = Some(
        m.positions
            .iter()
            .map(|&p| (p - center).normalize())
            .collect(),
    );
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere or point light outside the room's box (widened by a tenth) is named; one in
    /// it, or a quad reaching into it, is not.
    #[test]
    fn lights_outside_the_scene_are_named() {
        let f = LightsFile::parse(
            r#"{"lights": [
                {"type": "sphere", "center": [9, 9, 9], "radius": 0.1, "radiance": [1, 1, 1]},
                {"type": "sphere", "center": [0, 1, 0], "radius": 0.1, "radiance": [1, 1, 1]},
                {"type": "point", "position": [0, -5, 0], "intensity": [1, 1, 1]},
                {"type": "quad", "corner": [3, 1, 0], "edge1": [-2.5, 0, 0], "edge2": [0, 0, 0.5], "radiance": [1, 1, 1]}
            ]}"#,
            Path::new("lights.json"),
        )
        .unwrap();
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0));
        assert_eq!(f.outside(lo, hi), [0, 2]);
    }

    #[test]
    fn studio_light_file_reads_as_one_sphere_with_notes_ignored() {
        let text = r#"{"type": "sphere", "center": [-1.1, 2.2, 0.7], "radius": 0.15,
            "radiance": [70.0, 66.0, 58.0], "geometry": "icosphere", "render": "path"}"#;
        let f = LightsFile::parse(text, Path::new("x/light.json")).unwrap();
        assert_eq!(f.lights.len(), 1);
        assert_eq!(f.emitters, None);
        let (mesh, le, two) = f.lights[0].area(&f.dir).unwrap().unwrap();
        assert_eq!(mesh.triangles.len(), 1280);
        assert_eq!(le, Vec3::new(70.0, 66.0, 58.0));
        assert!(!two);
        // Outward winding; the area approaches 4πr².
        let c = Vec3::new(-1.1, 2.2, 0.7);
        let mut area = 0.0;
        for t in 0..mesh.triangles.len() {
            let v = mesh.vertices(t);
            assert!(mesh.face_normal(t).dot((v[0] + v[1] + v[2]) / 3.0 - c) > 0.0);
            area += mesh.area(t);
        }
        let exact = 4.0 * std::f32::consts::PI * 0.15 * 0.15;
        assert!((area / exact - 1.0).abs() < 0.02, "area {area} vs {exact}");
    }

    #[test]
    fn bad_lights_name_the_problem() {
        let p = Path::new("l.json");
        let err = |t: &str| LightsFile::parse(t, p).unwrap_err().to_string();
        assert!(err(r#"{"type": "laser", "position": [0,0,0]}"#).contains("laser"));
        assert!(err(
            r#"{"type": "point", "position": [0,0,0], "intensity": [1,1,1], "radius": 2}"#
        )
        .contains("radius"));
        assert!(
            err(r#"{"type": "sphere", "center": [0,0,0], "radius": 0, "radiance": [1,1,1]}"#)
                .contains("radius")
        );
        assert!(err(r#"{"lights": [], "emitter": "off"}"#).contains("unknown key `emitter`"));
        assert!(err(r#"{"lights": [], "emiters": 3}"#).contains("emiters"));
        let dim = err(r#"{"lights": [], "emitters": "dim"}"#);
        assert!(
            dim.contains("\"dim\"") && dim.contains("{\"scale\": K}"),
            "{dim}"
        );
        assert!(
            !dim.contains("scale=K"),
            "a file's message names the file's form: {dim}"
        );
        let negative = err(r#"{"lights": [], "emitters": {"scale": -2}}"#);
        assert!(negative.contains("{\"scale\": -2}"), "{negative}");
        for other in [r#"3"#, r#"{"scale": "x"}"#, r#"{"factor": 2}"#] {
            let e = err(&format!(r#"{{"lights": [], "emitters": {other}}}"#));
            assert!(e.contains("{\"scale\": K}"), "{other}: {e}");
        }
        assert!(err(r#"{"lights": [], "emitter_overrides": {"a": "off"}}"#).contains("`a`"));
        assert!(err("[1]").contains("JSON object"));
    }

    #[test]
    fn emitter_policies_parse_from_words_and_objects() {
        let f = LightsFile::parse(
            r#"{"lights": [{"type": "point", "position": [0,1,0], "intensity": [5,5,5]}],
               "emitters": {"scale": 0.5}, "emitter_overrides": {"2": "off", "0": "keep"}}"#,
            Path::new("l.json"),
        )
        .unwrap();
        assert_eq!(f.emitters, Some(EmitterPolicy::Scale(0.5)));
        assert_eq!(f.overrides[&2], EmitterPolicy::Off);
        assert_eq!(f.overrides[&0], EmitterPolicy::Keep);
        assert_eq!(
            "scale=3".parse::<EmitterPolicy>(),
            Ok(EmitterPolicy::Scale(3.0))
        );
        assert!("scale=-1".parse::<EmitterPolicy>().is_err());
    }

    #[test]
    fn spot_falls_off_between_beam_and_cutoff() {
        let s = LightSpec::Spot {
            position: [0.0; 3],
            direction: [0.0, 0.0, -2.0],
            intensity: [4.0; 3],
            cutoff_angle: 30.0,
            beam_width: Some(10.0),
        }
        .delta()
        .unwrap();
        let at = |deg: f32| {
            let r = deg.to_radians();
            s.intensity_towards(Vec3::new(r.sin(), 0.0, -r.cos())).x
        };
        assert_eq!(at(0.0), 4.0);
        assert_eq!(at(9.0), 4.0);
        assert!(at(20.0) > 0.0 && at(20.0) < 4.0);
        assert_eq!(at(31.0), 0.0);
        assert_eq!(at(120.0), 0.0);
    }
}
