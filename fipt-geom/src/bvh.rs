//! Ray queries on a mesh: an obvhs CWBVH with fipt's hit record and robust ray offsets.
use crate::mesh::Mesh;
use glam::Vec3;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

/// A closest hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Index of the triangle in [`Mesh::triangles`].
    pub tri: u32,
    /// Barycentric weights of vertices 1 and 2 (vertex 0 gets `1 − u − v`).
    pub u: f32,
    pub v: f32,
    /// Unit geometric normal from the stored winding (not flipped towards the ray).
    pub ng: Vec3,
}

/// BVH build quality presets (see obvhs's `BvhBuildParams`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildQuality {
    /// Fastest build, slower traversal (interactive edits, tests).
    Fast,
    /// The default: good traversal for a small build cost.
    #[default]
    Medium,
    /// Spatial pre-splits; best traversal, slowest build.
    Slow,
}

impl BuildQuality {
    pub const fn params(self) -> BvhBuildParams {
        match self {
            BuildQuality::Fast => BvhBuildParams::fast_build(),
            BuildQuality::Medium => BvhBuildParams::medium_build(),
            BuildQuality::Slow => BvhBuildParams::slow_build(),
        }
    }
}

/// A BVH over a mesh's triangles, safe to query from many threads.
///
/// obvhs's wide-node test ignores boxes closer than an absolute 1e-4 along the ray, which
/// would make hits within 0.1 mm of a ray origin disappear in a scene in metres (and whole
/// scenes in small units). The BVH therefore lives in a space scaled by a power of two
/// (exact in floating point) so that the scene's largest coordinate is about 1024: the blind
/// zone becomes ~1e-7 of the scene's extent. Callers never see the scaled space.
pub struct Bvh {
    bvh: CwBvh,
    /// World → BVH space scale (a power of two) and its inverse.
    scale: f32,
    inv_scale: f32,
    /// Triangles in BVH primitive order (one per primitive reference).
    tris: Vec<Triangle>,
    /// Mesh triangle index of each BVH primitive.
    prim_tri: Vec<u32>,
}

/// Möller–Trumbore returning (t, u, v) with u, v the weights of v1, v2; t = ∞ on a miss.
#[inline(always)]
fn intersect_uv(tri: &Triangle, ray: &Ray) -> (f32, f32, f32) {
    let e1 = tri.v1 - tri.v0;
    let e2 = tri.v2 - tri.v0;
    let p = ray.direction.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return (f32::INFINITY, 0.0, 0.0);
    }
    let inv = 1.0 / det;
    let s = ray.origin - tri.v0;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = ray.direction.dot(q) * inv;
    let t = e2.dot(q) * inv;
    if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > ray.tmin && t < ray.tmax {
        (t, u, v)
    } else {
        (f32::INFINITY, 0.0, 0.0)
    }
}

impl Bvh {
    /// Builds the BVH (parallel with rayon).
    pub fn build(mesh: &Mesh, quality: BuildQuality) -> Bvh {
        let bounds = mesh.bounds();
        let extent = bounds.min.abs().max(bounds.max.abs()).max_element();
        let scale = if extent.is_finite() && extent > 0.0 {
            2f32.powi((1024.0 / extent).log2().floor().clamp(-100.0, 100.0) as i32)
        } else {
            1.0
        };
        let src: Vec<Triangle> = (0..mesh.triangles.len())
            .map(|i| {
                let [a, b, c] = mesh.vertices(i).map(|v| v * scale);
                Triangle {
                    v0: a.into(),
                    v1: b.into(),
                    v2: c.into(),
                }
            })
            .collect();
        let mut t = std::time::Duration::default();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&src, quality.params(), &mut t);
        let prim_tri = bvh.primitive_indices.clone();
        let tris = prim_tri.iter().map(|&i| src[i as usize]).collect();
        Bvh {
            bvh,
            scale,
            inv_scale: 1.0 / scale,
            tris,
            prim_tri,
        }
    }

    /// [`offset_ray_origin`] applied in the BVH's scaled space, so that offsets are relative
    /// to the scene's extent (a scene modelled in micrometres behaves like one in metres).
    #[inline]
    pub fn offset(&self, p: Vec3, n: Vec3) -> Vec3 {
        offset_ray_origin(p * self.scale, n) * self.inv_scale
    }

    /// Number of primitive references (≥ triangles when pre-splitting).
    pub fn num_primitives(&self) -> usize {
        self.prim_tri.len()
    }

    /// Closest hit along `origin + t·dir` for t in (tmin, tmax); `dir` must be unit length.
    #[inline]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let tmax_s = tmax * self.scale;
        let ray = Ray::new(
            (origin * self.scale).into(),
            plus_zero(dir).into(),
            tmin * self.scale,
            tmax_s,
        );
        let mut rh = RayHit::none();
        let mut best = (f32::INFINITY, 0.0f32, 0.0f32);
        self.bvh.ray_traverse(ray, &mut rh, |r, id| {
            let (t, u, v) = intersect_uv(&self.tris[id], r);
            if t < best.0 {
                best = (t, u, v);
            }
            t
        });
        if rh.t >= tmax_s || rh.primitive_id == obvhs::ray::INVALID_ID {
            return None;
        }
        let tri = &self.tris[rh.primitive_id as usize];
        let ng = Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0).normalize_or_zero());
        Some(Hit {
            t: best.0 * self.inv_scale,
            tri: self.prim_tri[rh.primitive_id as usize],
            u: best.1,
            v: best.2,
            ng,
        })
    }

    /// True when anything lies on `origin + t·dir` for t in (0, tmax).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let ray = Ray::new(
            (origin * self.scale).into(),
            plus_zero(dir).into(),
            0.0,
            tmax * self.scale,
        );
        !self
            .bvh
            .ray_traverse_miss(ray, |r, id| intersect_uv(&self.tris[id], r).0)
    }

    /// Closest hits of many rays `(origin, dir)` in parallel (rayon, chunks of 256).
    pub fn closest_hits(&self, rays: &[(Vec3, Vec3)]) -> Vec<Option<Hit>> {
        let mut out = vec![None; rays.len()];
        out.par_chunks_mut(256)
            .zip(rays.par_chunks(256))
            .for_each(|(o, r)| {
                for (h, &(org, dir)) in o.iter_mut().zip(r) {
                    *h = self.closest_hit(org, dir, 0.0, f32::INFINITY);
                }
            });
        out
    }

    /// obvhs's own traversal and intersection with no hit record (benchmark baseline):
    /// returns the distance or ∞.
    #[inline]
    pub fn bare_traverse(&self, origin: Vec3, dir: Vec3) -> f32 {
        let ray = Ray::new_inf((origin * self.scale).into(), plus_zero(dir).into());
        let mut rh = RayHit::none();
        self.bvh
            .ray_traverse(ray, &mut rh, |r, id| self.tris[id].intersect(r));
        rh.t * self.inv_scale
    }
}

/// Turns −0.0 components into +0.0: obvhs 0.4's traversal misses every hit of a ray whose
/// direction has a negative-zero component (e.g. `-Vec3::Z`).
#[inline(always)]
fn plus_zero(d: Vec3) -> Vec3 {
    d + Vec3::ZERO
}

/// Hit point from barycentrics (more accurate than `o + t·d` far from the origin).
#[inline]
pub fn hit_point(mesh: &Mesh, hit: &Hit) -> Vec3 {
    let [a, b, c] = mesh.vertices(hit.tri as usize);
    a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v
}

/// Interpolated shading normal at a hit (the geometric normal when the mesh has no normals),
/// on the same side as the geometric normal.
#[inline]
pub fn shading_normal(mesh: &Mesh, hit: &Hit) -> Vec3 {
    match &mesh.normals {
        Some(ns) => {
            let t = mesh.triangles[hit.tri as usize];
            let n = ns[t[0] as usize] * (1.0 - hit.u - hit.v)
                + ns[t[1] as usize] * hit.u
                + ns[t[2] as usize] * hit.v;
            let n = n.normalize_or_zero();
            if n == Vec3::ZERO {
                hit.ng
            } else if n.dot(hit.ng) < 0.0 {
                -n
            } else {
                n
            }
        }
        None => hit.ng,
    }
}

/// Moves a surface point off its surface along `n` (the side the new ray leaves from) by a few
/// floating-point ulps scaled with the point's magnitude, after Wächter & Binder
/// ("A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, 2019).
/// Rays then start at t = 0 with no epsilon: no acne at grazing angles, no leaks through thin
/// walls.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let of = |pc: f32, nc: f32| -> f32 {
        let oi = (INT_SCALE * nc) as i32;
        let bits = pc.to_bits() as i32;
        let moved = f32::from_bits((if pc < 0.0 { bits - oi } else { bits + oi }) as u32);
        if pc.abs() < ORIGIN {
            pc + FLOAT_SCALE * nc
        } else {
            moved
        }
    };
    Vec3::new(of(p.x, n.x), of(p.y, n.y), of(p.z, n.z))
}
