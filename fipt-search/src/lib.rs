//! `fipt-search`: FIPT's material search over the factorised shadings (the algorithm; the run's
//! stage around it, with its caches and regions, is `fipt_method::search`). It imports the
//! shadings' types and the primary hits, never the pipeline: per region, the image loss as a function of
//! roughness σ and metallic m, and the (σ, m) it prefers.
//!
//! For a fixed (σ, m) the factorised image is linear in the base colour a:
//! `I ≈ a·b + c` with `b = (1 − m)·Ld(σ) + m·Ls0(σ)` and `c = 0.04·(1 − m)·Ls0(σ) + Ls1(σ)`
//! (kd = a·(1 − m), ks = 0.04·(1 − m) + a·m; Ld(σ) is constant under FIPT's model and a
//! polynomial in σ under `principled`, see [`fipt_core::reflectance`]). So at every candidate (σ, m) the best base colour
//! of each surface cell (the pixels of all views whose primary hit falls in one small voxel) is a
//! weighted least-squares fit in closed form, and what is left is the part of the views that
//! this (σ, m) cannot explain: how the cell's radiance changes with the viewing direction. The
//! search sums that residual over each region (a part, or a patch of the mesh) and keeps the
//! roughest σ and the non-metal answer unless the data prefers another by a stated margin.
//! Nothing here saturates or depends on an initialisation: it is an exhaustive search on a grid.
//!
//! [`profile`] computes the cost curves (also with a given base colour, the diagnostic of how
//! well the shadings explain the views at the true materials); [`choose`] turns a curve into a
//! decision. The residual is the training's: squared difference of sRGB-encoded values (no
//! clamp), averaged over pixels and channels.
use fipt_core::color::{srgb_oetf, Rgb};
use fipt_core::dataset::{Dataset, GtKind, Split};
use fipt_core::image::Image;
use fipt_core::shading::{level_segment, ViewShadings};
use fipt_shading::records::PrimaryHit;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Settings of the search (`[search]` in a run config).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchConfig {
    /// Run the search and pull the training towards its answer (false: the pull to σ = 1,
    /// m = 0 of `[train]`).
    pub enabled: bool,
    /// Search on the initial bake too (before the first training round). The bake's one-bounce
    /// shadings are noisier, so there the search only acts on overwhelming evidence: metals
    /// whose cost is below `bake_metal_margin` of the dielectric one, and no dielectric σ
    /// targets. Metals found before the first round are what makes the refinement grow paths
    /// through them (val kd +1.0 dB on `studio-mitsuba`, +0.6 dB on `room`, against the refined shadings only).
    pub on_bake: bool,
    /// `metal_margin` on the bake. Measured metal/dielectric cost ratios on bakes: true metals
    /// 0.05–0.34 (`studio-mitsuba`, `room`, `cornell-metal`), false ones 0.41–0.60 (walls of a
    /// 12-view cornell baked with 8 GGX samples a level; `cornell-metal`'s `fast` bake).
    pub bake_metal_margin: f32,
    /// σ candidates: this many values evenly spaced over the bake's levels' range.
    pub roughness_steps: usize,
    /// Metallic candidates.
    pub metallic: Vec<f32>,
    /// Edge of a surface cell (the pixels whose albedo is fitted together) in median pixel
    /// footprints.
    pub cell_footprints: f32,
    /// A dielectric region's σ is the roughest whose cost is within this fraction of its
    /// minimum; when that is the roughest candidate, the search sets no σ target (the training
    /// decides). A 4 % specular lobe leaves dielectrics little σ evidence, and a diffuse lobe
    /// that is not the data's (Mitsuba's Burley diffuse against FIPT's Lambert) makes up
    /// gains of the same size: on `studio-mitsuba` the diffuse box (σ 1) costs 13 % less as a
    /// mirror (README, *Why σ and metallic did not move*).
    pub dielectric_tolerance: f32,
    /// The same for metal regions, whose lobe carries all their light.
    pub metal_tolerance: f32,
    /// A dielectric whose minimum lies inside the σ range (at least `interior_sigma`) gets a
    /// σ target when σ = 1 costs this fraction more (weaker evidence than
    /// `dielectric_tolerance` asks for) and, with `held_out`, the minimum holds on held-out
    /// views: the roughest σ whose cost exceeds the minimum by at most `interior_tolerance` of
    /// σ = 1's excess, and by at most `interior_cap`. A minimum at the mirror end is what a
    /// mismatched diffuse lobe produces (on `studio-mitsuba` both boxes, whatever their σ); an
    /// interior one a lobe the data has: the glossy floor of `cornell-metal` (14 % below
    /// σ = 1), and the walls and the floor of `studio-mitsuba` (σ 0.85–0.95: 0.3–3 % below
    /// σ = 1 at 0.76–0.88 once `drop_edges` leaves out the ceiling's false minimum). Gains of
    /// 1–5 % are also what the noise of a small bake makes (a 12-view cornell at 48×36 with 8
    /// GGX samples a level: 9 of 10 regions got a target without `held_out`, 4 with it and
    /// `edge_contrast`; docs/material-search.md §7).
    pub interior_gain: f32,
    /// See `interior_gain`.
    pub interior_sigma: f32,
    /// See `interior_gain`: 0.25 puts the walls and the floor of `studio-mitsuba` at
    /// 0.86–0.92 (true 0.85–0.95), where their minima alone say 0.76–0.88. With 1 and
    /// `interior_gain` 0.05 the rule is the one before 2026-11-25.
    pub interior_tolerance: f32,
    /// The most the `interior_tolerance` rule may add to the minimum (relative). A deep
    /// minimum is where the σ is: the glossy parts of five Mitsuba rooms sit at their true σ
    /// within 0.02 at their minima, and a cap of 2 % (`metal_tolerance`, the rule until
    /// 2026-11-29) moved them 0.05–0.3 rougher (a lacquer of σ 0.12 to 0.44); shallow minima
    /// (rough walls, under 2 % below σ = 1) take the same quarter of their gain as before
    /// (`docs/roughness-rooms.md`).
    #[serde(default = "default_interior_cap")]
    pub interior_cap: f32,
    /// The `interior_gain` rule decides every dielectric whose minimum is interior and holds
    /// out, not only those `dielectric_tolerance` would leave at σ = 1. False: a minimum more
    /// than `dielectric_tolerance` below σ = 1 takes the roughest σ within that 25 %, which put
    /// `loft-mitsuba`'s glossy floor (σ 0.35, minimum at 0.36) at 0.74 and `studio-mitsuba`'s
    /// glossy box (0.30, minimum at 0.32) at 0.48 (`docs/loft-mitsuba.md`).
    #[serde(default = "default_interior_always")]
    pub interior_always: bool,
    /// A region is metal when its best metal cost is below its best dielectric cost by at
    /// least this fraction.
    pub metal_margin: f32,
    /// Regions with fewer pixels keep σ = 1, m = 0.
    pub min_pixels: usize,
    /// Where regions come from: `auto` (part ids, else semantic classes, else the mesh),
    /// `parts`, `semantic`, `mesh` (smooth connected patches of the mesh) or `none` (one region
    /// per surface cell is too noisy to decide: the search is then skipped).
    pub regions: RegionSource,
    /// Largest dihedral angle (degrees) across which a mesh patch grows (`regions = "mesh"`).
    pub mesh_angle_deg: f32,
    /// Leave out pixels with a neighbour (of the 8 around it in its view) in another region or
    /// in none that is `edge_contrast` times brighter. A camera's pixel integrates its whole
    /// footprint, so at a region's outline it mixes two surfaces (the ceiling's ring around a
    /// panel light), while the region, the shadings and the fitted colour are those of the
    /// pixel's centre.
    pub drop_edges: bool,
    /// With `drop_edges`: only a neighbour at least this many times brighter (luminance of the
    /// view) makes a pixel an outline pixel; 0: every neighbour in another region. With 0, on
    /// small images the outlines take too much of small regions (a 12-view `cornell-metal` at
    /// 64×48 without segmentation lost its metal block: recall 0.96 → 0.28); with 4 it keeps
    /// it (0.96), and on `studio-mitsuba` it drops 1 % of the ceiling's pixels, enough to move
    /// the ceiling's minimum from 0.60 to 1.00.
    pub edge_contrast: f32,
    /// A target from the `interior_gain` rule also has to hold on held-out views: the views
    /// split into two halves (even and odd), each profiled alone, and the σ that each half
    /// prefers (above the lowest candidate) must beat σ = 1 by `interior_gain` on the other
    /// half. Minima made by the noise of a small bake do not carry over.
    pub held_out: bool,
    /// A second way to hold out, for noisy views: the σ each half prefers lies inside the
    /// range (above the mirror end, below σ = 1) and the two lie within this distance of each
    /// other, however shallow each half's minimum. Pose error and pixel noise add a cost that
    /// no σ explains, so a wall whose gloss half the views barely see (`studio-mitsuba`'s right
    /// wall, σ 0.9, in a capture-like copy: halves at 0.78 and 0.82, the second 0.02 % below
    /// σ = 1) failed the `interior_gain` test and fell to σ ≈ 1 (`docs/captures.md`). 0: off.
    #[serde(default = "default_held_out_band")]
    pub held_out_band: f32,
    /// A dielectric left without a target whose minimum lies within this distance of the
    /// roughest candidate gets the roughest as its target, not the training's choice: a
    /// surface without gloss gives σ no gradient but noise, and the training alone let
    /// `studio-mitsuba`'s diffuse box (σ 1) drift to 0.91 in capture-like copies. 0: off.
    #[serde(default = "default_held_out_band")]
    pub rough_band: f32,
    /// At most this many pixels take part (a uniform random share of them beyond it, the
    /// same for the same views); only they and their shadings are held while the search
    /// runs, 182 bytes each with `principled`. 0: every pixel.
    #[serde(default = "default_max_pixels")]
    pub max_pixels: usize,
    /// With a value above 0, a dielectric whose fitted curve has σ = 1 less than this
    /// fraction above its minimum (faint gloss: rough walls, plaster, cloth) is also
    /// profiled with one base colour for the whole region ([`RegionProfile::one_colour`]).
    /// Its σ is then no glossier than the glossiest σ within `interior_gain` of that
    /// curve's minimum, and where the rules above leave it without a target (halves that
    /// disagree) it takes that curve's, by the `interior_tolerance` and `interior_cap`
    /// rule. A base colour per surface cell absorbs the broad glow a rough lobe spreads
    /// over a surface, which leaves only the within-cell view dependence as evidence:
    /// faint, and pulled glossy by noise and pose error (`docs/roughness-rooms.md`, *Faint
    /// gloss on one colour*). A one-colour curve whose minimum lies at the mirror end (a
    /// diffuse lobe that is not the data's) or that is not faint itself (a patch of two
    /// colours) is not read. 0 (the default): off. An ablation, off because on five Mitsuba
    /// rooms and a capture copy at 0.02 it moved val σ by +0.75 dB (`atelier`'s brick wall
    /// 0.88 → 0.96 for 1.0), 0, 0, −0.6, −0.9 and −0.3 (`loft`'s and `gallery`'s walls a
    /// step too rough: their one-colour minima sit 0.08 and 0.15 above the truth); the
    /// one-colour curve is no less biased than the per-cell one.
    /// Left out of the serialised settings when off, so that searches kept by runs before
    /// it existed (keyed on the settings) are reused.
    #[serde(default = "default_one_colour_below", skip_serializing_if = "is_off")]
    pub one_colour_below: f32,
    /// Dividing regions of two finishes by colour ([`split`]) or by gloss ([`gloss`]).
    #[serde(default)]
    pub split: split::SplitConfig,
}

fn default_one_colour_below() -> f32 {
    0.0
}

fn is_off(v: &f32) -> bool {
    *v == 0.0
}

fn default_interior_always() -> bool {
    true
}

fn default_interior_cap() -> f32 {
    0.005
}

fn default_held_out_band() -> f32 {
    0.1
}

fn default_max_pixels() -> usize {
    8_000_000
}

/// Where the search's regions come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RegionSource {
    Auto,
    Parts,
    Semantic,
    Mesh,
    None,
}

impl Default for SearchConfig {
    fn default() -> Self {
        SearchConfig {
            enabled: true,
            on_bake: true,
            bake_metal_margin: 0.6,
            roughness_steps: 50,
            metallic: vec![0.0, 1.0],
            cell_footprints: 4.0,
            dielectric_tolerance: 0.25,
            metal_tolerance: 0.02,
            interior_gain: 0.001,
            interior_sigma: 0.1,
            interior_tolerance: 0.25,
            interior_cap: default_interior_cap(),
            interior_always: true,
            metal_margin: 0.2,
            min_pixels: 200,
            regions: RegionSource::Auto,
            mesh_angle_deg: 30.0,
            drop_edges: true,
            edge_contrast: 4.0,
            held_out: true,
            held_out_band: default_held_out_band(),
            rough_band: default_held_out_band(),
            max_pixels: default_max_pixels(),
            one_colour_below: default_one_colour_below(),
            split: split::SplitConfig::default(),
        }
    }
}

impl SearchConfig {
    /// Range checks of every setting, naming the key and the range (`search.<key> = v (use
    /// …)`).
    pub fn validate(&self) -> Result<(), String> {
        let bad = |key: &str, v: &dyn std::fmt::Display, range: &str| {
            Err(format!("search.{key} = {v} (use {range})"))
        };
        let unit = |v: f32| (0.0..=1.0).contains(&v);
        let ranges = [
            ("bake_metal_margin", self.bake_metal_margin, 1.0),
            ("metal_margin", self.metal_margin, 1.0),
            ("interior_sigma", self.interior_sigma, 1.0),
            ("interior_tolerance", self.interior_tolerance, 1.0),
            ("interior_cap", self.interior_cap, 1e6),
            ("dielectric_tolerance", self.dielectric_tolerance, 1e6),
            ("metal_tolerance", self.metal_tolerance, 1e6),
            ("interior_gain", self.interior_gain, 1e6),
            ("held_out_band", self.held_out_band, 1.0),
            ("rough_band", self.rough_band, 1.0),
            ("one_colour_below", self.one_colour_below, 1e6),
            ("edge_contrast", self.edge_contrast, 1e6),
        ];
        for (key, v, hi) in ranges {
            if !(v >= 0.0 && v <= hi) {
                return bad(key, &v, &format!("[0, {hi}]"));
            }
        }
        if !(2..=10_000).contains(&self.roughness_steps) {
            return bad("roughness_steps", &self.roughness_steps, "2..=10000");
        }
        if self.metallic.is_empty()
            || self.metallic.len() > 100
            || !self.metallic.iter().all(|&m| unit(m))
        {
            return bad(
                "metallic",
                &format!("{:?}", self.metallic),
                "1 to 100 values in [0, 1]",
            );
        }
        if !(self.cell_footprints > 0.0 && self.cell_footprints <= 1e4) {
            return bad("cell_footprints", &self.cell_footprints, "(0, 1e4]");
        }
        if !(0.0..=180.0).contains(&self.mesh_angle_deg) {
            return bad("mesh_angle_deg", &self.mesh_angle_deg, "[0, 180]");
        }
        self.split.validate()
    }

    /// The search off (the reference's behaviour).
    pub fn off() -> Self {
        SearchConfig {
            enabled: false,
            ..Default::default()
        }
    }
}

/// The search in every preset but `reference`, which keeps the reference's behaviour (off).
impl fipt_core::presets::Presets for SearchConfig {
    fn paper() -> Self {
        SearchConfig::default()
    }
    fn balanced() -> Self {
        SearchConfig::default()
    }
    fn fast() -> Self {
        SearchConfig::default()
    }
    fn reference() -> Self {
        SearchConfig::off()
    }
}

/// One training pixel taking part in the search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchPixel {
    pub view: u32,
    pub pixel: u32,
    pub region: u32,
    /// Surface cell (dense, unique across regions).
    pub cell: u32,
}

/// The base colour at each candidate: fitted per surface cell, or given per pixel (the
/// diagnostic with ground truth).
pub enum Albedo<'a> {
    Fitted,
    /// Base colour a of each entry of the pixel list.
    Given(&'a [Rgb]),
}

/// The cost of every candidate for one region: `cost[mi][si]` is the mean squared sRGB error
/// at `metallic[mi]`, `sigma[si]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionProfile {
    pub region: u32,
    pub pixels: usize,
    pub cells: usize,
    pub sigma: Vec<f32>,
    pub metallic: Vec<f32>,
    pub cost: Vec<Vec<f64>>,
    /// With a given base colour only: `gain[mi][si]`, the linear least-squares scale of the
    /// views against the model, Σ I·P / Σ P·P over the region's pixels (1: the shadings carry
    /// the right amount of light; 1.1: they miss a tenth of it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gain: Vec<Vec<f64>>,
    /// The dielectric row (m = 0) with one base colour for the whole region instead of one
    /// per surface cell, where the search computed it (`one_colour_below` above 0; empty
    /// elsewhere).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub one_colour: Vec<f64>,
}

/// What the search decided for a region, with the evidence. None: no target (too few pixels,
/// or no σ evidence beyond the tolerance).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionChoice {
    pub region: u32,
    pub pixels: usize,
    pub roughness: Option<f32>,
    pub metallic: Option<f32>,
    /// The minimum over σ for each metallic candidate, and where it is.
    pub best_cost: Vec<f64>,
    pub argmin_sigma: Vec<f32>,
    /// Cost at (σ = 1, m = 0), the default answer.
    pub default_cost: f64,
}

/// The base colour a of the metallic workflow from a material's kd, ks and metallic as the
/// ground-truth maps store them: kd for a dielectric, ks (= a) for a metal.
pub fn base_colour(kd: Rgb, ks: Rgb, metallic: f32) -> Rgb {
    if metallic > 0.5 {
        ks
    } else {
        kd
    }
}

/// The true base colour ([`base_colour`]) at each of `pixels`, from `split`'s ground-truth
/// DiffCol, Specular and Metallic maps; None when the split lacks one of them.
pub fn true_base_colours(
    ds: &Dataset,
    split: &Split,
    pixels: &[SearchPixel],
) -> fipt_core::Result<Option<Vec<Rgb>>> {
    let kinds = [GtKind::DiffCol, GtKind::Specular, GtKind::Metallic];
    if !kinds.iter().all(|&k| split.has_gt(k)) {
        return Ok(None);
    }
    let mut maps = Vec::with_capacity(split.views.len());
    for v in &split.views {
        let mut m = [vec![], vec![], vec![]];
        for (slot, &kind) in m.iter_mut().zip(&kinds) {
            *slot = ds
                .load_gt(split, kind, v.index)?
                .map(|i| i.data)
                .unwrap_or_default();
        }
        maps.push(m);
    }
    Ok(Some(
        pixels
            .iter()
            .map(|p| {
                let [kd, ks, m] = &maps[p.view as usize];
                let i = p.pixel as usize;
                base_colour(kd[i], ks[i], m[i].x)
            })
            .collect(),
    ))
}

/// The σ candidates: `steps` values evenly spaced over `[lo, hi]`.
pub fn sigma_grid(lo: f32, hi: f32, steps: usize) -> Vec<f32> {
    let n = steps.max(2);
    (0..n)
        .map(|i| lo + (hi - lo) * i as f32 / (n - 1) as f32)
        .collect()
}

/// The surface cell (voxel of edge 1/`inv`) holding `p`.
#[inline]
/// The surface cell (voxel of edge `cell`) a point falls in.
pub fn voxel(p: Vec3, cell: f32) -> [i32; 3] {
    cell_of(p, 1.0 / cell.max(1e-9))
}

fn cell_of(p: Vec3, inv: f32) -> [i32; 3] {
    let q = (p * inv).floor();
    [q.x as i32, q.y as i32, q.z as i32]
}

/// Dense cell ids for `points` (with their region): voxels of edge `cell` per region.
pub fn cell_ids(points: &[(Vec3, u32)], cell: f32) -> Vec<u32> {
    cell_ids_keyed(points, cell).0
}

/// [`cell_ids`] and the voxel of each cell id.
pub fn cell_ids_keyed(points: &[(Vec3, u32)], cell: f32) -> (Vec<u32>, Vec<[i32; 3]>) {
    let inv = 1.0 / cell.max(1e-9);
    let mut map: HashMap<(u32, [i32; 3]), u32> = HashMap::new();
    let mut voxels = vec![];
    let ids = points
        .iter()
        .map(|&(p, r)| {
            let v = cell_of(p, inv);
            *map.entry((r, v)).or_insert_with(|| {
                voxels.push(v);
                voxels.len() as u32 - 1
            })
        })
        .collect();
    (ids, voxels)
}

/// How many training pixels fall in each surface cell: where the views observed a surface
/// (`{k:03}_observed.exr`), so users know where to trust the maps.
pub struct CellCounts {
    inv: f32,
    counts: HashMap<[i32; 3], u32>,
}

impl CellCounts {
    /// Counts of `points` in voxels of edge `cell`.
    pub fn new(points: impl IntoIterator<Item = Vec3>, cell: f32) -> Self {
        let inv = 1.0 / cell.max(1e-9);
        let mut counts: HashMap<[i32; 3], u32> = HashMap::new();
        for p in points {
            *counts.entry(cell_of(p, inv)).or_default() += 1;
        }
        CellCounts { inv, counts }
    }

    /// Training pixels in the cell of `p` (0: never observed).
    pub fn count(&self, p: Vec3) -> u32 {
        self.counts.get(&cell_of(p, self.inv)).copied().unwrap_or(0)
    }
}

/// A search pixel before its surface cell is known: (view, pixel, region, point).
pub type KeyedPixel = (u32, u32, u32, Vec3);

/// The search's pixels of the training views: every valid pixel whose `region_of` is `Some`,
/// with cells of edge `cell`.
pub fn gather_pixels<R: PrimaryHit>(
    records: &[Vec<Option<R>>],
    shadings: &[ViewShadings],
    cell: f32,
    region_of: &dyn Fn(usize, usize, &R) -> Option<u32>,
) -> Vec<SearchPixel> {
    gather_pixels_keyed(records, shadings, cell, region_of).0
}

/// [`gather_pixels`] and the voxel of each surface cell.
pub fn gather_pixels_keyed<R: PrimaryHit>(
    records: &[Vec<Option<R>>],
    shadings: &[ViewShadings],
    cell: f32,
    region_of: &dyn Fn(usize, usize, &R) -> Option<u32>,
) -> (Vec<SearchPixel>, Vec<[i32; 3]>) {
    let mut keyed = vec![];
    for (v, (recs, sh)) in records.iter().zip(shadings).enumerate() {
        keyed.extend(view_pixels(v, recs, &sh.valid, region_of));
    }
    with_cells_keyed(&keyed, cell)
}

/// View `v`'s search pixels: every pixel with a hit, `valid` shadings and a region from
/// `region_of`, in pixel order.
pub fn view_pixels<R: PrimaryHit>(
    v: usize,
    recs: &[Option<R>],
    valid: &[bool],
    region_of: &dyn Fn(usize, usize, &R) -> Option<u32>,
) -> Vec<KeyedPixel> {
    let mut keyed = vec![];
    for (i, r) in recs.iter().enumerate() {
        let Some(r) = r else { continue };
        if !valid.get(i).copied().unwrap_or(false) {
            continue;
        }
        if let Some(region) = region_of(v, i, r) {
            keyed.push((v as u32, i as u32, region, r.point()));
        }
    }
    keyed
}

/// The search pixels of `keyed` with their surface cells (edge `cell`).
pub fn with_cells(keyed: &[KeyedPixel], cell: f32) -> Vec<SearchPixel> {
    with_cells_keyed(keyed, cell).0
}

/// [`with_cells`] and the voxel of each cell ([`voxel`]).
pub fn with_cells_keyed(keyed: &[KeyedPixel], cell: f32) -> (Vec<SearchPixel>, Vec<[i32; 3]>) {
    let pts: Vec<(Vec3, u32)> = keyed.iter().map(|k| (k.3, k.2)).collect();
    let (cells, voxels) = cell_ids_keyed(&pts, cell);
    let pixels = keyed
        .iter()
        .zip(cells)
        .map(|(&(view, pixel, region, _), cell)| SearchPixel {
            view,
            pixel,
            region,
            cell,
        })
        .collect();
    (pixels, voxels)
}

/// Whether pixel `i` of a view (`width` pixels a row, region `ids` per pixel) has a neighbour
/// among the 8 around it whose region differs from its own (no region, None or a sentinel
/// id, counts as a region of its own; neighbours off the image do not count) and that `counts` (e.g. one much brighter).
pub fn on_region_edge<T: PartialEq>(
    ids: &[T],
    width: usize,
    i: usize,
    counts: &dyn Fn(usize) -> bool,
) -> bool {
    if width == 0 {
        return false;
    }
    let (x, y) = ((i % width) as isize, (i / width) as isize);
    let height = (ids.len() / width) as isize;
    for dy in -1..=1isize {
        for dx in -1..=1isize {
            let (nx, ny) = (x + dx, y + dy);
            if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= width as isize || ny >= height {
                continue;
            }
            let j = ny as usize * width + nx as usize;
            if ids[j] != ids[i] && counts(j) {
                return true;
            }
        }
    }
    false
}

#[inline]
fn oetf_grad(x: f32) -> f32 {
    fipt_core::color::srgb_oetf_grad(x.max(1e-3))
}

/// (b, c) of the linear model `a·b + c` at (σ, m) for one pixel.
#[inline]
pub(crate) fn linear_terms(sh: &ViewShadings, i: usize, sigma: f32, m: f32) -> (Rgb, Rgb) {
    let (k, t) = level_segment(&sh.levels, sigma);
    let s0 = sh.ls0[i][k] * (1.0 - t) + sh.ls0[i][k + 1] * t;
    let s1 = sh.ls1[i][k] * (1.0 - t) + sh.ls1[i][k + 1] * t;
    fipt_core::reflectance::image_linear_in_base_color(sh.diffuse(i, sigma), s0, s1, m)
}

/// The weighted least-squares base colour of `a·b + c` over a set of pixels at one (σ, m):
/// each channel's squared sRGB error linearised at the pixel's value (weight: the sRGB slope
/// squared). Shared by the search's profiles and the colour split.
#[derive(Clone, Copy, Default)]
pub(crate) struct AlbedoFit {
    sbb: Vec3,
    sbr: Vec3,
}

impl AlbedoFit {
    /// Adds pixel `i` of a view (its shadings and image) at (σ, m).
    #[inline]
    pub(crate) fn add(&mut self, sh: &ViewShadings, img: &Image, i: usize, sigma: f32, m: f32) {
        let (b, c) = linear_terms(sh, i, sigma, m);
        self.add_terms(&Observed::of(img.data[i]), b, c);
    }

    /// Adds a pixel whose linear terms at the candidate are `(b, c)`.
    #[inline]
    pub(crate) fn add_terms(&mut self, o: &Observed, b: Rgb, c: Rgb) {
        self.sbb += o.w * b * b;
        self.sbr += o.w * b * (o.g - c);
    }

    /// The fitted base colour (0 in a channel without evidence), unclamped.
    pub(crate) fn albedo(&self) -> Rgb {
        Vec3::select(
            self.sbb.cmpgt(Vec3::splat(1e-20)),
            self.sbr / self.sbb,
            Vec3::ZERO,
        )
    }
}

/// What the search's losses read of one pixel whatever the candidate (σ, m): its value, the
/// value's sRGB encoding and the squared sRGB slope there (its weight in the base-colour fit).
/// Computed once per pixel rather than once per candidate: the same numbers, a third of the
/// `powf` calls.
#[derive(Clone, Copy)]
pub(crate) struct Observed {
    g: Rgb,
    enc: Rgb,
    w: Rgb,
}

impl Observed {
    #[inline]
    pub(crate) fn of(g: Rgb) -> Self {
        let w = Vec3::new(oetf_grad(g.x), oetf_grad(g.y), oetf_grad(g.z));
        let enc = Vec3::new(srgb_oetf(g.x), srgb_oetf(g.y), srgb_oetf(g.z));
        Observed { g, enc, w: w * w }
    }

    /// The pixels `at` of `pixels`, in that order.
    pub(crate) fn of_pixels(at: &[usize], pixels: &[SearchPixel], images: &[Image]) -> Vec<Self> {
        (at.par_iter())
            .map(|&j| Observed::of(images[pixels[j].view as usize].data[pixels[j].pixel as usize]))
            .collect()
    }

    /// The squared sRGB error of `pred` against the pixel's value, summed over the channels.
    #[inline]
    pub(crate) fn sq_err(&self, pred: Rgb) -> f64 {
        let e = |p: f32, enc: f32| {
            let d = srgb_oetf(p) - enc;
            (d * d) as f64
        };
        e(pred.x, self.enc.x) + e(pred.y, self.enc.y) + e(pred.z, self.enc.z)
    }
}

/// The pixels' indices grouped by region, then by cell, and each region's cells as ranges of
/// that order.
#[allow(clippy::type_complexity)]
fn cell_spans(
    pixels: &[SearchPixel],
    regions: usize,
) -> (Vec<usize>, Vec<Vec<std::ops::Range<usize>>>) {
    let mut order: Vec<usize> = (0..pixels.len()).collect();
    order.sort_unstable_by_key(|&j| (pixels[j].region, pixels[j].cell, j));
    let mut spans: Vec<Vec<std::ops::Range<usize>>> = vec![vec![]; regions];
    let mut s = 0;
    while s < order.len() {
        let p = pixels[order[s]];
        let mut e = s + 1;
        while e < order.len() && pixels[order[e]].cell == p.cell {
            e += 1;
        }
        if (p.region as usize) < regions {
            spans[p.region as usize].push(s..e);
        }
        s = e;
    }
    (order, spans)
}

/// σ candidates per task of [`profile`]: a cell's pixels are read once for this many.
const SIGMA_RUN: usize = 10;

/// The cost curves of every region over the candidates `sigma` × `metallic`. Regions are
/// `0..regions`; a region without pixels gets an empty profile (`pixels` 0, costs NaN).
pub fn profile(
    pixels: &[SearchPixel],
    shadings: &[ViewShadings],
    images: &[Image],
    regions: usize,
    sigma: &[f32],
    metallic: &[f32],
    albedo: Albedo,
) -> Vec<RegionProfile> {
    let (order, spans) = cell_spans(pixels, regions);
    // In `order`'s order, so that a cell's pixels are read one after another.
    let observed = Observed::of_pixels(&order, pixels, images);
    // A task takes one region, one metallic and a run of σ candidates, and reads each cell's
    // pixels once for all of its candidates (they stay in cache), rather than once per
    // candidate. Each candidate's sums still add the pixels in the same order.
    let tasks: Vec<(usize, usize, std::ops::Range<usize>)> = (0..regions)
        .flat_map(|r| {
            (0..metallic.len()).flat_map(move |mi| {
                (0..sigma.len())
                    .step_by(SIGMA_RUN)
                    .map(move |s| (r, mi, s..(s + SIGMA_RUN).min(sigma.len())))
            })
        })
        .collect();
    let costs: Vec<(f64, f64)> = tasks
        .par_iter()
        .flat_map_iter(|(r, mi, run)| {
            let m = metallic[*mi];
            // Per candidate of the run: squared error, values, Σ pred·g, Σ pred·pred.
            let mut sums = vec![(0.0f64, 0usize, 0.0f64, 0.0f64); run.len()];
            // The cell's linear terms at a candidate, computed once for the fit and the cost.
            let mut terms: Vec<(Rgb, Rgb)> = vec![];
            for span in &spans[*r] {
                let (idx, obs) = (&order[span.clone()], &observed[span.clone()]);
                for (sum, &sg) in sums.iter_mut().zip(&sigma[run.clone()]) {
                    terms.clear();
                    terms.extend(idx.iter().map(|&j| {
                        let p = pixels[j];
                        linear_terms(&shadings[p.view as usize], p.pixel as usize, sg, m)
                    }));
                    let fitted = match albedo {
                        Albedo::Fitted => {
                            let mut fit = AlbedoFit::default();
                            for (o, &(b, c)) in obs.iter().zip(&terms) {
                                fit.add_terms(o, b, c);
                            }
                            Some(fit.albedo().clamp(Vec3::ZERO, Vec3::ONE))
                        }
                        Albedo::Given(_) => None,
                    };
                    let (total, count, ip, pp) = sum;
                    for ((&j, o), &(b, c)) in idx.iter().zip(obs).zip(&terms) {
                        let a = match (&albedo, fitted) {
                            (_, Some(a)) => a,
                            (Albedo::Given(given), None) => given[j],
                            (Albedo::Fitted, None) => unreachable!(),
                        };
                        let pred = a * b + c;
                        *total += o.sq_err(pred);
                        *count += 3;
                        *ip += pred.dot(o.g) as f64;
                        *pp += pred.dot(pred) as f64;
                    }
                }
            }
            sums.into_iter().map(|(total, count, ip, pp)| {
                if count == 0 {
                    (f64::NAN, f64::NAN)
                } else {
                    (total / count as f64, ip / pp)
                }
            })
        })
        .collect();
    let per_region = metallic.len() * sigma.len();
    (0..regions)
        .map(|r| RegionProfile {
            region: r as u32,
            pixels: spans[r].iter().map(|s| s.len()).sum(),
            cells: spans[r].len(),
            sigma: sigma.to_vec(),
            metallic: metallic.to_vec(),
            cost: costs[r * per_region..(r + 1) * per_region]
                .chunks(sigma.len())
                .map(|c| c.iter().map(|x| x.0).collect())
                .collect(),
            gain: match albedo {
                Albedo::Fitted => vec![],
                Albedo::Given(_) => costs[r * per_region..(r + 1) * per_region]
                    .chunks(sigma.len())
                    .map(|c| c.iter().map(|x| x.1).collect())
                    .collect(),
            },
            one_colour: vec![],
        })
        .collect()
}

mod choice;
use choice::argmin;
pub use choice::choose;

mod one_colour;
pub use one_colour::{one_cell_per_region, with_one_colour};

pub mod divided;
pub mod gloss;
pub mod split;

#[cfg(test)]
mod tests;
