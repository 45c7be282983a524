//! Range checks of the shading stages' settings: a value outside them would exhaust the machine
//! (a 100,000³ SLF asks for terabytes) or mean nothing (a resolution of 0), so it is refused
//! with the key, the value and the range before any work.

/// Largest SLF resolution per axis (a dense occupancy bit grid of resolution³/8 bytes: 8 GiB at
/// 4096; the sparse voxels grow with the observed surface).
pub const MAX_SLF_RESOLUTION: u32 = 4096;
/// Most samples of any one estimate per pixel or cell.
pub const MAX_SAMPLES: u32 = 1 << 20;

/// Checks the settings common to the bake and the refinement; `section` names the config
/// section in the message (e.g. "bake").
#[allow(clippy::too_many_arguments)]
pub fn check_shading(
    section: &str,
    slf_resolution: u32,
    slf_fallback_levels: u32,
    diffuse_samples: u32,
    specular_samples: &[u32],
    levels: &[f32],
    cache_cell_scale: f32,
) -> Result<(), String> {
    let bad =
        |key: &str, v: String, range: &str| Err(format!("[{section}] {key} = {v}: use {range}"));
    if !(1..=MAX_SLF_RESOLUTION).contains(&slf_resolution) {
        return bad(
            "slf_resolution",
            slf_resolution.to_string(),
            &format!("1 to {MAX_SLF_RESOLUTION}"),
        );
    }
    if slf_fallback_levels > 12 {
        return bad(
            "slf_fallback_levels",
            slf_fallback_levels.to_string(),
            "0 to 12",
        );
    }
    if diffuse_samples > MAX_SAMPLES {
        return bad(
            "diffuse_samples",
            diffuse_samples.to_string(),
            &format!("0 to {MAX_SAMPLES}"),
        );
    }
    if specular_samples.iter().any(|&n| n > MAX_SAMPLES) {
        return bad(
            "specular_samples",
            format!("{specular_samples:?}"),
            &format!("0 to {MAX_SAMPLES} each"),
        );
    }
    let lo = fipt_core::reflectance::MIN_ROUGHNESS;
    let increasing = levels.windows(2).all(|w| w[0] < w[1]);
    if !increasing || levels.iter().any(|&l| !(lo..=1.0).contains(&l)) {
        return bad(
            "levels",
            format!("{levels:?}"),
            &format!("increasing values in [{lo}, 1]"),
        );
    }
    if !(cache_cell_scale > 0.0 && cache_cell_scale <= 1e3) {
        return bad(
            "cache_cell_scale",
            cache_cell_scale.to_string(),
            "(0, 1000]",
        );
    }
    Ok(())
}
