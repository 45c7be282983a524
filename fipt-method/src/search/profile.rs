//! `fipt profile`: the search's cost curves per region on a run's shadings, with the ground
//! truth's base colour beside the fitted one when the scene has it.
use super::*;
use std::path::PathBuf;

/// `fipt profile`: the search's cost curves on a run's shadings.
pub struct ProfileRequest {
    /// Scene folder.
    pub scene: PathBuf,
    /// Output folder of `fipt run` / `fipt bake`.
    pub out: PathBuf,
    /// Which shadings in OUT: `bake`, `refine1`, ...
    pub shadings: String,
    /// Regions: auto, parts, semantic, mesh.
    pub regions: String,
    pub bad_pixels: BadPixelPolicy,
    /// Leave out the pixels on regions' outlines (`[search] drop_edges`).
    pub drop_edges: bool,
    /// With `drop_edges`: only neighbours this many times brighter count.
    pub edge_contrast: f32,
    /// With `drop_edges`: `[search] outline_share`.
    pub outline_share: f32,
    /// With `drop_edges`: `[search] silhouette_gap` and `silhouette_contrast`.
    pub silhouette_gap: f32,
    pub silhouette_contrast: f32,
    /// `[search] diffuse_radius`: the pixels over which the search averages Ld.
    pub diffuse_radius: u32,
}

/// One region of `fipt profile`: its cost curves with the fitted albedo, with the true one
/// (when the scene has it) and the search's decision.
#[derive(Serialize)]
pub struct ProfileRow {
    pub label: i64,
    /// The side of a divided region (`[search.split]`), None for a whole region.
    pub side: Option<u8>,
    /// Whether a divided region's sides keep their own decisions.
    pub sides_kept: Option<bool>,
    /// A divided region's decision for both sides together.
    pub whole: Option<RegionChoice>,
    pub fitted: RegionProfile,
    pub given: Option<RegionProfile>,
    /// The same with one base colour for the whole region (not per surface cell): what a part
    /// of one material shows when its albedo cannot absorb view dependence.
    pub part: RegionProfile,
    /// The fitted profile on each half of the views (even, odd), as `held_out` reads them.
    pub halves: Option<[RegionProfile; 2]>,
    pub choice: RegionChoice,
}

/// A placeholder profile (what is left after a row takes its own).
fn empty_profile() -> RegionProfile {
    RegionProfile {
        region: 0,
        pixels: 0,
        cells: 0,
        sigma: vec![],
        metallic: vec![],
        cost: vec![],
        gain: vec![],
        one_colour: vec![],
    }
}

/// The search's cost curves per region on the shadings `a` names.
/// The regions' profiles with the ground truth's base colour (kd for dielectrics, ks for
/// metals; None without ground truth), and with one fitted base colour per region.
fn reference_profiles(
    scene: &SceneRef,
    pixels: &[SearchPixel],
    shadings: &[ViewShadings],
    n: usize,
    grid: &[f32],
    cfg: &SearchConfig,
) -> Result<(Option<Vec<RegionProfile>>, Vec<RegionProfile>)> {
    let given = if let Some(base) = true_base_colours(&scene.ds, scene.ds.train(), pixels)? {
        let metal_grid = [0.0, 0.25, 0.5, 0.75, 1.0];
        Some(profile(
            pixels,
            shadings,
            &scene.images,
            n,
            grid,
            &metal_grid,
            Albedo::Given(&base),
        ))
    } else {
        None
    };
    // One base colour per region: every pixel of a region in one cell.
    let part = profile(
        &fipt_search::one_cell_per_region(pixels),
        shadings,
        &scene.images,
        n,
        grid,
        &cfg.metallic,
        Albedo::Fitted,
    );
    Ok((given, part))
}

/// `fipt profile`'s scene, stored shadings and search settings.
fn profile_inputs(
    a: &ProfileRequest,
) -> Result<(crate::scene::LoadedScene, Vec<ViewShadings>, SearchConfig)> {
    let scene = crate::scene::load(&a.scene, a.bad_pixels, &Default::default())?;
    let dir = a.out.join(&a.shadings);
    let shadings = match fipt_bake::bake_store::load_for_inputs(&dir, &scene.cache_key)? {
        Ok((_, s)) => s.load_all()?,
        Err(why) => bail!(
            "{}: {why} (run `fipt run` or `fipt bake` first)",
            dir.display()
        ),
    };
    let regions: RegionSource = serde_json::from_value(serde_json::json!(a.regions))
        .map_err(|_| crate::err!("--regions {}: use auto, parts, semantic or mesh", a.regions))?;
    let cfg = SearchConfig {
        regions,
        drop_edges: a.drop_edges,
        edge_contrast: a.edge_contrast,
        outline_share: a.outline_share,
        silhouette_gap: a.silhouette_gap,
        silhouette_contrast: a.silhouette_contrast,
        diffuse_radius: a.diffuse_radius,
        ..SearchConfig::default()
    };
    cfg.validate().map_err(crate::error::RunError::invalid)?;
    Ok((scene, shadings, cfg))
}

pub fn profile_rows(a: &ProfileRequest) -> Result<Vec<ProfileRow>> {
    let (loaded, shadings, cfg) = profile_inputs(a)?;
    let scene = crate::scene::SceneRef::loaded(&loaded);
    let split = scene.ds.train();
    let (records, footprint) =
        fipt_shading::records::hit_points_and_footprint(scene.geometry, &split.views);
    let Some(Prepared {
        regions,
        pixels,
        voxels,
        grid,
    }) = prepare(&scene, &records, &shadings, &cfg, footprint.unwrap_or(0.01))?
    else {
        bail!("no regions");
    };
    let mut shadings = shadings;
    let limit = diffuse::NEAR_FOOTPRINTS * footprint.unwrap_or(0.01);
    let near = |v: usize, i: usize, j: usize| match (&records[v][i], &records[v][j]) {
        (Some(a), Some(b)) => a.point().distance(b.point()) <= limit,
        _ => false,
    };
    diffuse::smooth_views(
        &mut shadings,
        cfg.diffuse_radius as usize,
        &|v, i| regions.id(v, i),
        &near,
    );
    let split = super::divide(
        &pixels,
        &voxels,
        &shadings,
        &scene.images,
        &grid,
        &regions,
        &cfg,
        false,
    );
    let pixels = split.apply(&pixels);
    let n = split.regions();
    let mut parent: Vec<usize> = (0..regions.len()).collect();
    for (r, s) in split.sub.iter().enumerate() {
        if s.is_some() {
            parent.push(r);
        }
    }
    let (fitted, mut halves) =
        fitted_profiles(&scene.images, &shadings, n, &pixels, &grid, &cfg, true);
    let choose_one = |p: &RegionProfile, held: Option<[&RegionProfile; 2]>, _: usize| {
        choose(p, &cfg, false, held)
    };
    let (whole, kept) = choose_regions(&fitted, halves.as_ref(), &split, &cfg.split, &choose_one);
    let (given, mut part) = reference_profiles(&scene, &pixels, &shadings, n, &grid, &cfg)?;
    let mut rows = vec![];
    for (r, f) in fitted.into_iter().enumerate() {
        let held = halves.as_ref().map(|h| [&h[0][r], &h[1][r]]);
        let c = choose(&f, &cfg, false, held);
        let halves = halves.as_mut().map(|h| {
            h.each_mut()
                .map(|h| std::mem::replace(&mut h[r], empty_profile()))
        });
        let g = given.as_ref().map(|g| g[r].clone());
        let top = parent[r];
        let side = split.sub[top].map(|_| u8::from(r != top));
        rows.push(ProfileRow {
            label: regions.labels[top],
            side,
            sides_kept: side.map(|_| kept.iter().any(|k| k.0 == top)),
            whole: side.map(|_| whole[top].clone()),
            fitted: f,
            given: g,
            part: std::mem::replace(&mut part[r], empty_profile()),
            halves,
            choice: c,
        });
    }
    Ok(rows)
}
