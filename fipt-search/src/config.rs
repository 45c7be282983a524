//! The search's settings (`[search]` in a run config): the decision rules' tolerances, where
//! regions come from, and the presets.
use crate::split;
use serde::{Deserialize, Serialize};

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
    /// With `drop_edges`: a region whose outline pixels (a neighbour, of the 8, in another
    /// region or in none, however bright) are at most this share of its pixels over the views
    /// loses all of them, not only those `edge_contrast` picks. A bright object's silhouette
    /// mixes it with the darker room behind it: on `atelier`'s plaster sphere (σ 1) that ring,
    /// 9 % of its pixels, made a minimum at σ 0.70 costing 13 % less than σ = 1; without it
    /// the minimum is at 1.00. A region mostly outline (small images) keeps the contrast rule
    /// alone. 0 (the default): the contrast rule alone. Off since 2026-12-04: at 0.25 it
    /// read that sphere right but moved faint-gloss walls and the silhouettes' real gloss
    /// (val σ −4.7 dB on `loft`, −1.2 on `studio-mitsuba`, −0.3 on `bedroom`, +1.6 on
    /// `atelier`; `docs/roughness-rooms.md`, *Silhouettes*).
    #[serde(default = "default_outline_share")]
    pub outline_share: f32,
    /// With `drop_edges`: also leave out silhouette pixels, beside a neighbour however much
    /// less bright than `edge_contrast` asks (`silhouette_contrast` decides): those with a
    /// neighbour (of the 8) in another region, or in none, whose hit lies farther from the
    /// pixel's own than this share of the pixel's distance to the camera (or that has no hit). Across an occlusion the pixel's footprint mixes a surface with
    /// the one behind or in front of it; along a crease, where two regions meet at one depth,
    /// the neighbours' hits are close and the contrast rule alone decides. A region whose
    /// silhouette is over a quarter of its pixels (thin, or small in the images) keeps them.
    /// With `silhouette_contrast` 1.5 and the colour sides' depth, on five Mitsuba rooms and a
    /// capture copy (balanced) val σ moved +0.70 (`studio-mitsuba`), −0.04, +0.06, −0.01,
    /// +1.20 (`atelier`: its plaster sphere 0.74 → 0.83 for 1.0) and +0.83 dB
    /// (`docs/roughness-rooms.md`, *Silhouettes by depth*). 0: off.
    #[serde(default = "default_silhouette_gap")]
    pub silhouette_gap: f32,
    /// With `silhouette_gap`: only a neighbour across the occlusion at least this many times
    /// brighter or darker makes a silhouette pixel (1: any). Mixing costs a pixel a share of
    /// the contrast; where the two surfaces are alike, the pixel keeps its grazing view, which
    /// carries gloss. With 1, the CLI's 12-view 48 × 36 accuracy scene (FIPT's Lambert model
    /// on principled views) lost its tall block's σ (0.95 read 0.64; train σ 13.6 dB against
    /// 16.8 for σ ≡ 1); 1.2 scored 13.9, 1.5 18.8, 2 18.1. At 1.5 `atelier` keeps its gain
    /// (val σ 24.56 against 24.63 at 1; `docs/roughness-rooms.md`, *Silhouettes by depth*).
    #[serde(default = "default_silhouette_contrast")]
    pub silhouette_contrast: f32,
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
    /// A dielectric whose minimum is interior (at least `interior_sigma`, beating σ = 1 by
    /// `interior_gain`, more than `rough_band` below the roughest candidate) but does not
    /// hold out on the halves gets the midpoint of the interior rule's σ and the roughest
    /// candidate as its target, not none. The views then say the surface is glossier than
    /// σ = 1 on the whole but not where; without a target the training took such walls to
    /// 0.99 (`loft`'s right wall, σ 0.85, once its pixels changed by 2 %: 30.1 → 16.8 dB), and
    /// the midpoint's worst error over the two readings is half of either's
    /// (`docs/roughness-rooms.md`, *Disputed minima*). false: no target, as before 2026-12-04.
    #[serde(default = "default_true")]
    pub hedge_disputed: bool,
    /// Under `dielectric_rule = "minimum"`, a dielectric whose minimum lies at or above this
    /// σ and whose halves of the views bear it out but put their own minima more than
    /// `held_out_band` apart takes the midpoint of its minimum and the rougher half's, not the
    /// minimum, however deep its curve. Pose error,
    /// pixel noise and a tone curve's error pull a rough surface's faint curve glossy in one
    /// half of the views and not the other: ceilings of σ 1 read 0.70–0.84 with halves at
    /// 1.0 in capture-like copies of `studio-mitsuba` and `room`, and `atelier`'s plaster
    /// sphere (σ 1) 0.84 with halves at 0.96 and 0.80. Below it the split is real gloss that
    /// half the views miss (`bedroom`'s painted wall, σ 0.45: 0.48 with halves at 0.48 and
    /// 1.0). The midpoint's worst error over the two readings is half of either's. 0: off.
    #[serde(default = "default_split_halves_above")]
    pub split_halves_above: f32,
    /// Under `dielectric_rule = "minimum"`, a dielectric whose curve is deep (σ = 1 at least
    /// this fraction above its minimum, which lies at or above `interior_sigma`) but whose
    /// halves do not bear its minimum out takes the median of its minimum and the halves' own
    /// (no lower than `interior_sigma`), not the lifted rules' answer, in a region of 2,000
    /// search pixels or more (after `max_pixels`; smaller ones' halves are too noisy). Those
    /// rules undo the glossy pull of noise on faint curves; on a deep one they lift a glossy
    /// object towards rough: `room`'s glossy box (σ 0.15, 0.2 in the val clamp) in capture-like copies, minimum
    /// 0.34 with halves at 0.34 and 0.10, read 0.54–0.58. Depth is evidence that the surface
    /// is glossy; the halves' disagreement says where between their readings, and the
    /// median is the reading two of the three share or lie either side of. The same median
    /// (held at `interior_sigma`) is the target of a dielectric the other rules leave without
    /// one whose deep minimum lies at the mirror end, under `interior_sigma`, where a half of
    /// the views finds a lobe (`bedroom`'s lamp pole, σ 0.4, read 0.95 without a target;
    /// `docs/phone-captures.md` section 12). 0: off.
    #[serde(default = "default_deep_median_gain")]
    pub deep_median_gain: f32,
    /// An ablation, off: an LDR view's clipped pixels off the lights take part in the search
    /// as lower bounds (no part in a cell's base-colour fit, a cost only where a candidate
    /// predicts less than the clipped value), and those within two pixels of a light's
    /// clipped pixels are left out. Off, they count as exact values, which a clipped
    /// highlight is not: a rougher lobe's lower peak fits the clip level best. On five
    /// capture-like copies it read `studio-mitsuba`'s metal sphere (σ 0.25) at 0.25–0.27
    /// where it reads 0.34–0.46, its mirror metal, and `room`'s glossy box (σ 0.15, 0.2 in
    /// the val clamp) at 0.20 where it reads 0.35; but val σ moved by −1.3 to +0.6 dB and
    /// novel views by −2.6 to +0.1 (`docs/phone-captures.md`, section 8). `fipt profile`
    /// does not apply it (its pixels count as exact there). Left out of the serialised
    /// settings when off, so that it changes no search key.
    #[serde(default, skip_serializing_if = "is_false")]
    pub clipped_as_bounds: bool,
    /// At most this many pixels take part (a uniform random share of them beyond it, the
    /// same for the same views); only they and their shadings are held while the search
    /// runs, 182 bytes each with `principled`. 0: every pixel.
    #[serde(default = "default_max_pixels")]
    pub max_pixels: usize,
    /// With a value above 0, a dielectric whose fitted curve has σ = 1 less than this
    /// fraction above its minimum (faint gloss: rough walls, plaster, cloth) is also
    /// profiled with one base colour for the whole region ([`RegionProfile::one_colour`](crate::RegionProfile::one_colour)).
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
    /// The search reads each pixel's diffuse shading (Ld, and [Ld1, Ld2] under
    /// `principled`) as the mean over the pixels within this many rows and columns of it, in
    /// the same view and region, with valid shadings, whose hits lie within two median pixel
    /// footprints of its own. Noise in Ld, the regressor of the per-cell base
    /// colour, pulls faintly glossy surfaces' minima glossy: with the ground truth's
    /// materials and lights refined, `room`'s walls (σ 0.85–0.95) had their minima at
    /// 0.62–0.72 with Ld as refined and 0.74–0.80 with 1 (`docs/roughness-rooms.md`, *Where
    /// rough walls' glossy minima come from*). 0: Ld as refined.
    #[serde(default = "default_diffuse_radius")]
    pub diffuse_radius: u32,
    /// How a dielectric's σ follows from its curve. `minimum` (the default): its minimum,
    /// when that lies at or above `interior_sigma` (below, a diffuse lobe that is not the
    /// data's) and, on a refined search with `held_out` (the halves are profiled only then),
    /// the halves of the views bear it out (one half's own minimum within `held_out_band` of
    /// it, neither more than the band glossier); otherwise the lifted rules decide. `lifted`:
    /// the tolerances, the interior rule and its quarter-of-the-gain lift, the held-out
    /// halves, `rough_band` and `hedge_disputed`, which were made to undo the glossy pull of
    /// noise in Ld. Replayed on the stored curves
    /// of five Mitsuba rooms (`docs/roughness-rooms.md`), the minimum with `diffuse_radius =
    /// 1` scored 28.9 dB against 25.4 for `lifted` with 0 (every room higher), and 21.6 with 0.
    #[serde(default)]
    pub dielectric_rule: DielectricRule,
    /// Dividing regions of two finishes by colour ([`split`](crate::split)) or by gloss ([`gloss`](crate::gloss)).
    #[serde(default)]
    pub split: split::SplitConfig,
}

fn default_diffuse_radius() -> u32 {
    1
}

fn default_one_colour_below() -> f32 {
    0.0
}

fn is_false(b: &bool) -> bool {
    !*b
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

fn default_deep_median_gain() -> f32 {
    0.05
}

fn default_split_halves_above() -> f32 {
    0.6
}

fn default_true() -> bool {
    true
}

fn default_outline_share() -> f32 {
    0.0
}

fn default_silhouette_gap() -> f32 {
    0.05
}

fn default_silhouette_contrast() -> f32 {
    1.5
}

fn default_max_pixels() -> usize {
    8_000_000
}

/// How a dielectric's σ follows from its cost curve (`[search] dielectric_rule`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DielectricRule {
    /// The curve's minimum.
    #[default]
    Minimum,
    /// The tolerance, interior, held-out and band rules.
    Lifted,
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
            outline_share: default_outline_share(),
            silhouette_gap: default_silhouette_gap(),
            silhouette_contrast: default_silhouette_contrast(),
            held_out: true,
            held_out_band: default_held_out_band(),
            rough_band: default_held_out_band(),
            hedge_disputed: true,
            split_halves_above: default_split_halves_above(),
            deep_median_gain: default_deep_median_gain(),
            clipped_as_bounds: false,
            max_pixels: default_max_pixels(),
            one_colour_below: default_one_colour_below(),
            diffuse_radius: default_diffuse_radius(),
            dielectric_rule: DielectricRule::default(),
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
            ("split_halves_above", self.split_halves_above, 1.0),
            ("deep_median_gain", self.deep_median_gain, 1e6),
            ("one_colour_below", self.one_colour_below, 1e6),
            ("edge_contrast", self.edge_contrast, 1e6),
            ("outline_share", self.outline_share, 1.0),
            ("silhouette_gap", self.silhouette_gap, 1e6),
        ];
        if !(self.silhouette_contrast >= 1.0 && self.silhouette_contrast <= 1e6) {
            return bad("silhouette_contrast", &self.silhouette_contrast, "[1, 1e6]");
        }
        for (key, v, hi) in ranges {
            if !(v >= 0.0 && v <= hi) {
                return bad(key, &v, &format!("[0, {hi}]"));
            }
        }
        if !(2..=10_000).contains(&self.roughness_steps) {
            return bad("roughness_steps", &self.roughness_steps, "2..=10000");
        }
        if self.diffuse_radius > 8 {
            return bad("diffuse_radius", &self.diffuse_radius, "0..=8");
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
