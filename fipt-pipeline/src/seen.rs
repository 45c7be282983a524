//! Materials where the training views did not look.
//!
//! A field fitted to the training views is only pinned on the surfaces those views saw; on the
//! rest (the side of a table no view faced, the strip of ceiling above a window) a hash-grid
//! field returns whatever its coarse levels and hash collisions give, and the maps and the
//! re-render showed it: `kitchen`'s ceiling above its window read σ 0.5 for a true 0.95, the
//! table's unseen side kd and σ of no surface in the room. [`SeenField`] wraps the run's field:
//! at a point whose surface cell no training pixel saw, the material is its triangle's as seen
//! (the mean of the field over the triangle's cells seen at least [`SEEN_COUNT`] times,
//! weighted by their counts), in each of albedo, σ and metallic whose spread over those cells
//! is within [`UNIFORM_SPREAD`] (a textured triangle keeps the field's albedo; σ and metallic
//! are always filled). A triangle
//! with no such cell takes the mean of its neighbours' (sharing a vertex, spread outwards
//! from the seen triangles); one that no seen triangle reaches keeps the field, as does every
//! cell a training pixel saw. The maps, the re-render, `fipt render`, `fipt eval
//! --cameras-from` and `fipt export` all read the field through it.
use crate::error::{Context, Result};
use fipt_core::field::{Material, MaterialField};
use fipt_geom::nearest::TriangleLocator;
use fipt_geom::Mesh;
use fipt_search::CellCounts;
use fipt_shading::records::HitPoint;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Training pixels in a surface cell ([`crate::fit::OBSERVED_CELL_FOOTPRINTS`] footprints
/// wide) from which the cell counts towards its triangle's seen material (the `observed` maps
/// and `fipt eval`'s observed pixels use the same count).
pub const SEEN_COUNT: u32 = 8;

/// Cells seen fewer times than this are blended towards the seen material, in proportion:
/// 1, only cells no training pixel saw (with 8 and no spread gate, `studio-mitsuba`'s checker
/// floor lost 0.4 dB more of its kd than with 1; `kitchen` gained the same either way).
pub const FILL_BELOW: u32 = 1;

/// Changes when what [`SeenField`] does changes (re-renders made before are made again).
pub const VERSION: &str = "seen-3";

/// The run's field with unseen surfaces filled from the seen ones (see the module).
pub struct SeenField<'a> {
    inner: &'a dyn MaterialField,
    counts: CellCounts,
    locator: TriangleLocator,
    /// Each triangle's seen material (None: no seen triangle reaches it).
    per_triangle: Vec<Option<Seen>>,
    /// Triangles with seen cells, and those filled from neighbours.
    pub seen_triangles: usize,
    pub filled_triangles: usize,
}

/// The spread (standard deviation, in the component's own units) of albedo, σ and metallic
/// over a triangle's well-seen cells up to which their mean stands for the unseen rest; above
/// it the field is kept for that component. Albedo: 0.15, so that a texture keeps the field
/// (`studio-mitsuba`'s checker floor, 0.72 / 0.20, spreads 0.25: a mean colour is wrong on
/// every tile, and there it cost the floor 1.4 dB of kd against the field's extrapolation),
/// while a surface the field reads unevenly is filled (`kitchen`'s ceiling, `bedroom`'s plank
/// floor: 0.05 refused both, 8.5 and 3.8 dB of their kd). σ and metallic: no limit
/// (`bedroom`'s floor σ 18.6 → 20.8 dB with none, unchanged with 0.05); the field's σ where no
/// view looked was no better than the seen mean on any room measured
/// (`docs/unseen-surfaces.md`).
pub const UNIFORM_SPREAD: [f32; 3] = [0.15, f32::INFINITY, f32::INFINITY];

/// A triangle's material as seen, and for albedo, σ and metallic whether it is uniform
/// enough ([`UNIFORM_SPREAD`]) to fill with.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Seen {
    material: Material,
    uniform: [bool; 3],
}

/// A running mean (and spread) of materials.
#[derive(Clone, Copy, Default)]
struct MeanMaterial {
    albedo: Vec3,
    albedo_sq: Vec3,
    roughness: [f64; 2],
    metallic: [f64; 2],
    weight: f64,
    /// For means of [`Seen`]s: whether every one was uniform, per component.
    not_uniform: [bool; 3],
}

impl MeanMaterial {
    fn add(&mut self, m: &Material, w: f64) {
        self.albedo += m.albedo * w as f32;
        self.albedo_sq += m.albedo * m.albedo * w as f32;
        let (r, k) = (m.roughness as f64, m.metallic as f64);
        self.roughness = [self.roughness[0] + r * w, self.roughness[1] + r * r * w];
        self.metallic = [self.metallic[0] + k * w, self.metallic[1] + k * k * w];
        self.weight += w;
    }
    fn add_seen(&mut self, s: &Seen) {
        self.add(&s.material, 1.0);
        for (n, u) in self.not_uniform.iter_mut().zip(s.uniform) {
            *n |= !u;
        }
    }
    fn mean(&self) -> Option<Material> {
        (self.weight > 0.0).then(|| Material {
            albedo: self.albedo / self.weight as f32,
            roughness: (self.roughness[0] / self.weight) as f32,
            metallic: (self.metallic[0] / self.weight) as f32,
        })
    }
    /// The mean and, per component, whether its spread is within [`UNIFORM_SPREAD`].
    fn seen(&self) -> Option<Seen> {
        let m = self.mean()?;
        let w = self.weight;
        let var = |s: [f64; 2]| ((s[1] / w - (s[0] / w).powi(2)).max(0.0)).sqrt() as f32;
        let a = (self.albedo_sq / w as f32 - m.albedo * m.albedo).max(Vec3::ZERO);
        let spread = [
            a.max_element().sqrt(),
            var(self.roughness),
            var(self.metallic),
        ];
        let mut uniform = [0, 1, 2].map(|i| spread[i] <= UNIFORM_SPREAD[i]);
        for (u, n) in uniform.iter_mut().zip(self.not_uniform) {
            *u &= !n;
        }
        Some(Seen {
            material: m,
            uniform,
        })
    }
}

impl<'a> SeenField<'a> {
    /// `inner` filled where `hits` (the training views' primary hits) are fewer than
    /// [`FILL_BELOW`] in a cell of `counts`, from the cells holding [`SEEN_COUNT`] or more.
    pub fn new(
        inner: &'a dyn MaterialField,
        mesh: &Mesh,
        hits: &[Vec<Option<HitPoint>>],
        counts: CellCounts,
    ) -> Result<Self> {
        // One point per (cell, triangle) of the well-seen cells, weighted by the cell's count.
        // Views in parallel, each deduplicated, then merged in view order.
        let per_view: Vec<HashMap<([i32; 3], u32), (Vec3, u32)>> = hits
            .par_iter()
            .map(|view| {
                let mut first = HashMap::new();
                for h in view.iter().flatten() {
                    let n = counts.count(h.p);
                    if n >= SEEN_COUNT {
                        first.entry((counts.cell(h.p), h.tri())).or_insert((h.p, n));
                    }
                }
                first
            })
            .collect();
        let mut first: HashMap<([i32; 3], u32), (Vec3, u32)> = HashMap::new();
        for view in per_view {
            for (k, v) in view {
                first.entry(k).or_insert(v);
            }
        }
        let mut points: Vec<(Vec3, u32, u32)> = first
            .into_iter()
            .map(|((_, t), (p, n))| (p, t, n))
            .collect();
        // Deterministic order (the map's is not): by triangle, then position.
        points.sort_unstable_by(|a, b| {
            (a.1, a.0.x, a.0.y, a.0.z)
                .partial_cmp(&(b.1, b.0.x, b.0.y, b.0.z))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let at: Vec<Vec3> = points.iter().map(|q| q.0).collect();
        let mats = inner
            .materials(&at)
            .context("querying the field on the seen surfaces")?;
        let mut sums = vec![MeanMaterial::default(); mesh.triangles.len()];
        for (q, m) in points.iter().zip(&mats) {
            if let Some(s) = sums.get_mut(q.1 as usize) {
                s.add(m, q.2 as f64);
            }
        }
        let mut per_triangle: Vec<Option<Seen>> = sums.iter().map(|s| s.seen()).collect();
        let seen_triangles = per_triangle.iter().filter(|m| m.is_some()).count();
        let filled_triangles = spread(mesh, &mut per_triangle);
        Ok(SeenField {
            inner,
            counts,
            locator: TriangleLocator::new(mesh),
            per_triangle,
            seen_triangles,
            filled_triangles,
        })
    }

    /// [`SeenField::new`] over the training views' `hits` with the `observed` maps' cells
    /// (their median pixel `footprint`): what `fipt render` and `fipt export` read a run's
    /// field through ([`crate::recovered::TracedViews::seen`]).
    pub fn with_footprint(
        inner: &'a dyn MaterialField,
        mesh: &Mesh,
        hits: &[Vec<Option<HitPoint>>],
        footprint: Option<f32>,
    ) -> Result<Self> {
        let cell = crate::fit::OBSERVED_CELL_FOOTPRINTS * footprint.unwrap_or(0.01);
        let counts = CellCounts::new(hits.iter().flatten().flatten().map(|h| h.p), cell);
        Self::new(inner, mesh, hits, counts)
    }

    /// Says what was filled.
    pub fn note(&self) {
        crate::note!(
            "unseen surfaces: where no training pixel saw a cell, its triangle's material as seen (its albedo only where the triangle reads uniform; {} triangles seen, {} filled from their neighbours)",
            self.seen_triangles,
            self.filled_triangles
        );
    }

    /// Training pixels per surface cell, as the fill read them (the `observed` maps' counts).
    pub fn counts(&self) -> &CellCounts {
        &self.counts
    }

    /// The share of `points` the field is taken at as it is (their cells well seen).
    pub fn seen_share(&self, points: &[Vec3]) -> f64 {
        let n = points
            .iter()
            .filter(|&&p| self.counts.count(p) >= SEEN_COUNT)
            .count();
        n as f64 / points.len().max(1) as f64
    }
}

/// Fills the triangles without a material from their neighbours' (sharing a vertex): the
/// mean, uniform where every neighbour was; returns how many were filled.
fn spread(mesh: &Mesh, value: &mut [Option<Seen>]) -> usize {
    mesh.spread_to_neighbours(value, |near| {
        let mut m = MeanMaterial::default();
        for v in near {
            m.add_seen(v);
        }
        let mut s = m.seen()?;
        // The spread between neighbours' means is not a texture's: only theirs counts.
        s.uniform = m.not_uniform.map(|n| !n);
        Some(s)
    })
}

/// `a` moved towards `b` by `t` ∈ [0, 1], in the components `b` is uniform in.
fn blend(a: &Material, b: &Seen, t: f32) -> Material {
    let [ka, kr, km] = b.uniform.map(|u| if u { t } else { 0.0 });
    let m = &b.material;
    Material {
        albedo: a.albedo + (m.albedo - a.albedo) * ka,
        roughness: a.roughness + (m.roughness - a.roughness) * kr,
        metallic: a.metallic + (m.metallic - a.metallic) * km,
    }
}

impl MaterialField for SeenField<'_> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn materials(&self, points: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        let mut mats = self.inner.materials(points)?;
        for (p, m) in points.iter().zip(mats.iter_mut()) {
            let n = self.counts.count(*p);
            if n >= FILL_BELOW {
                continue;
            }
            let seen = (self.locator.nearest(*p))
                .and_then(|t| self.per_triangle.get(t as usize).copied().flatten());
            if let Some(s) = seen {
                *m = blend(m, &s, 1.0 - n as f32 / FILL_BELOW as f32);
            }
        }
        Ok(mats)
    }

    fn emission_mask(&self, points: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        self.inner.emission_mask(points)
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        self.inner.as_any()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// σ 0.3 on the first square (x < 1) and 1 elsewhere; an albedo of stripes 0.1 wide
    /// (0.2 / 0.8, a texture); no metal.
    struct Field;
    impl MaterialField for Field {
        fn name(&self) -> &str {
            "test"
        }
        fn materials(&self, points: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
            Ok(points
                .iter()
                .map(|p| Material {
                    albedo: Vec3::splat(if (p.x * 10.0) as i32 % 2 == 0 {
                        0.2
                    } else {
                        0.8
                    }),
                    roughness: if p.x < 1.0 { 0.3 } else { 1.0 },
                    metallic: 0.0,
                })
                .collect())
        }
        fn emission_mask(&self, points: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
            Ok(vec![0.0; points.len()])
        }
    }

    /// Two unit squares side by side in z = 0 (x ∈ [0, 1] and [1, 2], sharing an edge) and a
    /// third apart (x ∈ [5, 6]); 2 triangles each.
    fn mesh() -> Mesh {
        let mut positions = vec![];
        let mut triangles = vec![];
        for x0 in [0.0f32, 1.0, 5.0] {
            let b = positions.len() as u32;
            positions.extend([
                Vec3::new(x0, 0.0, 0.0),
                Vec3::new(x0 + 1.0, 0.0, 0.0),
                Vec3::new(x0 + 1.0, 1.0, 0.0),
                Vec3::new(x0, 1.0, 0.0),
            ]);
            triangles.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
        }
        Mesh::from_triangles(positions, None, triangles)
    }

    /// Hits on the first square only: a 20 × 20 grid, each point seen `k` times.
    fn hits(k: usize) -> Vec<Vec<Option<HitPoint>>> {
        let mut v = vec![];
        for i in 0..20 {
            for j in 0..20 {
                let p = Vec3::new((i as f32 + 0.5) / 20.0, (j as f32 + 0.5) / 20.0, 0.0);
                let tri = if p.y <= p.x { 0 } else { 1 };
                for _ in 0..k {
                    v.push(Some(HitPoint::new(p, tri)));
                }
            }
        }
        vec![v]
    }

    #[test]
    fn unseen_surfaces_take_the_seen_finish_and_keep_the_field_where_it_varies() {
        let m = mesh();
        let h = hits(8);
        let counts = CellCounts::new(h.iter().flatten().flatten().map(|r| r.p), 0.1);
        let f = SeenField::new(&Field, &m, &h, counts).unwrap();
        assert_eq!(f.seen_triangles, 2);
        // The second square shares vertices with the first: filled; the third does not.
        assert_eq!(f.filled_triangles, 2);
        let pts = [
            Vec3::new(0.33, 0.2, 0.0),
            Vec3::new(1.55, 0.5, 0.0),
            Vec3::new(5.5, 0.5, 0.0),
        ];
        let field = Field.materials(&pts).unwrap();
        let got = f.materials(&pts).unwrap();
        // Seen: exactly the field.
        assert_eq!(got[0], field[0]);
        // Unseen beside the seen square: its uniform σ (0.3), not the field's 1; its
        // striped albedo is not uniform, so the field's is kept.
        assert!((got[1].roughness - 0.3).abs() < 1e-5, "{:?}", got[1]);
        assert_eq!(got[1].albedo, field[1].albedo);
        // Unreachable: the field.
        assert_eq!(got[2], field[2]);
        assert!((f.seen_share(&pts) - 1.0 / 3.0).abs() < 1e-9);
    }

    #[test]
    fn nothing_well_seen_leaves_the_field_and_a_blend_moves_only_uniform_components() {
        let m = mesh();
        let h = hits(2);
        // Cells of 0.05 hold 2 points: nothing well seen, nothing to fill from.
        let thin = CellCounts::new(h.iter().flatten().flatten().map(|r| r.p), 0.05);
        let g = SeenField::new(&Field, &m, &h, thin).unwrap();
        assert_eq!((g.seen_triangles, g.filled_triangles), (0, 0));
        let p = [Vec3::new(1.5, 0.1, 0.0)];
        assert_eq!(g.materials(&p).unwrap(), Field.materials(&p).unwrap());
        let a = Material {
            albedo: Vec3::ZERO,
            roughness: 0.8,
            metallic: 0.0,
        };
        let b = Seen {
            material: Material {
                albedo: Vec3::ONE,
                roughness: 0.5,
                metallic: 1.0,
            },
            uniform: [false, true, true],
        };
        let c = blend(&a, &b, 0.5);
        assert_eq!(c.albedo, Vec3::ZERO);
        assert!((c.roughness - 0.65).abs() < 1e-6 && (c.metallic - 0.5).abs() < 1e-6);
    }

    #[test]
    fn only_a_texture_keeps_the_field_albedo_and_sigma_is_always_filled() {
        let seen_of = |albedos: [f32; 2], sigmas: [f32; 2]| {
            let mut m = MeanMaterial::default();
            for (a, r) in albedos.into_iter().zip(sigmas) {
                let mat = Material {
                    albedo: Vec3::splat(a),
                    roughness: r,
                    metallic: 0.0,
                };
                m.add(&mat, 1.0);
            }
            m.seen().unwrap()
        };
        // Read unevenly (spread 0.1): filled. A checker of 0.72 / 0.20 (spread 0.26): kept.
        assert_eq!(seen_of([0.4, 0.6], [0.3, 0.3]).uniform, [true; 3]);
        assert_eq!(
            seen_of([0.2, 0.72], [0.3, 0.3]).uniform,
            [false, true, true]
        );
        // Two finishes (0.2 / 0.6): σ filled with their mean all the same.
        let s = seen_of([0.5, 0.5], [0.2, 0.6]);
        assert!(s.uniform[1] && (s.material.roughness - 0.4).abs() < 1e-6);
    }
}
