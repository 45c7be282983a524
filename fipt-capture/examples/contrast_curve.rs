//! Prints the light transport's contrast curve of a scene as `fipt run` loads it
//! (`fipt_capture::contrast`).
//! ```sh
//! cargo run --release -p fipt-capture --example contrast_curve -- SCENE [DOWNSCALE]
//! ```
use fipt_core::image::BadPixelPolicy;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = std::env::args()
        .nth(1)
        .ok_or("usage: contrast_curve SCENE [DOWNSCALE]")?;
    let cfg = fipt_capture::capture::CaptureConfig {
        downscale: std::env::args().nth(2).map_or(Ok(1), |d| d.parse())?,
        ..Default::default()
    };
    let t = std::time::Instant::now();
    let s = fipt_capture::scene::load(scene.as_ref(), BadPixelPolicy::Reject, &cfg)?;
    let loaded = t.elapsed().as_secs_f32();
    if let Some(cl) = &s.capture.clipped_lights {
        let lv: Vec<f32> = cl.estimates.iter().map(|e| e.levels).collect();
        println!(
            "clipped lights: {} triangles, {} pixels, levels {lv:?}",
            cl.triangles, cl.pixels
        );
    }
    // Where the load looked for the contrast itself, its curve (before it raised the views).
    let (c, sources, samples) = match &s.capture.contrast {
        Some(f) => (f.curve.clone(), f.sources, f.samples),
        None => {
            let p = fipt_capture::contrast::probe(
                &s.geometry,
                &s.ds.train().views,
                &s.images,
                &[],
                &s.capture,
            )
            .ok_or("no sample")?;
            (p.curve, p.sources, p.samples)
        }
    };
    println!("{sources} sources, {samples} samples");
    let var0 = c
        .iter()
        .find(|p| p.gamma == 1.0)
        .map(|p| p.variance)
        .unwrap_or(f64::NAN);
    for p in &c {
        println!(
            "gamma {:.2}  var {:.5} ({:+.2} %)",
            p.gamma,
            p.variance,
            100.0 * (p.variance / var0 - 1.0)
        );
    }
    let (g, depth) = fipt_capture::contrast::minimum(&c);
    let took = s
        .capture
        .contrast
        .as_ref()
        .map_or(t.elapsed().as_secs_f32() - loaded, |f| f.seconds);
    println!(
        "min gamma {g:.3} ({g:?}); var(1)/min-1 = {:.2} % ({depth:?}); load {loaded:.1} s, curve {took:.1} s",
        100.0 * depth
    );
    // What the load decoded with (after raising, where it raised the views), for scripts
    // that score the estimate against a copy's true exposures or curve.
    if let Some(f) = &s.capture.exposure_fit {
        println!("gains {:?}", f.gains);
    }
    if let Some(r) = &s.capture.response {
        // The fit's own word ("fitted", "srgb (kept): …"): `applied` is also set where the
        // contrast raised an sRGB decoding.
        let fitted = if r.outcome.starts_with("fitted") {
            "fitted"
        } else {
            "srgb"
        };
        println!("response {fitted} {:?}", r.linear);
    }
    if let Some(f) = &s.capture.contrast {
        println!("applied {} gamma {}", f.applied, f.gamma);
    }
    Ok(())
}
