//! Material regions of the training pixels for the search: the scene's part ids (`IndexMA/`),
//! its semantic classes (`segmentation/`), or smooth patches of the mesh.
use crate::bail;
use crate::error::{Context, Result};
use crate::scene::LoadedScene;
use fipt_core::dataset::GtKind;
use fipt_shading::records::HitPoint;
use fipt_shading::search::RegionSource;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Dense region ids per training pixel (`ids[v][i]`, None: no region), the label of each
/// region (the scene's id, or the patch number), and where they came from.
pub struct Regions {
    pub ids: Vec<Vec<Option<u32>>>,
    pub labels: Vec<i64>,
    pub source: &'static str,
}

impl Regions {
    pub fn len(&self) -> usize {
        self.labels.len()
    }
}

/// The id maps (`IndexMA/` or `segmentation/`) of every training view, in view order.
pub fn split_ids(scene: &LoadedScene, kind: GtKind) -> Result<Vec<Vec<i64>>> {
    let split = scene.ds.train();
    (0..split.views.len())
        .into_par_iter()
        .map(|k| {
            scene
                .ds
                .load_ids(split, kind, k)
                .map(|v| v.unwrap_or_default())
        })
        .collect::<Result<Vec<_>, _>>()
        .with_context(|| format!("reading the ids in {}/", kind.folder()))
}

/// The regions `source` asks for (None for `none`).
pub fn load(
    scene: &LoadedScene,
    records: &[Vec<Option<HitPoint>>],
    source: RegionSource,
    mesh_angle_deg: f32,
) -> Result<Option<Regions>> {
    let split = scene.ds.train();
    let (parts, classes) = (
        split.has_gt(GtKind::IndexMA),
        split.has_gt(GtKind::Segmentation),
    );
    let kind =
        match source {
            RegionSource::None => return Ok(None),
            RegionSource::Mesh => None,
            RegionSource::Auto if parts => Some(GtKind::IndexMA),
            RegionSource::Auto if classes => Some(GtKind::Segmentation),
            RegionSource::Auto => None,
            RegionSource::Parts if parts => Some(GtKind::IndexMA),
            RegionSource::Semantic if classes => Some(GtKind::Segmentation),
            RegionSource::Parts | RegionSource::Semantic => bail!(
            "search.regions = \"{}\" but {} has no {} folder (use \"auto\", \"mesh\" or \"none\")",
            format!("{source:?}").to_lowercase(),
            split.dir.display(),
            if source == RegionSource::Parts { "IndexMA/" } else { "segmentation/" }
        ),
        };
    let Some(kind) = kind else {
        let (patch, n) = fipt_geom::patches::smooth_patches(&scene.geometry.mesh, mesh_angle_deg);
        let ids = records
            .iter()
            .map(|recs| {
                recs.iter()
                    .map(|r| r.map(|r| patch[r.tri as usize]))
                    .collect()
            })
            .collect();
        return Ok(Some(Regions {
            ids,
            labels: (0..n as i64).collect(),
            source: "mesh",
        }));
    };
    let raw = split_ids(scene, kind)?;
    let mut dense: BTreeMap<i64, u32> = BTreeMap::new();
    for &id in raw.iter().flatten() {
        if id >= 0 {
            let next = dense.len() as u32;
            dense.entry(id).or_insert(next);
        }
    }
    let ids = raw
        .iter()
        .map(|v| v.iter().map(|id| dense.get(id).copied()).collect())
        .collect();
    let mut labels = vec![0; dense.len()];
    for (&id, &d) in &dense {
        labels[d as usize] = id;
    }
    Ok(Some(Regions {
        ids,
        labels,
        source: if kind == GtKind::IndexMA {
            "parts"
        } else {
            "semantic"
        },
    }))
}
