//! Does the apparent albedo follow the light? Per smooth patch of the mesh, the slope of
//! log(I / Ld) against log Ld over a run's training pixels (luminances; the bake's shadings,
//! Ld0 under `principled`; pixels within 5 % of their view's brightest left out, as possibly
//! clipped). A camera response decoded with the wrong contrast makes it non-zero where direct
//! light varies across a surface (`docs/phone-captures.md`, section 5). No ground truth needed.
//! ```sh
//! cargo run --release -p fipt-method --example kd_light_slope -- SCENE RUN [NAME]
//! ```
//! NAME: the shadings in RUN (`bake`, default; `refine1`).
use fipt_bake::bake_store;
use fipt_core::color::luminance;
use fipt_core::image::BadPixelPolicy;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 3 {
        return Err("usage: kd_light_slope SCENE RUN [NAME]".into());
    }
    let (scene, out) = (PathBuf::from(&a[1]), PathBuf::from(&a[2]));
    let name = a.get(3).map_or("bake", String::as_str);
    let loaded = fipt_capture::scene::load(&scene, BadPixelPolicy::Reject, &Default::default())?;
    let split = loaded.ds.train();
    // The scene is loaded with the default capture settings: a run made with others (its
    // `[capture]` table) has shadings of other inputs and is refused here.
    let dir = out.join(name);
    let sh = match bake_store::load_for_inputs(&dir, &loaded.cache_key)? {
        Ok((_, s)) => s.load_all()?,
        Err(why) => {
            let fix = "give a run folder of this scene and its shadings' name (bake, refine1)";
            return Err(format!("{}: {why}; {fix}", dir.display()).into());
        }
    };
    let (hits, _) = fipt_shading::records::hit_points_and_footprint(&loaded.geometry, &split.views);
    let (patch, n) = fipt_geom::patches::smooth_patches(&loaded.geometry.mesh, 30.0);
    // Per patch: Σ1, Σx, Σy, Σxx, Σxy of x = log Ld, y = log(I / Ld).
    let mut sums = vec![[0f64; 5]; n];
    for (k, img) in loaded.images.iter().enumerate() {
        let top = img.data.iter().map(|&p| luminance(p)).fold(0f32, f32::max);
        for (i, h) in hits[k].iter().enumerate() {
            let Some(h) = h else { continue };
            let (l, d) = (luminance(img.data[i]), luminance(sh[k].ld[i]));
            if !sh[k].valid[i] || !(l > 0.0 && d > 0.0) || l >= 0.95 * top {
                continue;
            }
            let (x, y) = ((d as f64).ln(), ((l / d) as f64).ln());
            let s = &mut sums[patch[h.tri() as usize] as usize];
            for (v, add) in s.iter_mut().zip([1.0, x, y, x * x, x * y]) {
                *v += add;
            }
        }
    }
    let mut rows = vec![];
    for (p, s) in sums.iter().enumerate() {
        let [c, x, y, xx, xy] = *s;
        let var = xx / c.max(1.0) - (x / c.max(1.0)).powi(2);
        if c < 2000.0 || var < 0.01 {
            continue;
        }
        let slope = (xy / c - x / c * y / c) / var;
        println!(
            "patch {p:4}  pixels {c:8.0}  log Ld spread {:.2}  slope {slope:+.3}",
            var.sqrt()
        );
        rows.push((c, slope));
    }
    rows.sort_by(|a, b| a.1.total_cmp(&b.1));
    let total: f64 = rows.iter().map(|r| r.0).sum();
    let mut acc = 0.0;
    let median = rows.iter().find(|r| {
        acc += r.0;
        acc >= total / 2.0
    });
    println!(
        "{}: pixel-weighted median slope {:+.3} over {} patches",
        out.display(),
        median.map_or(f64::NAN, |r| r.1),
        rows.len()
    );
    Ok(())
}
