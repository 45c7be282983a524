//! Reading an exported `.glb` back as a renderable scene: the mesh of every primitive and a
//! [`SurfaceModel`] that samples its textures (or per-vertex materials) at the hit point and
//! takes emission from emissive materials (on both sides when `doubleSided`, else towards the
//! winding) — what `fipt render scene.glb` renders, and how the
//! round trip of an export is checked against the scene it came from.
use crate::{ExportError, Result};
use fipt_core::color::{srgb_eotf, Rgb};
use fipt_core::emitter::EmitSide;
use fipt_core::materials::SurfacePoint;
use fipt_core::reflectance::{clamp_roughness, metallic_workflow};
use fipt_geom::Mesh;
use fipt_shading::scene::SurfaceModel;
use glam::{Vec2, Vec3};
use std::path::Path;

/// An 8-bit RGB texture, sampled bilinearly with clamped edges.
struct Texture {
    width: u32,
    height: u32,
    rgb: Vec<[f32; 3]>,
}

impl Texture {
    fn from_gltf(img: &gltf::image::Data, path: &Path) -> Result<Texture> {
        let n = match img.format {
            gltf::image::Format::R8G8B8 => 3,
            gltf::image::Format::R8G8B8A8 => 4,
            f => {
                return Err(ExportError::Invalid(format!(
                    "{}: texture format {f:?} is not 8-bit RGB(A)",
                    path.display()
                )))
            }
        };
        let rgb = img
            .pixels
            .chunks(n)
            .map(|p| [p[0], p[1], p[2]].map(|v| v as f32 / 255.0))
            .collect();
        Ok(Texture {
            width: img.width,
            height: img.height,
            rgb,
        })
    }

    fn sample(&self, uv: Vec2) -> Vec3 {
        let x = (uv.x * self.width as f32 - 0.5).clamp(0.0, self.width as f32 - 1.0);
        let y = (uv.y * self.height as f32 - 0.5).clamp(0.0, self.height as f32 - 1.0);
        let (x0, y0) = (x.floor() as u32, y.floor() as u32);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let at = |x: u32, y: u32| Vec3::from(self.rgb[(y * self.width + x) as usize]);
        let top = at(x0, y0).lerp(at(x1, y0), fx);
        let bottom = at(x0, y1).lerp(at(x1, y1), fx);
        top.lerp(bottom, fy)
    }
}

/// How a triangle's material is given.
#[derive(Clone)]
enum Source {
    /// Texture coordinates of its corners.
    Textured([Vec2; 3]),
    /// Materials at its corners: base colour, roughness, metallic.
    Vertex([(Rgb, f32, f32); 3]),
    /// An emitter (black, emitting): its radiance and whether it emits on both sides (its
    /// material's `doubleSided`; else only towards its winding).
    Emitter(Rgb, bool),
}

/// The surfaces of a loaded `.glb`.
pub struct GlbSurfaces {
    corners: Vec<[Vec3; 3]>,
    source: Vec<Source>,
    base_color: Option<Texture>,
    metallic_roughness: Option<Texture>,
}

fn barycentric(c: &[Vec3; 3], p: Vec3) -> Vec3 {
    let (e1, e2, d) = (c[1] - c[0], c[2] - c[0], p - c[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let den = d11 * d22 - d12 * d12;
    if den.abs() < 1e-20 {
        return Vec3::new(1.0, 0.0, 0.0);
    }
    let v = ((d22 * d1 - d12 * d2) / den).clamp(0.0, 1.0);
    let w = ((d11 * d2 - d12 * d1) / den).clamp(0.0, 1.0 - v);
    Vec3::new(1.0 - v - w, v, w)
}

impl SurfaceModel for GlbSurfaces {
    fn surface(&self, tri: u32, p: Vec3) -> SurfacePoint {
        let b = barycentric(&self.corners[tri as usize], p);
        let (albedo, roughness, metallic) = match &self.source[tri as usize] {
            Source::Emitter(le, _) => {
                return SurfacePoint {
                    roughness: 1.0,
                    emission: *le,
                    ..Default::default()
                }
            }
            Source::Textured(uv) => {
                let t = uv[0] * b.x + uv[1] * b.y + uv[2] * b.z;
                let a = self.base_color.as_ref().map_or(Vec3::ONE, |tex| {
                    tex.sample(t).to_array().map(srgb_eotf).into()
                });
                let mr = self
                    .metallic_roughness
                    .as_ref()
                    .map_or(Vec3::new(0.0, 1.0, 0.0), |tex| tex.sample(t));
                (a, mr.y, mr.z)
            }
            Source::Vertex(c) => (
                c[0].0 * b.x + c[1].0 * b.y + c[2].0 * b.z,
                c[0].1 * b.x + c[1].1 * b.y + c[2].1 * b.z,
                c[0].2 * b.x + c[1].2 * b.y + c[2].2 * b.z,
            ),
        };
        let (kd, ks) = metallic_workflow(albedo, metallic);
        SurfacePoint {
            kd,
            ks,
            roughness: clamp_roughness(roughness),
            metallic,
            emission: Vec3::ZERO,
        }
    }
    fn emission(&self, tri: u32) -> Rgb {
        match &self.source[tri as usize] {
            Source::Emitter(le, _) => *le,
            _ => Vec3::ZERO,
        }
    }
    fn emit_side(&self, tri: u32) -> EmitSide {
        match &self.source[tri as usize] {
            Source::Emitter(_, false) => EmitSide::Front,
            _ => EmitSide::Both,
        }
    }
    fn part(&self, _tri: u32) -> u32 {
        0
    }
}

/// Loads a `.glb` written by [`crate::export`] (or any glTF whose first mesh uses one
/// metallic-roughness material per primitive) as a mesh and its surfaces.
pub fn load_glb(path: &Path) -> Result<(Mesh, GlbSurfaces)> {
    let bad = |m: String| ExportError::Invalid(format!("{}: {m}", path.display()));
    fipt_geom::glb::check_glb(path).map_err(|e| ExportError::Invalid(e.to_string()))?;
    let doc = fipt_geom::glb::guarded(path, || {
        gltf::Gltf::open(path)
            .map(|g| g.document)
            .map_err(|e| e.to_string())
    })
    .map_err(|e| ExportError::Invalid(e.to_string()))?;
    fipt_geom::glb::check_external_files(&doc, path, true)
        .map_err(|e| ExportError::Invalid(e.to_string()))?;
    let (doc, buffers, images) =
        fipt_geom::glb::guarded(path, || gltf::import(path).map_err(|e| e.to_string()))
            .map_err(|e| ExportError::Invalid(e.to_string()))?;
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            check_primitive(&prim, &buffers, mesh.index()).map_err(bad)?;
        }
    }
    // The readers index the buffers unchecked in places: a panic left over is an error too.
    fipt_geom::glb::guarded(path, || Ok(read_glb(path, &doc, &buffers, &images)))
        .map_err(|e| ExportError::Invalid(e.to_string()))?
}

/// The triangles and surfaces of every mesh of a checked glTF ([`check_primitive`]).
fn read_glb(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    images: &[gltf::image::Data],
) -> Result<(Mesh, GlbSurfaces)> {
    let bad = |m: String| ExportError::Invalid(format!("{}: {m}", path.display()));
    let (mut positions, mut normals, mut tris) = (Vec::new(), Vec::new(), Vec::new());
    let mut source = Vec::new();
    let (mut base_color, mut metallic_roughness) = (None, None);
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let r = prim.reader(|b| Some(&buffers[b.index()]));
            let pos: Vec<Vec3> = r
                .read_positions()
                .ok_or_else(|| bad("a primitive without positions".into()))?
                .map(Vec3::from)
                .collect();
            let nrm: Vec<Vec3> = match r.read_normals() {
                Some(n) => n.map(Vec3::from).collect(),
                None => vec![Vec3::Y; pos.len()],
            };
            let idx: Vec<u32> = match r.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..pos.len() as u32).collect(),
            };
            let uv: Option<Vec<Vec2>> = r
                .read_tex_coords(0)
                .map(|t| t.into_f32().map(Vec2::from).collect());
            let col: Option<Vec<Rgb>> = r
                .read_colors(0)
                .map(|c| c.into_rgb_f32().map(Vec3::from).collect());
            let extra = |name: &str| extra_attribute(&prim, buffers, name);
            let (rough, metal) = (extra("ROUGHNESS"), extra("METALLIC"));
            let lens = [
                ("TEXCOORD_0", uv.as_ref().map(Vec::len)),
                ("COLOR_0", col.as_ref().map(Vec::len)),
                ("NORMAL", Some(nrm.len())),
                ("_ROUGHNESS", rough.as_ref().map(Vec::len)),
                ("_METALLIC", metal.as_ref().map(Vec::len)),
            ];
            if let Some((name, Some(n))) =
                lens.iter().find(|(_, n)| n.is_some_and(|n| n != pos.len()))
            {
                return Err(bad(format!(
                    "mesh {}: {name} has {n} values for {} positions",
                    mesh.index(),
                    pos.len()
                )));
            }
            let mat = prim.material();
            let strength = mat.emissive_strength().unwrap_or(1.0);
            let le = Vec3::from(mat.emissive_factor()) * strength;
            let pbr = mat.pbr_metallic_roughness();
            if let Some(t) = pbr.base_color_texture() {
                base_color = Some(Texture::from_gltf(
                    &images[t.texture().source().index()],
                    path,
                )?);
            }
            if let Some(t) = pbr.metallic_roughness_texture() {
                metallic_roughness = Some(Texture::from_gltf(
                    &images[t.texture().source().index()],
                    path,
                )?);
            }
            let off = positions.len() as u32;
            for f in idx.chunks_exact(3) {
                let c = [f[0], f[1], f[2]].map(|i| i as usize);
                if c.iter().any(|&i| i >= pos.len()) {
                    return Err(bad("an index beyond the vertices".into()));
                }
                tris.push([f[0] + off, f[1] + off, f[2] + off]);
                source.push(if le.max_element() > 0.0 {
                    Source::Emitter(le, mat.double_sided())
                } else if let Some(uv) = &uv {
                    Source::Textured(c.map(|i| uv[i]))
                } else if let (Some(col), Some(r), Some(m)) = (&col, &rough, &metal) {
                    Source::Vertex(c.map(|i| (col[i], r[i], m[i])))
                } else {
                    let b = Vec3::from_slice(&pbr.base_color_factor()[..3]);
                    let v = (b, pbr.roughness_factor(), pbr.metallic_factor());
                    Source::Vertex([v; 3])
                });
            }
            positions.extend(pos);
            normals.extend(nrm);
        }
    }
    let mesh = Mesh::from_triangles(positions, Some(normals), tris);
    let source = aligned_sources(&mesh, source);
    let corners = (0..mesh.triangles.len())
        .map(|t| mesh.vertices(t))
        .collect();
    Ok((
        mesh,
        GlbSurfaces {
            corners,
            source,
            base_color,
            metallic_roughness,
        },
    ))
}

/// The per-triangle sources of the file's triangles kept by the mesh (degenerate ones dropped).
fn aligned_sources(mesh: &Mesh, source: Vec<Source>) -> Vec<Source> {
    if mesh.dropped_degenerate == 0 {
        return source;
    }
    mesh.face_ids
        .iter()
        .map(|&f| source[f as usize].clone())
        .collect()
}

/// A primitive's custom per-vertex f32 attribute `name` (e.g. `_ROUGHNESS`), if present.
fn extra_attribute(
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    name: &str,
) -> Option<Vec<f32>> {
    let acc = prim
        .attributes()
        .find(|(s, _)| matches!(s, gltf::Semantic::Extras(n) if n == name))?;
    let view = acc.1.view()?;
    let buf = buffers.get(view.buffer().index())?;
    let start = view.offset() + acc.1.offset();
    Some(
        buf.get(start..start + 4 * acc.1.count())?
            .chunks(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
    )
}

/// The accessors [`load_glb`] reads, checked against their buffers before the `gltf` readers
/// touch them (they assume the types, the strides and the lengths, and panic otherwise): the
/// geometry's as the mesh loader checks them, then the material attributes.
fn check_primitive(
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    mesh: usize,
) -> std::result::Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    use gltf::Semantic;
    fipt_geom::glb::check_primitive_geometry(prim, buffers, mesh)?;
    let (f32_, norm) = (
        [DataType::F32],
        [DataType::F32, DataType::U8, DataType::U16],
    );
    for (sem, acc) in prim.attributes() {
        let what = format!("mesh {mesh} {sem:?}");
        let (types, dims): (&[DataType], Dimensions) = match &sem {
            Semantic::TexCoords(0) => (&norm, Dimensions::Vec2),
            Semantic::Colors(0) if acc.dimensions() == Dimensions::Vec4 => {
                (&norm, Dimensions::Vec4)
            }
            Semantic::Colors(0) => (&norm, Dimensions::Vec3),
            Semantic::Extras(n) if n == "ROUGHNESS" || n == "METALLIC" => {
                (&f32_, Dimensions::Scalar)
            }
            _ => continue,
        };
        fipt_geom::glb::check_accessor(&acc, buffers, &what, types, dims)?;
    }
    Ok(())
}
