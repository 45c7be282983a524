//! Cross-check against an independent renderer: the Mitsuba 3 `studio` scene in the reference
//! layout. Our cameras and material table must reproduce its per-pixel ground-truth maps
//! (a pose or pixel-centre convention error shows at once), and our path tracer must come close
//! to its renders.
use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::image::BadPixelPolicy;
use fipt_core::materials::SceneMaterials;
use fipt_core::metrics::{psnr, srgb_psnr};
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::Mesh;
use fipt_shading::render::{render, render_aovs, RenderConfig};
use fipt_shading::scene::{Scene, TableSurfaces};
use fipt_tests::studio_scene;
use glam::Vec3;

/// Interior pixels: the 3×3 neighbourhood has one part id and one GT value (no object,
/// checker or image edge), so a correct convention must match there exactly.
fn interior_mask(part: &[u32], gt: &[Vec3], w: usize, h: usize) -> Vec<bool> {
    let mut m = vec![false; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let mut ok = part[i] != u32::MAX;
            for dy in [-1i32, 0, 1] {
                for dx in [-1i32, 0, 1] {
                    let j = ((y as i32 + dy) as usize) * w + (x as i32 + dx) as usize;
                    ok &= part[j] == part[i] && (gt[j] - gt[i]).abs().max_element() < 1e-3;
                }
            }
            m[i] = ok;
        }
    }
    m
}

#[test]
#[cfg_attr(
    fipt_no_shared,
    ignore = "needs ../shared/scenes/studio-mitsuba (or FIPT_SHARED)"
)]
fn ground_truth_maps_match_through_our_cameras_and_material_table() {
    let Some(root) = studio_scene() else { return };
    let ds = Dataset::open(&root).expect("the loader reads the Mitsuba scene as it is");
    assert_eq!((ds.width, ds.height), (240, 160));
    assert_eq!(ds.splits.len(), 2);
    assert_eq!(ds.train().views.len(), 40);
    let mesh = Mesh::load(&ds.mesh).unwrap();
    assert_eq!(mesh.num_file_faces, 5480);
    let table = root.join("scene_parts.json");
    let mats = SceneMaterials::read_any(&table).unwrap();
    let scene = Scene::new(
        mesh,
        TableSurfaces::new(mats, &Mesh::load(&ds.mesh).unwrap(), &table).unwrap(),
    );
    let mut worst = (f64::INFINITY, String::new());
    let mut sum = 0.0;
    let mut n = 0;
    for split in &ds.splits {
        for v in &split.views {
            let aov = render_aovs(&scene, &v.camera);
            let gt_kd = ds
                .load_gt(split, GtKind::DiffCol, v.index)
                .unwrap()
                .unwrap();
            let gt_id = ds
                .load_gt(split, GtKind::IndexMA, v.index)
                .unwrap()
                .unwrap();
            let mask = interior_mask(&aov.part, &gt_kd.data, ds.width, ds.height);
            let interior = mask.iter().filter(|&&b| b).count();
            assert!(
                interior > ds.width * ds.height / 2,
                "{} view {}: only {interior} interior pixels",
                split.name,
                v.index
            );
            // Part ids agree on interior pixels.
            let id_ok = (0..mask.len())
                .filter(|&i| mask[i] && gt_id.data[i].x as u32 == aov.part[i])
                .count();
            assert!(
                id_ok as f64 >= 0.999 * interior as f64,
                "{} view {}: part ids agree on {id_ok}/{interior}",
                split.name,
                v.index
            );
            let p = psnr(&aov.kd.data, &gt_kd.data, Some(&mask), 1.0).unwrap();
            for (kind, ours) in [
                (GtKind::Roughness, &aov.roughness),
                (GtKind::Metallic, &aov.metallic),
                (GtKind::Specular, &aov.ks),
                (GtKind::Emit, &aov.emission),
            ] {
                let gt = ds.load_gt(split, kind, v.index).unwrap().unwrap();
                let peak = if kind == GtKind::Emit { 40.0 } else { 1.0 };
                let q = psnr(&ours.data, &gt.data, Some(&mask), peak).unwrap();
                assert!(
                    q >= 35.0,
                    "{} view {} {:?}: {q:.1} dB",
                    split.name,
                    v.index,
                    kind
                );
            }
            if p < worst.0 {
                worst = (p, format!("{} view {}", split.name, v.index));
            }
            sum += p;
            n += 1;
        }
    }
    eprintln!(
        "kd AOV vs Mitsuba DiffCol on interior pixels: mean {:.1} dB, worst {:.1} dB ({})",
        sum / n as f64,
        worst.0,
        worst.1
    );
    assert!(worst.0 >= 35.0, "kd PSNR {:.1} dB at {}", worst.0, worst.1);
}

/// Re-render PSNR: sRGB OETF of the linear radiance clamped to [0, 1], peak 1.
fn render_psnr(a: &[Vec3], b: &[Vec3]) -> f64 {
    srgb_psnr(a, b, None).unwrap()
}

/// Our path tracer (two-sided emitters) against Mitsuba's principled BSDF renders, 64 spp,
/// the 8 val views: (mean PSNR, mean radiance ratio ours / Mitsuba per view).
fn render_against_mitsuba(model: ReflectanceModel) -> Option<(f64, Vec<f64>)> {
    let root = studio_scene()?;
    let ds = Dataset::open(&root).unwrap();
    let mesh = Mesh::load(&ds.mesh).unwrap();
    let table = root.join("scene_parts.json");
    let mut surfaces =
        TableSurfaces::new(SceneMaterials::read_any(&table).unwrap(), &mesh, &table).unwrap();
    surfaces.model = model;
    let scene = Scene::new(mesh, surfaces);
    let cfg = RenderConfig {
        spp: 64,
        max_bounces: 7,
        seed: 3,
        ..Default::default()
    };
    let val = ds.split("val").unwrap();
    let mut ps = Vec::new();
    let mut rel = Vec::new();
    for v in &val.views {
        let (ours, stats) = render(&scene, &v.camera, &cfg, v.index as u64, &|_| {});
        assert_eq!(stats.nonfinite, 0);
        let (gt, _) = ds.load_image(v, BadPixelPolicy::Reject).unwrap();
        ps.push(render_psnr(&ours.data, &gt.data));
        let mo: f64 = ours.data.iter().map(|p| (p.x + p.y + p.z) as f64).sum();
        let mg: f64 = gt.data.iter().map(|p| (p.x + p.y + p.z) as f64).sum();
        rel.push(mo / mg);
    }
    let mean = ps.iter().sum::<f64>() / ps.len() as f64;
    eprintln!("{model}: path-traced val views vs Mitsuba: PSNR per view {:?}, mean {mean:.2} dB; mean radiance ratio ours/Mitsuba {:?}", ps.iter().map(|p| format!("{p:.1}")).collect::<Vec<_>>(), rel.iter().map(|r| format!("{r:.3}")).collect::<Vec<_>>());
    Some((mean, rel))
}

/// Both models come close to Mitsuba's renders of its own materials; the principled model (the
/// renderer's) comes closer than FIPT's. Measured (64 spp, so the PSNR is mostly noise): FIPT's
/// model 25.60 dB with every view 0–11 % darker than Mitsuba's; principled 25.89 dB and
/// 1.2–1.9 % brighter (the rest: Schlick for the exact dielectric Fresnel, see
/// `fipt_core::reflectance`).
#[test]
#[cfg_attr(
    fipt_no_shared,
    ignore = "needs ../shared/scenes/studio-mitsuba (or FIPT_SHARED)"
)]
fn path_traced_views_come_close_to_mitsuba() {
    let Some((fipt, rel)) = render_against_mitsuba(ReflectanceModel::Fipt) else {
        return;
    };
    for r in &rel {
        assert!(
            (r - 1.0).abs() < 0.15,
            "mean radiance differs by {:.1} %",
            100.0 * (r - 1.0)
        );
    }
    assert!(fipt >= 24.0, "mean re-render PSNR {fipt:.2} dB");
    let (principled, rel) = render_against_mitsuba(ReflectanceModel::Principled).unwrap();
    for r in &rel {
        assert!(
            (r - 1.0).abs() < 0.03,
            "principled: mean radiance differs by {:.1} %",
            100.0 * (r - 1.0)
        );
    }
    assert!(
        principled > fipt,
        "principled {principled:.2} dB, FIPT {fipt:.2} dB"
    );
}
