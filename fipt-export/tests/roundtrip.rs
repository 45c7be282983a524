//! Every export format read back: the glb through the `gltf` crate (textures sampled at the
//! points they were baked from), the Mitsuba XML through an XML parser (every file it names
//! exists), the OBJ's faces and material library.
use fipt_core::color::srgb_eotf;
use fipt_core::emitter::Emitter;
use fipt_core::materials::SurfacePoint;
use fipt_core::reflectance::metallic_workflow;
use fipt_export::{export, ExportOptions, Format};
use fipt_geom::Mesh;
use fipt_shading::scene::SurfaceModel;
use glam::{Vec2, Vec3};
use std::path::PathBuf;

/// Smoothly varying materials, so a wrong texture coordinate shows.
struct Waves;

fn albedo(p: Vec3) -> Vec3 {
    Vec3::new(
        0.5 + 0.4 * (3.0 * p.x).sin(),
        0.5 + 0.4 * (2.0 * p.z).cos(),
        0.5 + 0.3 * (2.0 * p.y).sin(),
    )
}
fn rough(p: Vec3) -> f32 {
    0.5 + 0.3 * (2.0 * p.x + p.z).sin()
}
fn metal(p: Vec3) -> f32 {
    if p.y > 1.5 {
        1.0
    } else {
        0.0
    }
}

impl SurfaceModel for Waves {
    fn surface(&self, _tri: u32, p: Vec3) -> SurfacePoint {
        let (kd, ks) = metallic_workflow(albedo(p), metal(p));
        SurfacePoint {
            kd,
            ks,
            roughness: rough(p),
            metallic: metal(p),
            emission: Vec3::ZERO,
        }
    }
    fn emission(&self, _tri: u32) -> Vec3 {
        Vec3::ZERO
    }
    fn part(&self, _tri: u32) -> u32 {
        0
    }
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fipt-export-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The cornell room (5 planar walls, blocks, a ceiling light).
fn scene() -> (Mesh, Vec<Emitter>) {
    let s = fipt_synth::cornell();
    let surf = fipt_shading::scene::TableSurfaces::new(
        s.materials.clone(),
        &s.mesh,
        std::path::Path::new("gt"),
    )
    .unwrap();
    let tris: Vec<u32> = (0..s.mesh.triangles.len() as u32)
        .filter(|&t| surf.emission(t).max_element() > 0.0)
        .collect();
    let le: Vec<Vec3> = tris.iter().map(|&t| surf.emission(t)).collect();
    // The panel emits from its winding side only, as `fipt synth` makes it.
    let sides = tris.iter().map(|&t| surf.emit_side(t)).collect();
    let e = Emitter::from_triangles(&s.mesh.positions, &s.mesh.triangles, tris, le, 1)
        .unwrap()
        .with_sides(&s.mesh.positions, &s.mesh.triangles, sides);
    let mut mesh = s.mesh;
    // A sphere of triangles a few texels across: each its own chart.
    mesh.append(&fipt_synth::icosphere_mesh(
        Vec3::new(0.4, 1.2, 0.3),
        0.15,
        2,
    ));
    (mesh, vec![e])
}

#[test]
fn glb_textures_hold_the_materials_at_the_points_they_map_to() {
    let (mesh, emitters) = scene();
    let dir = tmp("glb");
    let opts = ExportOptions {
        texel_size: 0.01,
        ..Default::default()
    };
    let sum = export(&mesh, &Waves, &emitters, Format::Glb, &dir, &opts).unwrap();
    assert_eq!(sum.emitters, 1);
    let (doc, buffers, images) = gltf::import(dir.join("scene.glb")).unwrap();
    let mesh0 = doc.meshes().next().unwrap();
    let prims: Vec<_> = mesh0.primitives().collect();
    assert_eq!(prims.len(), 2);
    // The surface: sample the textures at each triangle's centroid.
    let p = &prims[0];
    let r = p.reader(|b| Some(&buffers[b.index()]));
    let pos: Vec<Vec3> = r.read_positions().unwrap().map(Vec3::from).collect();
    let uv: Vec<Vec2> = r
        .read_tex_coords(0)
        .unwrap()
        .into_f32()
        .map(Vec2::from)
        .collect();
    let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
    assert_eq!(idx.len() / 3, mesh.triangles.len() - 2);
    let pbr = p.material().pbr_metallic_roughness();
    let base = &images[pbr.base_color_texture().unwrap().texture().source().index()];
    let mr = &images[pbr
        .metallic_roughness_texture()
        .unwrap()
        .texture()
        .source()
        .index()];
    let texel = |img: &gltf::image::Data, uv: Vec2, c: usize| {
        let x = ((uv.x * img.width as f32) as u32).min(img.width - 1);
        let y = ((uv.y * img.height as f32) as u32).min(img.height - 1);
        img.pixels[((y * img.width + x) * 3) as usize + c] as f32 / 255.0
    };
    let (mut worst_a, mut worst_r) = (0f32, 0f32);
    for f in idx.chunks(3) {
        let c = (pos[f[0] as usize] + pos[f[1] as usize] + pos[f[2] as usize]) / 3.0;
        let t = (uv[f[0] as usize] + uv[f[1] as usize] + uv[f[2] as usize]) / 3.0;
        for ch in 0..3 {
            let got = srgb_eotf(texel(base, t, ch));
            worst_a = worst_a.max((got - albedo(c)[ch]).abs());
        }
        worst_r = worst_r.max((texel(mr, t, 1) - rough(c)).abs());
        assert_eq!(texel(mr, t, 2), metal(c), "metallic at {c}");
    }
    // Gradient × texel + 8-bit quantisation.
    assert!(
        worst_a < 0.03 && worst_r < 0.03,
        "albedo off by {worst_a}, roughness by {worst_r}"
    );
    // The light: emissive factor × strength = its radiance (17, 12, 4).
    let em = prims[1].material();
    let strength = em.emissive_strength().unwrap();
    let le = Vec3::from(em.emissive_factor()) * strength;
    assert!((le - Vec3::new(17.0, 12.0, 4.0)).length() < 1e-3, "{le}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn per_vertex_fallback_loads_with_vertex_colours() {
    let (mesh, emitters) = scene();
    let dir = tmp("glb-pv");
    let opts = ExportOptions {
        per_vertex: true,
        ..Default::default()
    };
    let sum = export(&mesh, &Waves, &emitters, Format::Glb, &dir, &opts).unwrap();
    assert!(sum.atlas.is_none());
    let (doc, buffers, _) = gltf::import(dir.join("scene.glb")).unwrap();
    let p = doc.meshes().next().unwrap().primitives().next().unwrap();
    let r = p.reader(|b| Some(&buffers[b.index()]));
    let pos: Vec<Vec3> = r.read_positions().unwrap().map(Vec3::from).collect();
    let col: Vec<[f32; 3]> = r.read_colors(0).unwrap().into_rgb_f32().collect();
    for (p, c) in pos.iter().zip(&col) {
        assert!((Vec3::from(*c) - albedo(*p).clamp(Vec3::ZERO, Vec3::ONE)).length() < 1e-5);
    }
    // Mitsuba and OBJ need the atlas: a clear error that names the flag, not the atlas.
    for format in [Format::Mitsuba, Format::Obj] {
        let err = export(&mesh, &Waves, &emitters, format, &dir, &opts).unwrap_err();
        assert!(
            err.to_string().starts_with("--per-vertex is for glb only"),
            "{err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mitsuba_xml_parses_and_names_only_files_that_exist() {
    let (mesh, emitters) = scene();
    let dir = tmp("mitsuba");
    export(
        &mesh,
        &Waves,
        &emitters,
        Format::Mitsuba,
        &dir,
        &ExportOptions::default(),
    )
    .unwrap();
    let text = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let files: Vec<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("string") && n.attribute("name") == Some("filename"))
        .map(|n| n.attribute("value").unwrap())
        .collect();
    assert_eq!(files.len(), 3 + 2, "{files:?}");
    for f in &files {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    assert_eq!(
        doc.descendants()
            .filter(|n| n.has_tag_name("emitter"))
            .count(),
        1
    );
    assert!(doc
        .descendants()
        .any(|n| n.attribute("type") == Some("principled")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn obj_export_reloads_with_every_face_and_its_material_library() {
    let (mesh, emitters) = scene();
    let dir = tmp("obj");
    export(
        &mesh,
        &Waves,
        &emitters,
        Format::Obj,
        &dir,
        &ExportOptions::default(),
    )
    .unwrap();
    let back = Mesh::load(&dir.join("scene.obj")).unwrap();
    assert_eq!(back.triangles.len(), mesh.triangles.len());
    let mtl = std::fs::read_to_string(dir.join("scene.mtl")).unwrap();
    for line in mtl.lines().filter(|l| l.starts_with("map_")) {
        let f = line.split_whitespace().nth(1).unwrap();
        assert!(dir.join(f).is_file(), "{f}");
    }
    assert!(mtl.contains("Ke 17 12 4"), "{mtl}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_exported_glb_renders_like_the_scene_it_came_from() {
    use fipt_core::camera::Camera;
    use fipt_shading::render::{render, render_aovs, RenderConfig};
    use fipt_shading::scene::{Scene, TableSurfaces};
    let s = fipt_synth::cornell();
    let (_, emitters) = scene();
    let mesh = s.mesh.clone();
    let truth = TableSurfaces::new(s.materials.clone(), &mesh, std::path::Path::new("gt")).unwrap();
    let dir = tmp("glb-render");
    export(
        &mesh,
        &truth,
        &emitters,
        Format::Glb,
        &dir,
        &ExportOptions {
            texel_size: 0.01,
            ..Default::default()
        },
    )
    .unwrap();
    let (m2, back) = fipt_export::load::load_glb(&dir.join("scene.glb")).unwrap();
    assert_eq!(m2.triangles.len(), mesh.triangles.len());
    let cam = Camera::look_at(
        Vec3::new(0.0, 1.0, 0.95),
        Vec3::new(0.0, 0.7, 0.0),
        Vec3::Y,
        1.1,
        64,
        48,
    );
    let cfg = RenderConfig {
        spp: 256,
        ..Default::default()
    };
    let a = Scene::new(mesh, truth);
    let b = Scene::new(m2, back);
    let (ia, _) = render(&a, &cam, &cfg, 0, &|_| {});
    let (ib, _) = render(&b, &cam, &cfg, 0, &|_| {});
    let (ka, kb) = (render_aovs(&a, &cam).kd, render_aovs(&b, &cam).kd);
    let kd = fipt_core::metrics::psnr(&ka.data, &kb.data, None, 1.0).unwrap();
    let img = fipt_core::metrics::srgb_psnr(&ia.data, &ib.data, None).unwrap();
    let mean =
        |i: &fipt_core::image::Image| i.data.iter().map(|p| p.element_sum() as f64).sum::<f64>();
    let ratio = mean(&ib) / mean(&ia);
    eprintln!("glb round trip: kd {kd:.1} dB, render {img:.1} dB, radiance ratio {ratio:.4}");
    assert!(
        kd >= 30.0 && img >= 28.0 && (ratio - 1.0).abs() < 0.03,
        "kd {kd:.1} dB, render {img:.1} dB, ratio {ratio}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
