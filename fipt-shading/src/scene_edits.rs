//! `edits.json`: material edits on selected surfaces and inserted objects.
//!
//! ```json
//! {"materials": [{"select": {"at": {"view": 0, "x": 120, "y": 80}}, "edit": {"albedo": {"set": [0.8, 0.1, 0.1]}}},
//!                {"select": {"box": {"min": [-1, 0, -1], "max": [1, 0.01, 1]}}, "edit": {"roughness": {"scale": 0.5}}},
//!                {"select": {"faces": [12, 13]}, "edit": {"emission": {"set": [5, 5, 5]}}}],
//!  "objects": [{"file": "bunny.obj", "transform": {"translate": [0, 0, 0.3], "scale": 0.5},
//!               "material": {"albedo": [0.9, 0.9, 0.9], "roughness": 0.3, "metallic": 0}}]}
//! ```
//! Selections are whole triangles: `faces` (file face ids, as `scene_parts.json` counts them),
//! `box` (triangles whose centroid lies inside), `at` (the triangle a camera pixel sees, grown
//! over edge-sharing triangles of similar material) and `point` (the same from the triangle
//! nearest a point). Similar: base colour, roughness and metallic within `tolerance` (default
//! 0.1) of the seed's. A later edit of a triangle replaces an earlier one.
use crate::edit::{AddedSurface, EditedSurfaces, SurfaceEdit};
use crate::error::{Result, ShadingError};
use crate::lights::Transform;
use crate::scene::SurfaceModel;
use fipt_core::camera::Camera;
use fipt_core::materials::SurfacePoint;
use fipt_core::reflectance::{base_color, clamp_roughness, metallic_workflow};
use fipt_geom::{BuildQuality, Bvh, Mesh};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

fn default_tolerance() -> f32 {
    0.1
}

/// Which triangles an edit applies to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Selection {
    Faces(Vec<u32>),
    Box {
        min: [f32; 3],
        max: [f32; 3],
    },
    At {
        view: usize,
        x: u32,
        y: u32,
        #[serde(default = "default_tolerance")]
        tolerance: f32,
    },
    Point {
        position: [f32; 3],
        #[serde(default = "default_tolerance")]
        tolerance: f32,
    },
}

/// One material edit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialEditSpec {
    pub select: Selection,
    pub edit: SurfaceEdit,
}

fn one() -> f32 {
    1.0
}

/// The uniform material of an inserted object (metallic workflow).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectMaterial {
    pub albedo: [f32; 3],
    #[serde(default = "one")]
    pub roughness: f32,
    #[serde(default)]
    pub metallic: f32,
    #[serde(default)]
    pub emission: [f32; 3],
}

/// An object to insert: a mesh file (OBJ, PLY, glTF/GLB; relative to the edits file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    pub file: PathBuf,
    #[serde(default)]
    pub transform: Transform,
    pub material: ObjectMaterial,
}

/// A parsed `edits.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EditsFile {
    #[serde(default)]
    pub materials: Vec<MaterialEditSpec>,
    #[serde(default)]
    pub objects: Vec<ObjectSpec>,
    #[serde(default, skip_serializing)]
    pub comment: Option<serde_json::Value>,
}

/// Part index of inserted objects: `OBJECT_PART + k` for object k.
pub const OBJECT_PART: u32 = 1 << 30;

fn invalid(path: &Path, message: String) -> ShadingError {
    ShadingError::Invalid {
        path: path.to_path_buf(),
        message,
    }
}

impl EditsFile {
    pub fn read(path: &Path) -> Result<EditsFile> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| invalid(path, format!("cannot read the edits file: {e}")))?;
        let f: EditsFile = serde_json::from_str(&text).map_err(|e| {
            invalid(path, format!("{e} (expected {{\"materials\": [...], \"objects\": [...]}}; see docs/relighting-and-export.md, section edits.json)"))
        })?;
        if f.materials.is_empty() && f.objects.is_empty() {
            return Err(invalid(
                path,
                "the edits file holds no edit: give \"materials\" or \"objects\" (see docs/relighting-and-export.md, section edits.json)".into(),
            ));
        }
        for (k, m) in f.materials.iter().enumerate() {
            if m.edit.is_empty() {
                return Err(invalid(
                    path,
                    format!("material edit {k}: `edit` changes nothing"),
                ));
            }
            m.edit
                .check()
                .map_err(|e| invalid(path, format!("material edit {k}: {e}")))?;
        }
        for (k, o) in f.objects.iter().enumerate() {
            let m = &o.material;
            let ok = m.albedo.iter().all(|v| (0.0..=1.0).contains(v))
                && (m.emission.iter()).all(|v| (0.0..=fipt_core::range::MAX_RADIANCE).contains(v))
                && (0.0..=1.0).contains(&m.roughness)
                && (0.0..=1.0).contains(&m.metallic);
            if !ok {
                return Err(invalid(
                    path,
                    format!(
                        "object {k}: albedo {:?}, roughness {} and metallic {} must lie in [0, 1], emission {:?} in [0, {:e}]",
                        m.albedo, m.roughness, m.metallic, m.emission, fipt_core::range::MAX_RADIANCE
                    ),
                ));
            }
        }
        Ok(f)
    }
}

/// The material similarity of region growing: the largest difference of base colour,
/// roughness and metallic.
fn distance(a: &SurfacePoint, b: &SurfacePoint) -> f32 {
    let (ca, cb) = (
        base_color(a.kd, a.ks, a.metallic),
        base_color(b.kd, b.ks, b.metallic),
    );
    (ca - cb)
        .abs()
        .max_element()
        .max((a.roughness - b.roughness).abs())
        .max((a.metallic - b.metallic).abs())
        .max((a.emission - b.emission).abs().max_element())
}

fn centroid(mesh: &Mesh, t: usize) -> Vec3 {
    let v = mesh.vertices(t);
    (v[0] + v[1] + v[2]) / 3.0
}

/// Triangles reachable from `seed` over shared edges whose material is within `tol` of its.
fn grow<S: SurfaceModel>(mesh: &Mesh, surfaces: &S, seed: u32, tol: f32) -> Vec<u32> {
    let nb = mesh.edge_neighbours();
    let at = |t: u32| surfaces.surface(t, centroid(mesh, t as usize));
    let s0 = at(seed);
    let mut seen = vec![false; mesh.triangles.len()];
    seen[seed as usize] = true;
    let mut out = vec![seed];
    let mut k = 0;
    while k < out.len() {
        let t = out[k];
        k += 1;
        for &o in &nb[t as usize] {
            if !seen[o as usize] {
                seen[o as usize] = true;
                if distance(&at(o), &s0) <= tol {
                    out.push(o);
                }
            }
        }
    }
    out.sort_unstable();
    out
}

/// The base triangles a selection picks (`cameras` resolve `at`).
pub fn select<S: SurfaceModel>(
    mesh: &Mesh,
    bvh: &Bvh,
    surfaces: &S,
    sel: &Selection,
    cameras: &[Camera],
) -> std::result::Result<Vec<u32>, String> {
    let n = mesh.triangles.len();
    Ok(match sel {
        Selection::Faces(ids) => {
            if let Some(bad) = ids.iter().find(|&&f| f as usize >= mesh.num_file_faces) {
                return Err(format!(
                    "face {bad} is not in the mesh ({} faces)",
                    mesh.num_file_faces
                ));
            }
            (0..n as u32)
                .filter(|&t| ids.contains(&mesh.face_ids[t as usize]))
                .collect()
        }
        Selection::Box { min, max } => {
            let (lo, hi) = (Vec3::from(*min), Vec3::from(*max));
            (0..n as u32)
                .filter(|&t| {
                    let c = centroid(mesh, t as usize);
                    c.cmpge(lo).all() && c.cmple(hi).all()
                })
                .collect()
        }
        Selection::At {
            view,
            x,
            y,
            tolerance,
        } => {
            let cam = cameras
                .get(*view)
                .ok_or_else(|| format!("view {view} is not among the {} cameras", cameras.len()))?;
            if *x as usize >= cam.width || *y as usize >= cam.height {
                return Err(format!(
                    "pixel ({x}, {y}) is outside view {view} ({}×{})",
                    cam.width, cam.height
                ));
            }
            let (o, d) = cam.pixel_center_ray(*x as usize, *y as usize);
            let hit = bvh
                .closest_hit(o, d, 0.0, f32::INFINITY)
                .ok_or_else(|| format!("pixel ({x}, {y}) of view {view} sees no surface"))?;
            grow(mesh, surfaces, hit.tri, *tolerance)
        }
        Selection::Point {
            position,
            tolerance,
        } => {
            let p = Vec3::from(*position);
            let seed = (0..n)
                .min_by(|&a, &b| {
                    (centroid(mesh, a) - p)
                        .length_squared()
                        .total_cmp(&(centroid(mesh, b) - p).length_squared())
                })
                .ok_or("the mesh has no triangles")?;
            grow(mesh, surfaces, seed as u32, *tolerance)
        }
    })
}

/// What applying an edits file did: triangles per material edit, per object.
#[derive(Clone, Debug, Default, Serialize)]
pub struct EditsApplied {
    pub selected: Vec<usize>,
    pub object_triangles: Vec<usize>,
}

/// Applies `file` (read from `path`) to the base triangles of `surfaces`, then appends its
/// objects to `mesh`.
pub fn apply_edits<S: SurfaceModel>(
    mesh: &mut Mesh,
    surfaces: &mut EditedSurfaces<S>,
    file: &EditsFile,
    path: &Path,
    cameras: &[Camera],
) -> Result<EditsApplied> {
    let mut done = EditsApplied::default();
    if !file.materials.is_empty() {
        let bvh = Bvh::build(mesh, BuildQuality::Fast);
        let mut chosen = Vec::new();
        for (k, m) in file.materials.iter().enumerate() {
            let tris = select(mesh, &bvh, &surfaces.base, &m.select, cameras)
                .map_err(|e| invalid(path, format!("material edit {k}: {e}")))?;
            if tris.is_empty() {
                return Err(invalid(
                    path,
                    format!(
                        "material edit {k}: the selection {} holds no triangle (a box or point outside the mesh, or a tolerance too small?)",
                        serde_json::to_string(&m.select).unwrap_or_else(|_| format!("{:?}", m.select))
                    ),
                ));
            }
            chosen.push(tris);
        }
        for (m, tris) in file.materials.iter().zip(chosen) {
            done.selected.push(tris.len());
            surfaces.edit(tris, m.edit);
        }
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut objects = Vec::new();
    for (k, o) in file.objects.iter().enumerate() {
        let p = dir.join(&o.file);
        if !p.is_file() {
            return Err(invalid(
                path,
                format!(
                    "object {k}: {} not found (paths are relative to the edits file)",
                    p.display()
                ),
            ));
        }
        let mut m = Mesh::load(&p).map_err(|e| invalid(path, format!("object {k}: {e}")))?;
        if m.triangles.is_empty() {
            return Err(invalid(
                path,
                format!("object {k}: {} has no triangles", p.display()),
            ));
        }
        o.transform.apply(&mut m);
        objects.push(m);
    }
    for (k, (o, m)) in file.objects.iter().zip(objects).enumerate() {
        let mat = &o.material;
        let (kd, ks) = metallic_workflow(Vec3::from(mat.albedo).min(Vec3::ONE), mat.metallic);
        let what = AddedSurface {
            surface: SurfacePoint {
                kd,
                ks,
                roughness: clamp_roughness(mat.roughness),
                metallic: mat.metallic,
                emission: Vec3::from(mat.emission),
            },
            one_sided: false,
            part: OBJECT_PART + k as u32,
        };
        done.object_triangles.push(m.triangles.len());
        surfaces.add(mesh, &m, what);
    }
    Ok(done)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::TableSurfaces;

    fn cornell() -> (Mesh, EditedSurfaces<TableSurfaces>) {
        let s = fipt_synth::cornell();
        let t = TableSurfaces::new(s.materials, &s.mesh, Path::new("gt")).unwrap();
        let e = EditedSurfaces::new(t, &s.mesh);
        (s.mesh, e)
    }

    fn parse(text: &str) -> EditsFile {
        let p = std::env::temp_dir().join(format!(
            "fipt-edits-{}-{}.json",
            std::process::id(),
            text.len()
        ));
        std::fs::write(&p, text).unwrap();
        let f = EditsFile::read(&p);
        let _ = std::fs::remove_file(&p);
        f.unwrap()
    }

    #[test]
    fn a_region_grown_from_a_point_on_the_red_wall_is_the_red_wall() {
        let (mut mesh, mut s) = cornell();
        // The x = −1 wall (red) is one planar part of 2 triangles.
        let f = parse(
            r#"{"materials": [{"select": {"point": {"position": [-1.0, 1.0, 0.0]}},
                                           "edit": {"albedo": {"set": [0.1, 0.2, 0.9]}}}]}"#,
        );
        let cams: Vec<Camera> = Vec::new();
        let done = apply_edits(&mut mesh, &mut s, &f, Path::new("e.json"), &cams).unwrap();
        assert_eq!(done.selected, [2]);
        let red_wall = (0..mesh.triangles.len())
            .filter(|&t| centroid(&mesh, t).x < -0.99)
            .collect::<Vec<_>>();
        assert_eq!(red_wall.len(), 2);
        for t in 0..mesh.triangles.len() {
            let sp = s.surface(t as u32, centroid(&mesh, t));
            let edited = (sp.kd - Vec3::new(0.1, 0.2, 0.9)).length() < 1e-5;
            assert_eq!(edited, red_wall.contains(&t), "triangle {t}");
        }
    }

    #[test]
    fn boxes_faces_and_objects_apply_and_bad_selections_are_refused() {
        let (mut mesh, mut s) = cornell();
        let n0 = mesh.triangles.len();
        let obj = std::env::temp_dir().join(format!("fipt-edits-{}-cube.obj", std::process::id()));
        std::fs::write(
            &obj,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        )
        .unwrap();
        let text = format!(
            r#"{{"materials": [{{"select": {{"box": {{"min": [-2, -0.01, -2], "max": [2, 0.01, 2]}}}}, "edit": {{"roughness": {{"set": 0.05}}}}}},
                               {{"select": {{"faces": [0]}}, "edit": {{"emission": {{"set": [2, 2, 2]}}}}}}],
                "objects": [{{"file": "{}", "transform": {{"translate": [0, 0.5, 0], "scale": 0.2}},
                              "material": {{"albedo": [1, 0, 0], "roughness": 0.5, "metallic": 1}}}}]}}"#,
            obj.file_name().unwrap().to_str().unwrap()
        );
        let path = obj.with_extension("json");
        std::fs::write(&path, &text).unwrap();
        let f = EditsFile::read(&path).unwrap();
        let done = apply_edits(&mut mesh, &mut s, &f, &path, &[]).unwrap();
        assert_eq!(done.selected, [8, 1]); // the floor and the 3 blocks' bottoms; face 0
        assert_eq!(done.object_triangles, [4]);
        assert_eq!(mesh.triangles.len(), n0 + 4);
        assert!(s.surface(n0 as u32, Vec3::ZERO).metallic == 1.0);
        assert_eq!(s.part(n0 as u32), OBJECT_PART);
        let t0 = mesh.face_ids.iter().position(|&f| f == 0).unwrap() as u32;
        assert_eq!(s.emission(t0), Vec3::splat(2.0));
        // Refused: an empty box, a face out of range, a missing object, an empty edit.
        for (text, want) in [
            (
                r#"{"materials": [{"select": {"box": {"min": [5, 5, 5], "max": [6, 6, 6]}}, "edit": {"metallic": {"set": 1}}}]}"#,
                r#"the selection {"box":{"min":[5.0,5.0,5.0],"max":[6.0,6.0,6.0]}} holds no triangle"#,
            ),
            (
                r#"{"materials": [{"select": {"faces": [99999]}, "edit": {"metallic": {"set": 1}}}]}"#,
                "face 99999",
            ),
            (
                r#"{"objects": [{"file": "nope.obj", "material": {"albedo": [1, 1, 1]}}]}"#,
                "not found",
            ),
        ] {
            std::fs::write(&path, text).unwrap();
            let (mut mesh, mut s) = cornell();
            let f = EditsFile::read(&path).unwrap();
            let err = apply_edits(&mut mesh, &mut s, &f, &path, &[])
                .unwrap_err()
                .to_string();
            assert!(err.contains(want), "{text}: {err}");
        }
        // Refused as read: an edit that changes nothing (none given, or a scale of 1), an
        // albedo above 1, a file with no edit.
        for (text, want) in [
            (
                r#"{"materials": [{"select": {"faces": [0]}, "edit": {}}]}"#,
                "changes nothing",
            ),
            (
                r#"{"materials": [{"select": {"faces": [0]}, "edit": {"roughness": {"scale": 1}}}]}"#,
                "changes nothing",
            ),
            (
                r#"{"materials": [{"select": {"faces": [0]}, "edit": {"albedo": {"set": [1.5, 0.5, 0.5]}}}]}"#,
                "albedo: set values in [0, 1]",
            ),
            (
                r#"{"objects": [{"file": "x.obj", "material": {"albedo": [3, 3, 3]}}]}"#,
                "object 0: albedo [3.0, 3.0, 3.0]",
            ),
            ("{}", "holds no edit"),
        ] {
            std::fs::write(&path, text).unwrap();
            let err = EditsFile::read(&path).unwrap_err().to_string();
            assert!(err.contains(want), "{text}: {err}");
        }
        std::fs::write(
            &path,
            r#"{"materials": [{"select": {"sphere": 1}, "edit": {}}]}"#,
        )
        .unwrap();
        assert!(EditsFile::read(&path)
            .unwrap_err()
            .to_string()
            .contains("sphere"));
        let _ = std::fs::remove_file(&obj);
        let _ = std::fs::remove_file(&path);
    }
}
