//! Regions divided by colour or gloss (`[search.split]`, see [`crate::split`], [`crate::gloss`]): each
//! side's decision, the whole region's, and the side of a training pixel.
use crate::split::{crossed, merged, sides_differ, ColourSplit, SplitConfig};
use crate::{voxel, RegionChoice, RegionProfile};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// A divided region whose two sides keep their own decisions. The region's own entry
/// in the search holds the decision for both sides together, which pixels in cells the search
/// did not see take.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Divided {
    /// Dense region index and its label.
    pub region: u32,
    pub label: i64,
    /// The decision of each side (side 0: the cells 2-means put first).
    pub sides: [RegionChoice; 2],
    /// Pixels on each side (of the search's).
    pub pixels: [usize; 2],
    /// Each side's cost at the other side's minimum over its own, minus 1
    /// ([`crate::split::crossed`]): how firmly each side rejects the other's σ. None where the
    /// sides differ in metal (they divide on that alone) or a side has no finite minimum.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crossed: Option<[f32; 2]>,
}

/// The surface cells of the divided regions with their side, keyed by voxel.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct DividedCells {
    /// Edge of a surface cell.
    pub cell: f32,
    /// Per divided region (in the order of the search's `divided`), its cells' voxels and sides.
    pub cells: Vec<Vec<([i32; 3], u8)>>,
}

/// A region whose sides keep their own decisions: its index, each side's decision and pixels,
/// and how firmly each rejects the other's σ ([`crate::split::crossed`]).
pub type KeptSides = (usize, [RegionChoice; 2], [usize; 2], Option<[f32; 2]>);

/// Decides one profile: `(profile, its halves, the region it belongs to)`.
pub type ChooseOne<'a> =
    &'a dyn Fn(&RegionProfile, Option<[&RegionProfile; 2]>, usize) -> RegionChoice;

/// Per region (`0..parents`) its decision, and the regions whose sides keep their own.
/// `profiles` (and `halves`) are those of `split`'s regions: the parents, then the second
/// sides. `choose_one(profile, halves, parent)` decides one of them.
pub fn choose_regions(
    profiles: &[RegionProfile],
    halves: Option<&[Vec<RegionProfile>; 2]>,
    split: &ColourSplit,
    cfg: &SplitConfig,
    choose_one: ChooseOne,
) -> (Vec<RegionChoice>, Vec<KeptSides>) {
    let held = |r: usize| halves.map(|h| [&h[0][r], &h[1][r]]);
    let mut whole = vec![];
    let mut divided = vec![];
    for (r, sub) in split.sub.iter().enumerate() {
        let Some(s) = sub.map(|s| s as usize) else {
            whole.push(choose_one(&profiles[r], held(r), r));
            continue;
        };
        let both = merged(&profiles[r], &profiles[s]);
        let both_halves = halves.map(|h| [0, 1].map(|k| merged(&h[k][r], &h[k][s])));
        let c = choose_one(&both, both_halves.as_ref().map(|h| [&h[0], &h[1]]), r);
        let sides = [
            choose_one(&profiles[r], held(r), r),
            choose_one(&profiles[s], held(s), r),
        ];
        let side_halves = halves.map(|h| [[&h[0][r], &h[1][r]], [&h[0][s], &h[1][s]]]);
        let measured = cfg.gloss_view_means && split.deep_per_view.get(r) == Some(&true);
        if sides_differ(
            [&profiles[r], &profiles[s]],
            [&sides[0], &sides[1]],
            side_halves,
            cfg,
            measured,
        ) {
            let [m0, m1] = sides.each_ref().map(|c| c.metallic.unwrap_or(0.0));
            let cross = (m0 == m1)
                .then(|| crossed([&profiles[r], &profiles[s]], m0))
                .flatten();
            divided.push((r, sides, [profiles[r].pixels, profiles[s].pixels], cross));
        }
        whole.push(c);
    }
    (whole, divided)
}

/// The side of a point of each divided region, by the voxel it falls in.
pub struct SideLookup {
    cell: f32,
    /// Per region: the index in the divided list and its cells' sides.
    by_region: HashMap<u32, (usize, HashMap<[i32; 3], u8>)>,
}

impl SideLookup {
    pub fn new(divided: &[Divided], cells: &DividedCells) -> Self {
        let by_region = divided
            .iter()
            .zip(&cells.cells)
            .enumerate()
            .map(|(k, (d, c))| (d.region, (k, c.iter().copied().collect())))
            .collect();
        SideLookup {
            cell: cells.cell,
            by_region,
        }
    }

    /// The divided region (index in the search's `divided`) and side of a point of `region`,
    /// None when the region is whole or the search did not see the point's cell (the region's
    /// own decision applies).
    pub fn side(&self, region: u32, p: Vec3) -> Option<(usize, u8)> {
        let (k, sides) = self.by_region.get(&region)?;
        Some((*k, *sides.get(&voxel(p, self.cell))?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{choose, SearchConfig};

    /// A dielectric curve over σ ∈ {0.2, …, 1.0} with its minimum (1.0) at `min_at`, 0.5 higher per step away.
    fn curve(region: u32, min_at: usize) -> RegionProfile {
        RegionProfile {
            region,
            pixels: 1000,
            cells: 10,
            sigma: vec![0.2, 0.4, 0.6, 0.8, 1.0],
            metallic: vec![0.0],
            cost: vec![(0..5)
                .map(|i| 1.0 + 0.5 * (i as f64 - min_at as f64).abs())
                .collect()],
            gain: vec![],
            one_colour: vec![],
        }
    }

    #[test]
    fn divided_sides_keep_their_decisions_and_points_find_their_side() {
        let cfg = SearchConfig {
            min_pixels: 1,
            held_out: false,
            ..Default::default()
        };
        let choose_one =
            |p: &RegionProfile, h: Option<[&RegionProfile; 2]>, _: usize| choose(p, &cfg, false, h);
        // Region 0 stays whole; region 1 divides (its second side is region 2) into a side
        // with its minimum at σ 0.2 and one at σ 0.8.
        let profiles = [curve(0, 2), curve(1, 0), curve(2, 3)];
        let split = ColourSplit {
            sub: vec![None, Some(2)],
            side: vec![],
            deep_per_view: vec![],
        };
        let (whole, kept) = choose_regions(&profiles, None, &split, &cfg.split, &choose_one);
        assert_eq!(whole.len(), 2);
        assert_eq!(whole[0].roughness, Some(0.6));
        assert_eq!(kept.len(), 1);
        let (r, sides, pixels, crossed) = &kept[0];
        assert_eq!((*r, *pixels), (1, [1000, 1000]));
        // Each side's cost at the other's minimum: three steps away, 1 + 1.5 over 1.
        assert_eq!(*crossed, Some([1.5, 1.5]));
        assert_eq!(
            sides.each_ref().map(|c| c.roughness),
            [Some(0.2), Some(0.8)]
        );
        // Sides whose minima lie apart but whose curves barely reject the other side's σ (a
        // region of one finish, two colours): one decision; the same curves deeper divide.
        let shallow = |region: u32, min_at: usize, step: f64| RegionProfile {
            cost: vec![(0..5)
                .map(|i| 1.0 + step * (i as f64 - min_at as f64).abs())
                .collect()],
            ..curve(region, min_at)
        };
        let flat = [curve(0, 2), shallow(1, 0, 0.005), shallow(2, 3, 0.005)];
        let flat_sides = [1, 2].map(|k| choose_one(&flat[k], None, 1).roughness);
        assert_eq!(flat_sides, [Some(0.2), Some(0.8)]);
        let (_, kept_flat) = choose_regions(&flat, None, &split, &cfg.split, &choose_one);
        assert!(kept_flat.is_empty());
        // A division (a gloss cut, or a colour division as deep) passed its depth on each
        // view's pixels together: the profiles' depth, made pixel by pixel and mostly of the
        // views' noise, is not asked again; per pixel (`gloss_view_means` off) it is.
        let gloss_cut = ColourSplit {
            deep_per_view: vec![false, true],
            ..split.clone()
        };
        let (_, kept_gloss) = choose_regions(&flat, None, &gloss_cut, &cfg.split, &choose_one);
        assert_eq!(kept_gloss.len(), 1);
        let per_pixel = SplitConfig {
            gloss_view_means: false,
            ..cfg.split.clone()
        };
        let (_, kept_pixel) = choose_regions(&flat, None, &gloss_cut, &per_pixel, &choose_one);
        assert!(kept_pixel.is_empty());
        let deep = [curve(0, 2), shallow(1, 0, 0.1), shallow(2, 3, 0.1)];
        let (_, kept_deep) = choose_regions(&deep, None, &split, &cfg.split, &choose_one);
        assert_eq!(kept_deep.len(), 1);
        // Both sides' minima at the same σ: one decision for the region.
        let same = [curve(0, 2), curve(1, 1), curve(2, 1)];
        let (_, kept_same) = choose_regions(&same, None, &split, &cfg.split, &choose_one);
        assert!(kept_same.is_empty());
        // A point finds its side by its cell; a point in a cell the search did not see, none.
        let divided = [Divided {
            region: 1,
            label: 7,
            sides: sides.clone(),
            pixels: *pixels,
            crossed: *crossed,
        }];
        let cells = DividedCells {
            cell: 0.5,
            cells: vec![vec![([0, 0, 0], 0), ([1, 0, 0], 1)]],
        };
        let lookup = SideLookup::new(&divided, &cells);
        assert_eq!(lookup.side(1, Vec3::new(0.7, 0.2, 0.1)), Some((0, 1)));
        assert_eq!(lookup.side(1, Vec3::new(0.2, 0.2, 0.1)), Some((0, 0)));
        assert_eq!(lookup.side(1, Vec3::new(3.0, 0.2, 0.1)), None);
        assert_eq!(lookup.side(0, Vec3::new(0.7, 0.2, 0.1)), None);
    }
}
