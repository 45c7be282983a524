//! The clipped-light estimate (`fipt_capture::light_scale`) run on a clean HDR scene whose
//! `scene_parts.json` gives the true lights, as if every light were seen only clipped: what
//! the estimate's model of the room's light gets wrong, with no LDR loss, response or gain in
//! the way. Prints each light's estimate beside its true radiance (same units: the views').
//! Also prints, per part of the room (its `IndexMA` id), the median ratio of the model's kd at
//! the true radiances to the true kd (`DiffCol`) at the estimate's samples: above 1, the model
//! gives that part less light than it receives. DIRECT, the same scene rendered with the
//! lights' direct light alone (`max_depth` 2), splits that into the room's light and the
//! lights'. Beside each median, the slope of that ratio's log on the log of the model's
//! shading (A + Σ L·D) over the part: where it is β, the model keeps a share of the light's
//! fall-off in kd, and the views' contrast estimate (`fipt_capture::contrast`) on that part
//! alone reads about 1 − β. Every second training view is used.
//! ```sh
//! cargo run --release -p fipt-capture --example lights_against_truth -- SCENE [DIRECT]
//! ```
use fipt_core::dataset::{Dataset, GtKind, View};
use fipt_core::image::{BadPixelPolicy, Image};
use glam::Vec3;
use std::collections::{BTreeMap, HashSet};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = std::path::PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or("usage: lights_against_truth SCENE [DIRECT]")?,
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
    let direct = match std::env::args().nth(2) {
        Some(d) => Some(Dataset::open(std::path::Path::new(&d))?),
        None => None,
    };
    shading_by_part(
        &ds,
        direct.as_ref(),
        &g,
        &views,
        &images,
        &lights,
        &skip,
        &truth,
        &parts,
    )?;
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

/// Per part, the median (over the estimate's samples, green channel) of the model's kd at the
/// true radiances ÷ the true kd; with `direct` (the same views rendered with the lights' direct
/// light alone), also the model's light from the room A and from the lights Σ L·D, each ÷ the
/// truth's: (I − I_direct) / kd and I_direct / kd.
#[allow(clippy::too_many_arguments)]
fn shading_by_part(
    ds: &Dataset,
    direct: Option<&Dataset>,
    g: &fipt_geom::Geometry,
    views: &[View],
    images: &[Image],
    lights: &[Vec<u32>],
    skip: &[Vec<bool>],
    truth: &[serde_json::Value],
    parts: &serde_json::Value,
) -> Result<(), Box<dyn std::error::Error>> {
    let radiance: Vec<Vec3> = truth
        .iter()
        .map(|t| {
            let c = |i: usize| t[i].as_f64().unwrap_or(0.0) as f32;
            Vec3::new(c(0), c(1), c(2))
        })
        .collect();
    let shading =
        fipt_capture::light_scale::shading_at_radiances(g, views, images, lights, skip, &radiance);
    let split = ds.train();
    type Truth = (Image, Vec<i64>, Option<Image>);
    let mut gt: BTreeMap<usize, Truth> = BTreeMap::new();
    // Per part, per ratio: (ln of the model's shading, ln of the ratio).
    let mut by_part: BTreeMap<i64, [Vec<(f32, f32)>; 3]> = BTreeMap::new();
    for s in shading {
        let (v, x, y) = s.at;
        if !gt.contains_key(&v) {
            let i = views[v].index;
            let d = ds.load_gt(split, GtKind::DiffCol, i)?.ok_or("no DiffCol")?;
            let ids = ds
                .load_ids(split, GtKind::IndexMA, i)?
                .ok_or("no IndexMA")?;
            let dir = match direct {
                Some(dd) => Some(
                    dd.load_image(&dd.train().views[i], BadPixelPolicy::Clamp)?
                        .0,
                ),
                None => None,
            };
            gt.insert(v, (d, ids, dir));
        }
        let (d, ids, dir) = &gt[&v];
        let j = y * d.width + x;
        let kd = d.data[j].y;
        if kd <= 0.02 {
            continue;
        }
        let r = by_part.entry(ids[j]).or_default();
        let shade = (s.room.y + s.direct.y).ln();
        r[0].push((shade, s.seen.y / (s.room.y + s.direct.y) / kd));
        if let Some(dir) = dir {
            let i_dir = dir.data[j].y;
            r[1].push((shade, s.room.y / ((s.seen.y - i_dir) / kd)));
            r[2].push((shade, s.direct.y / (i_dir / kd)));
        }
    }
    let name = |id: i64| {
        parts["objects"]
            .as_array()
            .and_then(|o| o.iter().find(|o| o["index"].as_i64() == Some(id)))
            .and_then(|o| o["name"].as_str())
            .unwrap_or("?")
            .to_string()
    };
    println!("per part, medians (and slopes on ln shading): model kd / true kd; with a direct render, model A / true A and model Σ L·D / true");
    for (id, mut r) in by_part {
        let median_and_slope = |v: &mut Vec<(f32, f32)>| {
            v.retain(|(x, r)| x.is_finite() && r.is_finite() && *r > 0.0);
            let n = v.len() as f64;
            let (mx, my) = v.iter().fold((0.0, 0.0), |(a, b), (x, r)| {
                (a + *x as f64 / n, b + (*r as f64).ln() / n)
            });
            let (sxy, sxx) = v.iter().fold((0.0, 0.0), |(a, b), (x, r)| {
                let dx = *x as f64 - mx;
                (a + dx * ((*r as f64).ln() - my), b + dx * dx)
            });
            v.sort_by(|a, b| a.1.total_cmp(&b.1));
            v.get(v.len() / 2).map_or("-".to_string(), |m| {
                format!("{:.3} ({:+.3})", m.1, sxy / sxx.max(1e-12))
            })
        };
        let n = r[0].len();
        let (a, b, c) = (
            median_and_slope(&mut r[0]),
            median_and_slope(&mut r[1]),
            median_and_slope(&mut r[2]),
        );
        println!(
            "part {id:3} {:20} {n:6} samples  kd {a}  A {b}  direct {c}",
            name(id)
        );
    }
    Ok(())
}
