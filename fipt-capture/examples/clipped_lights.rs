//! Prints the estimates of the lights a scene's LDR views show only clipped, as `fipt run`
//! loads it (`fipt_capture::light_scale`): each light's triangles, radiance in clip levels, the
//! range the views allow, how it was chosen and how deep the flatness curve is.
//! ```sh
//! cargo run --release -p fipt-capture --example clipped_lights -- SCENE
//! ```
use fipt_core::image::BadPixelPolicy;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = std::env::args()
        .nth(1)
        .ok_or("usage: clipped_lights SCENE")?;
    let cfg = fipt_capture::capture::CaptureConfig::default();
    let t = std::time::Instant::now();
    let s = fipt_capture::scene::load(scene.as_ref(), BadPixelPolicy::Reject, &cfg)?;
    let Some(cl) = &s.capture.clipped_lights else {
        println!("no clipped light ({:.1} s)", t.elapsed().as_secs_f32());
        return Ok(());
    };
    println!(
        "{} patches ({} samples) left out as not one colour",
        cl.not_one_colour[0], cl.not_one_colour[1]
    );
    for e in &cl.estimates {
        println!(
            "{:4} triangles  {:8.2} levels  range {:.1} … {:.1}  contrast {:+.4}  {}",
            e.triangles, e.levels, e.range[0], e.range[1], e.contrast, e.chosen_by
        );
    }
    println!("load {:.1} s", t.elapsed().as_secs_f32());
    Ok(())
}
