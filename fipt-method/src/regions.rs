//! Material regions of the training pixels for the search: the scene's part ids (`IndexMA/`),
//! its semantic classes (`segmentation/`), or smooth patches of the mesh.
use crate::bail;
use crate::error::Result;
use crate::scene::SceneRef;
use fipt_core::dataset::GtKind;
use fipt_search::RegionSource;
use fipt_shading::records::HitPoint;
use std::collections::BTreeMap;

/// Dense region ids per training pixel (`ids[v][i]`, None: no region), the label of each
/// region (the scene's id, or the patch number), and where they came from.
pub struct Regions {
    /// Per training view and pixel, the region's index ([`Regions::NONE`] for none): 4 bytes
    /// a pixel (an `Option<u32>` took 8).
    pub ids: Vec<Vec<u32>>,
    pub labels: Vec<i64>,
    pub source: &'static str,
}

impl Regions {
    /// A pixel on no region.
    pub const NONE: u32 = u32::MAX;

    /// Pixel `i` of view `v`'s region.
    #[inline]
    pub fn id(&self, v: usize, i: usize) -> Option<u32> {
        Some(self.ids[v][i]).filter(|&r| r != Self::NONE)
    }

    pub fn len(&self) -> usize {
        self.labels.len()
    }
}

pub use crate::segments::split_ids;
use crate::segments::view_ids;

/// The regions `source` asks for (None for `none`).
pub fn load(
    scene: &SceneRef,
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
        let (patch, n) =
            fipt_geom::patches::smooth_patches_of(scene.positions, scene.triangles, mesh_angle_deg);
        let ids = records
            .iter()
            .map(|recs| {
                recs.iter()
                    .map(|r| r.map_or(Regions::NONE, |r| patch[r.tri() as usize]))
                    .collect()
            })
            .collect();
        return Ok(Some(Regions {
            ids,
            labels: (0..n as i64).collect(),
            source: "mesh",
        }));
    };
    // Numbered densely in order of first appearance, a few views at a time (every view's
    // ids at once took 8 bytes a pixel). An id's number is fixed when it first appears, so
    // a view's ids are final once the views before it are numbered.
    let split = scene.ds.train();
    let mut dense: BTreeMap<i64, u32> = BTreeMap::new();
    let mut ids = Vec::with_capacity(split.views.len());
    let all: Vec<usize> = (0..split.views.len()).collect();
    for chunk in all.chunks(rayon::current_num_threads().max(1) * 2) {
        let raw = view_ids(scene, kind, chunk)?;
        for view in raw {
            for &id in view.iter().filter(|&&id| id >= 0) {
                let next = dense.len() as u32;
                dense.entry(id).or_insert(next);
            }
            ids.push(
                (view.iter())
                    .map(|id| dense.get(id).copied().unwrap_or(Regions::NONE))
                    .collect(),
            );
        }
    }
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
