//! Loading a scene folder for the stages: dataset, geometry, training images, fingerprint.
use crate::progress::Stage;
use anyhow::{Context, Result};
use fipt_core::dataset::Dataset;
use fipt_core::image::{BadPixelPolicy, Image};
use fipt_geom::{Geometry, Mesh};
use rayon::prelude::*;
use std::path::Path;

pub struct LoadedScene {
    pub ds: Dataset,
    pub geometry: Geometry,
    pub images: Vec<Image>,
    /// Fingerprint of the mesh, the training cameras and images.
    pub inputs_hash: String,
}

pub fn load(root: &Path, policy: BadPixelPolicy) -> Result<LoadedScene> {
    let st = Stage::start("load scene");
    let ds = Dataset::open(root).with_context(|| format!("opening scene {}", root.display()))?;
    let mesh = Mesh::load(&ds.mesh).context("loading the scene mesh")?;
    if mesh.dropped_degenerate > 0 {
        eprintln!(
            "note: {} degenerate triangles dropped from {}",
            mesh.dropped_degenerate,
            ds.mesh.display()
        );
    }
    let geometry = Geometry::new(mesh);
    let split = ds.train();
    let images = split
        .views
        .par_iter()
        .map(|v| ds.load_image(v, policy).map(|(img, _)| img))
        .collect::<Result<Vec<_>, _>>()
        .context("reading the training images")?;
    let mut files = vec![ds.mesh.clone(), split.cameras_file.clone()];
    if let Some(k) = ds
        .root
        .join("K_list.txt")
        .is_file()
        .then(|| ds.root.join("K_list.txt"))
    {
        files.push(k);
    }
    files.extend(split.views.iter().map(|v| v.image.clone()));
    let inputs_hash = fipt_core::fsutil::hash_files(&files)?;
    st.done();
    Ok(LoadedScene {
        ds,
        geometry,
        images,
        inputs_hash,
    })
}
