//! The bake hands its views over one at a time (`ShadingBaker::bake_into`): each view once, in
//! order, equal bit for bit to the views of a whole bake, a shard's views only, a draw's pixels
//! only (each as the whole bake has it), and a sink's error stops the bake.
use fipt_bake::bake::{BakeConfig, FactorizedBaker};
use fipt_core::dataset::{Dataset, View};
use fipt_core::image::{BadPixelPolicy, Image};
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::shading::{
    PixelDraw, Progress, RayQuery, Reported, Scope, ShadingBaker, Shard, ViewShadings,
    DEFAULT_LEVELS,
};
use fipt_core::CoreError;
use fipt_geom::{Geometry, Mesh};
use fipt_shading::render::RenderConfig;
use fipt_synth::{build, write_dataset, SynthOptions};

mod common;
use common::check_drawn;

fn scene(name: &str) -> (Geometry, Vec<View>, Vec<Image>) {
    let dir = std::env::temp_dir().join(format!("fipt-stream-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let opts = SynthOptions {
        train_views: 7,
        val_views: 1,
        width: 32,
        height: 24,
        render: RenderConfig {
            spp: 4,
            ..Default::default()
        },
        model: Default::default(),
        lens: Default::default(),
    };
    write_dataset(build("cornell").unwrap(), &dir, &opts, &|_, _| {}).unwrap();
    let ds = Dataset::open(&dir).unwrap();
    let geo = Geometry::new(Mesh::load(&ds.mesh).unwrap());
    let views = ds.train().views.clone();
    let images = views
        .iter()
        .map(|v| ds.load_image(v, BadPixelPolicy::Reject).unwrap().0)
        .collect();
    let _ = std::fs::remove_dir_all(&dir);
    (geo, views, images)
}

/// The views `baker.bake_into` hands over for `scope`, with their indices.
fn handed(
    baker: &dyn ShadingBaker,
    scene: &(Geometry, Vec<View>, Images),
    scope: impl Into<Scope>,
) -> Vec<(usize, ViewShadings)> {
    let mut got = vec![];
    let (geo, views, images) = scene;
    baker
        .bake_into(geo, views, images, scope.into(), &|_, _| {}, &mut |k, s| {
            got.push((k, s));
            Ok(())
        })
        .unwrap();
    got
}

type Images = Vec<Image>;

/// The `fast` baker of `model` (with or without the diffuse cache) and its bake of every view.
fn whole_bake(
    scene: &(Geometry, Vec<View>, Images),
    model: ReflectanceModel,
    cache: bool,
) -> (FactorizedBaker, Vec<ViewShadings>) {
    let cfg = BakeConfig {
        diffuse_cache: cache,
        ..BakeConfig::fast()
    };
    let baker = FactorizedBaker::new(cfg).with_model(model);
    let (geo, views, images) = scene;
    let whole = baker.bake(geo, views, images, &|_, _| {}).unwrap().output;
    (baker, whole)
}

#[test]
fn views_are_handed_over_once_in_order_and_equal_a_whole_bake() {
    let scene = scene("order");
    let views = &scene.1;
    for (model, cache) in [
        (ReflectanceModel::Principled, true),
        (ReflectanceModel::Fipt, true),
        (ReflectanceModel::Fipt, false),
    ] {
        let (baker, whole) = whole_bake(&scene, model, cache);
        assert_eq!(whole.len(), views.len());
        let all = handed(&baker, &scene, Shard::ALL);
        let order: Vec<usize> = all.iter().map(|(k, _)| *k).collect();
        assert_eq!(order, (0..views.len()).collect::<Vec<_>>(), "{model:?}");
        for (k, s) in &all {
            assert!(s == &whole[*k], "{model:?} cache {cache}: view {k} differs");
        }
        // A shard: its views only, the same bits.
        let shard = Shard::new(1, 3).unwrap();
        let part = handed(&baker, &scene, shard);
        assert_eq!(part.iter().map(|(k, _)| *k).collect::<Vec<_>>(), [1, 4]);
        for (k, s) in &part {
            assert!(s == &whole[*k], "{model:?} shard: view {k} differs");
        }
    }
}

#[test]
fn a_sinks_error_stops_the_bake() {
    let (geo, views, images) = scene("error");
    let baker = FactorizedBaker::new(BakeConfig::fast());
    let mut calls = 0;
    let err = baker
        .bake_into(
            &geo,
            &views,
            &images,
            Shard::ALL.into(),
            &|_, _| {},
            &mut |k, _| {
                calls += 1;
                Err(CoreError::invalid(format!("view {k}"), "disk full"))
            },
        )
        .unwrap_err();
    assert_eq!(calls, 1);
    assert!(err.to_string().contains("disk full"), "{err}");
}

/// A baker that implements `bake` alone: the trait's default hands its shard's views over.
struct Constant;

impl ShadingBaker for Constant {
    fn name(&self) -> &str {
        "constant"
    }
    fn bake(
        &self,
        _geometry: &dyn RayQuery,
        views: &[View],
        _images: &[Image],
        _progress: Progress,
    ) -> fipt_core::Result<Reported<Vec<ViewShadings>>> {
        let output = (0..views.len())
            .map(|k| {
                let mut s = ViewShadings::zeros(2, 1, DEFAULT_LEVELS);
                s.ld[0].x = k as f32;
                s
            })
            .collect();
        Ok(Reported {
            output,
            report: serde_json::json!({ "views": views.len() }),
        })
    }
}

#[test]
fn the_default_hands_over_a_whole_bakes_shard() {
    let scene = scene("default");
    let part = handed(&Constant, &scene, Shard::new(0, 2).unwrap());
    let got: Vec<(usize, f32)> = part.iter().map(|(k, s)| (*k, s.ld[0].x)).collect();
    assert_eq!(got, [(0, 0.0), (2, 2.0), (4, 4.0), (6, 6.0)]);
}

/// A bake of a drawn share computes those pixels exactly as a bake of every pixel does (the
/// SLF and the diffuse cache's cells come from every pixel; sample streams are keyed by pixel)
/// and leaves the others as misses, with and without the cache, in a shard too.
#[test]
fn a_draw_bakes_its_pixels_as_a_whole_bake_and_no_others() {
    let scene = scene("draw");
    let draw = PixelDraw::new(7, Some(0.3));
    for (model, cache) in [
        (ReflectanceModel::Principled, true),
        (ReflectanceModel::Fipt, false),
    ] {
        let (baker, whole) = whole_bake(&scene, model, cache);
        let (mut kept, mut out) = (0, 0);
        for shard in [Shard::ALL, Shard::new(1, 2).unwrap()] {
            let got = handed(
                &baker,
                &scene,
                Scope {
                    shard,
                    pixels: draw,
                },
            );
            assert!(got.iter().all(|(k, _)| shard.contains(*k)));
            for (k, s) in &got {
                let (a, b) = check_drawn(*k, s, &whole[*k], draw);
                (kept, out) = (kept + a, out + b);
            }
        }
        let share = kept as f64 / (kept + out) as f64;
        assert!(
            (share - 0.3).abs() < 0.05,
            "{model:?}: {kept} of {} drawn",
            kept + out
        );
    }
}
