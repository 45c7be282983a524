//! A renderable scene: mesh, BVH, surfaces and the emitter sampler.
use crate::brdf::{BrdfModel, Lambert, MicrofacetBrdf};
use crate::lights::DeltaLight;
use fipt_core::color::{luminance, Rgb};
use fipt_core::emitter::EmitSide;
use fipt_core::materials::{SceneMaterials, SurfacePoint};
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::{BuildQuality, Bvh, Mesh, TriangleSampler};
use glam::Vec3;

/// What the renderer asks of surfaces. Ground-truth tables, a trained material field or a test
/// fixture implement it; emission is constant per triangle (method §1).
pub trait SurfaceModel: Sync {
    /// Material parameters at point `p` of mesh triangle `tri`.
    fn surface(&self, tri: u32, p: Vec3) -> SurfacePoint;
    /// A hint that [`SurfaceModel::surface`] will soon be asked at (`tri`, `p`): a model
    /// whose lookup misses the cache starts fetching here. Changes nothing; none by default.
    #[inline]
    fn prefetch(&self, _tri: u32, _p: Vec3) {}
    /// Emitted radiance of triangle `tri` (both sides).
    fn emission(&self, tri: u32) -> Rgb;
    /// Index of the material/part of triangle `tri` (for the `IndexMA` map).
    fn part(&self, tri: u32) -> u32;
    /// The side triangle `tri` emits from (both by default).
    fn emit_side(&self, _tri: u32) -> EmitSide {
        EmitSide::Both
    }
    /// The reflectance model of the surfaces (FIPT's unless overridden).
    fn model(&self) -> ReflectanceModel {
        ReflectanceModel::Fipt
    }
    /// The BRDF at a surface point (the [`SurfaceModel::model`]'s unless overridden).
    fn brdf(&self, sp: &SurfacePoint) -> BrdfModel {
        BrdfModel::Microfacet(MicrofacetBrdf::with_model(
            self.model(),
            sp.kd,
            sp.ks,
            sp.roughness,
        ))
    }
}

impl<S: SurfaceModel + ?Sized> SurfaceModel for &S {
    fn surface(&self, tri: u32, p: Vec3) -> SurfacePoint {
        (**self).surface(tri, p)
    }
    fn prefetch(&self, tri: u32, p: Vec3) {
        (**self).prefetch(tri, p)
    }
    fn emission(&self, tri: u32) -> Rgb {
        (**self).emission(tri)
    }
    fn part(&self, tri: u32) -> u32 {
        (**self).part(tri)
    }
    fn emit_side(&self, tri: u32) -> EmitSide {
        (**self).emit_side(tri)
    }
    fn model(&self) -> ReflectanceModel {
        (**self).model()
    }
    fn brdf(&self, sp: &SurfacePoint) -> BrdfModel {
        (**self).brdf(sp)
    }
}

/// Surfaces from a per-face material table (`scene_gt.json` / `scene_parts.json`).
pub struct TableSurfaces {
    pub materials: SceneMaterials,
    /// Material index of each mesh triangle.
    pub tri_material: Vec<u32>,
    /// Emitted radiance of each material (0 for reflecting ones).
    material_emission: Vec<Rgb>,
    /// The side each material emits from.
    material_side: Vec<EmitSide>,
    /// The reflectance model the table's parameters are meant for.
    pub model: ReflectanceModel,
}

impl TableSurfaces {
    /// Binds a material table (indexed by file face) to a mesh's triangles.
    pub fn new(
        materials: SceneMaterials,
        mesh: &Mesh,
        table_path: &std::path::Path,
    ) -> fipt_core::Result<Self> {
        let faces = materials.face_table(mesh.num_file_faces, table_path)?;
        let tri_material = mesh.face_ids.iter().map(|&f| faces[f as usize]).collect();
        let material_emission = (0..materials.materials.len() as u32)
            .map(|m| materials.eval(m, Vec3::ZERO).emission)
            .collect();
        let material_side = materials.materials.iter().map(|m| m.emit_side()).collect();
        Ok(TableSurfaces {
            materials,
            tri_material,
            material_emission,
            material_side,
            model: ReflectanceModel::Fipt,
        })
    }
}

impl SurfaceModel for TableSurfaces {
    fn model(&self) -> ReflectanceModel {
        self.model
    }
    #[inline]
    fn surface(&self, tri: u32, p: Vec3) -> SurfacePoint {
        self.materials.eval(self.tri_material[tri as usize], p)
    }
    #[inline]
    fn emission(&self, tri: u32) -> Rgb {
        self.material_emission[self.tri_material[tri as usize] as usize]
    }
    fn part(&self, tri: u32) -> u32 {
        self.tri_material[tri as usize]
    }
    fn emit_side(&self, tri: u32) -> EmitSide {
        self.material_side[self.tri_material[tri as usize] as usize]
    }
}

/// Lambertian surfaces with per-triangle albedo and emission (analytic test scenes).
pub struct LambertSurfaces {
    pub albedo: Vec<Rgb>,
    pub emission: Vec<Rgb>,
}

impl SurfaceModel for LambertSurfaces {
    fn surface(&self, tri: u32, _p: Vec3) -> SurfacePoint {
        SurfacePoint {
            kd: self.albedo[tri as usize],
            roughness: 1.0,
            emission: self.emission[tri as usize],
            ..Default::default()
        }
    }
    fn emission(&self, tri: u32) -> Rgb {
        self.emission[tri as usize]
    }
    fn part(&self, _tri: u32) -> u32 {
        0
    }
    fn brdf(&self, sp: &SurfacePoint) -> BrdfModel {
        BrdfModel::Lambert(Lambert { albedo: sp.kd })
    }
}

/// The emitter sampler of a mesh whose triangle `t` emits `emission(t)`: triangles chosen ∝
/// area × luminance(Le) (None when nothing emits), and the area density of the samples on
/// every mesh triangle (0 off the emitters), for the MIS weights of BRDF-sampled hits.
pub fn emitter_sampler(
    mesh: &Mesh,
    emission: impl Fn(u32) -> Rgb,
) -> (Option<TriangleSampler>, Vec<f32>) {
    let mut tris = Vec::new();
    let mut weights = Vec::new();
    for t in 0..mesh.triangles.len() as u32 {
        let w = mesh.area(t as usize) as f64 * luminance(emission(t)).max(0.0) as f64;
        if w > 0.0 {
            tris.push(t);
            weights.push(w);
        }
    }
    let lights = TriangleSampler::weighted(mesh, &tris, &weights);
    let mut pdf_area = vec![0.0; mesh.triangles.len()];
    if let Some(l) = &lights {
        for (k, &t) in l.triangles().iter().enumerate() {
            pdf_area[t as usize] = l.pdf_area(k);
        }
    }
    (lights, pdf_area)
}

/// A scene ready for path tracing.
pub struct Scene<S: SurfaceModel> {
    pub mesh: Mesh,
    pub bvh: Bvh,
    pub surfaces: S,
    /// Emitter triangles, chosen ∝ area × luminance(Le).
    pub lights: Option<TriangleSampler>,
    /// Area density of light samples on each mesh triangle (0 for non-emitters), for the MIS
    /// weight of BRDF-sampled hits on emitters.
    pub light_pdf_area: Vec<f32>,
    /// Point and spot lights, sampled at every vertex besides the emitting triangles.
    pub delta_lights: Vec<DeltaLight>,
}

impl<S: SurfaceModel> Scene<S> {
    pub fn new(mesh: Mesh, surfaces: S) -> Self {
        let bvh = Bvh::build(&mesh, BuildQuality::Medium);
        Self::with_bvh(mesh, bvh, surfaces)
    }

    pub fn with_bvh(mesh: Mesh, bvh: Bvh, surfaces: S) -> Self {
        let (lights, light_pdf_area) = emitter_sampler(&mesh, |t| surfaces.emission(t));
        Scene {
            mesh,
            bvh,
            surfaces,
            lights,
            light_pdf_area,
            delta_lights: Vec::new(),
        }
    }

    /// Whether anything in the scene emits.
    pub fn has_light(&self) -> bool {
        self.lights.is_some()
            || self
                .delta_lights
                .iter()
                .any(|d| d.intensity.max_element() > 0.0)
    }

    /// Emitter triangles.
    pub fn emitter_triangles(&self) -> &[u32] {
        self.lights.as_ref().map(|l| l.triangles()).unwrap_or(&[])
    }
}
