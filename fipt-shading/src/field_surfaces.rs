//! Surfaces of a recovered scene, for path tracing it: materials from a
//! [`MaterialField`] cached on a sparse voxel grid around the observed surface, emission per
//! triangle from the extracted emitters.
//!
//! The field is a network: querying it per path vertex would cost a batch call per sample.
//! Instead it is evaluated once at the mean point of every occupied voxel (voxels of edge
//! `cell`, occupied by the given surface points). A point in no such voxel takes its
//! triangle's fallback: the mean material of the observed points on that triangle, or, for a
//! triangle no view saw, of the nearest observed triangles across shared vertices. The field
//! itself is not asked there: a network extrapolates far from its training points (on the
//! tiny `cornell`, albedo 1.0 on the hidden faces of the blocks and the ceiling above the
//! light), and paths that bounce off such surfaces brightened the refined Ld by 6 %.
use crate::material_table::{Key, MaterialTable};
use crate::scene::SurfaceModel;
use fipt_core::color::Rgb;
use fipt_core::emitter::{EmitSide, Emitter};
use fipt_core::field::{Material, MaterialField};
use fipt_core::hash::floor_i32;
use fipt_core::materials::SurfacePoint;
use fipt_core::parted::PartedMap;
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::Mesh;
use glam::Vec3;

/// No triangle: a point whose triangle is unknown (it still gets a voxel).
pub const NO_TRIANGLE: u32 = u32::MAX;

pub struct FieldSurfaces {
    cell: f32,
    voxels: MaterialTable,
    tri_facing: Vec<u8>,
    per_triangle: Vec<SurfacePoint>,
    emission: Vec<Rgb>,
    /// The side each triangle emits from (the extracted emitters' [`EmitSide`]).
    side: Vec<EmitSide>,
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

/// A running sum of surface points (kd, ks, σ and metallic averaged linearly).
#[derive(Clone, Copy, Default)]
struct MeanSurface {
    kd: Vec3,
    ks: Vec3,
    roughness: f64,
    metallic: f64,
    weight: f64,
}

impl MeanSurface {
    fn add(&mut self, sp: &SurfacePoint, w: f64) {
        self.kd += sp.kd * w as f32;
        self.ks += sp.ks * w as f32;
        self.roughness += sp.roughness as f64 * w;
        self.metallic += sp.metallic as f64 * w;
        self.weight += w;
    }
    fn mean(&self) -> Option<SurfacePoint> {
        (self.weight > 0.0).then(|| {
            let w = self.weight;
            SurfacePoint {
                kd: self.kd / w as f32,
                ks: self.ks / w as f32,
                roughness: (self.roughness / w) as f32,
                metallic: (self.metallic / w) as f32,
                emission: Vec3::ZERO,
            }
        })
    }
}

/// Each triangle's fallback: its observed mean, else (breadth first across shared vertices
/// from the observed triangles) the mean of its neighbours' fallbacks when it is reached;
/// triangles no observed one connects to take the mean of every observed point, and with no
/// observed point at all, `centroid_value`.
fn triangle_fallbacks(
    mesh: &Mesh,
    observed: Vec<MeanSurface>,
    centroid_value: impl Fn() -> fipt_core::Result<Vec<SurfacePoint>>,
) -> fipt_core::Result<Vec<SurfacePoint>> {
    let mut all = MeanSurface::default();
    for m in &observed {
        if let Some(sp) = m.mean() {
            all.add(&sp, m.weight);
        }
    }
    let Some(global) = all.mean() else {
        return centroid_value();
    };
    let mut value: Vec<Option<SurfacePoint>> = observed.iter().map(|m| m.mean()).collect();
    mesh.spread_to_neighbours(&mut value, |near| {
        let mut m = MeanSurface::default();
        for sp in near {
            m.add(sp, 1.0);
        }
        m.mean()
    });
    Ok(value.into_iter().map(|v| v.unwrap_or(global)).collect())
}

/// The side a triangle faces: its normal's dominant axis and sign (0..6), 6 for no triangle.
fn facing(mesh: &Mesh, tri: u32) -> u8 {
    if (tri as usize) >= mesh.triangles.len() {
        return 6;
    }
    let n = mesh.face_normal(tri as usize);
    let a = n.abs();
    let (axis, v) = if a.x >= a.y && a.x >= a.z {
        (0, n.x)
    } else if a.y >= a.z {
        (1, n.y)
    } else {
        (2, n.z)
    };
    2 * axis + u8::from(v < 0.0)
}

/// [`facing`] of every triangle.
fn facings(mesh: &Mesh) -> Vec<u8> {
    (0..mesh.triangles.len() as u32)
        .map(|t| facing(mesh, t))
        .collect()
}

/// The voxel of edge `cell` holding `p`, on the side triangle `t` faces (6 for none).
fn voxel_key(p: Vec3, cell: f32, tri_facing: &[u8], t: u32) -> Key {
    let q = p / cell;
    let side = tri_facing.get(t as usize).copied().unwrap_or(6);
    (floor_i32(q.x), floor_i32(q.y), floor_i32(q.z), side)
}

/// Hands every observed point (position, triangle) to its argument, in batches (a view's
/// hits, say), in a fixed order.
pub type PointVisitor<'a> = &'a dyn Fn(&mut PointSink);

/// What a [`PointVisitor`] hands each batch of points to.
pub type PointSink<'a> = dyn FnMut(&[(Vec3, u32)]) + 'a;

impl FieldSurfaces {
    /// Caches `field` at voxels of edge `cell` occupied by the `observed` points (each with
    /// its mesh triangle, or [`NO_TRIANGLE`]); see the module's notes for the fallback.
    pub fn build(
        field: &dyn MaterialField,
        mesh: &Mesh,
        emitters: &[Emitter],
        observed: &[(Vec3, u32)],
        cell: f32,
    ) -> fipt_core::Result<Self> {
        Self::build_with(field, mesh, emitters, observed, &[], cell)
    }

    /// [`FieldSurfaces::build`] with voxels also at the `extra` points (which do not count
    /// as observed for the triangles' fallbacks).
    ///
    /// A voxel is split by the side its points' triangles face (so a floor and the wall
    /// beside it keep their own materials in a shared voxel), and the field is asked at the
    /// point nearest the mean of the voxel's points: a surface point, where the mean itself
    /// of a corner's points lies off the surface, where the field was never trained.
    fn build_with(
        field: &dyn MaterialField,
        mesh: &Mesh,
        emitters: &[Emitter],
        observed: &[(Vec3, u32)],
        extra: &[(Vec3, u32)],
        cell: f32,
    ) -> fipt_core::Result<Self> {
        let visit = |f: &mut PointSink| f(observed);
        Self::build_visiting(field, mesh, emitters, &visit, extra, cell)
    }

    /// [`FieldSurfaces::build`] from the observed points that `observed` hands to its argument
    /// (twice, in the same order each time): for callers that trace them again rather than
    /// hold them all.
    pub fn build_from(
        field: &dyn MaterialField,
        mesh: &Mesh,
        emitters: &[Emitter],
        observed: PointVisitor,
        cell: f32,
    ) -> fipt_core::Result<Self> {
        Self::build_visiting(field, mesh, emitters, observed, &[], cell)
    }

    fn build_visiting(
        field: &dyn MaterialField,
        mesh: &Mesh,
        emitters: &[Emitter],
        observed: PointVisitor,
        extra: &[(Vec3, u32)],
        cell: f32,
    ) -> fipt_core::Result<Self> {
        let cell = if cell > 0.0 && cell.is_finite() {
            cell
        } else {
            0.01
        };
        let tri_facing = facings(mesh);
        let key = |p: Vec3, t: u32| voxel_key(p, cell, &tri_facing, t);
        let mut emission = vec![Vec3::ZERO; mesh.triangles.len()];
        let mut side = vec![EmitSide::Both; mesh.triangles.len()];
        for e in emitters {
            for (i, (t, l)) in e.triangles.iter().zip(&e.radiance).enumerate() {
                if let Some(slot) = emission.get_mut(*t as usize) {
                    *slot = Vec3::from(*l);
                    side[*t as usize] = e.side(i);
                }
            }
        }
        // Point sums per voxel, and observed points per (voxel, triangle): emitters' points
        // say nothing of the surfaces around them. Non-finite points are left out. The maps
        // fill on every thread, each voxel's points in their order (observed, then extra).
        let voxel = |&(p, t): &(Vec3, u32)| p.is_finite().then(|| key(p, t));
        let mut acc: PartedMap<Key, (Vec3, u32)> = PartedMap::new();
        let mut on_triangle: PartedMap<(Key, u32), u32> = PartedMap::new();
        let mut sum = |pts: &[(Vec3, u32)], seen: bool| {
            acc.add_all(
                pts,
                |_, pt| voxel(pt),
                |_| (Vec3::ZERO, 0),
                |e, _, &(p, _)| {
                    e.0 += p;
                    e.1 += 1;
                },
            );
            let unlit = |t: u32| emission.get(t as usize) == Some(&Vec3::ZERO);
            if seen {
                on_triangle.add_all(
                    pts,
                    |_, pt| voxel(pt).filter(|_| unlit(pt.1)).map(|k| (k, pt.1)),
                    |_| 0,
                    |n, _, _| *n += 1,
                );
            }
        };
        observed(&mut |pts| sum(pts, true));
        sum(extra, false);
        // Each voxel's point nearest its mean (the first such point).
        let mut nearest: PartedMap<Key, (f32, Vec3)> = PartedMap::new();
        let mut near = |pts: &[(Vec3, u32)]| {
            nearest.add_all(
                pts,
                |_, pt| voxel(pt),
                |&(p, _)| (f32::INFINITY, p),
                |e, _, &(p, t)| {
                    let (s, n) = acc.get(&key(p, t)).expect("every voxel is summed");
                    let d = p.distance_squared(*s / *n as f32);
                    if d < e.0 {
                        *e = (d, p);
                    }
                },
            )
        };
        observed(&mut near);
        near(extra);
        let mut keys: Vec<Key> = acc.iter().map(|(k, _)| *k).collect();
        keys.sort_unstable();
        let centers: Vec<Vec3> = keys
            .iter()
            .map(|k| nearest.get(k).expect("every voxel has a point").1)
            .collect();
        let mats = field.materials(&centers)?;
        let voxels = MaterialTable::new(keys.into_iter().zip(mats.iter().copied()));
        let mut per_tri = vec![MeanSurface::default(); mesh.triangles.len()];
        let mut votes: Vec<((Key, u32), u32)> = on_triangle.iter().map(|(k, n)| (*k, *n)).collect();
        votes.sort_unstable();
        for ((k, t), n) in votes {
            let m = voxels.get(&k).expect("every voted voxel is held");
            per_tri[t as usize].add(&to_surface(&m), n as f64);
        }
        let per_triangle = triangle_fallbacks(mesh, per_tri, || {
            let centroids: Vec<Vec3> = (0..mesh.triangles.len())
                .map(|t| mesh.vertices(t).iter().sum::<Vec3>() / 3.0)
                .collect();
            Ok(field
                .materials(&centroids)?
                .iter()
                .map(to_surface)
                .collect())
        })?;
        Ok(FieldSurfaces {
            cell,
            voxels,
            tri_facing,
            per_triangle,
            emission,
            side,
            model: ReflectanceModel::Fipt,
        })
    }

    /// As [`FieldSurfaces::build`], and also caches the field on the voxels of the rest of the
    /// mesh surface (points spread over every triangle at about one per `cell`², at most
    /// `max_fill` of them), so views of surfaces no input view saw still vary within a
    /// triangle. Voxels the observed points occupy keep exactly their value of `build`.
    pub fn build_covering(
        field: &dyn MaterialField,
        mesh: &Mesh,
        emitters: &[Emitter],
        observed: &[(Vec3, u32)],
        cell: f32,
        max_fill: usize,
    ) -> fipt_core::Result<Self> {
        let tri_facing = facings(mesh);
        let key = |p: Vec3, t: u32| voxel_key(p, cell, &tri_facing, t);
        let mut seen: PartedMap<Key, ()> = PartedMap::new();
        seen.add_all(
            observed,
            |_, &(p, t)| p.is_finite().then(|| key(p, t)),
            |_| (),
            |_, _, _| {},
        );
        let area: f64 = (0..mesh.triangles.len()).map(|t| mesh.area(t) as f64).sum();
        let spacing = (cell as f64).max((area / max_fill.max(1) as f64).sqrt());
        let mut fill = Vec::new();
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
                if !seen.contains(&key(p, t as u32)) {
                    fill.push((p, t as u32));
                }
            }
        }
        Self::build_with(field, mesh, emitters, observed, &fill, cell)
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
        match self
            .voxels
            .get(&voxel_key(p, self.cell, &self.tri_facing, tri))
        {
            Some(m) => to_surface(&m),
            None => self.per_triangle[tri as usize],
        }
    }
    #[inline]
    fn prefetch(&self, tri: u32, p: Vec3) {
        self.voxels
            .prefetch(&voxel_key(p, self.cell, &self.tri_facing, tri));
    }
    fn emission(&self, tri: u32) -> Rgb {
        self.emission[tri as usize]
    }
    fn emit_side(&self, tri: u32) -> EmitSide {
        self.side[tri as usize]
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
        // Points on triangle 0 while x + z < 1, then on triangle 1 (the emitter).
        let pts: Vec<(Vec3, u32)> = (0..100)
            .map(|i| Vec3::new(i as f32 / 100.0 + 0.005, 0.0, 0.3))
            .map(|p| (p, u32::from(p.x + p.z >= 1.0)))
            .collect();
        let em = Emitter {
            triangles: vec![1],
            radiance: vec![[2.0, 3.0, 4.0]],
            area: 0.5,
            mean_radiance: [2.0, 3.0, 4.0],
            power: [0.0; 3],
            centroid: [0.0; 3],
            pixels: 1,
            sides: Vec::new(),
        };
        let s = FieldSurfaces::build(&Ramp, &mesh, &[em], &pts, 0.05).unwrap();
        assert_eq!(s.voxels(), 20);
        for x in [0.02f32, 0.31, 0.77] {
            let sp = s.surface(0, Vec3::new(x, 0.0, 0.3));
            assert!((sp.kd.x - x).abs() <= 0.05, "x={x}: kd {}", sp.kd.x);
            assert_eq!(sp.ks, Vec3::splat(0.04));
        }
        // Off the observed points: the mean of the triangle's observed points (x 0.005 to
        // 0.695), not the field at its centroid (1/3).
        let off = s.surface(0, Vec3::new(0.2, 0.0, 0.9)).kd.x;
        assert!((off - 0.35).abs() < 1e-4, "fallback kd {off}");
        // Covering the mesh: observed voxels keep their value, the rest follow the field.
        let c = FieldSurfaces::build_covering(&Ramp, &mesh, &[], &pts, 0.05, 10_000).unwrap();
        let b = FieldSurfaces::build(&Ramp, &mesh, &[], &pts, 0.05).unwrap();
        assert!(c.voxels() > 200, "{} voxels", c.voxels());
        for (p, _) in &pts {
            assert_eq!(c.surface(0, *p), b.surface(0, *p));
        }
        let off = c.surface(0, Vec3::new(0.2, 0.0, 0.7)).kd.x;
        assert!((off - 0.2).abs() <= 0.05, "unobserved point: kd {off}");
        let e = s.surface(1, Vec3::new(0.9, 0.0, 0.9));
        assert_eq!(e.kd, Vec3::ZERO);
        assert_eq!(s.emission(1), Vec3::new(2.0, 3.0, 4.0));
        assert_eq!(s.emission(0), Vec3::ZERO);
    }

    /// The observed points handed in batches of any size (a view's hits at a time) build the
    /// surfaces one slice of all of them builds, voxel for voxel.
    #[test]
    fn batches_of_any_size_build_the_same_surfaces() {
        let mesh = Mesh::from_triangles(
            vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 0.0, 1.0)],
            None,
            vec![[0, 1, 2]],
        );
        // A scatter of points on the triangle, some repeated, one not finite.
        let mut pts: Vec<(Vec3, u32)> = (0..2000u32)
            .map(|i| {
                let u = (i as f32 * 0.618_034).fract() * 0.5;
                let v = (i as f32 * 0.414_214).fract() * 0.5;
                (Vec3::new(u, 0.0, v), 0)
            })
            .collect();
        pts.extend_from_within(0..300);
        pts.push((Vec3::NAN, 0));
        let whole = FieldSurfaces::build(&Ramp, &mesh, &[], &pts, 0.03).unwrap();
        for batch in [1, 7, 333] {
            let visit = |f: &mut PointSink| pts.chunks(batch).for_each(&mut *f);
            let s = FieldSurfaces::build_from(&Ramp, &mesh, &[], &visit, 0.03).unwrap();
            assert_eq!(s.voxels(), whole.voxels(), "batches of {batch}");
            for (p, _) in pts.iter().filter(|(p, _)| p.is_finite()) {
                assert_eq!(s.surface(0, *p), whole.surface(0, *p), "batches of {batch}");
            }
            let off = Vec3::new(0.9, 0.0, 0.05);
            assert_eq!(s.surface(0, off), whole.surface(0, off));
        }
    }

    /// A triangle no view saw takes the value of the observed triangles it shares a vertex
    /// with (even when the file repeats vertices per face); one connected to none of them
    /// takes the mean of every observed point; points on an emitter count for nothing.
    #[test]
    fn unseen_triangles_take_their_observed_neighbours_value() {
        let tri_at = |x0: f32| {
            [
                Vec3::new(x0, 0.0, 0.0),
                Vec3::new(x0 + 1.0, 0.0, 0.0),
                Vec3::new(x0 + 1.0, 0.0, 1.0),
            ]
        };
        // Triangles 0 and 1 touch at x = 1 (separate vertex copies); 2 is far away; 3 is an
        // emitter beside 0.
        let positions: Vec<Vec3> = [0.0, 1.0, 5.0, -1.0].into_iter().flat_map(tri_at).collect();
        let tris: Vec<[u32; 3]> = (0..4u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let mesh = Mesh::from_triangles(positions, None, tris);
        let em = Emitter {
            triangles: vec![3],
            radiance: vec![[1.0; 3]],
            area: 0.5,
            mean_radiance: [1.0; 3],
            power: [0.0; 3],
            centroid: [0.0; 3],
            pixels: 1,
            sides: Vec::new(),
        };
        let seen = [
            (Vec3::new(0.8, 0.0, 0.1), 0),
            (Vec3::new(-0.1, 0.0, 0.1), 3),
        ];
        let s = FieldSurfaces::build(&Ramp, &mesh, &[em], &seen, 0.05).unwrap();
        let far = |t: u32| s.surface(t, Vec3::new(9.0, 9.0, 9.0)).kd.x;
        let want = 0.8; // the field at the observed point
        assert!(
            (far(0) - want).abs() < 1e-5,
            "observed triangle: {}",
            far(0)
        );
        assert!((far(1) - want).abs() < 1e-5, "its neighbour: {}", far(1));
        assert!((far(2) - want).abs() < 1e-5, "disconnected: {}", far(2));
        // Nothing observed at all: the field at each centroid.
        let none = FieldSurfaces::build(&Ramp, &mesh, &[], &[], 0.05).unwrap();
        let c = none.surface(2, Vec3::splat(9.0)).kd.x;
        assert!((c - 1.0).abs() < 1e-6, "centroid x 5.67 clamps to 1: {c}");
    }

    /// 0.2 on the floor y = 0, 0.6 on the wall x = 0, 1 off both (where a network was never
    /// trained).
    struct Corner;
    impl MaterialField for Corner {
        fn name(&self) -> &str {
            "corner"
        }
        fn materials(&self, p: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
            let kd = |q: &Vec3| match (q.y.abs() < 1e-6, q.x.abs() < 1e-6) {
                (true, _) => 0.2,
                (_, true) => 0.6,
                _ => 1.0,
            };
            Ok(p.iter()
                .map(|q| Material {
                    albedo: Vec3::splat(kd(q)),
                    roughness: 1.0,
                    metallic: 0.0,
                })
                .collect())
        }
        fn emission_mask(&self, p: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
            Ok(vec![0.0; p.len()])
        }
    }

    /// A floor and a wall meeting in one voxel keep their own materials, asked at surface
    /// points (the mean of the voxel's points lies off both).
    #[test]
    fn a_corner_voxel_keeps_each_side_on_its_surface() {
        let mesh = Mesh::from_triangles(
            vec![
                Vec3::ZERO,
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            None,
            vec![[0, 2, 1], [0, 3, 2]],
        );
        let mut pts = Vec::new();
        for i in 0..5 {
            let a = 0.01 + 0.015 * i as f32;
            pts.push((Vec3::new(a, 0.0, 0.05), 0)); // floor
            pts.push((Vec3::new(0.0, a, 0.05), 1)); // wall
        }
        let s = FieldSurfaces::build(&Corner, &mesh, &[], &pts, 0.1).unwrap();
        assert_eq!(s.voxels(), 2, "one voxel, two sides");
        let p = Vec3::new(0.05, 0.0, 0.05);
        assert_eq!(s.surface(0, p).kd, Vec3::splat(0.2));
        assert_eq!(
            s.surface(1, Vec3::new(0.0, 0.05, 0.05)).kd,
            Vec3::splat(0.6)
        );
    }
}
