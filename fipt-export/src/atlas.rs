//! A texture atlas of a triangle mesh: one chart per connected planar region (triangles
//! sharing an edge whose normals agree within about 1°), each chart projected onto its plane
//! at a uniform texel size and packed on shelves, with a gutter of `PAD` texels.
use fipt_geom::Mesh;
use glam::{Vec2, Vec3};

/// Gutter texels around each chart (filled by dilation, so bilinear lookups at chart edges
/// never read another chart).
pub const PAD: u32 = 2;

/// Normals of one planar region agree to within this cosine (≈ 1.1°).
const COPLANAR_COS: f32 = 0.9998;

/// One chart: a planar region of triangles and its place in the atlas.
#[derive(Clone, Debug)]
pub struct Chart {
    pub triangles: Vec<u32>,
    /// Plane basis: point p = origin + x·u + y·v.
    pub origin: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    /// Lower corner of the chart's 2-D bounds (plane coordinates).
    pub min: Vec2,
    /// Texel rectangle in the atlas (gutter included): corner and size.
    pub texel: [u32; 2],
    pub size: [u32; 2],
}

/// A packed atlas.
#[derive(Clone, Debug)]
pub struct Atlas {
    pub width: u32,
    pub height: u32,
    /// World size of a texel's edge.
    pub texel_size: f32,
    pub charts: Vec<Chart>,
    /// Per mesh triangle: its chart (None: excluded).
    pub chart_of: Vec<Option<u32>>,
}

/// Why an atlas could not be made.
#[derive(Clone, Debug, PartialEq)]
pub struct TooLarge {
    pub charts: usize,
    pub max_size: u32,
}

fn plane_basis(n: Vec3) -> (Vec3, Vec3) {
    let a = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let u = n.cross(a).normalize();
    (u, n.cross(u))
}

/// Connected planar regions of the included triangles.
pub fn planar_regions(mesh: &Mesh, include: &[bool]) -> Vec<Vec<u32>> {
    let neighbours = mesh.edge_neighbours();
    let normals: Vec<Vec3> = (0..mesh.triangles.len())
        .map(|t| mesh.face_normal(t))
        .collect();
    let mut region = vec![u32::MAX; mesh.triangles.len()];
    let mut out = Vec::new();
    for seed in 0..mesh.triangles.len() {
        if !include[seed] || region[seed] != u32::MAX {
            continue;
        }
        let r = out.len() as u32;
        let n0 = normals[seed];
        let mut members = vec![seed as u32];
        region[seed] = r;
        let mut k = 0;
        while k < members.len() {
            let t = members[k] as usize;
            k += 1;
            for &o in &neighbours[t] {
                let o = o as usize;
                if include[o] && region[o] == u32::MAX && normals[o].dot(n0) > COPLANAR_COS {
                    region[o] = r;
                    members.push(o as u32);
                }
            }
        }
        out.push(members);
    }
    out
}

/// Charts of `regions` at texel size `s`, unplaced.
fn charts(mesh: &Mesh, regions: Vec<Vec<u32>>, s: f32) -> Vec<Chart> {
    regions
        .into_iter()
        .map(|tris| {
            let n = mesh.face_normal(tris[0] as usize);
            let (u, v) = plane_basis(n);
            let origin = mesh.vertices(tris[0] as usize)[0];
            let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
            for &t in &tris {
                for p in mesh.vertices(t as usize) {
                    let q = Vec2::new((p - origin).dot(u), (p - origin).dot(v));
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
            }
            let ext = ((hi - lo) / s).ceil();
            Chart {
                triangles: tris,
                origin,
                u,
                v,
                min: lo,
                texel: [0, 0],
                size: [ext.x as u32 + 1 + 2 * PAD, ext.y as u32 + 1 + 2 * PAD],
            }
        })
        .collect()
}

/// Shelf packing into `width` columns; returns the height used.
fn pack(charts: &mut [Chart], width: u32) -> Option<u32> {
    let mut order: Vec<usize> = (0..charts.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse((charts[i].size[1], charts[i].size[0])));
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    for i in order {
        let [w, h] = charts[i].size;
        if w > width {
            return None;
        }
        if x + w > width {
            y += shelf;
            x = 0;
            shelf = 0;
        }
        charts[i].texel = [x, y];
        x += w;
        shelf = shelf.max(h);
    }
    Some(y + shelf)
}

impl Atlas {
    /// Builds an atlas of the `include`d triangles with texels of about `texel_size` (grown
    /// by 25 % steps until the atlas fits in `max_size`²).
    pub fn build(
        mesh: &Mesh,
        include: &[bool],
        texel_size: f32,
        max_size: u32,
    ) -> Result<Atlas, TooLarge> {
        let regions = planar_regions(mesh, include);
        let floor_charts = (regions.len() as f64) * ((1 + 2 * PAD) as f64).powi(2);
        if floor_charts > (max_size as f64).powi(2) * 0.8 {
            return Err(TooLarge {
                charts: regions.len(),
                max_size,
            });
        }
        let mut s = texel_size.max(1e-6);
        for _ in 0..80 {
            let mut cs = charts(mesh, regions.clone(), s);
            let texels: u64 = cs.iter().map(|c| c.size[0] as u64 * c.size[1] as u64).sum();
            let width = ((texels as f64 * 1.15).sqrt().ceil() as u32)
                .next_power_of_two()
                .clamp(64, max_size);
            if let Some(h) = pack(&mut cs, width) {
                if h <= max_size {
                    let mut chart_of = vec![None; mesh.triangles.len()];
                    for (c, ch) in cs.iter().enumerate() {
                        for &t in &ch.triangles {
                            chart_of[t as usize] = Some(c as u32);
                        }
                    }
                    return Ok(Atlas {
                        width,
                        height: h.div_ceil(4) * 4,
                        texel_size: s,
                        charts: cs,
                        chart_of,
                    });
                }
            }
            s *= 1.25;
        }
        Err(TooLarge {
            charts: regions.len(),
            max_size,
        })
    }

    /// Plane coordinates of world point `p` in chart `c`.
    pub fn plane(&self, c: usize, p: Vec3) -> Vec2 {
        let ch = &self.charts[c];
        Vec2::new((p - ch.origin).dot(ch.u), (p - ch.origin).dot(ch.v))
    }

    /// Texel coordinates (continuous, texel centres at k + 0.5) of `p` in chart `c`.
    pub fn texel_coords(&self, c: usize, p: Vec3) -> Vec2 {
        let ch = &self.charts[c];
        let q = (self.plane(c, p) - ch.min) / self.texel_size;
        Vec2::new(
            ch.texel[0] as f32 + PAD as f32 + 0.5 + q.x,
            ch.texel[1] as f32 + PAD as f32 + 0.5 + q.y,
        )
    }

    /// glTF / OBJ texture coordinates in [0, 1] of `p` in chart `c` (v down, as glTF).
    pub fn uv(&self, c: usize, p: Vec3) -> Vec2 {
        self.texel_coords(c, p) / Vec2::new(self.width as f32, self.height as f32)
    }

    /// The world point at continuous texel coordinates `tc` of chart `c` (the inverse of
    /// [`Atlas::texel_coords`] on the chart's plane).
    pub fn point_at(&self, c: usize, tc: Vec2) -> Vec3 {
        let ch = &self.charts[c];
        let corner =
            Vec2::new(ch.texel[0] as f32, ch.texel[1] as f32) + Vec2::splat(PAD as f32 + 0.5);
        let q = ch.min + (tc - corner) * self.texel_size;
        ch.origin + ch.u * q.x + ch.v * q.y
    }

    /// The world point at the centre of texel (x, y) of chart `c`.
    pub fn texel_point(&self, c: usize, x: u32, y: u32) -> Vec3 {
        let ch = &self.charts[c];
        let q = ch.min
            + Vec2::new(
                x as f32 - ch.texel[0] as f32 - PAD as f32,
                y as f32 - ch.texel[1] as f32 - PAD as f32,
            ) * self.texel_size;
        ch.origin + ch.u * q.x + ch.v * q.y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube (12 triangles, 6 faces) and a fan-tessellated square.
    fn cube() -> Mesh {
        let p: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let tris = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        Mesh::from_triangles(p, None, tris)
    }

    #[test]
    fn a_cube_gives_six_charts_that_do_not_overlap() {
        let m = cube();
        let a = Atlas::build(&m, &[true; 12], 0.05, 1024).unwrap();
        assert_eq!(a.charts.len(), 6);
        assert!(a.charts.iter().all(|c| c.triangles.len() == 2));
        for (i, c) in a.charts.iter().enumerate() {
            assert!(c.texel[0] + c.size[0] <= a.width && c.texel[1] + c.size[1] <= a.height);
            for d in &a.charts[i + 1..] {
                let apart = c.texel[0] + c.size[0] <= d.texel[0]
                    || d.texel[0] + d.size[0] <= c.texel[0]
                    || c.texel[1] + c.size[1] <= d.texel[1]
                    || d.texel[1] + d.size[1] <= c.texel[1];
                assert!(apart, "{c:?} overlaps {d:?}");
            }
        }
        // Texel centres map back to the plane points they came from.
        let p = Vec3::new(0.3, 0.0, 0.7);
        let t = a.chart_of[4].unwrap() as usize;
        let tc = a.texel_coords(t, p);
        let back = a.texel_point(t, (tc.x - 0.5) as u32, (tc.y - 0.5) as u32);
        assert!((back - p).length() <= 0.05 * 1.5, "{back} vs {p}");
    }

    #[test]
    fn excluded_triangles_get_no_chart_and_tiny_budgets_grow_the_texels() {
        let m = cube();
        let mut inc = [true; 12];
        inc[0] = false;
        let a = Atlas::build(&m, &inc, 0.001, 128).unwrap();
        assert_eq!(a.chart_of[0], None);
        assert!(a.texel_size > 0.001 && a.width <= 128 && a.height <= 128);
        assert_eq!(a.charts.len(), 6);
        assert_eq!(a.charts[a.chart_of[1].unwrap() as usize].triangles, [1]);
    }
}
