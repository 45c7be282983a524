//! The σ / metallic diagnostic on `studio-mitsuba` (rendered by Mitsuba 3's `principled` BSDF):
//! with the ground truth's base colour, the image loss over the baked shadings as a function of
//! σ and metallic, per object (`IndexMA/`). Where its minimum sits at the true material, the
//! shadings carry the evidence and recovering it is the optimiser's job; where it does not,
//! no optimiser of this reflectance model can find the truth.
//!
//! Measured (README, *Why σ and metallic did not move*): the metals and the walls hold; the
//! floor and both boxes put their minimum far from the truth under the FIPT model (Lambert
//! diffuse, Schlick-GGX masking) and at the truth when the same scene is rendered with that
//! model. The first test pins both halves under the FIPT model; the second shows that the
//! `principled` model (the renderer's) removes the mismatch: the glossy box's minimum moves to
//! its true σ on the bake (the diffuse box and the floor reach theirs after one refinement,
//! which needs a trained field: `docs/reflectance-models.md`).
use fipt_bake::bake::{primary_records, BakeConfig, FactorizedBaker};
use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::image::BadPixelPolicy;
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::{Geometry, Mesh};
use fipt_search::{gather_pixels, profile, sigma_grid, Albedo, RegionProfile};
use fipt_tests::studio_scene;

/// One level spacing of the bake's roughness levels.
const SPACING: f32 = 0.196;

/// σ at the minimum of metallic row `mi`, and that minimum.
fn argmin_sigma(p: &RegionProfile, mi: usize) -> (f32, f64) {
    let row = &p.cost[mi];
    let si = (0..row.len())
        .min_by(|&a, &b| row[a].total_cmp(&row[b]))
        .unwrap();
    (p.sigma[si], row[si])
}

/// The metallic candidate whose best σ explains the views best.
fn argmin_metallic(p: &RegionProfile) -> f32 {
    let mi = (0..p.metallic.len())
        .min_by(|&a, &b| argmin_sigma(p, a).1.total_cmp(&argmin_sigma(p, b).1))
        .unwrap();
    p.metallic[mi]
}

/// The per-object profiles (metallic rows 0, 0.25, …, 1) over a `balanced` bake of `model`.
fn studio_profiles(model: ReflectanceModel) -> Option<Vec<RegionProfile>> {
    let root = studio_scene()?;
    let ds = Dataset::open(&root).unwrap();
    let split = ds.train();
    let geometry = Geometry::new(Mesh::load(&ds.mesh).unwrap());
    let images: Vec<_> = split
        .views
        .iter()
        .map(|v| ds.load_image(v, BadPixelPolicy::Reject).unwrap().0)
        .collect();
    // `balanced`'s sample counts: with `fast`'s quarter, the noisier shadings move the walls'
    // minima to σ 0.52–0.68 (measured).
    let baker = FactorizedBaker::new(BakeConfig::default()).with_model(model);
    let (shadings, _, _) = baker.bake_detailed(&geometry, &split.views, &images, &|_, _| {});
    let records: Vec<_> = split
        .views
        .iter()
        .map(|v| primary_records(&geometry, v))
        .collect();
    let ids: Vec<Vec<i64>> = (0..split.views.len())
        .map(|k| ds.load_ids(split, GtKind::IndexMA, k).unwrap().unwrap())
        .collect();
    let regions = 12;
    let pixels = gather_pixels(&records, &shadings, 0.05, &|v, i, _| {
        let id = ids[v][i];
        (0..regions as i64).contains(&id).then_some(id as u32)
    });
    let base = fipt_search::true_base_colours(&ds, split, &pixels)
        .unwrap()
        .expect("studio-mitsuba has DiffCol, Specular and Metallic");
    let grid = sigma_grid(0.02, 1.0, 50);
    let metals = [0.0, 0.25, 0.5, 0.75, 1.0];
    let prof: Vec<RegionProfile> = profile(
        &pixels,
        &shadings,
        &images,
        regions,
        &grid,
        &metals,
        Albedo::Given(&base),
    );
    for (r, p) in prof.iter().enumerate() {
        let last = p.metallic.len() - 1;
        eprintln!(
            "{model}: object {r}: argmin σ {:.2} at m = 0, {:.2} at m = 1; argmin metallic {:.2}",
            argmin_sigma(p, 0).0,
            argmin_sigma(p, last).0,
            argmin_metallic(p)
        );
    }
    Some(prof)
}

/// Must hold under either model: the metals (σ within a level spacing at metallic 1, the metal
/// row far below the dielectric one, the metallic minimum within a grid step of 1) and three
/// walls (σ 0.9 at metallic 0; the back wall's 0.95 needs the refined shadings).
fn assert_metals_and_walls(prof: &[RegionProfile]) {
    let last = prof[0].metallic.len() - 1;
    for (object, sigma) in [(9, 0.25), (10, 0.05)] {
        let p = &prof[object];
        let ((s, metal), (_, dielectric)) = (argmin_sigma(p, last), argmin_sigma(p, 0));
        assert!(
            (s - sigma).abs() <= SPACING,
            "object {object}: σ argmin {s}, true {sigma}"
        );
        assert!(
            metal < 0.5 * dielectric,
            "object {object}: metal {metal} vs dielectric {dielectric}"
        );
        assert!(
            argmin_metallic(p) >= 0.75,
            "object {object}: metallic argmin {}",
            argmin_metallic(p)
        );
    }
    for object in [2, 3, 5] {
        let s = argmin_sigma(&prof[object], 0).0;
        assert!(
            (s - 0.9).abs() <= SPACING,
            "wall {object}: σ argmin {s}, true 0.9"
        );
    }
}

#[test]
#[cfg_attr(
    fipt_no_shared,
    ignore = "needs ../shared/scenes/studio-mitsuba (or FIPT_SHARED)"
)]
fn the_loss_minimum_sits_at_the_true_metals_and_walls_and_shows_the_model_mismatch() {
    let Some(prof) = studio_profiles(ReflectanceModel::Fipt) else {
        return;
    };
    assert_metals_and_walls(&prof);
    // The model mismatch: the boxes (σ 0.3 and 1.0) prefer a near-mirror lobe.
    for object in [8, 11] {
        let s = argmin_sigma(&prof[object], 0).0;
        assert!(
            s < 0.15,
            "object {object}: σ argmin {s} (the mismatch is gone: update the README)"
        );
    }
}

/// Under the renderer's own model the glossy box's minimum sits at its true σ (measured 0.28
/// for 0.3 on the bake; FIPT's model: 0.02), and the metals and walls still hold.
#[test]
#[cfg_attr(
    fipt_no_shared,
    ignore = "needs ../shared/scenes/studio-mitsuba (or FIPT_SHARED)"
)]
fn the_principled_model_removes_the_mismatch_of_the_glossy_box() {
    let Some(prof) = studio_profiles(ReflectanceModel::Principled) else {
        return;
    };
    assert_metals_and_walls(&prof);
    let s = argmin_sigma(&prof[8], 0).0;
    assert!(
        (s - 0.3).abs() <= SPACING,
        "glossy box: σ argmin {s}, true 0.3"
    );
    // Measured on the bake: diffuse box 0.48 (true 1.0; 0.98 after one refinement), floor
    // 0.62 (0.85; 0.80 after one refinement). Not asserted: the refinement needs a field.
}
