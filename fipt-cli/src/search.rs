//! `fipt profile <scene> OUT`: the material search's cost curves per region, printed (with the
//! ground truth's base colour beside the fitted one when the scene has it).
use crate::info::Policy;
use anyhow::Result;
use fipt_method::search::{given_summary, profile_rows, ProfileRequest};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder.
    scene: PathBuf,
    /// Output folder of `fipt run` / `fipt bake`.
    out: PathBuf,
    /// Which shadings in OUT: `bake`, `refine1`, ...
    #[arg(long, default_value = "bake")]
    shadings: String,
    /// Regions: auto, parts, semantic, mesh.
    #[arg(long, default_value = "auto")]
    regions: String,
    /// Write the profiles as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "reject")]
    bad_pixels: Policy,
    /// Leave out the pixels on regions' outlines (`[search] drop_edges = true`, as `fipt run`
    /// does with `--edge-contrast 4`; by default every pixel counts).
    #[arg(long)]
    drop_edges: bool,
    /// With --drop-edges: only neighbours this many times brighter count (`[search] edge_contrast`).
    #[arg(long, default_value_t = 0.0)]
    edge_contrast: f32,
    /// With --drop-edges: a region whose outline is at most this share of its pixels loses
    /// all its outline pixels, however bright their neighbours (`[search] outline_share`,
    /// 0 in `fipt run`: the contrast alone).
    #[arg(long, default_value_t = 0.0)]
    outline_share: f32,
    /// With --drop-edges: also leave out pixels beside another region whose hit is farther
    /// than this share of the pixel's distance to the camera: silhouettes
    /// (`[search] silhouette_gap`; 0: off)
    #[arg(long, default_value_t = fipt_search::SearchConfig::default().silhouette_gap)]
    silhouette_gap: f32,
    /// With --silhouette-gap: only neighbours this many times brighter or darker count
    /// (`[search] silhouette_contrast`, at least 1)
    #[arg(long, default_value_t = fipt_search::SearchConfig::default().silhouette_contrast)]
    silhouette_contrast: f32,
    /// Average each pixel's Ld over the pixels within this many of it in its view and region
    /// (`[search] diffuse_radius`; 0: Ld as refined)
    #[arg(long, default_value_t = fipt_search::SearchConfig::default().diffuse_radius)]
    diffuse_radius: u32,
}

/// The lowest cost over σ at the `mi`-th metallic candidate (NaN when there is none).
fn part_best(p: &fipt_search::RegionProfile, mi: usize) -> f64 {
    p.cost.get(mi).map_or(f64::NAN, |c| {
        c.iter()
            .copied()
            .filter(|x| x.is_finite())
            .fold(f64::NAN, f64::min)
    })
}

pub fn run(a: Args) -> Result<()> {
    let rows = profile_rows(&ProfileRequest {
        scene: a.scene,
        out: a.out,
        shadings: a.shadings,
        regions: a.regions,
        bad_pixels: a.bad_pixels.into(),
        drop_edges: a.drop_edges,
        edge_contrast: a.edge_contrast,
        outline_share: a.outline_share,
        silhouette_gap: a.silhouette_gap,
        silhouette_contrast: a.silhouette_contrast,
        diffuse_radius: a.diffuse_radius,
    })?;
    println!(
        "{:>6} {:>7} {:>6} | {:>18} {:>7} | {:>8} {:>8} | {:>9} {:>9} {:>9} | {:>9} {:>9} | chosen σ, m",
        "region",
        "pixels",
        "cells",
        "GT a: argmin σ@m",
        "GT gain",
        "fit σ m0",
        "fit σ m1",
        "cost σ=1",
        "best m0",
        "best m1",
        "part m0",
        "part m1"
    );
    for row in &rows {
        let (f, c) = (&row.fitted, &row.choice);
        // A side of a divided region: `7a`, `7b`; `*` when the sides keep their own.
        let label = match row.side {
            Some(s) => format!(
                "{}{}{}",
                row.label,
                ["a", "b"][s as usize],
                if row.sides_kept == Some(true) {
                    "*"
                } else {
                    ""
                }
            ),
            None => row.label.to_string(),
        };
        let (gt, gain) = row.given.as_ref().map_or(("–".to_string(), f64::NAN), |g| {
            let ([m0, m1], gain) = given_summary(g);
            (format!("{m0:.2}@0 {m1:.2}@1"), gain)
        });
        println!(
            "{:>6} {:>7} {:>6} | {:>18} {:>7.3} | {:>8.2} {:>8.2} | {:>9.6} {:>9.6} {:>9.6} | {:>9.6} {:>9.6} | {}, {}",
            label,
            f.pixels,
            f.cells,
            gt,
            gain,
            c.argmin_sigma[0],
            c.argmin_sigma.get(1).copied().unwrap_or(f32::NAN),
            c.default_cost,
            c.best_cost[0],
            c.best_cost.get(1).copied().unwrap_or(f64::NAN),
            part_best(&row.part, 0),
            part_best(&row.part, 1),
            c.roughness.map_or("–".into(), |v| format!("{v:.2}")),
            c.metallic.map_or("–".into(), |v| format!("{v:.0}"))
        );
    }
    for row in rows.iter().filter(|r| r.side == Some(0)) {
        if let Some(w) = &row.whole {
            println!(
                "region {} divided; both sides together: {}, {}{}",
                row.label,
                w.roughness.map_or("–".into(), |v| format!("{v:.2}")),
                w.metallic.map_or("–".into(), |v| format!("{v:.0}")),
                if row.sides_kept == Some(true) {
                    " (the sides keep their own: *)"
                } else {
                    " (taken by both sides)"
                }
            );
        }
    }
    if let Some(path) = &a.json {
        fipt_core::fsutil::write_json_atomic(path, &rows)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
