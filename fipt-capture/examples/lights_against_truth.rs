//! The clipped-light estimate (`fipt_capture::light_scale`) run on a clean HDR scene whose
//! `scene_parts.json` gives the true lights, as if every light were seen only clipped: what
//! the estimate's model of the room's light gets wrong, with no LDR loss, response or gain in
//! the way. Prints each light's estimate beside its true radiance (same units: the views').
//! Every second training view is used.
//! ```sh
//! cargo run --release -p fipt-capture --example lights_against_truth -- SCENE
//! ```
use fipt_core::image::BadPixelPolicy;
use std::collections::HashSet;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = std::path::PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or("usage: lights_against_truth SCENE")?,
    );
    let ds = fipt_core::dataset::Dataset::open(&scene)?;
    let g = fipt_geom::Geometry::new(fipt_geom::Mesh::load(&ds.mesh)?);
    let parts_path = scene.join("scene_parts.json");
    let parts: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&parts_path)
            .map_err(|e| format!("{}: {e} (a scene with ground truth)", parts_path.display()))?,
    )?;
    let (mut lights, mut truth) = (vec![], vec![]);
    for o in parts["objects"]
        .as_array()
        .ok_or("scene_parts.json: no objects")?
    {
        if o["type"] == "emitter" {
            let face = |k: &str| o[k].as_u64().map(|x| x as u32).ok_or("no face range");
            lights.push((face("face_start")?..face("face_end")?).collect::<Vec<u32>>());
            truth.push(o["radiance"].clone());
        }
    }
    let views: Vec<_> = ds.train().views.iter().step_by(2).cloned().collect();
    let images = views
        .iter()
        .map(|v| ds.load_image(v, BadPixelPolicy::Clamp).map(|x| x.0))
        .collect::<Result<Vec<_>, _>>()?;
    let is_light: HashSet<u32> = lights.iter().flatten().copied().collect();
    let skip: Vec<Vec<bool>> = views
        .iter()
        .map(|v| {
            fipt_shading::records::hit_points(&g, v)
                .iter()
                .map(|h| h.is_some_and(|h| is_light.contains(&h.tri())))
                .collect()
        })
        .collect();
    let (est, _, mixed) =
        fipt_capture::light_scale::estimate(&g, &views, &images, &lights, &skip, 1.0, &[])
            .ok_or("no sample off the lights")?;
    println!(
        "{} patches ({} samples) left out as not one colour",
        mixed[0], mixed[1]
    );
    for (e, t) in est.iter().zip(&truth) {
        let r = e.radiance;
        println!(
            "{:4} triangles  estimate [{:.2}, {:.2}, {:.2}]  truth {t}  {}  contrast {:+.3}  range {:.2} … {:.2}",
            e.triangles, r[0], r[1], r[2], e.chosen_by, e.contrast, e.range[0], e.range[1]
        );
    }
    Ok(())
}
