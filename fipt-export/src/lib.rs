//! # fipt-export
//!
//! A scene's recovered materials and lights in the formats other tools render:
//! * `glb`: glTF 2.0 binary, the mesh with a texture atlas (a chart per connected planar
//!   region) carrying the base colour (sRGB) and metallic-roughness (G = roughness, B =
//!   metallic) textures, and each emitter as its own primitive with an emissive material
//!   (`emissiveFactor` × `KHR_materials_emissive_strength` = its mean radiance);
//! * `mitsuba`: a Mitsuba 3 scene (`scene.xml`, OBJ meshes with texture coordinates, PNG
//!   textures, a `principled` BSDF, area emitters);
//! * `obj`: one OBJ with its MTL (`map_Kd`, and the PBR extension's `map_Pr` / `map_Pm`; `Ke`
//!   for emitters).
//!
//! Roughness is written as it is: σ is the perceptual roughness of glTF and of Mitsuba's
//! `principled` (α = σ²). Emitter triangles are oriented to face the centre of the scene's
//! bounds (area emitters of Mitsuba emit from the front only; rooms' lights face inwards).
//!
//! When a mesh has too many planar regions for an atlas of `max_atlas`² texels, `glb` falls
//! back to per-vertex materials (`COLOR_0` = base colour, custom attributes `_ROUGHNESS` and
//! `_METALLIC`; viewers show the colour), and the other formats refuse.
pub mod atlas;
mod glb;
pub mod load;
mod mitsuba;
mod obj;
pub mod textures;

use atlas::Atlas;
use fipt_core::color::Rgb;
use fipt_core::emitter::{EmitSide, Emitter};
use fipt_geom::Mesh;
use fipt_shading::scene::SurfaceModel;
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use textures::MaterialTextures;

pub use glb::write_glb;

/// Errors of exporting.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error(transparent)]
    Core(#[from] fipt_core::CoreError),
    #[error("{0}")]
    Invalid(String),
}

pub type Result<T, E = ExportError> = std::result::Result<T, E>;

/// An export format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    Glb,
    Mitsuba,
    Obj,
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Format::Glb => "glb",
            Format::Mitsuba => "mitsuba",
            Format::Obj => "obj",
        })
    }
}

impl std::str::FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "glb" => Ok(Format::Glb),
            "mitsuba" => Ok(Format::Mitsuba),
            "obj" => Ok(Format::Obj),
            _ => Err(format!("unknown format `{s}` (glb, mitsuba, obj)")),
        }
    }
}

/// Export settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportOptions {
    /// World size of a texel (grown until the atlas fits).
    pub texel_size: f32,
    /// Largest atlas edge in texels.
    pub max_atlas: u32,
    /// Per-vertex materials instead of textures (glb only).
    pub per_vertex: bool,
}

/// Bytes an atlas holds per texel while it is filled and written (its maps, coverage, the
/// texel positions queried and the 8-bit copies encoded).
pub const ATLAS_BYTES_PER_TEXEL: u64 = 64;

impl ExportOptions {
    /// Refuses a texel that is not a positive length up to 100 m and an atlas edge outside
    /// 16..=16384, naming the option.
    pub fn validate(&self) -> std::result::Result<(), String> {
        fipt_core::range::positive("--texel", self.texel_size as f64, 100.0)?;
        fipt_core::range::check("--max-atlas", self.max_atlas, 16, 16_384)
    }

    /// The most memory the atlas may take (`max_atlas`² texels).
    pub fn atlas_bytes(&self) -> u64 {
        (self.max_atlas as u64).pow(2) * ATLAS_BYTES_PER_TEXEL
    }
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            texel_size: 0.01,
            max_atlas: 4096,
            per_vertex: false,
        }
    }
}

/// Vertex arrays of one primitive (glTF texture coordinates: v down).
#[derive(Clone, Debug, Default)]
pub struct Primitive {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    /// Per-vertex materials (the fallback): base colour, roughness, metallic.
    pub colors: Vec<Rgb>,
    pub roughness: Vec<f32>,
    pub metallic: Vec<f32>,
    pub indices: Vec<u32>,
}

/// A light as exported: its triangles and mean radiance.
#[derive(Clone, Debug)]
pub struct EmitterPrimitive {
    pub id: usize,
    pub radiance: Rgb,
    pub primitive: Primitive,
    /// Some triangle emits on both sides (glTF `doubleSided`); otherwise each is wound to face
    /// the side it emits from.
    pub two_sided: bool,
}

/// Everything a writer needs: the reflecting surface (textured or per-vertex) and the lights.
pub struct Prepared {
    pub surface: Primitive,
    pub textures: Option<MaterialTextures>,
    pub atlas: Option<(u32, u32, usize, f32)>,
    pub emitters: Vec<EmitterPrimitive>,
}

fn vertex_normal(mesh: &Mesh, t: usize, corner: usize) -> Vec3 {
    match &mesh.normals {
        Some(n) => n[mesh.triangles[t][corner] as usize],
        None => mesh.face_normal(t),
    }
}

/// The emitters' primitives, wound to face the side each triangle emits from
/// ([`Emitter::sides`]; for a two-sided one, the centre of the mesh's bounds: Mitsuba's area
/// lights emit on their front only).
fn emitter_primitives(mesh: &Mesh, emitters: &[Emitter]) -> Vec<EmitterPrimitive> {
    let b = mesh.bounds();
    let centre = (b.min + b.max) * 0.5;
    emitters
        .iter()
        .enumerate()
        .map(|(id, e)| {
            let mut p = Primitive::default();
            for (i, &t) in e.triangles.iter().enumerate() {
                let t = t as usize;
                if t >= mesh.triangles.len() {
                    continue;
                }
                let mut v = mesh.vertices(t);
                let mut n = mesh.face_normal(t);
                let flip = match e.side(i) {
                    EmitSide::Front => false,
                    EmitSide::Back => true,
                    EmitSide::Both => n.dot(centre - (v[0] + v[1] + v[2]) / 3.0) < 0.0,
                };
                if flip {
                    v.swap(1, 2);
                    n = -n;
                }
                let base = p.positions.len() as u32;
                p.positions.extend(v);
                p.normals.extend([n; 3]);
                p.indices.extend([base, base + 1, base + 2]);
            }
            EmitterPrimitive {
                id,
                radiance: Vec3::from(e.mean_radiance),
                primitive: p,
                two_sided: (0..e.triangles.len()).any(|i| e.side(i) == EmitSide::Both),
            }
        })
        .collect()
}

/// Lays out the reflecting triangles (all but the emitters') and bakes their materials.
pub fn prepare<S: SurfaceModel>(
    mesh: &Mesh,
    surfaces: &S,
    emitters: &[Emitter],
    opts: &ExportOptions,
) -> Result<Prepared> {
    let mut include = vec![true; mesh.triangles.len()];
    for e in emitters {
        for &t in &e.triangles {
            if let Some(x) = include.get_mut(t as usize) {
                *x = false;
            }
        }
    }
    let emitters = emitter_primitives(mesh, emitters);
    let atlas = if opts.per_vertex {
        None
    } else {
        Atlas::build(mesh, &include, opts.texel_size, opts.max_atlas).ok()
    };
    let Some(atlas) = atlas else {
        return Ok(Prepared {
            surface: per_vertex(mesh, surfaces, &include),
            textures: None,
            atlas: None,
            emitters,
        });
    };
    let textures = MaterialTextures::bake(mesh, &atlas, surfaces);
    let mut p = Primitive::default();
    let mut index: HashMap<(u32, u32), u32> = HashMap::new();
    for (c, chart) in atlas.charts.iter().enumerate() {
        for &t in &chart.triangles {
            let t = t as usize;
            for corner in 0..3 {
                let v = mesh.triangles[t][corner];
                let k = *index.entry((c as u32, v)).or_insert_with(|| {
                    let pos = mesh.positions[v as usize];
                    p.positions.push(pos);
                    p.normals.push(vertex_normal(mesh, t, corner));
                    p.uvs.push(atlas.uv(c, pos));
                    p.positions.len() as u32 - 1
                });
                p.indices.push(k);
            }
        }
    }
    Ok(Prepared {
        surface: p,
        atlas: Some((
            atlas.width,
            atlas.height,
            atlas.charts.len(),
            atlas.texel_size,
        )),
        textures: Some(textures),
        emitters,
    })
}

/// Per-vertex materials: each corner gets the surface at its vertex, triangles unwelded.
fn per_vertex<S: SurfaceModel>(mesh: &Mesh, surfaces: &S, include: &[bool]) -> Primitive {
    let mut p = Primitive::default();
    for t in (0..mesh.triangles.len()).filter(|&t| include[t]) {
        for corner in 0..3 {
            let pos = mesh.positions[mesh.triangles[t][corner] as usize];
            let sp = surfaces.surface(t as u32, pos);
            let m = sp.metallic.clamp(0.0, 1.0);
            p.positions.push(pos);
            p.normals.push(vertex_normal(mesh, t, corner));
            p.colors.push(
                fipt_core::reflectance::base_color(sp.kd, sp.ks, m).clamp(Vec3::ZERO, Vec3::ONE),
            );
            p.roughness.push(sp.roughness);
            p.metallic.push(m);
            p.indices.push(p.positions.len() as u32 - 1);
        }
    }
    p
}

/// What an export wrote.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ExportSummary {
    pub format: Format,
    /// Files written, with their sizes in bytes.
    pub files: Vec<(PathBuf, u64)>,
    /// Atlas width, height, charts and texel size (None: per-vertex).
    pub atlas: Option<(u32, u32, usize, f32)>,
    /// Triangles of the reflecting surface.
    pub triangles: usize,
    /// Lights, and their triangles (written apart from the surface).
    pub emitters: usize,
    pub emitter_triangles: usize,
}

/// Exports a scene to `dir` in `format`.
pub fn export<S: SurfaceModel>(
    mesh: &Mesh,
    surfaces: &S,
    emitters: &[Emitter],
    format: Format,
    dir: &Path,
    opts: &ExportOptions,
) -> Result<ExportSummary> {
    if format != Format::Glb && opts.per_vertex {
        return Err(ExportError::Invalid(
            "--per-vertex is for glb only (OBJ and Mitsuba scenes take textured materials): export glb, or leave --per-vertex out".into(),
        ));
    }
    let prepared = prepare(mesh, surfaces, emitters, opts)?;
    if format != Format::Glb && prepared.textures.is_none() {
        return Err(ExportError::Invalid(format!(
            "{} planar regions do not fit a {}² atlas and per-vertex materials are glb only: raise --max-atlas or export glb",
            atlas::planar_regions(mesh, &vec![true; mesh.triangles.len()]).len(),
            opts.max_atlas
        )));
    }
    let files = match format {
        Format::Glb => vec![write_glb(&prepared, &dir.join("scene.glb"))?],
        Format::Mitsuba => mitsuba::write(&prepared, dir)?,
        Format::Obj => obj::write(&prepared, dir)?,
    };
    Ok(ExportSummary {
        format,
        files: files
            .into_iter()
            .map(|p| {
                let n = std::fs::metadata(&p).map_or(0, |m| m.len());
                (p, n)
            })
            .collect(),
        atlas: prepared.atlas,
        triangles: prepared.surface.indices.len() / 3,
        emitters: prepared.emitters.len(),
        emitter_triangles: (prepared.emitters.iter())
            .map(|e| e.primitive.indices.len() / 3)
            .sum(),
    })
}

/// Writes `bytes` to `path` atomically (`fipt_core::fsutil::write_bytes_atomic`); returns the
/// path for the export's file list.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<PathBuf> {
    fipt_core::fsutil::write_bytes_atomic(path, bytes)?;
    Ok(path.to_path_buf())
}

/// PNG bytes of 8-bit pixels (`color`: Rgb8 or L8).
pub(crate) fn png(
    pixels: &[u8],
    width: u32,
    height: u32,
    color: image::ExtendedColorType,
) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(pixels, width, height, color)
        .expect("PNG encoding to memory");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An emitter triangle at y = 1 wound to face +y, above a floor triangle: exported facing
    /// the side it emits from, and a two-sided one facing the bounds' centre (below it).
    #[test]
    fn an_exported_light_faces_the_side_it_emits_from() {
        let p = vec![
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let mesh = Mesh::from_triangles(p, None, vec![[0, 1, 2], [3, 4, 5]]);
        assert!(mesh.face_normal(0).y > 0.99);
        let light = Emitter::from_triangles(
            &mesh.positions,
            &mesh.triangles,
            vec![0],
            vec![Vec3::ONE],
            1,
        )
        .unwrap();
        for (side, up) in [
            (EmitSide::Front, true),
            (EmitSide::Back, false),
            (EmitSide::Both, false),
        ] {
            let e = light
                .clone()
                .with_sides(&mesh.positions, &mesh.triangles, vec![side]);
            let prim = &emitter_primitives(&mesh, &[e])[0].primitive;
            let v = &prim.positions;
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            assert_eq!(n.y > 0.0, up, "{side:?}: winding normal {n}");
            assert_eq!(prim.normals[0].y > 0.0, up, "{side:?}");
        }
    }
}
