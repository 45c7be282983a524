//! `fipt-synth`: procedural indoor scenes with exact ground truth, rendered by fipt-shading's
//! path tracer and written in the reference synthetic layout. It owns the scenes' geometry,
//! materials and cameras; it imports the renderer, never the pipeline.
//!
//! * `cornell`: a tiny box room, one ceiling emitter, two diffuse blocks and one glossy block
//!   (tests);
//! * `room`: a small furnished room: ceiling panel, a small very bright lamp, a checkered wood
//!   floor with varying roughness, walls of different colours, a glossy dielectric box, a rough
//!   metal sphere and a near-mirror panel.
//!
//! Everything is generated from a seed; cameras stand inside the room, outside every object,
//! looking at varied targets (some at the emitters).
use fipt_core::camera::Camera;
use fipt_core::dataset::{image_file_name, write_transforms, GtKind};
use fipt_core::image::{ExrPrecision, Image};
use fipt_core::materials::{FaceRange, MaterialDesc, Pattern, SceneMaterials, Texture};
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::rng::Pcg32;
use fipt_geom::shapes::icosphere_into as icosphere;
pub use fipt_geom::shapes::icosphere_mesh;
use fipt_geom::Mesh;
use fipt_shading::error::{Result, ShadingError};
use fipt_shading::render::{render, render_aovs, Aovs, RenderConfig, RenderStats};
use fipt_shading::scene::{Scene, TableSurfaces};
use glam::{Vec2, Vec3};

mod cornell;
mod room;
pub use cornell::{cornell, cornell_metal};
pub use room::room;
use std::path::Path;

/// Names of the built-in scenes.
pub const SCENES: [&str; 3] = ["cornell", "cornell-metal", "room"];

/// An axis-aligned box that cameras must stay out of.
#[derive(Clone, Copy, Debug)]
pub struct Obstacle {
    pub min: Vec3,
    pub max: Vec3,
}

/// A generated scene before rendering.
pub struct SynthScene {
    pub name: String,
    pub mesh: Mesh,
    pub materials: SceneMaterials,
    /// Semantic class of each material (written to `segmentation/`).
    pub semantic: Vec<u32>,
    /// Interior of the room (cameras are placed inside, with a margin).
    pub room_min: Vec3,
    pub room_max: Vec3,
    pub obstacles: Vec<Obstacle>,
    /// Points worth looking at (object centres, emitters).
    pub targets: Vec<Vec3>,
    /// Emitter centres (some views aim at them).
    pub emitter_targets: Vec<Vec3>,
    /// Horizontal field of view (radians).
    pub fov_x: f32,
}

/// Accumulates geometry part by part; one material per part.
struct Builder {
    pos: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    materials: Vec<MaterialDesc>,
    semantic: Vec<u32>,
    faces: Vec<FaceRange>,
    obstacles: Vec<Obstacle>,
    targets: Vec<Vec3>,
    emitters: Vec<Vec3>,
}

const WALL: u32 = 1;
const FLOOR: u32 = 2;
const CEILING: u32 = 3;
const LIGHT: u32 = 4;
const FURNITURE: u32 = 5;
const DECOR: u32 = 6;

impl Builder {
    fn new() -> Self {
        Builder {
            pos: vec![],
            tris: vec![],
            materials: vec![],
            semantic: vec![],
            faces: vec![],
            obstacles: vec![],
            targets: vec![],
            emitters: vec![],
        }
    }

    fn part(
        &mut self,
        mat: MaterialDesc,
        class: u32,
        geom: impl FnOnce(&mut Vec<Vec3>, &mut Vec<[u32; 3]>),
    ) {
        let start = self.tris.len() as u32;
        geom(&mut self.pos, &mut self.tris);
        let m = self.materials.len() as u32;
        self.faces.push(FaceRange {
            start,
            end: self.tris.len() as u32,
            material: m,
        });
        self.materials.push(mat);
        self.semantic.push(class);
    }

    /// An emitting quad (corner `o`, edges `a`, `b`), emitting towards a × b only, with its
    /// centre as a camera target.
    fn quad_light(&mut self, name: &str, radiance: [f32; 3], o: Vec3, a: Vec3, b: Vec3) {
        self.part(
            // A luminaire's back is dark (as Mitsuba's area lights): a two-sided panel 1 cm
            // under a ceiling lit a ring of it that no light seen from the room explains.
            MaterialDesc::Emitter {
                name: name.into(),
                radiance,
                one_sided: true,
            },
            LIGHT,
            |p, t| quad(p, t, o, a, b),
        );
        self.emitters.push(o + 0.5 * (a + b));
    }

    fn finish(self, name: &str, room_min: Vec3, room_max: Vec3, fov_x: f32) -> SynthScene {
        let mesh = Mesh::from_triangles(self.pos, None, self.tris);
        debug_assert_eq!(mesh.dropped_degenerate, 0);
        SynthScene {
            name: name.to_string(),
            mesh,
            materials: SceneMaterials {
                version: 1,
                materials: self.materials,
                faces: self.faces,
                note: format!("fipt synth {name}"),
            },
            semantic: self.semantic,
            room_min,
            room_max,
            obstacles: self.obstacles,
            targets: self.targets,
            emitter_targets: self.emitters,
            fov_x,
        }
    }
}

/// A quad `o, o+a, o+a+b, o+b`; normal along a × b.
fn quad(pos: &mut Vec<Vec3>, tris: &mut Vec<[u32; 3]>, o: Vec3, a: Vec3, b: Vec3) {
    let i = pos.len() as u32;
    pos.extend([o, o + a, o + a + b, o + b]);
    tris.push([i, i + 1, i + 2]);
    tris.push([i, i + 2, i + 3]);
}

/// A box rotated by `yaw` about +y; normals outward (or inward with `inward`).
fn boxed(
    pos: &mut Vec<Vec3>,
    tris: &mut Vec<[u32; 3]>,
    center: Vec3,
    half: Vec3,
    yaw: f32,
    inward: bool,
) {
    let (s, c) = yaw.sin_cos();
    let rot = |v: Vec3| Vec3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z);
    let corner =
        |x: f32, y: f32, z: f32| center + rot(Vec3::new(x * half.x, y * half.y, z * half.z));
    // Each face: origin corner and two edges with a × b pointing outward.
    let faces = [
        (
            corner(1., -1., -1.),
            corner(1., 1., -1.),
            corner(1., -1., 1.),
        ), // +x
        (
            corner(-1., -1., -1.),
            corner(-1., -1., 1.),
            corner(-1., 1., -1.),
        ), // -x
        (
            corner(-1., 1., -1.),
            corner(-1., 1., 1.),
            corner(1., 1., -1.),
        ), // +y
        (
            corner(-1., -1., -1.),
            corner(1., -1., -1.),
            corner(-1., -1., 1.),
        ), // -y
        (
            corner(-1., -1., 1.),
            corner(1., -1., 1.),
            corner(-1., 1., 1.),
        ), // +z
        (
            corner(-1., -1., -1.),
            corner(-1., 1., -1.),
            corner(1., -1., -1.),
        ), // -z
    ];
    for (o, pa, pb) in faces {
        let (a, b) = (pa - o, pb - o);
        if inward {
            quad(pos, tris, o, b, a)
        } else {
            quad(pos, tris, o, a, b)
        }
    }
}

fn principled(name: &str, base: Texture, rough: Texture, metal: f32) -> MaterialDesc {
    MaterialDesc::Principled {
        name: name.into(),
        base_color: base,
        roughness: rough,
        metallic: Texture::Scalar(metal),
    }
}

fn rgb(r: f32, g: f32, b: f32) -> Texture {
    Texture::Rgb([r, g, b])
}

/// The room shell: floor, ceiling and four walls (normals inward), one part each.
fn shell(
    b: &mut Builder,
    lo: Vec3,
    hi: Vec3,
    floor: MaterialDesc,
    ceiling: MaterialDesc,
    walls: [MaterialDesc; 4],
) {
    let e = hi - lo;
    b.part(floor, FLOOR, |p, t| {
        quad(p, t, lo, Vec3::new(0., 0., e.z), Vec3::new(e.x, 0., 0.))
    });
    b.part(ceiling, CEILING, |p, t| {
        quad(
            p,
            t,
            Vec3::new(lo.x, hi.y, lo.z),
            Vec3::new(e.x, 0., 0.),
            Vec3::new(0., 0., e.z),
        )
    });
    let [wl, wr, wb, wf] = walls;
    b.part(wl, WALL, |p, t| {
        quad(p, t, lo, Vec3::new(0., e.y, 0.), Vec3::new(0., 0., e.z))
    }); // x- wall, normal +x
    b.part(wr, WALL, |p, t| {
        quad(
            p,
            t,
            Vec3::new(hi.x, lo.y, lo.z),
            Vec3::new(0., 0., e.z),
            Vec3::new(0., e.y, 0.),
        )
    }); // x+
    b.part(wb, WALL, |p, t| {
        quad(p, t, lo, Vec3::new(e.x, 0., 0.), Vec3::new(0., e.y, 0.))
    }); // z- wall, normal +z
    b.part(wf, WALL, |p, t| {
        quad(
            p,
            t,
            Vec3::new(lo.x, lo.y, hi.z),
            Vec3::new(0., e.y, 0.),
            Vec3::new(e.x, 0., 0.),
        )
    }); // z+
}

fn add_box(b: &mut Builder, mat: MaterialDesc, class: u32, center: Vec3, half: Vec3, yaw: f32) {
    b.part(mat, class, |p, t| boxed(p, t, center, half, yaw, false));
    let r = half.x.hypot(half.z);
    b.obstacles.push(Obstacle {
        min: center - Vec3::new(r, half.y, r),
        max: center + Vec3::new(r, half.y, r),
    });
    b.targets.push(center);
}

/// Builds a scene by name.
pub fn build(name: &str) -> Result<SynthScene> {
    match name {
        "cornell" => Ok(cornell()),
        "cornell-metal" => Ok(cornell_metal()),
        "room" => Ok(room()),
        other => Err(ShadingError::UnknownScene(other.to_string())),
    }
}

/// Options of [`write_dataset`].
#[derive(Clone, Debug)]
pub struct SynthOptions {
    pub train_views: usize,
    pub val_views: usize,
    pub width: usize,
    pub height: usize,
    pub render: RenderConfig,
    /// The reflectance model the views are rendered with.
    pub model: ReflectanceModel,
    /// The lens every view is rendered through (the maps too; `transforms.json` records it).
    pub lens: fipt_core::distortion::Distortion,
}

impl SynthOptions {
    /// Defaults per scene: `cornell` is tiny (tests), `room` matches the benchmark size.
    pub fn defaults(name: &str) -> Self {
        match name {
            "cornell" | "cornell-metal" => SynthOptions {
                train_views: 12,
                val_views: 4,
                width: 64,
                height: 48,
                render: RenderConfig::ground_truth(64),
                model: ReflectanceModel::Fipt,
                lens: Default::default(),
            },
            _ => SynthOptions {
                train_views: 48,
                val_views: 8,
                width: 240,
                height: 160,
                render: RenderConfig::ground_truth(128),
                model: ReflectanceModel::Fipt,
                lens: Default::default(),
            },
        }
    }
}

impl SynthScene {
    /// The same scene with every triangle split into four at its edge midpoints, `levels`
    /// times: 4^levels consecutive triangles per triangle, so the face ranges of the material
    /// table scale by 4^levels and the geometry, materials and renders stay the same (for
    /// measuring how the stages grow with the triangle count).
    pub fn subdivided(mut self, levels: u32) -> SynthScene {
        self.mesh = self.mesh.subdivided(levels);
        let f = 4u32.pow(levels);
        for r in &mut self.materials.faces {
            (r.start, r.end) = (r.start * f, r.end * f);
        }
        self
    }

    fn inside_obstacle(&self, p: Vec3, margin: f32) -> bool {
        self.obstacles
            .iter()
            .any(|o| p.cmpge(o.min - margin).all() && p.cmple(o.max + margin).all())
    }

    /// `n` cameras from `seed`: positions inside the room (30 cm from walls, outside every
    /// object by 20 cm), looking at objects, emitters or the walls, with nothing closer than
    /// 30 cm along the optical axis.
    pub fn cameras(
        &self,
        n: usize,
        seed: u64,
        width: usize,
        height: usize,
        bvh: &fipt_geom::Bvh,
    ) -> Vec<Camera> {
        let mut rng = Pcg32::new(seed, 0xCA3E);
        let mut out = Vec::with_capacity(n);
        let size = self.room_max - self.room_min;
        let margin = Vec3::new(0.3, 0.0, 0.3);
        let mut attempts = 0;
        while out.len() < n {
            attempts += 1;
            let r = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let lo = self.room_min + margin + Vec3::new(0.0, 0.35 * size.y, 0.0);
            let hi = self.room_max - margin - Vec3::new(0.0, 0.2 * size.y, 0.0);
            let o = lo + (hi - lo) * r;
            if self.inside_obstacle(o, 0.2) && attempts < 100_000 {
                continue;
            }
            let k = out.len();
            let target = if k % 5 == 2 && !self.emitter_targets.is_empty() {
                self.emitter_targets[(k / 5) % self.emitter_targets.len()]
            } else if k % 3 == 0 || self.targets.is_empty() {
                // A random point on the floor or low on the walls.
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                self.room_min + Vec3::new(u.x * size.x, 0.5 * rng.next_f32() * size.y, u.y * size.z)
            } else {
                self.targets[(rng.next_u32() as usize) % self.targets.len()]
                    + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.3
            };
            if (target - o).length() < 0.5 {
                continue;
            }
            let cam = Camera::look_at(o, target, Vec3::Y, self.fov_x, width, height);
            let (co, cd) = cam.pixel_center_ray(width / 2, height / 2);
            let near = bvh
                .closest_hit(co, cd, 0.0, f32::INFINITY)
                .map(|h| h.t)
                .unwrap_or(0.0);
            if near < 0.3 && attempts < 100_000 {
                continue;
            }
            out.push(cam);
        }
        out
    }
}

/// Writes one view's input image and ground-truth maps into `split_dir`.
pub fn write_view(
    split_dir: &Path,
    k: usize,
    image: &Image,
    aovs: &Aovs,
    semantic: &[u32],
) -> Result<()> {
    let (w, h) = (image.width, image.height);
    image.write_exr(
        &split_dir.join("Image").join(image_file_name(k)),
        ExrPrecision::F32,
    )?;
    let half = ExrPrecision::F16;
    aovs.kd.write_exr(
        &split_dir
            .join(GtKind::DiffCol.folder())
            .join(GtKind::DiffCol.file_name(k)),
        half,
    )?;
    aovs.ks.write_exr(
        &split_dir
            .join(GtKind::Specular.folder())
            .join(GtKind::Specular.file_name(k)),
        half,
    )?;
    aovs.roughness.write_exr(
        &split_dir
            .join(GtKind::Roughness.folder())
            .join(GtKind::Roughness.file_name(k)),
        half,
    )?;
    aovs.metallic.write_exr(
        &split_dir
            .join(GtKind::Metallic.folder())
            .join(GtKind::Metallic.file_name(k)),
        half,
    )?;
    aovs.emission.write_exr(
        &split_dir
            .join(GtKind::Emit.folder())
            .join(GtKind::Emit.file_name(k)),
        ExrPrecision::F32,
    )?;
    aovs.albedo().write_exr(
        &split_dir
            .join(GtKind::Albedo.folder())
            .join(GtKind::Albedo.file_name(k)),
        half,
    )?;
    Aovs::id_image(&aovs.part, w, h, -1.0).write_exr(
        &split_dir
            .join(GtKind::IndexMA.folder())
            .join(GtKind::IndexMA.file_name(k)),
        ExrPrecision::F32,
    )?;
    let sem: Vec<u32> = aovs
        .part
        .iter()
        .map(|&p| {
            if p == u32::MAX {
                u32::MAX
            } else {
                semantic.get(p as usize).copied().unwrap_or(0)
            }
        })
        .collect();
    Aovs::id_image(&sem, w, h, 0.0).write_exr(
        &split_dir
            .join(GtKind::Segmentation.folder())
            .join(GtKind::Segmentation.file_name(k)),
        ExrPrecision::F32,
    )?;
    let preview = split_dir.join("preview").join(format!("{k:03}.png"));
    image.write_png(&preview, 1.0)?;
    Ok(())
}

/// What [`write_dataset`] produced.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SynthSummary {
    pub triangles: usize,
    pub emitters: usize,
    pub views: usize,
    pub stats: RenderStats,
    pub seconds: f64,
}

/// Generates scene `scene`, renders its views and writes the synthetic layout to `out`.
/// `progress(done_pixels, total_pixels)` reports rendering progress.
pub fn write_dataset(
    scene: SynthScene,
    out: &Path,
    opts: &SynthOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<SynthSummary> {
    let t0 = std::time::Instant::now();
    fipt_core::lock::output_folder(out)?;
    std::fs::create_dir_all(out).map_err(|e| fipt_core::CoreError::io(out, e))?;
    scene.mesh.write_obj(
        &out.join("scene.obj"),
        &format!(
            "fipt synth {}: world space, y up, metres; faces in file order match scene_gt.json",
            scene.name
        ),
    )?;
    fipt_core::fsutil::write_json_atomic(&out.join("scene_gt.json"), &scene.materials)?;
    let semantic = scene.semantic.clone();
    let table = out.join("scene_gt.json");
    let bvh = fipt_geom::Bvh::build(&scene.mesh, fipt_geom::BuildQuality::Medium);
    let lensed = |cams: Vec<Camera>| -> Vec<Camera> {
        cams.into_iter()
            .map(|c| Camera {
                distortion: opts.lens,
                ..c
            })
            .collect()
    };
    let train = lensed(scene.cameras(
        opts.train_views,
        opts.render.seed,
        opts.width,
        opts.height,
        &bvh,
    ));
    let val = lensed(scene.cameras(
        opts.val_views,
        opts.render.seed ^ 0x5EED_0F7A,
        opts.width,
        opts.height,
        &bvh,
    ));
    let mut surfaces = TableSurfaces::new(scene.materials, &scene.mesh, &table)?;
    surfaces.model = opts.model;
    let rs = Scene::with_bvh(scene.mesh, bvh, surfaces);
    let total = (train.len() + val.len()) * opts.width * opts.height;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut stats = RenderStats::default();
    for (split, cams, key_base) in [("train", &train, 0u64), ("val", &val, 1u64 << 32)] {
        let dir = out.join(split);
        for (k, cam) in cams.iter().enumerate() {
            let (img, st) = render(&rs, cam, &opts.render, key_base + k as u64, &|n| {
                let d = done.fetch_add(n, std::sync::atomic::Ordering::Relaxed) + n;
                progress(d, total);
            });
            stats.paths += st.paths;
            stats.rays += st.rays;
            stats.nonfinite += st.nonfinite;
            let aovs = render_aovs(&rs, cam);
            write_view(&dir, k, &img, &aovs, &semantic)?;
        }
        write_transforms(&dir.join("transforms.json"), cams)?;
    }
    Ok(SynthSummary {
        triangles: rs.mesh.triangles.len(),
        emitters: rs.emitter_triangles().len(),
        views: train.len() + val.len(),
        stats,
        seconds: t0.elapsed().as_secs_f64(),
    })
}
