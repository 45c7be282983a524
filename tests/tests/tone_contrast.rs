//! The tone curve's contrast from the light transport (`fipt_capture::contrast`) on JPEG
//! copies of `studio-mitsuba` without exposures: a phone's S-curve over sRGB is found and the
//! views decoded at the power it asks for; an sRGB camera's views are left as decoded.
use fipt_capture::degrade::{
    degrade, tone_curve, CopyLayout, DegradeRequest, LdrMode, Meter, ViewFormat,
};
use fipt_tests::{studio_scene, temp_dir};
use std::path::Path;

/// What the run's load found on an auto-exposed JPEG copy of `src` through `tone`.
fn contrast_of(src: &Path, out: &Path, tone: &str) -> fipt_capture::contrast::ContrastFit {
    degrade(&DegradeRequest {
        source: src.to_path_buf(),
        out: out.to_path_buf(),
        layout: CopyLayout::Real,
        lens: None,
        drop_gt: false,
        pose_mm: 5.0,
        pose_deg: 0.15,
        pixel_noise: 0.01,
        ldr: LdrMode::Auto,
        tone: tone_curve(tone).expect("a tone curve"),
        meter: Meter::Median,
        format: ViewFormat::Jpg,
        jpeg_quality: 80,
        upscale: 1,
        exif: false,
        subdivide: 0,
        warp_mm: 0.0,
        ripple_mm: 0.0,
        ripple_cm: 0.0,
        seed: 3,
    })
    .expect("degrade");
    let s = fipt_capture::scene::load(
        out,
        fipt_core::image::BadPixelPolicy::Reject,
        &Default::default(),
    )
    .expect("load");
    s.capture
        .contrast
        .expect("looked for: 8-bit views, no exposures, no stated response")
}

#[test]
#[cfg_attr(
    fipt_no_shared,
    ignore = "needs ../shared/scenes/studio-mitsuba (or FIPT_SHARED)"
)]
fn a_phone_s_curve_is_found_in_the_light_and_srgb_is_left_alone() {
    let Some(root) = studio_scene() else { return };
    let dir = temp_dir("tone-contrast");
    let s = contrast_of(&root, &dir.join("scurve"), "scurve:1.5");
    // The true power is about 0.69 (the gains fitted under sRGB spread ×1.46 too far in
    // log); 0.69 estimated (docs/phone-captures.md, section 9).
    assert!(s.applied && (0.6..0.8).contains(&s.gamma), "{s:?}");
    // The true power is 1.02; 1.05 estimated.
    let srgb = contrast_of(&root, &dir.join("srgb"), "srgb");
    assert!(
        !srgb.applied && (0.9..1.15).contains(&srgb.gamma),
        "{srgb:?}"
    );
    // Neither is called unidentified.
    for c in [&s, &srgb] {
        assert!(fipt_capture::contrast::off_the_grid(&c.curve, c.depth).is_none());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
