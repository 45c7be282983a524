//! [`MaskExtractorConfig::drop_outlines`](crate::MaskExtractorConfig::drop_outlines): a light
//! seen only along a much larger light's outline, beside it, is that light's outline shifted
//! onto the surface next to it (pose error, a scan a few millimetres off).
use fipt_core::emitter::{EmitterInputs, PixelHit};
use glam::Vec3;
use std::collections::HashMap;

/// The share of a light's pixels that must border a larger light…
pub const OUTLINE_SHARE: f32 = 0.75;
/// …within this many pixels (rows and columns) in their view…
pub const OUTLINE_RADIUS: i64 = 2;
/// …that has at least this many times its pixels…
pub const OUTLINE_RATIO: usize = 10;
/// …and whose bounds lie within this share of the mesh's bounding-box diagonal of its own
/// (a bulb seen in front of a window, metres from it, stays a light). The slivers measured on a
/// scanned `atelier` lay within 3.1 cm of their light, 0.4 % of its 7.5 m diagonal.
pub const OUTLINE_GAP: f32 = 0.01;

/// The groups but those seen only along a much larger group's outline, in their order; and how
/// many were dropped, with how many pixels.
pub fn without_outlines(
    inp: &EmitterInputs,
    groups: Vec<Vec<usize>>,
    obs: &HashMap<u32, Vec<PixelHit>>,
) -> (Vec<Vec<usize>>, (usize, usize)) {
    let pixels_of = |g: &[usize]| -> Vec<&PixelHit> {
        g.iter()
            .flat_map(|t| obs.get(&(*t as u32)).into_iter().flatten())
            .collect()
    };
    let sizes: Vec<usize> = groups.iter().map(|g| pixels_of(g).len()).collect();
    let bounds: Vec<(Vec3, Vec3)> = groups.iter().map(|g| bounds_of(inp, g)).collect();
    let (lo, hi) = (inp.positions.iter()).fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |b, &p| (b.0.min(p), b.1.max(p)),
    );
    let gap = OUTLINE_GAP * (hi - lo).length();
    let mut owner: HashMap<[u32; 3], usize> = HashMap::new();
    for (k, g) in groups.iter().enumerate() {
        for h in pixels_of(g) {
            if let Some(at) = h.at {
                owner.insert(at, k);
            }
        }
    }
    let outline = |k: usize| {
        let placed: Vec<[u32; 3]> = pixels_of(&groups[k]).iter().filter_map(|h| h.at).collect();
        let near = |j: usize| {
            let d = (bounds[j].0 - bounds[k].1).max(bounds[k].0 - bounds[j].1);
            d.max(Vec3::ZERO).length() <= gap
        };
        let larger = |j: usize| j != k && sizes[j] >= OUTLINE_RATIO * sizes[k].max(1) && near(j);
        let borders = |&[v, x, y]: &[u32; 3]| {
            let r = OUTLINE_RADIUS;
            (-r..=r).any(|dy| {
                (-r..=r).any(|dx| {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    (nx >= 0 && ny >= 0)
                        && owner
                            .get(&[v, nx as u32, ny as u32])
                            .is_some_and(|&j| larger(j))
                })
            })
        };
        let bordering = placed.iter().filter(|a| borders(a)).count();
        !placed.is_empty() && bordering as f32 >= OUTLINE_SHARE * placed.len() as f32
    };
    let dropped: Vec<bool> = (0..groups.len()).map(outline).collect();
    let count = dropped.iter().filter(|&&d| d).count();
    let pixels = (0..groups.len())
        .filter(|&k| dropped[k])
        .map(|k| sizes[k])
        .sum();
    let kept = (groups.into_iter().zip(dropped))
        .filter_map(|(g, d)| (!d).then_some(g))
        .collect();
    (kept, (count, pixels))
}

/// The axis-aligned bounds of triangles `g`.
fn bounds_of(inp: &EmitterInputs, g: &[usize]) -> (Vec3, Vec3) {
    let mut b = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &t in g {
        for i in inp.triangles[t] {
            let p = inp.positions[i as usize];
            b = (b.0.min(p), b.1.max(p));
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use crate::mask::tests::BoxMask;
    use crate::{MaskExtractor, MaskExtractorConfig};
    use fipt_core::emitter::{EmitterExtractor, EmitterInputs, PixelHit};
    use glam::Vec3;

    /// A 1 m panel (triangles 0, 1), a 2 cm strip beside it on the wall (2, 3) and a small
    /// lamp 3 m away (4, 5); each quad its own vertices.
    fn scene() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (mut pos, mut tris) = (vec![], vec![]);
        let mut quad = |o: Vec3, u: Vec3, v: Vec3| {
            for t in [[o, o + u, o + u + v], [o, o + u + v, o + v]] {
                let b = pos.len() as u32;
                pos.extend(t);
                tris.push([b, b + 1, b + 2]);
            }
        };
        quad(Vec3::ZERO, Vec3::X, Vec3::Y);
        quad(Vec3::new(1.005, 0.0, 0.0), Vec3::X * 0.02, Vec3::Y);
        quad(Vec3::new(0.5, 0.5, 3.0), Vec3::X * 0.05, Vec3::Y * 0.05);
        (pos, tris)
    }

    /// The panel seen as 10×10 pixels, and 6 pixels of triangle `t` in column `x0`.
    fn hits(t: u32, x0: u32) -> Vec<PixelHit> {
        let hit = |t: u32, at: [u32; 3]| PixelHit {
            triangle: t,
            radiance: Vec3::splat(5.0),
            max_reflected: None,
            at: Some(at),
            front: None,
        };
        let mut v: Vec<PixelHit> = (0..100)
            .map(|i| hit(0, [0, 10 + i % 10, 10 + i / 10]))
            .collect();
        v.extend((0..6).map(|y| hit(t, [0, x0, 12 + y])));
        v
    }

    fn extract(hits: &Vec<PixelHit>, drop_outlines: bool) -> (usize, Vec<String>) {
        let (pos, tris) = scene();
        let ex = MaskExtractor::new(MaskExtractorConfig {
            drop_outlines,
            ..Default::default()
        });
        let inp = EmitterInputs {
            positions: &pos,
            triangles: &tris,
            field: &BoxMask(Vec3::splat(-1e9), Vec3::splat(1e9)),
            pixel_hits: hits,
        };
        (ex.extract(&inp).unwrap().len(), ex.notes())
    }

    /// The strip beside the panel, seen 2 pixels off its edge: the panel's outline, dropped
    /// (and said); the same strip apart from it in the image, or the lamp metres away seen
    /// beside it, stay lights; without the rule every group is a light.
    #[test]
    fn a_sliver_along_a_larger_lights_outline_is_not_a_light() {
        let (n, notes) = extract(&hits(2, 21), true);
        assert_eq!(n, 1, "a sliver 2 pixels off the edge");
        assert!(
            notes.len() == 1 && notes[0].starts_with("1 light(s) of 6 pixel(s)"),
            "{notes:?}"
        );
        assert_eq!(extract(&hits(2, 21), false), (2, vec![]));
        assert_eq!(
            extract(&hits(2, 40), true),
            (2, vec![]),
            "apart in the image"
        );
        assert_eq!(
            extract(&hits(4, 21), true),
            (2, vec![]),
            "metres away in the scene"
        );
    }
}
