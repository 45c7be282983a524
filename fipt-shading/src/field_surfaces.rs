//! Surfaces of a recovered scene, for path tracing it: materials from a
//! [`MaterialField`] cached on a sparse voxel grid around the observed surface, emission per
//! triangle from the extracted emitters.
//!
//! The field is a network: querying it per path vertex would cost a batch call per sample.
//! Instead it is evaluated once at the mean point of every occupied voxel (voxels of edge
//! `cell`, occupied by the given surface points), and per triangle at its centroid as the
//! fallback for voxels no point occupied.
use crate::scene::SurfaceModel;
use fipt_core::color::Rgb;
use fipt_core::emitter::Emitter;
use fipt_core::field::{Material, MaterialField};
use fipt_core::materials::SurfacePoint;
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::Mesh;
use glam::Vec3;
use std::collections::HashMap;

type Key = (i32, i32, i32);

pub struct FieldSurfaces {
    cell: f32,
    voxels: HashMap<Key, SurfacePoint>,
    per_triangle: Vec<SurfacePoint>,
    emission: Vec<Rgb>,
    model: ReflectanceModel,
}

fn to_surface(m: &Material) -> SurfacePoint {
    SurfacePoint {
        kd: m.kd(),
        ks: m.ks(),
        roughness: m.roughness,
        metallic: m.metallic,
        emission: Vec3::ZERO,
    }
}

impl FieldSurfaces {
    /// Caches `field` at voxels of edge `cell` occupied by `points`, and at triangle centroids.
    pub fn build(
        field: &dyn MaterialField,
        mesh: &Mesh,
        emitters: &[Emitter],
        points: impl IntoIterator<Item = Vec3>,
        cell: f32,
    ) -> fipt_core::Result<Self> {
        let cell = if cell > 0.0 && cell.is_finite() {
            cell
        } else {
            0.01
        };
        let key = |p: Vec3| -> Key {
            let q = (p / cell).floor();
            (q.x as i32, q.y as i32, q.z as i32)
        };
        let mut acc: HashMap<Key, (Vec3, u32)> = HashMap::new();
        for p in points {
            if p.is_finite() {
                let e = acc.entry(key(p)).or_insert((Vec3::ZERO, 0));
                e.0 += p;
                e.1 += 1;
            }
        }
        let mut keys: Vec<Key> = acc.keys().copied().collect();
        keys.sort_unstable();
        let centers: Vec<Vec3> = keys.iter().map(|k| acc[k].0 / acc[k].1 as f32).collect();
        let mats = field.materials(&centers)?;
        let voxels = keys.into_iter().zip(mats.iter().map(to_surface)).collect();
        let centroids: Vec<Vec3> = mesh
            .triangles
            .iter()
            .map(|t| t.iter().map(|&v| mesh.positions[v as usize]).sum::<Vec3>() / 3.0)
            .collect();
        let per_triangle = field
            .materials(&centroids)?
            .iter()
            .map(to_surface)
            .collect();
        let mut emission = vec![Vec3::ZERO; mesh.triangles.len()];
        for e in emitters {
            for (t, l) in e.triangles.iter().zip(&e.radiance) {
                if let Some(slot) = emission.get_mut(*t as usize) {
                    *slot = Vec3::from(*l);
                }
            }
        }
        Ok(FieldSurfaces {
            cell,
            voxels,
            per_triangle,
            emission,
            model: ReflectanceModel::Fipt,
        })
    }

    /// As [`FieldSurfaces::build`], and also caches the field on the voxels of the rest of the
    /// mesh surface (points spread over every triangle at about one per `cell`², at most
    /// `max_fill` of them), so views of surfaces no input view saw still vary within a
    /// triangle. Voxels the given points occupy keep exactly their value of `build`.
    pub fn build_covering(
        field: &dyn MaterialField,
        mesh: &Mesh,
        emitters: &[Emitter],
        points: Vec<Vec3>,
        cell: f32,
        max_fill: usize,
    ) -> fipt_core::Result<Self> {
        let key = |p: Vec3| -> Key {
            let q = (p / cell).floor();
            (q.x as i32, q.y as i32, q.z as i32)
        };
        let seen: std::collections::HashSet<Key> = points
            .iter()
            .filter(|p| p.is_finite())
            .map(|&p| key(p))
            .collect();
        let area: f64 = (0..mesh.triangles.len()).map(|t| mesh.area(t) as f64).sum();
        let spacing = (cell as f64).max((area / max_fill.max(1) as f64).sqrt());
        let mut all = points;
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.vertices(t);
            let n = (mesh.area(t) as f64 / (spacing * spacing)).ceil().max(1.0) as usize;
            // A rank-1 lattice folded into the triangle: deterministic and even.
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                let v = (i as f32 * 0.618_034 + 0.5).fract();
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                let p = a + (b - a) * u + (c - a) * v;
                if !seen.contains(&key(p)) {
                    all.push(p);
                }
            }
        }
        Self::build(field, mesh, emitters, all, cell)
    }

    /// The same surfaces under reflectance model `model` (FIPT's by default).
    pub fn with_model(mut self, model: ReflectanceModel) -> Self {
        self.model = model;
        self
    }

    /// Edge of the cache's voxels.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// Occupied voxels.
    pub fn voxels(&self) -> usize {
        self.voxels.len()
    }
}

impl SurfaceModel for FieldSurfaces {
    fn model(&self) -> ReflectanceModel {
        self.model
    }
    fn surface(&self, tri: u32, p: Vec3) -> SurfacePoint {
        let le = self.emission[tri as usize];
        if le.max_element() > 0.0 {
            // Emitters are black and reflect nothing.
            return SurfacePoint {
                roughness: 1.0,
                emission: le,
                ..Default::default()
            };
        }
        let q = (p / self.cell).floor();
        self.voxels
            .get(&(q.x as i32, q.y as i32, q.z as i32))
            .copied()
            .unwrap_or(self.per_triangle[tri as usize])
    }
    fn emission(&self, tri: u32) -> Rgb {
        self.emission[tri as usize]
    }
    fn part(&self, tri: u32) -> u32 {
        tri
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// kd = the point's x (clamped), so the cache's resolution is visible.
    struct Ramp;
    impl MaterialField for Ramp {
        fn name(&self) -> &str {
            "ramp"
        }
        fn materials(&self, p: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
            Ok(p.iter()
                .map(|q| Material {
                    albedo: Vec3::splat(q.x.clamp(0.0, 1.0)),
                    roughness: 0.5,
                    metallic: 0.0,
                })
                .collect())
        }
        fn emission_mask(&self, p: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
            Ok(vec![0.0; p.len()])
        }
    }

    #[test]
    fn cached_materials_follow_the_field_within_a_cell_and_emitters_are_black() {
        let mesh = Mesh::from_triangles(
            vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(1.0, 0.0, 1.0),
            ],
            None,
            vec![[0, 1, 2], [1, 3, 2]],
        );
        let pts: Vec<Vec3> = (0..100)
            .map(|i| Vec3::new(i as f32 / 100.0 + 0.005, 0.0, 0.3))
            .collect();
        let em = Emitter {
            triangles: vec![1],
            radiance: vec![[2.0, 3.0, 4.0]],
            area: 0.5,
            mean_radiance: [2.0, 3.0, 4.0],
            power: [0.0; 3],
            centroid: [0.0; 3],
            pixels: 1,
        };
        let s = FieldSurfaces::build(&Ramp, &mesh, &[em], pts.clone(), 0.05).unwrap();
        assert_eq!(s.voxels(), 20);
        for x in [0.02f32, 0.31, 0.77] {
            let sp = s.surface(0, Vec3::new(x, 0.0, 0.3));
            assert!((sp.kd.x - x).abs() <= 0.05, "x={x}: kd {}", sp.kd.x);
            assert_eq!(sp.ks, Vec3::splat(0.04));
        }
        // Off the observed points: the triangle's centroid value.
        assert!((s.surface(0, Vec3::new(0.2, 0.0, 0.9)).kd.x - 1.0 / 3.0).abs() < 1e-5);
        // Covering the mesh: observed voxels keep their value, the rest follow the field.
        let c =
            FieldSurfaces::build_covering(&Ramp, &mesh, &[], pts.clone(), 0.05, 10_000).unwrap();
        let b = FieldSurfaces::build(&Ramp, &mesh, &[], pts.clone(), 0.05).unwrap();
        assert!(c.voxels() > 200, "{} voxels", c.voxels());
        for p in &pts {
            assert_eq!(c.surface(0, *p), b.surface(0, *p));
        }
        let off = c.surface(0, Vec3::new(0.2, 0.0, 0.7)).kd.x;
        assert!((off - 0.2).abs() <= 0.05, "unobserved point: kd {off}");
        let e = s.surface(1, Vec3::new(0.9, 0.0, 0.9));
        assert_eq!(e.kd, Vec3::ZERO);
        assert_eq!(s.emission(1), Vec3::new(2.0, 3.0, 4.0));
        assert_eq!(s.emission(0), Vec3::ZERO);
    }
}
