//! One indexed triangle mesh, loaded from OBJ (tobj), glTF/GLB (gltf) or PLY (ASCII or binary).
//!
//! Faces keep their file order: `face_ids[i]` is the index of triangle `i` among the file's
//! triangles (polygons are fan-triangulated first), so per-face tables such as `scene_gt.json`
//! and `scene_parts.json` apply after degenerate triangles have been dropped.
use crate::error::{GeomError, Result};
use glam::Vec3;
use std::io::Write;
use std::path::Path;

/// An indexed triangle mesh in world space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Optional per-vertex shading normals (same length as `positions`).
    pub normals: Option<Vec<Vec3>>,
    pub triangles: Vec<[u32; 3]>,
    /// File face index of each triangle.
    pub face_ids: Vec<u32>,
    /// Triangles in the file (before degenerate ones were dropped).
    pub num_file_faces: usize,
    /// Degenerate triangles dropped (repeated index, zero area, non-finite vertex).
    pub dropped_degenerate: usize,
}

/// Axis-aligned bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Mesh {
    /// Builds a mesh from raw triangles, dropping degenerate ones (and counting them).
    pub fn from_triangles(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        tris: Vec<[u32; 3]>,
    ) -> Mesh {
        let n = tris.len();
        let mut m = Mesh {
            positions,
            normals,
            triangles: Vec::with_capacity(n),
            face_ids: Vec::with_capacity(n),
            num_file_faces: n,
            dropped_degenerate: 0,
        };
        if m.normals.as_ref().is_some_and(|nr| {
            nr.len() != m.positions.len()
                || nr
                    .iter()
                    .any(|v| !v.is_finite() || v.length_squared() == 0.0)
        }) {
            m.normals = None;
        }
        for (f, t) in tris.into_iter().enumerate() {
            if m.is_degenerate(t) {
                m.dropped_degenerate += 1;
            } else {
                m.triangles.push(t);
                m.face_ids.push(f as u32);
            }
        }
        m
    }

    fn is_degenerate(&self, t: [u32; 3]) -> bool {
        let np = self.positions.len() as u32;
        if t.iter().any(|&i| i >= np) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return true;
        }
        let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            return true;
        }
        (b - a).cross(c - a).length_squared() == 0.0
    }

    /// Vertices of triangle `i`.
    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        self.triangles[i].map(|v| self.positions[v as usize])
    }

    /// Unit geometric normal of triangle `i` (right-hand rule on the stored winding).
    #[inline]
    pub fn face_normal(&self, i: usize) -> Vec3 {
        face_normal(self.vertices(i))
    }

    /// Area of triangle `i`.
    pub fn area(&self, i: usize) -> f32 {
        let [a, b, c] = self.vertices(i);
        0.5 * (b - a).as_dvec3().cross((c - a).as_dvec3()).length() as f32
    }

    /// Bounds of the referenced vertices.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds {
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
        };
        for t in &self.triangles {
            for &v in t {
                let p = self.positions[v as usize];
                b.min = b.min.min(p);
                b.max = b.max.max(p);
            }
        }
        b
    }

    /// Gives every triangle its own three vertices carrying its face normal, so a mesh without
    /// vertex normals shades the same once it has some (triangle order and ids unchanged).
    pub fn unweld_flat(&mut self) {
        let mut positions = Vec::with_capacity(self.triangles.len() * 3);
        let mut normals = Vec::with_capacity(self.triangles.len() * 3);
        for t in 0..self.triangles.len() {
            let n = self.face_normal(t);
            positions.extend(self.vertices(t));
            normals.extend([n; 3]);
            let b = 3 * t as u32;
            self.triangles[t] = [b, b + 1, b + 2];
        }
        self.positions = positions;
        self.normals = Some(normals);
    }

    /// Appends another mesh (its face ids continue after this mesh's file faces). When only
    /// one of the two has vertex normals, the other is unwelded with its face normals
    /// ([`Mesh::unweld_flat`]), so neither changes how it shades.
    pub fn append(&mut self, other: &Mesh) {
        let flat;
        let other = match (&self.normals, &other.normals) {
            (Some(_), None) => {
                let mut m = other.clone();
                m.unweld_flat();
                flat = m;
                &flat
            }
            (None, Some(_)) => {
                self.unweld_flat();
                other
            }
            _ => other,
        };
        let off = self.positions.len() as u32;
        let foff = self.num_file_faces as u32;
        if let (Some(a), Some(b)) = (&mut self.normals, &other.normals) {
            a.extend_from_slice(b);
        }
        self.positions.extend_from_slice(&other.positions);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + off)));
        self.face_ids
            .extend(other.face_ids.iter().map(|f| f + foff));
        self.num_file_faces += other.num_file_faces;
        self.dropped_degenerate += other.dropped_degenerate;
    }

    /// Writes a Wavefront OBJ (positions, normals when present, faces in order), atomically.
    pub fn write_obj(&self, path: &Path, header: &str) -> Result<()> {
        write_atomic(path, |w| {
            for line in header.lines() {
                writeln!(w, "# {line}")?;
            }
            for p in &self.positions {
                writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
            }
            if let Some(ns) = &self.normals {
                for n in ns {
                    writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
                }
            }
            for t in &self.triangles {
                let [a, b, c] = t.map(|i| i + 1);
                if self.normals.is_some() {
                    writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
                } else {
                    writeln!(w, "f {a} {b} {c}")?;
                }
            }
            Ok(())
        })
    }

    /// Writes a binary little-endian PLY (float x y z [nx ny nz], uchar-int face lists), atomically.
    pub fn write_ply(&self, path: &Path) -> Result<()> {
        write_atomic(path, |w| {
            writeln!(
                w,
                "ply\nformat binary_little_endian 1.0\ncomment written by fipt"
            )?;
            writeln!(
                w,
                "element vertex {}\nproperty float x\nproperty float y\nproperty float z",
                self.positions.len()
            )?;
            if self.normals.is_some() {
                writeln!(w, "property float nx\nproperty float ny\nproperty float nz")?;
            }
            writeln!(
                w,
                "element face {}\nproperty list uchar int vertex_indices\nend_header",
                self.triangles.len()
            )?;
            for (i, p) in self.positions.iter().enumerate() {
                for c in p.to_array() {
                    w.write_all(&c.to_le_bytes())?;
                }
                if let Some(ns) = &self.normals {
                    for c in ns[i].to_array() {
                        w.write_all(&c.to_le_bytes())?;
                    }
                }
            }
            for t in &self.triangles {
                w.write_all(&[3u8])?;
                for &i in t {
                    w.write_all(&(i as i32).to_le_bytes())?;
                }
            }
            Ok(())
        })
    }
}

fn write_atomic<F>(path: &Path, f: F) -> Result<()>
where
    F: FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
{
    let io = |e| GeomError::Io {
        path: path.to_path_buf(),
        source: e,
    };
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(io)?;
    }
    let tmp = fipt_core::fsutil::temp_path(path);
    let result = (|| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        f(&mut w)?;
        w.flush()?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

/// Fan-triangulates polygon `poly` into `out`.
pub(crate) fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}

/// The unit normal of the triangle `[a, b, c]` (counter-clockwise side).
pub fn face_normal([a, b, c]: [Vec3; 3]) -> Vec3 {
    (b - a).cross(c - a).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn tetra() -> Mesh {
        let p = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::new(1e-4, 2e-4, 3e-4),
        ];
        // Last triangle is degenerate (repeated index), one tiny but valid triangle.
        let t = vec![
            [0, 2, 1],
            [0, 1, 3],
            [0, 3, 2],
            [1, 2, 3],
            [0, 0, 1],
            [0, 4, 1],
        ];
        Mesh::from_triangles(p, None, t)
    }

    fn tmp(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("fipt-geom-{}-{name}", std::process::id()))
    }

    #[test]
    fn degenerate_dropped_tiny_kept_and_face_ids_follow_file() {
        let m = tetra();
        assert_eq!(m.dropped_degenerate, 1);
        assert_eq!(m.triangles.len(), 5);
        assert_eq!(m.face_ids, vec![0, 1, 2, 3, 5]);
        assert!(m.area(4) > 0.0 && m.area(4) < 1e-3);
        let nan = Mesh::from_triangles(
            vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(f32::NAN, 0.0, 0.0),
                Vec3::Y,
                Vec3::new(2.0, 0.0, 0.0),
            ],
            None,
            vec![[0, 1, 2], [0, 1, 3], [0, 1, 4]],
        );
        assert_eq!(
            nan.dropped_degenerate, 2,
            "NaN vertex and collinear triangle"
        );
    }

    #[test]
    fn obj_and_ply_round_trips() {
        let mut m = tetra();
        m.normals = Some(
            m.positions
                .iter()
                .map(|p| (*p - Vec3::splat(0.25)).normalize())
                .collect(),
        );
        for (name, write) in [("a.obj", 0), ("b.ply", 1)] {
            let p = tmp(name);
            if write == 0 {
                m.write_obj(&p, "test").unwrap()
            } else {
                m.write_ply(&p).unwrap()
            }
            let back = Mesh::load(&p).unwrap();
            assert_eq!(back.triangles.len(), m.triangles.len(), "{name}");
            for i in 0..m.triangles.len() {
                let (a, b) = (m.vertices(i), back.vertices(i));
                for k in 0..3 {
                    assert!((a[k] - b[k]).length() < 1e-6, "{name}: tri {i}");
                }
            }
            let (na, nb) = (m.normals.as_ref().unwrap(), back.normals.as_ref().unwrap());
            for t in 0..m.triangles.len() {
                for k in 0..3 {
                    let (ia, ib) = (m.triangles[t][k] as usize, back.triangles[t][k] as usize);
                    assert!((na[ia] - nb[ib]).length() < 1e-5);
                }
            }
            std::fs::remove_file(&p).ok();
        }
    }

    #[test]
    fn ascii_and_big_endian_ply_with_quads() {
        let ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
        let p = tmp("q.ply");
        std::fs::write(&p, ascii).unwrap();
        let m = Mesh::load(&p).unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert!((m.face_normal(0) - Vec3::Z).length() < 1e-6);
        let mut be = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
        for v in [[0.0f64, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, -2.0]] {
            for c in v {
                be.extend_from_slice(&c.to_be_bytes());
            }
        }
        be.push(3);
        for i in [0u32, 1, 2] {
            be.extend_from_slice(&i.to_be_bytes());
        }
        std::fs::write(&p, &be).unwrap();
        let m = Mesh::load(&p).unwrap();
        assert_eq!(m.positions[1], Vec3::new(2.0, 0.0, 0.0));
        assert!((m.face_normal(0) - Vec3::Y).length() < 1e-6);
        be.truncate(be.len() - 2);
        std::fs::write(&p, &be).unwrap();
        let err = Mesh::load(&p).unwrap_err().to_string();
        assert!(
            err.contains("q.ply") && err.contains("ends before"),
            "{err}"
        );
        std::fs::remove_file(&p).ok();
    }

    #[test]
    fn gltf_round_trip_through_a_minimal_file() {
        // A node with a translation: positions come out in world space.
        let mut bin = Vec::new();
        for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in v {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        for i in [0u16, 1, 2, 0] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let dir = tmp("gltf");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("b.bin"), &bin).unwrap();
        let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
          "nodes":[{"mesh":0,"translation":[0,2,0]}],
          "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
          "buffers":[{"uri":"b.bin","byteLength":44}],
          "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
          "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                       {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#;
        std::fs::write(dir.join("m.gltf"), json).unwrap();
        let m = Mesh::load(&dir.join("m.gltf")).unwrap();
        assert_eq!(m.triangles.len(), 1);
        assert_eq!(
            m.vertices(0),
            [
                Vec3::new(0.0, 2.0, 0.0),
                Vec3::new(1.0, 2.0, 0.0),
                Vec3::new(0.0, 3.0, 0.0)
            ]
        );
        std::fs::remove_dir_all(&dir).ok();
        let err = Mesh::load(Path::new("/nonexistent/scene.obj"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("/nonexistent/scene.obj"), "{err}");
    }
}
