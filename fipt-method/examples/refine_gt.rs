//! Diagnostic for the material search: the path-grown refinement run with the ground truth's
//! materials and emitters (a scene of `fipt synth`, which writes `scene_gt.json`, or of
//! `scripts/mitsuba_loft.py`, which writes `scene_parts.json`), written beside a finished
//! run's shadings as `OUT/NAME`, so that
//! `fipt profile SCENE OUT --shadings NAME` shows where σ's minima lie when the shadings owe
//! nothing to the recovered materials (`docs/roughness-rooms.md`, *Where rough walls' glossy
//! minima come from*).
//!
//! ```sh
//! cargo run --release -p fipt-method --example refine_gt -- SCENE OUT NAME BRDF [KEY=JSON ...]
//! cargo run --release -p fipt-method --example refine_gt -- dump SCENE OUT NAME FILE
//! ```
//! The refinement takes `OUT/refine1`'s settings, with `KEY=JSON` overrides of `[refine]`
//! (`specular_samples=[128,128,128,128,128,128]`, `diffuse_cache=false`, ...); BRDF is the
//! model the views were rendered with (`fipt` for `fipt synth`'s default). `dump` writes, per
//! hit pixel of the training views, 57 little-endian f32: view, pixel, part (`IndexMA`), hit
//! point (3), ωo (3), cos θo, image (3, divided by the run's exposure scale), Ld (3), Ls0
//! (6 × 3), Ls1 (6 × 3), true kd (3), true σ, 0.
use fipt_bake::bake_store::{self, BakeManifest};
use fipt_bake::refine::{PathGrownRefiner, RefineConfig};
use fipt_core::emitter::Emitter;
use fipt_core::field::{Material, MaterialField};
use fipt_core::image::BadPixelPolicy;
use fipt_core::materials::SceneMaterials;
use fipt_core::shading::{RayQuery, RefineInputs};
use fipt_geom::nearest::TriangleLocator;
use fipt_geom::Mesh;
use fipt_shading::scene::{SurfaceModel, TableSurfaces};
use glam::Vec3;
use std::path::PathBuf;

struct GtField {
    loc: TriangleLocator,
    table: TableSurfaces,
}

impl MaterialField for GtField {
    fn name(&self) -> &str {
        "ground truth"
    }
    fn materials(&self, pts: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        Ok(pts
            .iter()
            .map(|&p| {
                let t = self.loc.nearest(p).unwrap_or(0);
                Material::of_surface(&self.table.surface(t, p))
            })
            .collect())
    }
    fn emission_mask(&self, p: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        Ok(vec![0.0; p.len()])
    }
}

/// `dump SCENE OUT NAME FILE` (the layout in the module doc).
fn dump(a: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    use fipt_core::dataset::GtKind;
    let (scene, out, name, file) = (PathBuf::from(&a[2]), PathBuf::from(&a[3]), &a[4], &a[5]);
    let loaded = fipt_capture::scene::load(&scene, BadPixelPolicy::Reject, &Default::default())?;
    let split = loaded.ds.train();
    let dir = out.join(name);
    let sh = match bake_store::load_for_inputs(&dir, &loaded.cache_key)? {
        Ok((_, s)) => s.load_all()?,
        Err(why) => return Err(why.into()),
    };
    let (hits, _) = fipt_shading::records::hit_points_and_footprint(&loaded.geometry, &split.views);
    let mut buf: Vec<f32> = vec![];
    for (k, v) in split.views.iter().enumerate() {
        let g = |kind| {
            loaded.ds.load_gt(split, kind, v.index)?.ok_or_else(|| {
                fipt_core::CoreError::invalid(&scene, format!("no ground truth {kind:?}"))
            })
        };
        let (kd, ro, part) = (
            g(GtKind::DiffCol)?,
            g(GtKind::Roughness)?,
            g(GtKind::IndexMA)?,
        );
        let (org, _) = v.camera.pixel_center_ray(0, 0);
        for (i, h) in hits[k].iter().enumerate() {
            let Some(h) = h else { continue };
            if !sh[k].valid[i] {
                continue;
            }
            let wo = (org - h.p).normalize();
            let hit = loaded.geometry.intersect(org, -wo);
            let cos = hit.map_or(0.0, |s| s.ns.dot(wo).abs());
            let img = loaded.images[k].data[i];
            let mut row = vec![k as f32, i as f32, part.data[i].x];
            row.extend(h.p.to_array());
            row.extend(wo.to_array());
            row.push(cos);
            row.extend(img.to_array());
            row.extend(sh[k].ld[i].to_array());
            for l in 0..6 {
                row.extend(sh[k].ls0[i][l].to_array());
            }
            for l in 0..6 {
                row.extend(sh[k].ls1[i][l].to_array());
            }
            row.extend(kd.data[i].to_array());
            row.push(ro.data[i].x);
            row.push(0.0);
            buf.extend(row);
        }
    }
    let bytes: Vec<u8> = buf.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(file, bytes)?;
    eprintln!("{} rows", buf.len() / 57);
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    if a.get(1).map(String::as_str) == Some("dump") && a.len() == 6 {
        return dump(&a);
    }
    if a.len() < 5 || a[1] == "dump" {
        return Err("usage: refine_gt SCENE OUT NAME BRDF [KEY=JSON ...] | refine_gt dump SCENE OUT NAME FILE".into());
    }
    let (scene, out, name, brdf) = (
        PathBuf::from(&a[1]),
        PathBuf::from(&a[2]),
        &a[3],
        a[4].parse::<fipt_core::reflectance::ReflectanceModel>()?,
    );
    let loaded = fipt_capture::scene::load(&scene, BadPixelPolicy::Reject, &Default::default())?;
    let mesh = Mesh::load(&loaded.ds.mesh)?;
    let gt = SceneMaterials::file_in(&scene).unwrap_or_else(|| scene.join("scene_gt.json"));
    let mats = SceneMaterials::read_any(&gt)?;
    let mut table = TableSurfaces::new(mats, &mesh, &gt)?;
    table.model = brdf;
    let s = 1.0 / loaded.exposure;
    let (mut tris, mut rad, mut sides) = (vec![], vec![], vec![]);
    for t in 0..mesh.triangles.len() as u32 {
        let le = table.emission(t);
        if le != Vec3::ZERO {
            tris.push(t);
            rad.push(le * s);
            sides.push(table.emit_side(t));
        }
    }
    let emitter = Emitter::from_triangles(&mesh.positions, &mesh.triangles, tris, rad, 0)
        .ok_or("the ground truth has no emitting triangles")?
        .with_sides(&mesh.positions, &mesh.triangles, sides);
    let field = GtField {
        loc: TriangleLocator::new(&mesh),
        table,
    };
    let split = loaded.ds.train();
    let inputs = RefineInputs {
        geometry: &loaded.geometry,
        positions: &mesh.positions,
        triangles: &mesh.triangles,
        views: &split.views,
        images: &loaded.images,
        field: &field,
        emitters: std::slice::from_ref(&emitter),
    };
    // The run's refine settings, with overrides.
    let m1: BakeManifest =
        serde_json::from_slice(&std::fs::read(out.join("refine1/manifest.json"))?)?;
    let mut settings = m1.config["settings"].clone();
    for kv in &a[5..] {
        let (k, v) = kv
            .split_once('=')
            .ok_or(format!("{kv}: expected KEY=JSON"))?;
        settings[k] = serde_json::from_str(v)?;
    }
    let cfg: RefineConfig = serde_json::from_value(settings.clone())?;
    eprintln!("refine with {cfg:?}, exposure {}", loaded.exposure);
    let t0 = std::time::Instant::now();
    let (sh, stats) = PathGrownRefiner::new(cfg)
        .with_model(brdf)
        .refine_detailed(&inputs, &|_, _| {})?;
    eprintln!("{:.1} s {stats:?}", t0.elapsed().as_secs_f64());
    let mut m = m1.clone();
    m.hashes.clear();
    m.inputs_hash = loaded.cache_key.clone();
    m.config["settings"] = settings;
    bake_store::save(&out.join(name), &m, &sh)?;
    Ok(())
}
