//! The material search between the bake (or a refinement) and a training round, and its cost
//! curves per region for `fipt profile` (with the ground truth's base colour beside the fitted
//! one when the scene has it).
use crate::bail;
use crate::error::Result;
use crate::regions::Regions;
use crate::scene::SceneRef;
use fipt_bake::bake_store::StoredShadings;
use fipt_core::fsutil::{read_json, write_json_atomic};
use fipt_core::image::{BadPixelPolicy, Image};
use fipt_core::shading::{ViewShadings, NUM_LEVELS};
use fipt_search::divided::{choose_regions, Divided, DividedCells, SideLookup};
use fipt_search::gloss::gloss_split;
use fipt_search::split::{colour_split, ColourSplit};
use fipt_search::{
    choose, gather_pixels_keyed, profile, sigma_grid, true_base_colours, view_pixels,
    with_cells_keyed, Albedo, RegionChoice, RegionProfile, RegionSource, SearchConfig, SearchPixel,
};
use fipt_shading::records::{HitPoint, PrimaryHit};
use serde::Serialize;

mod clipped;
mod diffuse;
mod outline;
mod profile;
use outline::{region_rule, train_eyes};
pub use profile::{profile_rows, ProfileRequest, ProfileRow};

/// What the search found: per region the decision, and per training pixel its targets
/// (σ*, m*), None off the regions.
#[derive(Serialize)]
pub struct Searched {
    pub source: &'static str,
    pub regions: Vec<(i64, RegionChoice)>,
    /// Regions divided (by colour or by gloss) whose sides keep their own decisions
    /// (`[search.split]`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub divided: Vec<Divided>,
    #[serde(skip)]
    pub targets: PixelTargets,
    /// The training pixels (view, pixel) on the second side of divided region k: the segment
    /// prior treats each side as a part of its own.
    #[serde(skip)]
    pub second_sides: Vec<(u32, u32, u32)>,
    pub seconds: f64,
}

/// Each training pixel's search target (σ*, m*; NaN where its region has none), as an index
/// into the few distinct targets: 4 bytes a pixel where an `Option<[f32; 2]>` took 12.
#[derive(Default)]
pub struct PixelTargets {
    /// The regions' choices in region order, then each divided region's two sides.
    pub table: Vec<[f32; 2]>,
    /// `index[v][i]`: the entry of pixel `i` of view `v`; [`PixelTargets::NONE`] off the
    /// regions.
    pub index: Vec<Vec<u32>>,
}

impl PixelTargets {
    pub const NONE: u32 = u32::MAX;

    /// Pixel `i` of view `v`: its target, None off the regions; None outside the views.
    pub fn get(&self, v: usize, i: usize) -> Option<Option<[f32; 2]>> {
        let k = *self.index.get(v)?.get(i)?;
        Some((k != Self::NONE).then(|| self.table[k as usize]))
    }
}

/// The search's regions, pixels and σ candidates for one set of shadings.
struct Prepared {
    regions: Regions,
    pixels: Vec<SearchPixel>,
    /// The voxel of each surface cell.
    voxels: Vec<[i32; 3]>,
    grid: Vec<f32>,
}

/// The search's pixels, regions and σ grid for `shadings`.
fn prepare(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    shadings: &[ViewShadings],
    cfg: &SearchConfig,
    footprint: f32,
) -> Result<Option<Prepared>> {
    let Some(regions) = crate::regions::load(scene, records, cfg.regions, cfg.mesh_angle_deg)?
    else {
        return Ok(None);
    };
    let (pixels, voxels, grid) = search_pixels(scene, records, shadings, &regions, cfg, footprint);
    Ok(Some(Prepared {
        regions,
        pixels,
        voxels,
        grid,
    }))
}

/// The σ candidates of the search on shadings of these levels.
fn sigma_candidates(first: Option<&ViewShadings>, cfg: &SearchConfig) -> Vec<f32> {
    let levels = first.map_or(fipt_core::shading::DEFAULT_LEVELS, |s| s.levels);
    sigma_grid(levels[0], levels[NUM_LEVELS - 1], cfg.roughness_steps)
}

/// The search's pixels of `regions` (outlines left out with `cfg.drop_edges`), the voxels of
/// their cells and the σ candidates.
fn search_pixels(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    shadings: &[ViewShadings],
    regions: &Regions,
    cfg: &SearchConfig,
    footprint: f32,
) -> (Vec<SearchPixel>, Vec<[i32; 3]>, Vec<f32>) {
    let rule = region_rule(&scene.images, records, train_eyes(scene), regions, cfg);
    let cell = cfg.cell_footprints * footprint;
    let (pixels, voxels) = gather_pixels_keyed(records, shadings, cell, &rule);
    (pixels, voxels, sigma_candidates(shadings.first(), cfg))
}

/// The regions divided in two: by colour, then by gloss where the colour leaves a region whole
/// or its colour sides are the shallower division
/// (none on the bake, where dielectric σ waits for the refined shadings). Prints what the
/// gloss split measured on each region it could cut.
#[allow(clippy::too_many_arguments)]
fn divide(
    pixels: &[SearchPixel],
    voxels: &[[i32; 3]],
    shadings: &[ViewShadings],
    images: &[Image],
    grid: &[f32],
    regions: &Regions,
    cfg: &SearchConfig,
    on_bake: bool,
) -> ColourSplit {
    if on_bake {
        return ColourSplit::none(regions.len());
    }
    let n = regions.len();
    let by_colour = colour_split(pixels, shadings, images, n, cfg.min_pixels, &cfg.split);
    let (split, cuts) = gloss_split(
        by_colour,
        pixels,
        voxels,
        shadings,
        images,
        grid,
        cfg.min_pixels,
        &cfg.split,
    );
    // A cut the two halves of the views do not reproduce (about half the cells agree) is
    // noise: only the others, and every cut that divides, are printed.
    const PRINTED_AGREEMENT: f64 = 0.6;
    for c in (cuts.iter()).filter(|c| c.divided || c.agreement >= PRINTED_AGREEMENT) {
        crate::note!(
            "search: region {} cut by gloss at σ {:.2} / {:.2} ({:.0} % rougher side, halves agree on {:.0} %, depth {:.1} %): {}",
            regions.labels[c.region as usize],
            c.sigma[0],
            c.sigma[1],
            100.0 * c.share,
            100.0 * c.agreement,
            100.0 * c.depth,
            if c.divided {
                "divided"
            } else if c.colour_stands {
                "the colour division stands"
            } else {
                "kept whole"
            }
        );
    }
    split
}

/// The hits on a region (the shadings' validity is known view by view), and the share of them
/// the search keeps: 1, or `search.max_pixels` of them.
fn candidates_and_share(
    records: &[Vec<Option<HitPoint>>],
    regions: &Regions,
    cfg: &SearchConfig,
) -> (usize, f64) {
    let candidates: usize = (regions.ids.iter().zip(records))
        .map(|(ids, recs)| {
            (ids.iter().zip(recs))
                .filter(|(&r, h)| r != Regions::NONE && h.is_some())
                .count()
        })
        .sum();
    let share = match cfg.max_pixels {
        0 => 1.0,
        m => m as f64 / candidates.max(1) as f64,
    };
    (candidates, share)
}

/// The share of the hit pixels the search will keep (`search.max_pixels`; drawn from the run's
/// `train.seed`), before any shading exists: 1 when it keeps every one, None when it does not
/// run. `hits`: every view's hits (when no more than the cap, the regions are not read).
pub(crate) fn drawn_share(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    cfg: &SearchConfig,
    hits: usize,
) -> Result<Option<f64>> {
    if !cfg.enabled || cfg.regions == fipt_search::RegionSource::None {
        return Ok(None);
    }
    if cfg.max_pixels == 0 || hits <= cfg.max_pixels {
        return Ok(Some(1.0));
    }
    let Some(regions) = crate::regions::load(scene, records, cfg.regions, cfg.mesh_angle_deg)?
    else {
        return Ok(None);
    };
    Ok(Some(
        candidates_and_share(records, &regions, cfg).1.min(1.0),
    ))
}

/// What the search reads, and nothing more.
struct Compact {
    pixels: Vec<SearchPixel>,
    /// Per view, the shadings of its search pixels as one row (`SearchPixel::pixel` indexes it).
    shadings: Vec<ViewShadings>,
    /// The same pixels' image values.
    images: Vec<Image>,
    grid: Vec<f32>,
    /// The voxel of each surface cell.
    voxels: Vec<[i32; 3]>,
}

/// The search's pixels with only their shadings and image values held: each view's shadings
/// are read from disk in turn and cut down to the pixels the search uses, at most
/// `cfg.max_pixels` of them (a uniform random share beyond).
fn compact_inputs(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    on: &SearchOn,
    regions: &Regions,
    cfg: &SearchConfig,
    footprint: f32,
) -> Result<Compact> {
    let (stored, seed) = (on.shadings, on.seed);
    let rule = region_rule(&scene.images, records, train_eyes(scene), regions, cfg);
    let (candidates, share) = candidates_and_share(records, regions, cfg);
    let wanted = fipt_core::shading::PixelDraw::new(seed, Some(share));
    if let Some(why) = crate::bake::uncovered(&stored.pixels, &wanted) {
        crate::bail!(
            "the shadings in {}: {why} (search.max_pixels, train.seed): run with the settings that made them, or with --force",
            stored.dir.display()
        );
    }
    // Pixels a view's mask leaves out (people, screens) say nothing of the materials.
    let masked = |v: usize, i: usize| scene.masked.get(v).is_some_and(|m| m.get(i) == Some(&true));
    let keep = |v: usize, i: usize, h: &HitPoint| {
        rule(v, i, h)
            .filter(|_| !masked(v, i))
            .filter(|_| fipt_core::rng::pixel_kept(seed, v, i, share))
    };
    let limit = diffuse::NEAR_FOOTPRINTS * footprint;
    let near = |recs: &[Option<HitPoint>], i: usize, j: usize| match (&recs[i], &recs[j]) {
        (Some(a), Some(b)) => a.point().distance(b.point()) <= limit,
        _ => false,
    };
    let (mut keyed, mut shadings, mut images, mut clipped) = (vec![], vec![], vec![], vec![]);
    // One buffer for every view's file, and only the kept pixels decoded (a whole view
    // decoded is 181 bytes a pixel, 55 MB at 640 × 480, read and freed for every view).
    let mut buf = vec![];
    for (v, recs) in records.iter().enumerate() {
        let file = stored.read_view(v, &mut buf)?;
        let valid = file.valid();
        // Clipped pixels off the lights (an LDR view's highlights): lower bounds, and those
        // beside a light left out.
        let marks = (scene.left_out.get(v))
            .filter(|o| cfg.clipped_as_bounds && !o.is_empty())
            .map(|o| clipped::marks(o, &scene.images[v]));
        let beside =
            |i: usize| (marks.as_ref()).is_some_and(|m| m.beside_light.get(i) == Some(&true));
        let keep_v = |v: usize, i: usize, h: &HitPoint| keep(v, i, h).filter(|_| !beside(i));
        let mine = view_pixels(v, recs, &valid, &keep_v);
        let idx: Vec<u32> = mine.iter().map(|k| k.1).collect();
        let mut rows = file.select(&idx);
        let nb = diffuse::Neighbours {
            radius: cfg.diffuse_radius as usize,
            region: &|j| regions.id(v, j),
            valid: &|j| valid[j],
            near: &|i, j| near(recs, i, j),
        };
        diffuse::smooth(&mut rows, &idx, file.size(), &nb, &|ix| file.select(ix));
        shadings.push(rows);
        let data = idx
            .iter()
            .map(|&i| scene.images[v].data[i as usize])
            .collect();
        images.push(Image {
            width: idx.len(),
            height: 1,
            data,
        });
        let bound =
            |i: u32| (marks.as_ref()).is_some_and(|m| m.bound.get(i as usize) == Some(&true));
        clipped.extend(idx.iter().map(|&i| bound(i)));
        let at = mine.into_iter().enumerate();
        keyed.extend(at.map(|(j, (v, _, r, p))| (v, j as u32, r, p)));
    }
    if share < 1.0 {
        crate::note!(
            "search: {} of {candidates} pixels, a uniform share (search.max_pixels)",
            keyed.len()
        );
    }
    let (mut pixels, voxels) = with_cells_keyed(&keyed, cfg.cell_footprints * footprint);
    for (p, c) in pixels.iter_mut().zip(clipped) {
        p.clipped = c;
    }
    Ok(Compact {
        pixels,
        grid: sigma_candidates(shadings.first(), cfg),
        shadings,
        images,
        voxels,
    })
}

/// Every region's profile on each half of the views (even, odd), for `held_out`.
type Halves = Option<[Vec<RegionProfile>; 2]>;

/// The fitted profiles of every region, with their one-colour rows (`one_colour_below`), and
/// with `cfg.held_out` the same on each half of the views. Neither is wanted on the bake
/// (`refined` false), where dielectric σ waits for the refined shadings.
fn fitted_profiles(
    images: &[Image],
    shadings: &[ViewShadings],
    regions: usize,
    pixels: &[SearchPixel],
    grid: &[f32],
    cfg: &SearchConfig,
    refined: bool,
) -> (Vec<RegionProfile>, Halves) {
    let halves = cfg.held_out && refined;
    let fitted = |pixels: &[SearchPixel]| {
        profile(
            pixels,
            shadings,
            images,
            regions,
            grid,
            &cfg.metallic,
            Albedo::Fitted,
        )
    };
    let halves = halves.then(|| {
        [0, 1].map(|parity| {
            let half: Vec<SearchPixel> = pixels
                .iter()
                .filter(|p| p.view % 2 == parity)
                .copied()
                .collect();
            fitted(&half)
        })
    });
    let whole = fitted(pixels);
    let whole = if refined && cfg.one_colour_below > 0.0 {
        fipt_search::with_one_colour(whole, pixels, shadings, images, grid)
    } else {
        whole
    };
    (whole, halves)
}

/// The shadings a search reads: where they are, their fingerprint, whether a search kept
/// beside them may be reused (not with `--force`), and the seed its share of the pixels is
/// drawn from beyond `search.max_pixels` (the run's `train.seed`: the share then nests with
/// the training set's, and the pixels drawn before the bake hold both).
pub struct SearchOn<'a> {
    pub shadings: &'a StoredShadings,
    pub id: &'a str,
    pub force: bool,
    pub seed: u64,
}

/// A finished search kept beside its shadings (`search.json`): what it was keyed on and what
/// it decided (the per-pixel targets follow from the regions).
#[derive(Serialize, serde::Deserialize)]
struct KeptSearch {
    key: String,
    source: String,
    regions: Vec<(i64, RegionChoice)>,
    #[serde(default)]
    divided: Vec<Divided>,
    #[serde(default)]
    divided_cells: DividedCells,
    seconds: f64,
}

/// Runs the search (None when it is off or has no regions; the reason is printed).
/// The search on the initial bake, when `cfg.on_bake` asks for it.
pub fn on_bake(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    on: SearchOn,
    cfg: &SearchConfig,
    footprint: f32,
) -> Result<Option<Searched>> {
    if !cfg.on_bake {
        return Ok(None);
    }
    stage(scene, records, on, cfg, footprint, None, When::Bake)
}

/// Which shadings the search reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum When {
    /// The initial bake: dielectric σ waits for the refined shadings.
    Bake,
    /// A refinement.
    Refined,
    /// The refinement of a settling round (`rounds.settle_rounds`): a dielectric keeps a σ
    /// target only where the previous search set one too. The round corrects the light that
    /// the last albedo fed back; gloss seen only now has no round to confirm it (on the tiny
    /// `cornell` a second search made the ceiling's light-rim residual σ 0.54).
    Settling,
}

/// The search on the shadings `on` names: reused from `search.json` beside them when it was
/// made with the same shadings, settings, regions and previous decisions (a resumed run does
/// not read every view's shadings again), else run and kept there.
pub fn stage(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    on: SearchOn,
    cfg: &SearchConfig,
    footprint: f32,
    previous: Option<&Searched>,
    when: When,
) -> Result<Option<Searched>> {
    if !cfg.enabled {
        return Ok(None);
    }
    let Some(regions) = crate::regions::load(scene, records, cfg.regions, cfg.mesh_angle_deg)?
    else {
        crate::note!("search: skipped (search.regions = \"none\")");
        return Ok(None);
    };
    let key = search_key(&on, cfg, footprint, previous, when, &regions)?;
    let kept = on.shadings.dir.join("search.json");
    let reuse = (!on.force)
        .then(|| read_json::<KeptSearch>(&kept).ok())
        .flatten()
        .filter(|k| k.key == key);
    let (found, seconds) = match reuse {
        Some(k) => {
            crate::note!(
                "reusing the search in {} ({:.1} s); --force to redo it",
                kept.display(),
                k.seconds
            );
            crate::observe::reused(Some(k.seconds));
            let found = Decisions {
                choices: k.regions.into_iter().map(|r| r.1).collect(),
                divided: k.divided,
                cells: k.divided_cells,
            };
            (found, k.seconds)
        }
        None => {
            let t = std::time::Instant::now();
            let found = decide(
                scene, records, &on, cfg, footprint, previous, when, &regions,
            )?;
            let seconds = t.elapsed().as_secs_f64();
            let keep = KeptSearch {
                key,
                source: regions.source.to_string(),
                regions: (regions.labels.iter().copied())
                    .zip(found.choices.clone())
                    .collect(),
                divided: found.divided.clone(),
                divided_cells: found.cells.clone(),
                seconds,
            };
            write_json_atomic(&kept, &keep)?;
            (found, seconds)
        }
    };
    let Decisions {
        choices,
        divided,
        cells,
    } = found;
    let (targets, second_sides) = pixel_targets(&regions, records, &choices, &divided, &cells);
    let glossy = choices.iter().filter(|c| c.roughness.is_some()).count();
    let metal = choices.iter().filter(|c| c.metallic > Some(0.5)).count();
    crate::note!(
        "search: {} regions ({}): {} with a σ target, {} metal, {} divided, in {:.1} s",
        regions.len(),
        regions.source,
        glossy,
        metal,
        divided.len(),
        seconds
    );
    if when != When::Bake {
        crate::note!("{}", pinning(&regions.labels, &choices, &divided, cfg));
    }
    Ok(Some(Searched {
        source: regions.source,
        regions: regions.labels.iter().copied().zip(choices).collect(),
        divided,
        targets,
        second_sides,
        seconds,
    }))
}

/// How strongly the views pin each region's σ: σ = 1's cost over the dielectric minimum
/// (0 %: the views say nothing of σ; tens of %: a lobe they see clearly), beside the decision.
fn pinning(
    labels: &[i64],
    choices: &[RegionChoice],
    divided: &[Divided],
    cfg: &SearchConfig,
) -> String {
    let d = cfg.metallic.iter().position(|&m| m == 0.0);
    let entry = |name: String, c: &RegionChoice| {
        let best = d.and_then(|d| c.best_cost.get(d).copied());
        let depth = best.map(|b| 100.0 * (c.default_cost / b - 1.0));
        let depth = match depth.filter(|d| d.is_finite()) {
            Some(d) => format!("{d:.1} %"),
            None => "no pixel profiled".into(),
        };
        let sigma = c.roughness.map_or("–".to_string(), |s| format!("{s:.2}"));
        let metal = if c.metallic > Some(0.5) { " metal" } else { "" };
        format!("{name} {sigma}{metal} ({depth})")
    };
    let mut parts = vec![];
    for (label, c) in labels.iter().zip(choices) {
        match divided.iter().find(|d| d.label == *label) {
            Some(d) => {
                parts.push(entry(format!("{label}a"), &d.sides[0]));
                parts.push(entry(format!("{label}b"), &d.sides[1]));
            }
            None => parts.push(entry(label.to_string(), c)),
        }
    }
    format!(
        "search: σ per region and how strongly the views pin it (σ = 1's excess over the minimum): {}",
        parts.join(", ")
    )
}

/// Each training pixel's σ and metallic target ([NaN, NaN] where its region has none; none
/// off the regions): its region's choice, or the side of a divided region it lies on; and the
/// pixels on second sides (view, pixel, divided region).
#[allow(clippy::type_complexity)]
fn pixel_targets(
    regions: &crate::regions::Regions,
    records: &[Vec<Option<HitPoint>>],
    choices: &[RegionChoice],
    divided: &[Divided],
    cells: &DividedCells,
) -> (PixelTargets, Vec<(u32, u32, u32)>) {
    let sides = SideLookup::new(divided, cells);
    let target = |c: &RegionChoice| {
        [
            c.roughness.unwrap_or(f32::NAN),
            c.metallic.unwrap_or(f32::NAN),
        ]
    };
    let table = (choices.iter().map(target))
        .chain(divided.iter().flat_map(|d| d.sides.iter().map(target)))
        .collect();
    let first_side = choices.len() as u32;
    let mut second_sides = vec![];
    let index = (regions.ids.iter().zip(records).enumerate())
        .map(|(v, (ids, recs))| {
            (ids.iter().zip(recs).enumerate())
                .map(|(i, (r, h))| {
                    let r = *r;
                    if r == Regions::NONE {
                        return PixelTargets::NONE;
                    }
                    let Some((k, side)) = h.and_then(|h| sides.side(r, h.point())) else {
                        return r;
                    };
                    if side == 1 {
                        second_sides.push((v as u32, i as u32, k as u32));
                    }
                    first_side + 2 * k as u32 + side as u32
                })
                .collect()
        })
        .collect();
    (PixelTargets { table, index }, second_sides)
}

/// What a search's decisions are a function of.
fn search_key(
    on: &SearchOn,
    cfg: &SearchConfig,
    footprint: f32,
    previous: Option<&Searched>,
    when: When,
    regions: &Regions,
) -> Result<String> {
    // Hashed piece by piece (the bytes of every pixel's id together took 4 bytes a pixel).
    let mut ids = fipt_core::fsutil::Fnv::new();
    for view in &regions.ids {
        let bytes: Vec<u8> = (view.iter()).flat_map(|r| r.to_le_bytes()).collect();
        ids.feed(&bytes);
    }
    for l in &regions.labels {
        ids.feed(&l.to_le_bytes());
    }
    let previous = previous
        .map(|p| serde_json::to_value(&p.regions))
        .transpose()?;
    let settings = serde_json::json!({
        "search": cfg,
        "when": when,
        "footprint": footprint,
        "previous": previous,
    });
    let mut key = format!(
        "{}|{}|{}|{}",
        on.id,
        fipt_core::fsutil::hash_json(&settings),
        regions.source,
        ids.hex()
    );
    if on.seed != 0 {
        key += &format!("|seed {}", on.seed);
    }
    Ok(key)
}

/// What a search decided: per region, then the divided regions and their cells.
struct Decisions {
    choices: Vec<RegionChoice>,
    divided: Vec<Divided>,
    cells: DividedCells,
}

/// The search's decision per region on `shadings` (read view by view; only the search's own
/// pixels' shadings are held, see [`compact_inputs`]).
#[allow(clippy::too_many_arguments)]
fn decide(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    on: &SearchOn,
    cfg: &SearchConfig,
    footprint: f32,
    previous: Option<&Searched>,
    when: When,
    regions: &Regions,
) -> Result<Decisions> {
    let on_bake = when == When::Bake;
    let bake_cfg = SearchConfig {
        metal_margin: cfg.bake_metal_margin,
        ..cfg.clone()
    };
    let cfg = if on_bake { &bake_cfg } else { cfg };
    let c = compact_inputs(scene, records, on, regions, cfg, footprint)?;
    // Dielectric σ waits for the refined shadings, and with it the division of regions.
    let split = divide(
        &c.pixels,
        &c.voxels,
        &c.shadings,
        &c.images,
        &c.grid,
        regions,
        cfg,
        on_bake,
    );
    let (profiles, halves) = fitted_profiles(
        &c.images,
        &c.shadings,
        split.regions(),
        &split.apply(&c.pixels),
        &c.grid,
        cfg,
        !on_bake,
    );
    // What the previous search said of a region (as a whole or on either side).
    let previously = |label: i64, test: &dyn Fn(&RegionChoice) -> bool| {
        previous.is_some_and(|s| {
            let whole = s.regions.iter().any(|(l, c)| *l == label && test(c));
            whole || (s.divided.iter()).any(|d| d.label == label && d.sides.iter().any(test))
        })
    };
    let choose_one = |p: &RegionProfile, held: Option<[&RegionProfile; 2]>, r: usize| {
        let label = regions.labels[r];
        let was_metal = previously(label, &|c| c.metallic > Some(0.5));
        let mut c = choose(p, cfg, was_metal, held);
        let dielectric = c.metallic < Some(0.5);
        let had_target = previously(label, &|c| c.roughness.is_some());
        if dielectric && (on_bake || (when == When::Settling && !had_target)) {
            c.roughness = None;
        }
        c
    };
    let (choices, kept) =
        choose_regions(&profiles, halves.as_ref(), &split, &cfg.split, &choose_one);
    let mut cells = DividedCells {
        cell: cfg.cell_footprints * footprint,
        cells: vec![vec![]; kept.len()],
    };
    let slot: std::collections::HashMap<u32, usize> = (kept.iter().enumerate())
        .map(|(k, d)| (d.0 as u32, k))
        .collect();
    let mut region_of_cell = vec![u32::MAX; c.voxels.len()];
    for p in &c.pixels {
        region_of_cell[p.cell as usize] = p.region;
    }
    for (cell, &r) in region_of_cell.iter().enumerate() {
        if let Some(&k) = slot.get(&r) {
            cells.cells[k].push((c.voxels[cell], split.side[cell]));
        }
    }
    let divided = kept
        .into_iter()
        .map(|(r, sides, pixels, crossed)| Divided {
            region: r as u32,
            label: regions.labels[r],
            sides,
            pixels,
            crossed,
        })
        .collect();
    Ok(Decisions {
        choices,
        divided,
        cells,
    })
}

/// The true base colour's σ argmins at m = 0 and m = 1, and the views' scale against the
/// model at the better of the two (`GT gain`).
pub fn given_summary(g: &RegionProfile) -> ([f32; 2], f64) {
    let am = |row: &[f64]| -> Option<(usize, f64)> {
        row.iter()
            .copied()
            .enumerate()
            .filter(|x| x.1.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let at = |row: &[f64]| am(row).map_or(f32::NAN, |x| g.sigma[x.0]);
    let m = [0, 4]
        .into_iter()
        .min_by(|&a, &b| {
            let c = |k: usize| am(&g.cost[k]).map_or(f64::INFINITY, |x| x.1);
            c(a).total_cmp(&c(b))
        })
        .unwrap_or(0);
    let gain = am(&g.cost[m]).map_or(f64::NAN, |x| g.gain[m][x.0]);
    ([at(&g.cost[0]), at(&g.cost[4])], gain)
}
