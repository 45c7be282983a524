//! Reading a mesh file by its extension: OBJ (tobj), glTF/GLB (gltf), PLY (`ply.rs`).
use crate::error::parse_err;
use crate::error::{GeomError, Result};
use crate::mesh::Mesh;
use glam::{Mat3, Mat4, Vec3};
use std::path::Path;

impl Mesh {
    /// Loads a mesh by extension: `.obj`, `.ply`, `.gltf`, `.glb`.
    pub fn load(path: &Path) -> Result<Mesh> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if !path.is_file() {
            return Err(GeomError::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        let mesh = match ext.as_str() {
            "obj" => load_obj(path)?,
            "ply" => crate::ply::load(path)?,
            "gltf" | "glb" => load_gltf(path)?,
            _ => {
                return Err(GeomError::Format {
                    path: path.to_path_buf(),
                })
            }
        };
        if mesh.triangles.is_empty() {
            return Err(GeomError::Empty {
                path: path.to_path_buf(),
                dropped: mesh.dropped_degenerate,
            });
        }
        Ok(mesh)
    }
}

fn load_obj(path: &Path) -> Result<Mesh> {
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|e| parse_err(path, e.to_string()))?;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut all_normals = true;
    let mut tris = Vec::new();
    for m in &models {
        let mesh = &m.mesh;
        let off = positions.len() as u32;
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if mesh.normals.len() == mesh.positions.len() {
            normals.extend(
                mesh.normals
                    .chunks_exact(3)
                    .map(|p| Vec3::new(p[0], p[1], p[2])),
            );
        } else {
            all_normals = false;
        }
        tris.extend(
            mesh.indices
                .chunks_exact(3)
                .map(|t| [t[0] + off, t[1] + off, t[2] + off]),
        );
    }
    Ok(Mesh::from_triangles(
        positions,
        (all_normals && !normals.is_empty()).then_some(normals),
        tris,
    ))
}

fn load_gltf(path: &Path) -> Result<Mesh> {
    crate::glb::check_glb(path)?;
    // Geometry only: the images are not decoded.
    let g = crate::glb::guarded(path, || gltf::Gltf::open(path).map_err(|e| e.to_string()))?;
    crate::glb::check_external_files(&g.document, path, false)?;
    let buffers = crate::glb::guarded(path, || {
        gltf::import_buffers(&g.document, path.parent(), g.blob.clone()).map_err(|e| e.to_string())
    })?;
    let doc = g.document;
    // The readers index the buffers unchecked in places: a malformed accessor is an error
    // naming the file, not a panic.
    let (positions, normals, tris) = crate::glb::guarded(path, || gltf_triangles(&doc, &buffers))?;
    Ok(Mesh::from_triangles(positions, normals, tris))
}

/// The triangles of the default scene (or the first), in world space: positions, normals
/// (when every primitive has them) and vertex indices.
type GltfTriangles = (Vec<Vec3>, Option<Vec<Vec3>>, Vec<[u32; 3]>);

fn gltf_triangles(
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> std::result::Result<GltfTriangles, String> {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut all_normals = true;
    let mut tris = Vec::new();
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let mut stack: Vec<(gltf::Node, Mat4)> = match &scene {
        Some(s) => s.nodes().map(|n| (n, Mat4::IDENTITY)).collect(),
        None => Vec::new(),
    };
    let mut seen = vec![false; doc.nodes().len()];
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(format!(
                "node {} is reached twice (a node that is its own ancestor, or the child of two \
                 nodes): glTF nodes form trees",
                node.index()
            ));
        }
        let m = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let nm = Mat3::from_mat4(m).inverse().transpose();
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                crate::glb::check_primitive_geometry(&prim, buffers, mesh.index())?;
                let reader = prim.reader(|b| Some(&buffers[b.index()]));
                let Some(pos) = reader.read_positions() else {
                    continue;
                };
                let off = positions.len() as u32;
                let before = positions.len();
                positions.extend(pos.map(|p| m.transform_point3(Vec3::from_array(p))));
                let count = positions.len() - before;
                match reader.read_normals() {
                    Some(ns) => {
                        normals.extend(ns.map(|n| (nm * Vec3::from_array(n)).normalize_or_zero()))
                    }
                    None => all_normals = false,
                }
                let idx: Vec<u32> = match (reader.read_indices(), prim.indices()) {
                    (Some(i), _) => i.into_u32().collect(),
                    (None, Some(a)) => {
                        return Err(format!(
                            "mesh {}: its index accessor {} cannot be read (no buffer view, or \
                             past its buffer)",
                            mesh.index(),
                            a.index()
                        ))
                    }
                    (None, None) => (0..count as u32).collect(),
                };
                if let Some(&i) = idx.iter().find(|&&i| i as usize >= count) {
                    return Err(format!(
                        "mesh {}: index {i} beyond its {count} vertices",
                        mesh.index()
                    ));
                }
                let flip = m.determinant() < 0.0;
                for t in idx.chunks_exact(3) {
                    let t = [t[0] + off, t[1] + off, t[2] + off];
                    tris.push(if flip { [t[0], t[2], t[1]] } else { t });
                }
            }
        }
        for c in node.children() {
            stack.push((c, m));
        }
    }
    let normals = (all_normals && normals.len() == positions.len()).then_some(normals);
    Ok((positions, normals, tris))
}
