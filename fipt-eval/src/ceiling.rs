//! `fipt eval SRC OUT --ceiling COPY`: what the geometry of a copy allows. A scene's true
//! materials (its `scene_parts.json`, or `scene_gt.json` of `fipt synth`) are laid on the mesh of a copy made from it (a scan
//! made by `fipt degrade --subdivide K --mesh-warp MM`, whose faces are the source's, each
//! split into 4^K in order), rendered at the scene's own cameras and scored against its ground
//! truth with the protocol of [`crate::eval`]. A run of the copy cannot score better than this
//! but for noise: its kd and σ maps are looked up on the same mesh, so where the mesh lies off
//! the true surface they read the material of another point.
use crate::error::{Context, Result};
use crate::eval::{evaluate_scaled, Scales};
use crate::render::{render_unchecked, RenderRequest};
use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::materials::{FaceRange, SceneMaterials};
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::Mesh;
use std::path::{Path, PathBuf};

/// What to score.
#[derive(Clone, Debug)]
pub struct CeilingRequest {
    /// The scene folder with ground truth and `scene_parts.json`.
    pub truth: PathBuf,
    /// The copy whose mesh carries the materials (a folder holding a mesh, or a mesh file).
    pub copy: PathBuf,
    /// A new folder (or one this command wrote) for the renders and `metrics.json`.
    pub out: PathBuf,
    /// The split of `truth` to score at (default `val`).
    pub split: Option<String>,
    pub spp: u32,
    pub seed: u64,
}

/// The faces of a subdivided copy of a mesh: each range of the source's table times `ratio`.
pub fn scale_faces(m: &SceneMaterials, ratio: u32) -> SceneMaterials {
    SceneMaterials {
        faces: (m.faces.iter())
            .map(|r| FaceRange {
                start: r.start * ratio,
                end: r.end * ratio,
                material: r.material,
            })
            .collect(),
        note: format!("{} (face ranges × {ratio})", m.note),
        ..m.clone()
    }
}

/// How a copy's faces stand for the source's.
enum FaceMap {
    /// Refined: per source face, its first face in the copy (one more entry at the end).
    Refined(Vec<u32>),
    /// Subdivided: this many faces per source face, in order.
    Subdivided(u32),
}

/// The faces of a refined copy of a mesh: each range of the source's table through `starts`
/// (per source face, its first face in the copy; one more entry at the end).
pub fn map_faces(m: &SceneMaterials, starts: &[u32], copy: &Path) -> Result<SceneMaterials> {
    let at = |f: u32| {
        starts.get(f as usize).copied().ok_or_else(|| {
            fipt_run::err!(
                "{}: degrade.json maps {} source faces, and the scene's table names face {f}",
                copy.display(),
                starts.len().saturating_sub(1)
            )
        })
    };
    let mut faces = Vec::with_capacity(m.faces.len());
    for r in &m.faces {
        faces.push(FaceRange {
            start: at(r.start)?,
            end: at(r.end)?,
            material: r.material,
        });
    }
    Ok(SceneMaterials {
        faces,
        note: format!("{} (face ranges through the copy's refinement)", m.note),
        ..m.clone()
    })
}

/// A refined copy's face map from its `degrade.json` (`face_starts`), checked against both
/// meshes; None for a copy without one (subdivided at most: faces × 4^K).
fn refined_faces(copy: &Path, source_faces: usize, copy_faces: usize) -> Result<Option<Vec<u32>>> {
    let record = copy.join("degrade.json");
    if !record.is_file() {
        return Ok(None);
    }
    let text =
        std::fs::read_to_string(&record).map_err(|e| fipt_core::CoreError::io(&record, e))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        fipt_run::err!(
            "{}: not JSON ({e}); make the copy again with `fipt degrade`",
            record.display()
        )
    })?;
    let Some(list) = v.get("face_starts").and_then(|s| s.as_array()) else {
        return Ok(None);
    };
    let starts: Vec<u32> = list
        .iter()
        .filter_map(|x| x.as_u64().map(|x| x as u32))
        .collect();
    let monotone = starts.windows(2).all(|w| w[0] <= w[1]);
    if starts.len() != list.len()
        || starts.len() != source_faces + 1
        || !monotone
        || starts.last().copied() != Some(copy_faces as u32)
    {
        crate::bail!(
            "{}: face_starts maps {} faces to {} and does not fit the meshes ({source_faces} source faces, {copy_faces} in the copy); make the copy again with `fipt degrade`",
            record.display(),
            starts.len().saturating_sub(1),
            starts.last().copied().unwrap_or(0)
        );
    }
    Ok(Some(starts))
}

/// How many faces of the copy stand for each face of the source: a power of 4, or an error
/// naming both meshes.
pub fn subdivision_ratio(source_faces: usize, copy_faces: usize, copy: &Path) -> Result<u32> {
    let mut r = 1usize;
    while source_faces > 0 && source_faces * r < copy_faces {
        r *= 4;
    }
    if source_faces == 0 || source_faces * r != copy_faces {
        crate::bail!(
            "{}: its mesh has {copy_faces} faces, not the source's {source_faces} times a power of 4; the ceiling needs a copy made by `fipt degrade` (its faces in the source's order)",
            copy.display()
        );
    }
    Ok(r as u32)
}

/// The map a render in the dataset layout writes, and the name a run's maps give it.
const MAPS: [(GtKind, &str); 5] = [
    (GtKind::DiffCol, "kd"),
    (GtKind::Specular, "ks"),
    (GtKind::Roughness, "roughness"),
    (GtKind::Metallic, "metallic"),
    (GtKind::Emit, "emission"),
];

/// Renders and scores the ceiling; writes `OUT/metrics.json` and returns it.
pub fn evaluate_ceiling(
    a: &CeilingRequest,
    components: &crate::Components,
) -> Result<serde_json::Value> {
    let ds =
        Dataset::open(&a.truth).with_context(|| format!("opening scene {}", a.truth.display()))?;
    let split = crate::eval_at::pick_split(&ds, a.split.as_deref())?.clone();
    let Some(parts) = SceneMaterials::file_in(&a.truth) else {
        crate::bail!(
            "{}: no scene_parts.json or scene_gt.json; the ceiling lays the scene's true materials on the copy's mesh",
            a.truth.display()
        );
    };
    let copy_mesh = crate::render::mesh_of(&a.copy)?;
    let source_faces = Mesh::load(&ds.mesh)?.num_file_faces;
    let copy_faces = Mesh::load(&copy_mesh)?.num_file_faces;
    // Per source face its first face in a refined copy, else faces × 4^K: checked here,
    // before anything is written.
    // degrade.json lies beside the copy's mesh (COPY may name the folder or the mesh).
    let copy_dir = copy_mesh.parent().unwrap_or(&a.copy);
    let faces = match refined_faces(copy_dir, source_faces, copy_faces)? {
        Some(starts) => FaceMap::Refined(starts),
        None => FaceMap::Subdivided(subdivision_ratio(source_faces, copy_faces, &a.copy)?),
    };
    use fipt_core::lock::{refuse_owned_output, Owner};
    refuse_owned_output(&a.out, "eval --ceiling", &[Owner::Run, Owner::Scene])?;
    std::fs::create_dir_all(&a.out).map_err(|e| fipt_core::CoreError::io(&a.out, e))?;
    let table = a.out.join("materials.json");
    let source = SceneMaterials::read_any(&parts)?;
    // Faces per source face: exact for a subdivided copy, a mean for a refined one.
    let (materials, ratio) = match faces {
        FaceMap::Refined(s) => (
            map_faces(&source, &s, &a.copy)?,
            serde_json::json!(copy_faces as f64 / source_faces.max(1) as f64),
        ),
        FaceMap::Subdivided(r) => (scale_faces(&source, r), serde_json::json!(r)),
    };
    fipt_core::fsutil::write_json_atomic(&table, &materials)?;
    let rendered = a.out.join("render");
    render_unchecked(
        &RenderRequest {
            source: copy_mesh,
            materials: Some(table),
            scene: None,
            cameras: split.cameras_file.clone(),
            out: rendered.clone(),
            size: Some((ds.width, ds.height)),
            spp: a.spp,
            max_bounces: fipt_pipeline::run_config::DEFAULT_MAX_BOUNCES,
            seed: a.seed,
            views: None,
            brdf: Some(ReflectanceModel::Principled),
            lights: vec![],
            emitters: None,
            edits: None,
            reference: None,
            denoise: Some(false),
        },
        components,
    )?;
    let views = a.out.join("views").join(&split.name);
    std::fs::create_dir_all(&views).map_err(|e| fipt_core::CoreError::io(&views, e))?;
    for v in &split.views {
        let k = v.index;
        let mut moves: Vec<(PathBuf, String)> = (MAPS.iter())
            .map(|(g, name)| {
                (
                    rendered.join(g.folder()).join(g.file_name(k)),
                    name.to_string(),
                )
            })
            .collect();
        let image = rendered
            .join("Image")
            .join(fipt_core::dataset::image_file_name(k));
        moves.push((image, "render".into()));
        for (from, name) in moves {
            let to = views.join(format!("{k:03}_{name}.exr"));
            std::fs::rename(&from, &to).map_err(|e| fipt_core::CoreError::io(&from, e))?;
        }
    }
    let only = Dataset {
        splits: vec![split.clone()],
        ..ds.clone()
    };
    let mut m = evaluate_scaled(&only, &a.out, 1.0, Scales::ONE)?;
    m[&split.name]["ceiling"] = serde_json::json!({
        "truth": a.truth,
        "copy": a.copy,
        "faces_per_source_face": ratio,
        "spp": a.spp,
        "what": "the scene's true materials on the copy's mesh, at the scene's cameras",
    });
    fipt_core::fsutil::write_json_atomic(&a.out.join("metrics.json"), &m)?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ratio_is_a_power_of_four_or_an_error_naming_the_copy() {
        let p = Path::new("copy");
        assert_eq!(subdivision_ratio(10, 10, p).unwrap(), 1);
        assert_eq!(subdivision_ratio(10, 160, p).unwrap(), 16);
        let e = subdivision_ratio(10, 80, p).unwrap_err().to_string();
        assert!(e.contains("copy") && e.contains("80 faces"), "{e}");
        assert!(subdivision_ratio(0, 4, p).is_err());
    }

    #[test]
    fn face_ranges_scale_and_keep_their_materials() {
        let m = SceneMaterials {
            version: 1,
            materials: vec![],
            faces: vec![
                FaceRange {
                    start: 0,
                    end: 2,
                    material: 1,
                },
                FaceRange {
                    start: 2,
                    end: 5,
                    material: 0,
                },
            ],
            note: "t".into(),
        };
        let s = scale_faces(&m, 16);
        assert_eq!(
            (s.faces.iter())
                .map(|r| (r.start, r.end, r.material))
                .collect::<Vec<_>>(),
            vec![(0, 32, 1), (32, 80, 0)]
        );
    }
}
