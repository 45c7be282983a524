//! Where the cameras stand against the mesh: how much of each view's pixel-centre rays hit it,
//! and whether the cameras' spread and the mesh's size agree on one unit of length (a mesh in
//! millimetres with poses in metres puts every camera within a few units of each other in a
//! room thousands of units across). `fipt info` and `fipt run` say the same.
use fipt_core::dataset::View;
use fipt_geom::Bvh;
use glam::Vec3;
use rayon::prelude::*;

/// Every `STRIDE`-th pixel centre, on both axes, is traced.
const STRIDE: usize = 4;
/// A mesh this many times larger than the box around the cameras, or more: a warning (a room
/// captured by walking through it measures 1–5 times the cameras' box).
pub const MESH_OVER_SPREAD: f32 = 100.0;

/// The cameras of one split against the mesh.
#[derive(Clone, Debug, Default)]
pub struct Placement {
    /// Per view, the share of its traced pixel-centre rays that hit the mesh.
    pub coverage: Vec<f32>,
    /// The diagonal of the box around the cameras' centres.
    pub spread: f32,
    /// The diagonal of the mesh's bounding box.
    pub extent: f32,
}

/// The cameras of `views` against the mesh in `bvh`, whose bounding box's diagonal is
/// `extent`.
pub fn placement(bvh: &Bvh, extent: f32, views: &[View]) -> Placement {
    let coverage: Vec<f32> = views
        .par_iter()
        .map(|v| fipt_geom::view_coverage(bvh, &v.camera, STRIDE))
        .collect();
    let (lo, hi) = views.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), v| (lo.min(v.camera.origin), hi.max(v.camera.origin)),
    );
    Placement {
        coverage,
        spread: if views.is_empty() {
            0.0
        } else {
            (hi - lo).length()
        },
        extent,
    }
}

/// What a user should know of `p`, the cameras of split `split`: views that miss the mesh,
/// and cameras that stand much closer together than the mesh's size.
pub fn warnings(split: &str, p: &Placement) -> Vec<String> {
    let mut w = vec![];
    for (k, &c) in p.coverage.iter().enumerate() {
        if c == 0.0 {
            w.push(format!("{split} view {k}: no pixel-centre ray hits the mesh (wrong pose convention, poses in other units than the mesh's, or a camera outside the scene?)"));
        } else if c < 0.5 {
            w.push(format!("{split} view {k}: only {:.0} % of pixel-centre rays hit the mesh (open scene? rays that escape see no light)", 100.0 * c));
        }
    }
    if p.coverage.len() >= 4 && p.extent > MESH_OVER_SPREAD * p.spread {
        w.push(format!(
            "{split}: the {} cameras stand within {:.3} units of each other in a mesh {:.3} units across ({}): poses and mesh in different units (a mesh in millimetres with poses in metres: scale the mesh by 0.001)? If the cameras did stand in one spot, the views see each surface from one side only and pin little of its gloss",
            p.coverage.len(),
            p.spread,
            p.extent,
            if p.spread > 0.0 {
                format!("×{:.0}", p.extent / p.spread)
            } else {
                "all at one point".into()
            }
        ));
    }
    w
}
