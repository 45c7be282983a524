//! The part (or semantic class) id of every training pixel, from the scene's `IndexMA/` or
//! `segmentation/` maps: for a method that wants segments, and FIPT's regions.
use crate::error::{Context, Result};
use crate::scene::SceneRef;
use fipt_core::dataset::GtKind;
use rayon::prelude::*;

/// The id maps (`IndexMA/` or `segmentation/`) of every training view, in view order.
pub fn split_ids(scene: &SceneRef, kind: GtKind) -> Result<Vec<Vec<i64>>> {
    let all: Vec<usize> = (0..scene.ds.train().views.len()).collect();
    view_ids(scene, kind, &all)
}

/// The id maps of the training views `views`, in their order (read in parallel).
pub fn view_ids(scene: &SceneRef, kind: GtKind, views: &[usize]) -> Result<Vec<Vec<i64>>> {
    let split = scene.ds.train();
    views
        .par_iter()
        .copied()
        .map(|k| {
            scene
                .ds
                .load_ids(split, kind, k)
                .map(|v| v.unwrap_or_default())
        })
        .collect::<Result<Vec<_>, _>>()
        .with_context(|| format!("reading the ids in {}/", kind.folder()))
}
