//! Lights that LDR views show only clipped: found, their radiance estimated, the other clipped
//! pixels left out of the material loss.
use super::CaptureReport;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_geom::Geometry;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;

/// Triangles whose every view clips: lights whose radiance the views do not give.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ClippedLights {
    pub triangles: usize,
    /// Their pixels; `assumed`: the clip levels a light that lights no sampled surface gets.
    pub pixels: usize,
    pub assumed: f32,
    /// Other clipped pixels, left out of the material loss.
    pub left_out_pixels: usize,
    pub convention: String,
    /// Per connected light, its estimated radiance ([`crate::light_scale`]).
    pub estimates: Vec<crate::light_scale::LightEstimate>,
    /// Surface patches (and their samples) the estimate left out as not one diffuse colour.
    pub not_one_colour: [usize; 2],
    /// The room's light the estimates were measured against (draws the maps at the ends of
    /// an unpinned light's range); not written.
    #[serde(skip)]
    pub model: Option<std::sync::Arc<crate::light_ends::LightModel>>,
}

/// A connected set of clipped triangles seen by fewer pixels (over all views) is a highlight.
const MIN_LIGHT_PIXELS: usize = 16;
/// A triangle seen by three pixels or more counts as a clipped light when this share of its
/// pixels clip (over all views).
const CLIPPED_TRIANGLE_SHARE: f64 = 0.9;
/// A triangle joins a clipped light it touches when at least this share of its pixels clip,
/// however few they are. A small curved light is mostly outline in every view: on
/// `studio-mitsuba`'s S-curve copy (5 mm / 0.15° of pose error) the bulb's 320 triangles are
/// seen by 1,354 pixels, two thirds of its triangles by fewer than three or with a pixel of
/// the wall beside them, and the strict rule alone split it into five lights, four of them
/// set to a clip level or so.
const JOINING_TRIANGLE_SHARE: f64 = 0.5;
/// The radiance assumed for a clipped light that lights no sampled surface, in clip levels:
/// not identifiable from LDR views, fixed by this convention (a lamp is typically one to two orders of magnitude brighter than
/// the surfaces a camera meters for; what it lights then fixes the scale of kd).
pub const CLIPPED_LIGHT_LEVELS: f32 = 16.0;

/// For LDR views: the pixels of the clipped lights ([`find_lights`]) are set to each light's
/// radiance as [`crate::light_scale::estimate`] bounds and chooses it (where it has no sample
/// at all, [`CLIPPED_LIGHT_LEVELS`] × the clip level of their view, white), so that the
/// stages see a light; the other clipped pixels are marked to be left out of the material
/// loss.
pub fn restore_clipped_lights(
    geometry: &Geometry,
    views: &[View],
    images: &mut [Image],
    report: &mut CaptureReport,
) {
    let Some(level) = report.clip_level else {
        return;
    };
    if report.clipped.is_empty() {
        return;
    }
    let (hits, lights) = find_lights(geometry, views, &report.clipped);
    let kept: std::collections::HashSet<u32> = lights.iter().flatten().copied().collect();
    let light = |t: u32| kept.contains(&t);
    let mut cl = ClippedLights {
        assumed: CLIPPED_LIGHT_LEVELS,
        ..Default::default()
    };
    // Clipped or masked (a person, a screen): neither tells the lights' radiance.
    let sizes: Vec<usize> = images.iter().map(|i| i.data.len()).collect();
    let skip = super::clipped_or_masked(report, &sizes);
    let seen_clipped: Vec<f32> = clip_bounds(&hits, &lights, &report.clipped, &report.view_clip)
        .into_iter()
        .map(|b| b * report.clip_fraction)
        .collect();
    let estimates = crate::light_scale::estimate(
        geometry,
        views,
        images,
        &lights,
        &skip,
        level,
        &seen_clipped,
    );
    let (estimates, model) = estimates.map_or((None, None), |(e, m, mixed)| {
        cl.not_one_colour = mixed;
        (Some(e), Some(m))
    });
    // Kept only where a light's range is left open (its end maps need it).
    let open = estimates
        .as_ref()
        .is_some_and(|e| !crate::light_ends::ends(e).is_empty());
    cl.model = model.filter(|_| open).map(std::sync::Arc::new);
    let mut radiance: HashMap<u32, glam::Vec3> = HashMap::new();
    for (e, tris) in lights.iter().enumerate() {
        let est = estimates.as_ref().and_then(|v| v.get(e));
        if let Some(x) = est {
            for &t in tris {
                radiance.insert(t, glam::Vec3::from_array(x.radiance));
            }
        }
    }
    cl.estimates = estimates.unwrap_or_default();
    cl.triangles = lights.iter().map(Vec::len).sum();
    report.left_out = vec![];
    for (v, img) in images.iter_mut().enumerate() {
        let clip = report.view_clip.get(v).copied().unwrap_or(level);
        let mut out = vec![false; img.data.len()];
        for (i, p) in img.data.iter_mut().enumerate() {
            if !report.clipped[v][i] {
                continue;
            }
            match hits[v][i].filter(|&t| light(t)) {
                Some(t) => {
                    *p = radiance
                        .get(&t)
                        .copied()
                        .unwrap_or(glam::Vec3::splat(CLIPPED_LIGHT_LEVELS * clip));
                    cl.pixels += 1;
                }
                None => {
                    out[i] = true;
                    cl.left_out_pixels += 1;
                }
            }
        }
        report.left_out.push(out);
    }
    cl.convention = describe(&cl, lights.len());
    report.warnings.push(cl.convention.clone());
    report.clipped_lights = Some(cl);
}

/// Per training view the triangle each pixel sees, and the clipped lights ([`lights_of`]).
#[allow(clippy::type_complexity)]
pub(crate) fn find_lights(
    geometry: &Geometry,
    views: &[View],
    clipped: &[Vec<bool>],
) -> (Vec<Vec<Option<u32>>>, Vec<Vec<u32>>) {
    let hits: Vec<Vec<Option<u32>>> = views
        .par_iter()
        .map(|v| {
            fipt_shading::records::hit_points(geometry, v)
                .into_iter()
                .map(|h| h.map(|h| h.tri()))
                .collect()
        })
        .collect();
    let lights = lights_seen(&geometry.mesh, &hits, clipped);
    (hits, lights)
}

/// The clipped lights ([`lights_of`]) given the triangle each pixel of each view sees.
pub(crate) fn lights_seen(
    mesh: &fipt_geom::mesh::Mesh,
    hits: &[Vec<Option<u32>>],
    clipped: &[Vec<bool>],
) -> Vec<Vec<u32>> {
    let mut count: HashMap<u32, (usize, usize)> = HashMap::new();
    for (v, hv) in hits.iter().enumerate() {
        for (i, t) in hv.iter().enumerate() {
            if let Some(t) = t {
                let e = count.entry(*t).or_default();
                e.0 += usize::from(clipped[v][i]);
                e.1 += 1;
            }
        }
    }
    lights_of(mesh, &count)
}

/// The clipped lights among `mesh`'s triangles, given each one's (clipped, seen) pixels over
/// all views: the connected pieces of triangles with [`JOINING_TRIANGLE_SHARE`] of their
/// pixels clipped, kept where their triangles with [`CLIPPED_TRIANGLE_SHARE`] of three pixels
/// or more clipped are seen by [`MIN_LIGHT_PIXELS`] pixels or more.
fn lights_of(mesh: &fipt_geom::mesh::Mesh, count: &HashMap<u32, (usize, usize)>) -> Vec<Vec<u32>> {
    let share = |t: u32, least: usize, share: f64| {
        count
            .get(&t)
            .is_some_and(|&(c, n)| n >= least && c as f64 >= share * n as f64)
    };
    let core = |t: u32| share(t, 3, CLIPPED_TRIANGLE_SHARE);
    let joins = |t: u32| share(t, 1, JOINING_TRIANGLE_SHARE);
    let (piece, _) = fipt_geom::patches::patches_among(mesh, 180.0, joins);
    let mut groups: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
    for t in (0..mesh.triangles.len() as u32).filter(|&t| joins(t)) {
        groups.entry(piece[t as usize]).or_default().push(t);
    }
    // A light is seen clipped by a few pixels at least, on triangles that clip nearly
    // always: fewer are a highlight's (left out).
    let lights: Vec<Vec<u32>> = groups
        .into_values()
        .filter(|g| {
            let core_pixels = g.iter().filter(|&&t| core(t)).map(|t| count[t].1);
            core_pixels.sum::<usize>() >= MIN_LIGHT_PIXELS
        })
        .collect();
    with_unseen_faces(mesh, |t| count.contains_key(&t), lights)
}

/// Each light with the faces of it no view saw: a connected piece of triangles that no pixel
/// centre hits joins the light it touches when every triangle it touches is that light's or
/// unseen too (the top of a pendant box that lights the ceiling above it, the crown of a bulb
/// between pixel centres), and its area is at most the light's own; a piece that touches a
/// seen surface or another light continues a wall or a fixture, and a larger one (the outside
/// of a scanned wall behind a window) is no face of a lamp: they stay out. Without the box's
/// top, `kitchen`'s pendant lit its ceiling through its sides alone and the albedo bound set it
/// 2.9× too bright against the window.
fn with_unseen_faces(
    mesh: &fipt_geom::mesh::Mesh,
    seen: impl Fn(u32) -> bool,
    lights: Vec<Vec<u32>>,
) -> Vec<Vec<u32>> {
    if lights.is_empty() {
        return lights;
    }
    let near = mesh.edge_neighbours();
    let mut owner: HashMap<u32, usize> = HashMap::new();
    for (e, l) in lights.iter().enumerate() {
        owner.extend(l.iter().map(|&t| (t, e)));
    }
    let mut visited = std::collections::HashSet::new();
    let mut out = lights.clone();
    for (e, light) in lights.iter().enumerate() {
        let area = |ts: &[u32]| ts.iter().map(|&t| mesh.area(t as usize)).sum::<f32>();
        let own = area(light);
        for &t in light {
            for &start in &near[t as usize] {
                if seen(start) || owner.contains_key(&start) || !visited.insert(start) {
                    continue;
                }
                let (mut piece, mut todo, mut closed) = (vec![start], vec![start], true);
                while let Some(x) = todo.pop() {
                    for &y in &near[x as usize] {
                        match owner.get(&y) {
                            Some(&o) if o == e => continue,
                            Some(_) => closed = false,
                            None if seen(y) => closed = false,
                            None => {
                                if visited.insert(y) {
                                    piece.push(y);
                                    todo.push(y);
                                }
                            }
                        }
                    }
                }
                if closed && area(&piece) <= own {
                    out[e].extend(piece);
                }
            }
        }
    }
    for l in &mut out {
        l.sort_unstable();
    }
    out
}

/// Per light, the highest clip level (in the stages' units) of the views that see it clipped
/// (times the clip fraction, the least radiance its clipped pixels imply).
fn clip_bounds(
    hits: &[Vec<Option<u32>>],
    lights: &[Vec<u32>],
    clipped: &[Vec<bool>],
    view_clip: &[f32],
) -> Vec<f32> {
    let of: HashMap<u32, usize> = lights
        .iter()
        .enumerate()
        .flat_map(|(e, t)| t.iter().map(move |&t| (t, e)))
        .collect();
    let mut bound = vec![0f32; lights.len()];
    for (v, hv) in hits.iter().enumerate() {
        for (i, t) in hv.iter().enumerate() {
            if let Some(&e) = t.and_then(|t| of.get(&t)) {
                if clipped[v][i] {
                    bound[e] = bound[e].max(view_clip.get(v).copied().unwrap_or(0.0));
                }
            }
        }
    }
    bound
}

/// What `report.json` and the log say of the clipped lights.
fn describe(cl: &ClippedLights, lights: usize) -> String {
    if lights == 0 {
        return format!(
            "no light is seen clipped (no triangle clips in {:.0} % of its pixels): the {} clipped pixels (highlights, bright surfaces) are left out of the material loss",
            100.0 * CLIPPED_TRIANGLE_SHARE,
            cl.left_out_pixels
        );
    }
    let said: Vec<String> = cl
        .estimates
        .iter()
        .map(|e| {
            let range = format!(
                "the views allow {:.1} … {} clip levels",
                e.range[0],
                if e.range[1].is_finite() { format!("{:.0}", e.range[1]) } else { "∞".into() }
            );
            match e.chosen_by.as_str() {
                "flatness" | "flatness, clamped to the range" => format!("{} triangles: {:.1} clip levels, RGB {:.2?}, pinned by the surfaces it lights (the curve rises {:.0} % at 10× off; {range})", e.triangles, e.levels, e.radiance, 100.0 * e.contrast),
                "albedo" => format!("{} triangles: NOT PINNED by the shading it casts (the curve rises {:.1} % at 10× off); {range}; set to {:.1} clip levels, RGB {:.2?}: {:.2}× the least radiance that keeps every surface it lights strongly at albedo {} or less, or the range's lower end if that is higher (a prior, not a measurement; how far off it can be: docs/clipped-lights.md)", e.triangles, 100.0 * e.contrast, e.levels, e.radiance, crate::light_scale::KD_MAX / crate::light_scale::KD_BRIGHT, crate::light_scale::KD_MAX),
                _ => format!("{} triangles: NOT PINNED and lighting too few unclipped surfaces to bound it; set to its lower bound, {:.1} clip levels ({range})", e.triangles, e.levels),
            }
        })
        .collect();
    format!(
        "{} triangles clip in at least {:.0} % of their pixels over all views, or in {:.0} % beside those: {} light(s) whose radiance the LDR views do not give. Estimated from the surfaces they light: {}. The absolute scale of radiance and kd rests on these estimates; {} other clipped pixels are left out of the material loss",
        cl.triangles,
        100.0 * CLIPPED_TRIANGLE_SHARE,
        100.0 * JOINING_TRIANGLE_SHARE,
        lights,
        if said.is_empty() { format!("no estimate (no sample): set by convention to {CLIPPED_LIGHT_LEVELS} clip levels") } else { said.join("; ") },
        cl.left_out_pixels
    ) + &match cl.not_one_colour {
        [0, _] => String::new(),
        [p, n] => format!(". {p} surface patch(es) ({n} samples) whose kd spreads over ×{} between its quartiles at every radiance tried (mirrors, metals, highlights) did not bound or pin the lights", crate::light_scale::MAX_QUARTILE_RATIO),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// With no light seen clipped the report says so, and not that a light was set by
    /// convention.
    #[test]
    fn no_clipped_light_is_said_as_such() {
        let cl = ClippedLights {
            left_out_pixels: 37,
            ..Default::default()
        };
        let said = describe(&cl, 0);
        assert!(
            said.starts_with("no light is seen clipped") && said.contains("the 37 clipped pixels"),
            "{said}"
        );
        assert!(!said.contains("convention"), "{said}");
    }

    /// A strip of `n` triangles, each sharing an edge with the next.
    fn strip(n: u32) -> fipt_geom::mesh::Mesh {
        let positions = (0..n + 2)
            .map(|i| Vec3::new((i / 2) as f32, (i % 2) as f32, 0.0))
            .collect();
        let tris = (0..n).map(|i| [i, i + 1, i + 2]).collect();
        fipt_geom::mesh::Mesh::from_triangles(positions, None, tris)
    }

    /// Two pieces of a light that clip in every pixel, joined by triangles that clip in half
    /// of their one or two pixels (a small light's outline under pose error), are one light;
    /// a triangle clipping in a third of its pixels parts lights; joining triangles alone,
    /// or beside too few pixels that clip always, are no light.
    #[test]
    fn outline_triangles_join_a_light_but_make_none() {
        let count: HashMap<u32, (usize, usize)> = [
            (0, (10, 10)),
            (1, (1, 2)),
            (2, (1, 1)),
            (3, (1, 2)),
            (4, (9, 10)),
            (5, (1, 3)),
            (6, (2, 2)),
            (7, (3, 4)),
            (8, (1, 3)),
            (9, (8, 8)),
            (10, (2, 2)),
        ]
        .into_iter()
        .collect();
        let lights = lights_of(&strip(11), &count);
        assert_eq!(lights, vec![vec![0, 1, 2, 3, 4]]);
        // 8 more pixels that always clip make the last piece a light.
        let mut more = count.clone();
        more.insert(10, (8, 8));
        let lights = lights_of(&strip(11), &more);
        assert_eq!(lights, vec![vec![0, 1, 2, 3, 4], vec![9, 10]]);
    }

    /// Triangles no pixel saw join the light they touch when nothing seen lies beyond them
    /// (a pendant's top face); where they lead on to a seen surface (a wall continuing past
    /// a window) they stay out.
    #[test]
    fn a_lights_unseen_faces_join_it_unless_they_lead_to_a_seen_surface() {
        let clipped = |ts: &[u32]| -> HashMap<u32, (usize, usize)> {
            ts.iter().map(|&t| (t, (10, 10))).collect()
        };
        // Triangles 2 and 3 unseen, the strip's end: they join.
        assert_eq!(
            lights_of(&strip(4), &clipped(&[0, 1])),
            vec![vec![0, 1, 2, 3]]
        );
        // Triangle 3 seen and not clipped: 2 leads to it and stays out.
        let mut count = clipped(&[0, 1]);
        count.insert(3, (0, 10));
        assert_eq!(lights_of(&strip(4), &count), vec![vec![0, 1]]);
        // Between two lights: neither takes it.
        let two = clipped(&[0, 1, 3, 4]);
        assert_eq!(lights_of(&strip(5), &two), vec![vec![0, 1], vec![3, 4]]);
        // Three unseen triangles beside a light of two: larger than the light, they stay out.
        assert_eq!(lights_of(&strip(5), &clipped(&[0, 1])), vec![vec![0, 1]]);
    }
}
