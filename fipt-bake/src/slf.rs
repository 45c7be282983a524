//! The surface light field (SLF, method §4.1): a sparse voxel grid over the scene holding the
//! mean HDR radiance of the training pixels whose primary hit falls in each voxel. It stands in
//! for the incident radiance at secondary hits during the initial bake.
use fipt_core::color::Rgb;
use glam::{DVec3, Vec3};

/// The voxel maps' hasher (`fipt_core::hash`).
pub use fipt_core::hash::GridHasher as VoxelHasher;

/// A map keyed by packed voxel coordinates.
pub type VoxelMap<V> = fipt_core::hash::GridMap<u64, V>;

/// The cube the SLF covers: all primary hit points, enlarged ×1.1 about their centre.
pub use fipt_core::cube::Cube;

/// One level of the SLF: a dense index of 8³-voxel bricks, with storage only for bricks that
/// hold an observed voxel. Neighbouring voxels share a brick, so lookups of nearby secondary
/// hits stay in cache (a hash map scattered them and missed the cache on most lookups).
#[derive(Clone, Debug)]
struct BrickGrid {
    nb: u64,
    blocks: Vec<u32>,
    bricks: Vec<Brick>,
}

#[derive(Clone, Debug)]
struct Brick {
    mask: [u64; 8],
    vals: [Rgb; 512],
}

impl BrickGrid {
    fn from_sums(res: u64, sums: &VoxelMap<(DVec3, u32)>) -> Self {
        let nb = res.div_ceil(8);
        let mut g = BrickGrid {
            nb,
            blocks: vec![u32::MAX; (nb * nb * nb) as usize],
            bricks: Vec::new(),
        };
        for (&k, &(s, n)) in sums {
            let (x, y, z) = (k % res, (k / res) % res, k / (res * res));
            let b = ((z >> 3) * nb + (y >> 3)) * nb + (x >> 3);
            let slot = &mut g.blocks[b as usize];
            if *slot == u32::MAX {
                *slot = g.bricks.len() as u32;
                g.bricks.push(Brick {
                    mask: [0; 8],
                    vals: [Vec3::ZERO; 512],
                });
            }
            let brick = &mut g.bricks[*slot as usize];
            let i = (((z & 7) << 6) | ((y & 7) << 3) | (x & 7)) as usize;
            brick.mask[i >> 6] |= 1 << (i & 63);
            brick.vals[i] = (s / n as f64).as_vec3();
        }
        g
    }

    /// The brick holding voxel (x, y, z) and the voxel's index in it (None: no brick there).
    #[inline]
    fn locate(&self, x: u64, y: u64, z: u64) -> Option<(&Brick, usize)> {
        let b = self.blocks[(((z >> 3) * self.nb + (y >> 3)) * self.nb + (x >> 3)) as usize];
        let i = (((z & 7) << 6) | ((y & 7) << 3) | (x & 7)) as usize;
        (b != u32::MAX).then(|| (&self.bricks[b as usize], i))
    }

    #[inline]
    fn get(&self, x: u64, y: u64, z: u64) -> Option<Rgb> {
        let (brick, i) = self.locate(x, y, z)?;
        (brick.mask[i >> 6] >> (i & 63) & 1 == 1).then(|| brick.vals[i])
    }

    /// Starts loading the cache lines `get(x, y, z)` reads: the brick's mask word and the
    /// value's 12 bytes (one in eight straddles two lines).
    #[inline]
    fn prefetch(&self, x: u64, y: u64, z: u64) {
        if let Some((brick, i)) = self.locate(x, y, z) {
            let value = &brick.vals[i] as *const Rgb;
            fipt_core::memory::prefetch(&brick.mask[i >> 6]);
            fipt_core::memory::prefetch(value);
            fipt_core::memory::prefetch(value.cast::<u8>().wrapping_add(11));
        }
    }

    fn occupied(&self) -> usize {
        self.bricks
            .iter()
            .map(|b| {
                b.mask
                    .iter()
                    .map(|m| m.count_ones() as usize)
                    .sum::<usize>()
            })
            .sum()
    }

    fn memory_bytes(&self) -> usize {
        self.blocks.len() * 4 + self.bricks.len() * std::mem::size_of::<Brick>()
    }
}

/// The surface light field.
///
/// Besides the voxels at `resolution`, it keeps `fallback_levels` coarser grids (each halving
/// the resolution) of the same observations: a lookup in an empty fine voxel falls back to the
/// finest non-empty coarser voxel. With sparse observations (few or small views) the fine grid
/// is mostly holes and the reference's strict lookup returns 0 for most secondary hits — direct
/// light from a small emitter seen in a few pixels disappears. `fallback_levels = 0` gives the
/// reference's behaviour.
#[derive(Clone, Debug)]
pub struct SurfaceLightField {
    pub cube: Cube,
    pub resolution: u32,
    inv_cell: f32,
    /// Level 0 = full resolution, level k = resolution / 2^k.
    levels: Vec<BrickGrid>,
}

impl SurfaceLightField {
    /// Voxel key of a point (None outside the cube).
    #[inline]
    pub fn voxel(&self, p: Vec3) -> Option<u64> {
        voxel_key(self.cube.min, self.inv_cell, self.resolution, p)
    }

    /// Mean radiance of the voxel containing `p`, else of the finest occupied coarser voxel;
    /// 0 when none is occupied or `p` is outside.
    #[inline]
    pub fn lookup(&self, p: Vec3) -> Rgb {
        let Some((mut x, mut y, mut z)) = self.cell_of(p) else {
            return Vec3::ZERO;
        };
        for level in &self.levels {
            if let Some(v) = level.get(x, y, z) {
                return v;
            }
            x >>= 1;
            y >>= 1;
            z >>= 1;
        }
        Vec3::ZERO
    }

    /// Starts loading the full-resolution voxel that [`SurfaceLightField::lookup`] of `p` reads
    /// first (a hint: no effect on any answer).
    #[inline]
    pub fn prefetch(&self, p: Vec3) {
        if let Some((x, y, z)) = self.cell_of(p) {
            self.levels[0].prefetch(x, y, z);
        }
    }

    /// The full-resolution voxel coordinates of `p` (None outside the cube).
    #[inline]
    fn cell_of(&self, p: Vec3) -> Option<(u64, u64, u64)> {
        voxel_cell(self.cube.min, self.inv_cell, self.resolution, p)
    }

    /// Whether the full-resolution voxel containing `p` holds radiance.
    pub fn occupied_at(&self, p: Vec3) -> bool {
        self.cell_of(p)
            .is_some_and(|(x, y, z)| self.levels[0].get(x, y, z).is_some())
    }

    /// Number of occupied full-resolution voxels.
    pub fn occupied(&self) -> usize {
        self.levels[0].occupied()
    }

    /// Heap memory (bytes): 6 KiB per occupied 8³ brick plus a 4-byte index per brick of the
    /// grid (128 KiB at 256³), so it follows the occupied surface, not the grid volume.
    pub fn memory_bytes(&self) -> usize {
        self.levels.iter().map(|l| l.memory_bytes()).sum()
    }
}

/// The voxel coordinates of `p` in a grid of `res`³ voxels of edge 1 / `inv_cell` from `min`
/// (None outside it): the one place the SLF and its builder place a point.
#[inline]
fn voxel_cell(min: Vec3, inv_cell: f32, res: u32, p: Vec3) -> Option<(u64, u64, u64)> {
    let q = (p - min) * inv_cell;
    if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
        return None;
    }
    let (x, y, z) = (q.x as u64, q.y as u64, q.z as u64);
    let r = res as u64;
    (x < r && y < r && z < r).then_some((x, y, z))
}

#[inline]
fn voxel_key(min: Vec3, inv_cell: f32, res: u32, p: Vec3) -> Option<u64> {
    let r = res as u64;
    voxel_cell(min, inv_cell, res, p).map(|(x, y, z)| (z * r + y) * r + x)
}

/// The voxel of an observation of radiance `l` at `p` (None outside the grid or if `l` is not
/// finite).
#[inline]
fn observation_key(min: Vec3, inv_cell: f32, res: u32, p: Vec3, l: Rgb) -> Option<u64> {
    fipt_core::color::is_finite(l)
        .then(|| voxel_key(min, inv_cell, res, p))
        .flatten()
}

/// Adds one observation's radiance to a voxel's (sum, count).
#[inline]
fn accumulate(e: &mut (DVec3, u32), l: Rgb) {
    e.0 += l.as_dvec3();
    e.1 += 1;
}

/// Accumulates radiance samples into voxels.
pub struct SlfBuilder {
    cube: Cube,
    resolution: u32,
    inv_cell: f32,
    fallback_levels: u32,
    sums: fipt_core::parted::PartedMap<u64, (DVec3, u32)>,
}

impl SlfBuilder {
    /// A builder with the reference's strict lookup (no coarser fallback).
    pub fn new(cube: Cube, resolution: u32) -> Self {
        Self::with_fallback(cube, resolution, 0)
    }

    /// A builder whose SLF falls back to up to `fallback_levels` coarser grids.
    pub fn with_fallback(cube: Cube, resolution: u32, fallback_levels: u32) -> Self {
        let resolution = resolution.max(1);
        SlfBuilder {
            cube,
            resolution,
            inv_cell: resolution as f32 / cube.size,
            fallback_levels,
            sums: Default::default(),
        }
    }

    /// Adds one observation of radiance `l` at point `p` (ignored outside the cube or if not finite).
    pub fn add(&mut self, p: Vec3, l: Rgb) {
        let key = observation_key(self.cube.min, self.inv_cell, self.resolution, p, l);
        self.sums
            .add_one(key, || (DVec3::ZERO, 0), |e| accumulate(e, l));
    }

    /// Adds the observations (point, radiance) in order, as [`SlfBuilder::add`] one at a time
    /// would, on every thread.
    pub fn add_all(&mut self, observations: &[(Vec3, Rgb)]) {
        let (min, inv, res) = (self.cube.min, self.inv_cell, self.resolution);
        self.sums.add_all(
            observations,
            |_, &(p, l)| observation_key(min, inv, res, p, l),
            |_| (DVec3::ZERO, 0),
            |e, _, &(_, l)| accumulate(e, l),
        );
    }

    pub fn finish(self) -> SurfaceLightField {
        let mut levels = Vec::new();
        // One map filled in the order the voxels were first met, as a single map filled one
        // observation at a time: the coarser levels sum in its order.
        let mut sums: VoxelMap<(DVec3, u32)> = VoxelMap::default();
        for (k, v) in self.sums.into_first_seen() {
            sums.insert(k, v);
        }
        let mut r = self.resolution as u64;
        for level in 0..=self.fallback_levels {
            let coarser = if level < self.fallback_levels {
                let rc = r.div_ceil(2);
                let mut m: VoxelMap<(DVec3, u32)> = VoxelMap::default();
                for (&k, &(s, n)) in &sums {
                    let (x, y, z) = (k % r, (k / r) % r, k / (r * r));
                    let e = m
                        .entry(((z / 2) * rc + y / 2) * rc + x / 2)
                        .or_insert((DVec3::ZERO, 0));
                    e.0 += s;
                    e.1 += n;
                }
                Some((m, rc))
            } else {
                None
            };
            levels.push(BrickGrid::from_sums(r, &sums));
            match coarser {
                Some((m, rc)) => {
                    sums = m;
                    r = rc;
                }
                None => break,
            }
        }
        SurfaceLightField {
            cube: self.cube,
            resolution: self.resolution,
            inv_cell: self.inv_cell,
            levels,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voxels_average_their_samples_and_empty_is_zero() {
        let cube = Cube::around([Vec3::ZERO, Vec3::ONE].into_iter(), 1.1).unwrap();
        assert!((cube.size - 1.1).abs() < 1e-6);
        let mut b = SlfBuilder::new(cube, 4);
        b.add(Vec3::splat(0.1), Vec3::splat(1.0));
        b.add(Vec3::splat(0.12), Vec3::splat(3.0));
        b.add(Vec3::splat(0.9), Vec3::new(5.0, 0.0, 0.0));
        b.add(Vec3::splat(0.5), Vec3::splat(f32::NAN));
        b.add(Vec3::splat(7.0), Vec3::ONE); // outside
        let slf = b.finish();
        assert_eq!(slf.occupied(), 2);
        assert_eq!(slf.lookup(Vec3::splat(0.11)), Vec3::splat(2.0));
        assert_eq!(slf.lookup(Vec3::splat(0.9)), Vec3::new(5.0, 0.0, 0.0));
        assert_eq!(slf.lookup(Vec3::splat(0.5)), Vec3::ZERO);
        assert_eq!(slf.lookup(Vec3::splat(-3.0)), Vec3::ZERO);
        assert!(
            slf.memory_bytes() < 16 * 1024,
            "sparse: {} bytes for a 4³ grid with 2 voxels",
            slf.memory_bytes()
        );
    }

    #[test]
    fn empty_voxels_fall_back_to_coarser_levels() {
        let cube = Cube {
            min: Vec3::ZERO,
            size: 8.0,
        };
        let mut b = SlfBuilder::with_fallback(cube, 8, 2);
        b.add(Vec3::new(0.5, 0.5, 0.5), Vec3::splat(2.0)); // voxel (0,0,0)
        b.add(Vec3::new(1.5, 0.5, 0.5), Vec3::splat(4.0)); // voxel (1,0,0)
        b.add(Vec3::new(7.5, 7.5, 7.5), Vec3::splat(9.0));
        let slf = b.finish();
        assert_eq!(
            slf.lookup(Vec3::new(0.5, 0.5, 0.5)),
            Vec3::splat(2.0),
            "fine voxel wins"
        );
        // (1,1,0) is empty; its 2× parent (0,0,0) holds the mean of both samples.
        assert_eq!(slf.lookup(Vec3::new(1.5, 1.5, 0.5)), Vec3::splat(3.0));
        // (3,3,3) is empty at 8³ and 4³; the 2³ parent (0,0,0) averages the first two.
        assert_eq!(slf.lookup(Vec3::new(3.5, 3.5, 3.5)), Vec3::splat(3.0));
        // (4,4,4) → 2³ parent (1,1,1) holds the last sample.
        assert_eq!(slf.lookup(Vec3::new(4.5, 4.5, 4.5)), Vec3::splat(9.0));
        let strict = {
            let mut b = SlfBuilder::new(cube, 8);
            b.add(Vec3::splat(0.5), Vec3::ONE);
            b.finish()
        };
        assert_eq!(
            strict.lookup(Vec3::new(1.5, 1.5, 0.5)),
            Vec3::ZERO,
            "reference behaviour without fallback"
        );
    }
}
