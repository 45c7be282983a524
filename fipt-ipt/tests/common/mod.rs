//! A tiny generated scene for the IPT tests: `cornell` (constant-material parts, one area
//! light) rendered by the forward tracer, with its part ids.
#![allow(dead_code)]
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::Geometry;
use fipt_shading::render::{render, render_aovs, RenderConfig};
use fipt_shading::scene::{Scene, SurfaceModel, TableSurfaces};
use fipt_synth::SynthScene;
use std::path::PathBuf;

pub struct Fixture {
    pub synth: SynthScene,
    pub table: TableSurfaces,
    pub geometry: Geometry,
    pub views: Vec<View>,
    pub images: Vec<Image>,
    /// Part id per view and pixel.
    pub parts: Vec<Vec<i64>>,
}

/// `cornell` seen by `n` cameras of `w`×`h` at `spp`, rendered with `model`.
pub fn cornell(n: usize, w: usize, h: usize, spp: u32, model: ReflectanceModel) -> Fixture {
    let synth = fipt_synth::build("cornell").unwrap();
    let mut table = TableSurfaces::new(
        synth.materials.clone(),
        &synth.mesh,
        std::path::Path::new("cornell"),
    )
    .unwrap();
    table.model = model;
    let geometry = Geometry::new(synth.mesh.clone());
    let cams = synth.cameras(n, 7, w, h, &geometry.bvh);
    let scene = Scene::new(synth.mesh.clone(), &table);
    let cfg = RenderConfig {
        spp,
        ..Default::default()
    };
    let (mut views, mut images, mut parts) = (vec![], vec![], vec![]);
    for (k, cam) in cams.into_iter().enumerate() {
        let (img, _) = render(&scene, &cam, &cfg, k as u64, &|_| {});
        let aovs = render_aovs(&scene, &cam);
        parts.push(
            aovs.part
                .iter()
                .map(|&p| if p == u32::MAX { -1 } else { p as i64 })
                .collect(),
        );
        images.push(img);
        views.push(View {
            index: k,
            camera: cam,
            image: PathBuf::from(format!("{k}.exr")),
            mask: None,
        });
    }
    Fixture {
        synth,
        table,
        geometry,
        views,
        images,
        parts,
    }
}

impl Fixture {
    /// The emitted radiance of triangle `t`.
    pub fn emission(&self, t: u32) -> glam::Vec3 {
        self.table.emission(t)
    }
}
