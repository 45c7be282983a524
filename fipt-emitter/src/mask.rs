//! Emitters from the emission mask and the observed radiance.
use fipt_core::color::luminance;
use fipt_core::disjoint::DisjointSets;
use fipt_core::emitter::{EmitSide, Emitter, EmitterExtractor, EmitterInputs, PixelHit};
use fipt_core::rng::Pcg32;
use fipt_core::Result;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};

/// Settings of [`MaskExtractor`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaskExtractorConfig {
    /// A triangle emits when its mean α exceeds this (reference: 0.01).
    pub threshold: f32,
    /// Uniform points per triangle at which α is averaged (reference: 100).
    pub samples_per_triangle: usize,
    /// Keep a masked triangle only if most of its pixels (with a known bound) are brighter than
    /// anything the surface could reflect there. The mask also covers surfaces the model
    /// merely failed to explain (measured: two walls of a 4-view cornell became "lights");
    /// an emitter is what no reflectance can explain. false: the reference's rule.
    pub require_unexplained: bool,
    /// A triangle's radiance from the inner pixels of its light: those whose 8 neighbours in
    /// their view also see an emitter triangle. A pixel on a light's outline integrates its
    /// footprint, part of which lies beside the light, and a small light is mostly outline
    /// (`room`'s bulb, about 5 pixels across: 4 % low from all its pixels). A triangle with
    /// no inner pixel takes its light's inner median; a light with none keeps all its pixels.
    /// false: every pixel (the reference). Needs the pixels' places ([`PixelHit::at`]).
    #[serde(default = "yes")]
    pub inner_pixels: bool,
    /// A triangle emits only on the sides its pixels saw it lit from (at least a quarter of
    /// its light's luminance; both when seen lit from both); one not seen lit as the nearest
    /// seen triangle of its light facing the same way, else on both. A luminaire's back is dark, as an area light's in Mitsuba: on
    /// `studio-mitsuba`, whose ceiling panel hangs 1 cm under the ceiling, two-sided lights
    /// lit a ring of ceiling the views show dark. false: both sides (the reference). Needs
    /// the pixels' sides ([`PixelHit::front`]).
    #[serde(default = "yes")]
    pub observed_sides: bool,
    /// Drop a light seen only along the outline of a much larger one: at least
    /// [`crate::outline::OUTLINE_SHARE`] of its pixels lie within
    /// [`crate::outline::OUTLINE_RADIUS`] pixels of a light with
    /// [`crate::outline::OUTLINE_RATIO`] times its pixels, in the same view, and its bounds
    /// within [`crate::outline::OUTLINE_GAP`] of that light's. That is the larger light's outline
    /// landing on the surface beside it (pose error, a scan a few millimetres off): on a
    /// scanned `atelier` (1.2 M triangles) nine such slivers, 1–31 pixels each, all within
    /// 3.1 cm of a true light. false: every group is a light (the reference). Needs the
    /// pixels' places ([`PixelHit::at`]).
    #[serde(default = "yes")]
    pub drop_outlines: bool,
    pub seed: u64,
}

fn yes() -> bool {
    true
}

impl Default for MaskExtractorConfig {
    fn default() -> Self {
        MaskExtractorConfig {
            threshold: 0.01,
            samples_per_triangle: 100,
            require_unexplained: true,
            inner_pixels: true,
            observed_sides: true,
            drop_outlines: true,
            seed: 0,
        }
    }
}

/// The same extraction in every preset (the reference's threshold and samples).
impl fipt_core::presets::Presets for MaskExtractorConfig {
    fn paper() -> Self {
        Self::default()
    }
    fn balanced() -> Self {
        Self::default()
    }
    fn fast() -> Self {
        Self::default()
    }
}

impl MaskExtractorConfig {
    /// Refuses a negative threshold (above the mask's largest value no triangle emits: the
    /// extraction off) and more than 100,000 samples per triangle (the reference takes 100;
    /// memory grows with it), naming the key.
    pub fn validate(&self) -> std::result::Result<(), String> {
        fipt_core::range::check("emitters.threshold", self.threshold, 0.0, 1e6)?;
        fipt_core::range::check(
            "emitters.samples_per_triangle",
            self.samples_per_triangle,
            1,
            100_000,
        )
    }
}

/// The reference's extraction, with grouping into lights and radiance for emitter triangles
/// that no pixel centre hits (the median of their light's pixels).
pub struct MaskExtractor {
    pub config: MaskExtractorConfig,
    /// What the last extraction left out ([`EmitterExtractor::notes`]).
    pub notes: std::sync::Mutex<Vec<String>>,
}

impl MaskExtractor {
    /// An extractor of these settings.
    pub fn new(config: MaskExtractorConfig) -> Self {
        MaskExtractor {
            config,
            notes: Default::default(),
        }
    }
}

fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f32::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The side each of a light's triangles `tris` emits from: the sides from which its pixels saw
/// it lit, at least a quarter of the light's luminance `light` ([`EmitSide::from_counts`]; a
/// view of a panel's dark back is no sign that the back emits). A triangle not seen lit takes
/// the side of the nearest seen triangle of the light lying in the same plane (normals within
/// about 8°, the side flipped when its winding is reversed): a panel of many small
/// triangles, some between pixel centres, stays dark at the back. Otherwise (the unseen top
/// of a bulb) it emits on both sides.
fn observed_sides(
    inp: &EmitterInputs,
    tris: &[u32],
    obs: &HashMap<u32, Vec<PixelHit>>,
    light: Vec3,
) -> Vec<EmitSide> {
    let geo = |t: u32| {
        let [a, b, c] = inp.triangles[t as usize].map(|i| inp.positions[i as usize]);
        ((b - a).cross(c - a).normalize_or_zero(), (a + b + c) / 3.0)
    };
    let lit = 0.25 * luminance(light);
    let seen_lit = |t: &u32| -> Option<EmitSide> {
        let v = obs.get(t)?;
        let count = |front: bool| {
            v.iter()
                .filter(|h| h.front == Some(front) && luminance(h.radiance) >= lit)
                .count()
        };
        let (f, b) = (count(true), count(false));
        (f + b > 0).then(|| EmitSide::from_counts(f, b))
    };
    let lit_sides: Vec<Option<EmitSide>> = tris.iter().map(seen_lit).collect();
    let seen: Vec<(EmitSide, Vec3, Vec3)> = tris
        .iter()
        .zip(&lit_sides)
        .filter_map(|(t, side)| {
            let (n, c) = geo(*t);
            Some(((*side)?, n, c))
        })
        .collect();
    tris.iter()
        .zip(lit_sides)
        .map(|(t, side)| {
            if let Some(side) = side {
                return side;
            }
            let (n, c) = geo(*t);
            // The same plane: parallel normals (either winding) and the centroids within ~3°
            // of it (the far side of a sphere is parallel too, and not in the plane).
            seen.iter()
                .filter(|(_, m, d)| {
                    n.dot(*m).abs() > 0.99 && m.dot(c - *d).abs() <= 0.05 * c.distance(*d)
                })
                .min_by(|a, b| a.2.distance_squared(c).total_cmp(&b.2.distance_squared(c)))
                .map_or(EmitSide::Both, |&(side, m, _)| match side {
                    EmitSide::Front if n.dot(m) < 0.0 => EmitSide::Back,
                    EmitSide::Back if n.dot(m) < 0.0 => EmitSide::Front,
                    s => s,
                })
        })
        .collect()
}

impl EmitterExtractor for MaskExtractor {
    fn name(&self) -> &str {
        "emission-mask"
    }

    fn notes(&self) -> Vec<String> {
        self.notes.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The emission mask is queried at every sample of every triangle (about 10 M queries a
    /// second on 2 cores): at most 1e10 queries.
    fn check(&self, triangles: usize) -> std::result::Result<(), String> {
        let factors = [
            (
                "emitters.samples_per_triangle",
                self.config.samples_per_triangle as f64,
            ),
            ("triangles", triangles as f64),
        ];
        fipt_core::range::product("the emission mask's queries", &factors, 1e10, "queries")
            .map(|_| ())
    }

    fn extract(&self, inp: &EmitterInputs) -> Result<Vec<Emitter>> {
        let c = &self.config;
        // 1. Mean α per triangle.
        let alpha = mean_alpha(inp, c)?;
        let mut is_emitter: Vec<bool> = alpha.iter().map(|&a| a > c.threshold).collect();
        // 2. Observed pixels per emitter triangle; with `require_unexplained`, drop triangles
        //    whose pixels are mostly within what they could reflect.
        let obs = observed(inp, &mut is_emitter, c.require_unexplained)?;
        // 3. Connected groups: emitter triangles sharing a vertex.
        let mut groups = connected_groups(inp, &is_emitter);
        let mut notes = vec![];
        if c.drop_outlines {
            let (kept, dropped) = crate::outline::without_outlines(inp, groups, &obs);
            groups = kept;
            if dropped.0 > 0 {
                notes.push(format!(
                    "{} light(s) of {} pixel(s) in all dropped: seen only along the outline of a light with {}× their pixels (pose error or a scan's geometry; emitters.drop_outlines)",
                    dropped.0,
                    dropped.1,
                    crate::outline::OUTLINE_RATIO
                ));
            }
        }
        *self.notes.lock().unwrap_or_else(|e| e.into_inner()) = notes;
        // 4. Radiance per triangle: median of its pixels, else of its light's pixels.
        let seen = seen_radiance(&obs, c.inner_pixels);
        let mut out = Vec::new();
        for g in groups {
            out.extend(group_emitter(inp, c, &g, &obs, &seen));
        }
        out.sort_by(|a, b| {
            let p = |e: &Emitter| e.power.iter().sum::<f32>();
            p(b).total_cmp(&p(a))
        });
        Ok(out)
    }
}

fn tri_pts(inp: &EmitterInputs, t: usize) -> [Vec3; 3] {
    inp.triangles[t].map(|i| inp.positions[i as usize])
}

/// The emission mask's mean α over `samples_per_triangle` seeded points of each triangle,
/// queried in chunks of triangles.
fn mean_alpha(inp: &EmitterInputs, c: &MaskExtractorConfig) -> Result<Vec<f32>> {
    let ns = c.samples_per_triangle.max(1);
    let n = inp.triangles.len();
    let mut alpha = vec![0f32; n];
    let chunk = (262_144 / ns).max(1);
    for start in (0..n).step_by(chunk) {
        let end = (start + chunk).min(n);
        let mut pts = Vec::with_capacity((end - start) * ns);
        for t in start..end {
            let [a, b, cc] = tri_pts(inp, t);
            let mut r = Pcg32::from_keys(&[c.seed, t as u64, 0xE417]);
            for _ in 0..ns {
                let (u, v) = (r.next_f32(), r.next_f32());
                let su = u.sqrt();
                pts.push(a * (1.0 - su) + b * (su * (1.0 - v)) + cc * (su * v));
            }
        }
        let al = inp.field.emission_mask(&pts)?;
        for (k, t) in (start..end).enumerate() {
            alpha[t] = al[k * ns..(k + 1) * ns].iter().sum::<f32>() / ns as f32;
        }
    }
    Ok(alpha)
}

/// The pixels that see each emitter triangle. With `require_unexplained`, triangles whose
/// pixels are mostly within what they could reflect stop being emitters.
fn observed(
    inp: &EmitterInputs,
    is_emitter: &mut [bool],
    require_unexplained: bool,
) -> Result<HashMap<u32, Vec<PixelHit>>> {
    let n = is_emitter.len();
    let mut obs: HashMap<u32, Vec<PixelHit>> = HashMap::new();
    let mut votes: HashMap<u32, (usize, usize)> = HashMap::new();
    inp.pixel_hits.visit(&mut |h| {
        let t = h.triangle;
        if (t as usize) < n && is_emitter[t as usize] {
            obs.entry(t).or_default().push(*h);
            if let Some(b) = h.max_reflected {
                let v = votes.entry(t).or_default();
                v.0 += (luminance(h.radiance) > luminance(b)) as usize;
                v.1 += 1;
            }
        }
    })?;
    if require_unexplained {
        for (t, (above, total)) in votes {
            if 2 * above < total {
                is_emitter[t as usize] = false;
                obs.remove(&t);
            }
        }
    }
    Ok(obs)
}

/// The emitter triangles in groups that share a vertex (by position, so that split vertices
/// of an OBJ still connect).
fn connected_groups(inp: &EmitterInputs, is_emitter: &[bool]) -> Vec<Vec<usize>> {
    let key = |p: Vec3| {
        let q = |x: f32| (x * 1e5).round() as i64;
        (q(p.x), q(p.y), q(p.z))
    };
    let ids: Vec<usize> = (0..is_emitter.len()).filter(|&t| is_emitter[t]).collect();
    let mut sets = DisjointSets::new(ids.len());
    let mut first: HashMap<(i64, i64, i64), usize> = HashMap::new();
    for (k, &t) in ids.iter().enumerate() {
        for p in tri_pts(inp, t) {
            match first.get(&key(p)) {
                Some(&j) => {
                    sets.union(k, j);
                }
                None => {
                    first.insert(key(p), k);
                }
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut slot: HashMap<usize, usize> = HashMap::new();
    for k in 0..ids.len() {
        let r = sets.find(k);
        let g = *slot.entry(r).or_insert_with(|| {
            groups.push(vec![]);
            groups.len() - 1
        });
        groups[g].push(ids[k]);
    }
    groups
}

/// Per emitter triangle: every pixel's radiance, and (with `inner_pixels`) the radiance of its
/// pixels that lie wholly on a light.
fn seen_radiance(
    obs: &HashMap<u32, Vec<PixelHit>>,
    inner_pixels: bool,
) -> HashMap<u32, (Vec<Vec3>, Vec<Vec3>)> {
    let on_light: HashSet<[u32; 3]> = if inner_pixels {
        obs.values().flatten().filter_map(|h| h.at).collect()
    } else {
        HashSet::new()
    };
    let inner = |h: &PixelHit| {
        h.at.is_some_and(|[v, x, y]| {
            (-1i64..=1).all(|dy| {
                (-1i64..=1).all(|dx| {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    nx >= 0 && ny >= 0 && on_light.contains(&[v, nx as u32, ny as u32])
                })
            })
        })
    };
    obs.iter()
        .map(|(&t, v)| {
            let all = v.iter().map(|h| h.radiance).collect();
            let inside = v.iter().filter(|h| inner(h)).map(|h| h.radiance).collect();
            (t, (all, inside))
        })
        .collect()
}

/// The per-channel median of `ls`.
fn channel_median(ls: &[Vec3]) -> Vec3 {
    let mut ch: [Vec<f32>; 3] = Default::default();
    for l in ls {
        for (i, c) in ch.iter_mut().enumerate() {
            c.push(l[i]);
        }
    }
    Vec3::new(median(&mut ch[0]), median(&mut ch[1]), median(&mut ch[2]))
}

/// The light of one group: each triangle's radiance (its pixels' median, else the group's),
/// none when the group was never seen.
fn group_emitter(
    inp: &EmitterInputs,
    c: &MaskExtractorConfig,
    g: &[usize],
    obs: &HashMap<u32, Vec<PixelHit>>,
    seen: &HashMap<u32, (Vec<Vec3>, Vec<Vec3>)>,
) -> Option<Emitter> {
    let radiance_of = |t: usize, inner_only: bool| -> &[Vec3] {
        seen.get(&(t as u32))
            .map_or(&[], |(all, inside)| if inner_only { inside } else { all })
    };
    let all: Vec<Vec3> = g
        .iter()
        .flat_map(|&t| radiance_of(t, false))
        .copied()
        .collect();
    if all.is_empty() {
        return None; // never seen: no radiance to give it
    }
    let inside: Vec<Vec3> = g
        .iter()
        .flat_map(|&t| radiance_of(t, true))
        .copied()
        .collect();
    let use_inner = c.inner_pixels && !inside.is_empty();
    let fallback = channel_median(if use_inner { &inside } else { &all });
    let (mut tris, mut rad) = (vec![], vec![]);
    for &t in g {
        let own = radiance_of(t, use_inner);
        let l = if own.is_empty() {
            fallback
        } else {
            channel_median(own)
        };
        if l.max_element() <= 0.0 || !l.is_finite() {
            continue;
        }
        tris.push(t as u32);
        rad.push(l);
    }
    let pixels = tris.iter().map(|t| obs.get(t).map_or(0, |v| v.len())).sum();
    let sides = if c.observed_sides {
        observed_sides(inp, &tris, obs, fallback)
    } else {
        vec![EmitSide::Both; tris.len()]
    };
    Emitter::from_triangles(inp.positions, inp.triangles, tris, rad, pixels)
        .map(|e| e.with_sides(inp.positions, inp.triangles, sides))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use fipt_core::emitter::PixelHit;
    use fipt_core::field::{Material, MaterialField};

    /// α = 1 inside a box, 0 elsewhere.
    pub(crate) struct BoxMask(pub(crate) Vec3, pub(crate) Vec3);
    impl MaterialField for BoxMask {
        fn name(&self) -> &str {
            "box"
        }
        fn materials(&self, p: &[Vec3]) -> Result<Vec<Material>> {
            Ok(p.iter()
                .map(|_| Material {
                    albedo: Vec3::splat(0.5),
                    roughness: 1.0,
                    metallic: 0.0,
                })
                .collect())
        }
        fn emission_mask(&self, p: &[Vec3]) -> Result<Vec<f32>> {
            Ok(p.iter()
                .map(|&q| (q.cmpge(self.0).all() && q.cmple(self.1).all()) as u8 as f32)
                .collect())
        }
    }

    /// A pixel of triangle `triangle` with radiance `radiance`, its reflectable bound
    /// `max_reflected`, and no place or side.
    fn pixel(triangle: u32, radiance: Vec3, max_reflected: Option<Vec3>) -> PixelHit {
        PixelHit {
            triangle,
            radiance,
            max_reflected,
            at: None,
            front: None,
        }
    }

    fn inputs<'a>(
        positions: &'a [Vec3],
        triangles: &'a [[u32; 3]],
        field: &'a dyn MaterialField,
        pixel_hits: &'a Vec<PixelHit>,
    ) -> EmitterInputs<'a> {
        EmitterInputs {
            positions,
            triangles,
            field,
            pixel_hits,
        }
    }

    /// Two separate unit quads at x = 0 and x = 10 (2 triangles each, split vertices), and a
    /// floor quad.
    fn scene() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut pos = vec![];
        let mut tris = vec![];
        let mut quad = |o: Vec3, u: Vec3, v: Vec3| {
            for t in [[o, o + u, o + u + v], [o, o + u + v, o + v]] {
                let b = pos.len() as u32;
                pos.extend(t);
                tris.push([b, b + 1, b + 2]);
            }
        };
        quad(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z);
        quad(Vec3::new(10.0, 2.0, 0.0), Vec3::X * 0.01, Vec3::Z * 0.01); // 1 cm² lamp
        quad(Vec3::new(-5.0, 0.0, -5.0), Vec3::X * 20.0, Vec3::Z * 20.0);
        (pos, tris)
    }

    #[test]
    fn finds_both_lights_groups_triangles_and_takes_medians() {
        let (pos, tris) = scene();
        let field = BoxMask(Vec3::new(-1.0, 1.5, -1.0), Vec3::new(11.0, 2.5, 1.0));
        let hit = |t: u32, l: Vec3| pixel(t, l, Some(Vec3::splat(1.0)));
        let mut hits = vec![];
        for k in 0..9 {
            // Triangle 0: 9 pixels around 5 with one outlier; triangle 1 unseen.
            let l = if k == 8 {
                Vec3::splat(1e4)
            } else {
                Vec3::new(5.0, 4.0, 3.0)
            };
            hits.push(hit(0, l));
        }
        hits.push(hit(2, Vec3::new(100.0, 90.0, 80.0))); // the tiny lamp: one pixel
        hits.push(hit(4, Vec3::splat(0.3))); // floor
        let ex = MaskExtractor::new(MaskExtractorConfig::default());
        let e = ex.extract(&inputs(&pos, &tris, &field, &hits)).unwrap();
        assert_eq!(e.len(), 2, "{e:?}");
        let big = e.iter().find(|e| e.triangles.contains(&0)).unwrap();
        assert_eq!(big.triangles, vec![0, 1]);
        assert_eq!(
            big.radiance[0],
            [5.0, 4.0, 3.0],
            "median ignores the outlier"
        );
        assert_eq!(
            big.radiance[1],
            [5.0, 4.0, 3.0],
            "unseen triangle takes its light's median"
        );
        assert!((big.area - 1.0).abs() < 1e-5);
        let p = 2.0 * std::f32::consts::PI * 5.0;
        assert!((big.power[0] - p).abs() < 1e-3 * p);
        let tiny = e.iter().find(|e| e.triangles.contains(&2)).unwrap();
        assert_eq!(tiny.triangles, vec![2, 3]);
        assert_eq!(tiny.pixels, 1);
        assert!((tiny.area - 1e-4).abs() < 1e-7);
    }

    /// A light seen as a 5×5-pixel square whose outline pixels are half covered by the dark
    /// floor beside it: its radiance comes from the 3×3 inner pixels, also for a triangle
    /// whose pixels are all on the outline; the reference's rule takes every pixel.
    #[test]
    fn a_lights_radiance_comes_from_its_inner_pixels() {
        let (pos, tris) = scene();
        let field = BoxMask(Vec3::new(-1.0, 1.5, -1.0), Vec3::new(2.0, 2.5, 2.0));
        let l = Vec3::new(8.0, 6.0, 4.0);
        let mut hits = vec![];
        for y in 0..5u32 {
            for x in 0..5u32 {
                let outline = x == 0 || y == 0 || x == 4 || y == 4;
                // Triangle 1 holds only outline pixels (the top row).
                let (t, radiance) = (u32::from(y == 0), if outline { l * 0.5 } else { l });
                hits.push(PixelHit {
                    at: Some([3, 10 + x, 20 + y]),
                    ..pixel(t, radiance, Some(Vec3::splat(0.1)))
                });
            }
        }
        let mut ex = MaskExtractor::new(MaskExtractorConfig::default());
        let inp = inputs(&pos, &tris, &field, &hits);
        let e = ex.extract(&inp).unwrap();
        assert_eq!(e.len(), 1, "{e:?}");
        assert_eq!(e[0].triangles, vec![0, 1]);
        assert_eq!(e[0].radiance, vec![l.to_array(); 2]);
        assert_eq!(e[0].pixels, 25);
        // Every pixel: 11 of triangle 0's 20 pixels are on the outline, all of triangle 1's.
        ex.config.inner_pixels = false;
        let e = ex.extract(&inp).unwrap();
        assert_eq!(e[0].radiance, vec![(l * 0.5).to_array(); 2]);
        // Without the pixels' places nothing is inner: every pixel counts.
        ex.config.inner_pixels = true;
        let unplaced: Vec<PixelHit> = hits.iter().map(|h| PixelHit { at: None, ..*h }).collect();
        let e = ex
            .extract(&EmitterInputs {
                pixel_hits: &unplaced,
                ..inp
            })
            .unwrap();
        assert_eq!(e[0].radiance[1], (l * 0.5).to_array());
    }

    /// A light seen only from its winding side emits only there, one seen only from the
    /// other side only there, one seen from both on both; power counts the emitting sides.
    /// With `observed_sides` off (the reference) or the sides unknown, both sides emit.
    #[test]
    fn a_light_emits_on_the_sides_its_pixels_saw() {
        let (pos, tris) = scene();
        let field = BoxMask(Vec3::new(-1.0, 1.5, -1.0), Vec3::new(11.0, 2.5, 1.0));
        let hit = |t: u32, front: Option<bool>| PixelHit {
            front,
            ..pixel(t, Vec3::splat(5.0), Some(Vec3::splat(0.5)))
        };
        // Panel (triangles 0, 1): 0 seen lit from its winding side and dark from the other
        // (a view of a luminaire's back), 1 lit from both.
        // Lamp (2, 3): 2 seen from the other side only, 3 unseen: it lies in 2's plane,
        // wound the same way, and takes 2's side.
        let dark_back = PixelHit {
            radiance: Vec3::splat(0.5),
            ..hit(0, Some(false))
        };
        let hits = vec![
            hit(0, Some(true)),
            hit(0, Some(true)),
            dark_back,
            hit(1, Some(true)),
            hit(1, Some(false)),
            hit(2, Some(false)),
        ];
        let mut ex = MaskExtractor::new(MaskExtractorConfig::default());
        let inp = inputs(&pos, &tris, &field, &hits);
        let e = ex.extract(&inp).unwrap();
        let light = |t: u32| e.iter().find(|l| l.triangles.contains(&t)).unwrap();
        assert_eq!(light(0).sides, vec![EmitSide::Front, EmitSide::Both]);
        assert_eq!(light(2).sides, vec![EmitSide::Back, EmitSide::Back]);
        let pi5 = std::f32::consts::PI * 5.0;
        // Panel: area 0.5 on one side + 0.5 on both = 1.5 sides·m².
        assert!(
            (light(0).power[0] - 1.5 * pi5).abs() < 1e-3,
            "{:?}",
            light(0)
        );
        let (up, down) = (Vec3::Y, -Vec3::Y);
        let n0 = (pos[1] - pos[0]).cross(pos[2] - pos[0]);
        assert!(light(0).side(0).emits_towards(n0, n0) && !light(0).side(0).emits_towards(n0, -n0));
        assert!(light(0).side(1).emits_towards(n0, up) && light(0).side(1).emits_towards(n0, down));
        assert!(EmitSide::Back.emits_towards(n0, -n0) && !EmitSide::Back.emits_towards(n0, n0));
        // The unseen triangle wound the other way takes the other side.
        let mut flipped = tris.clone();
        flipped[3].swap(1, 2);
        let e = ex
            .extract(&EmitterInputs {
                triangles: &flipped,
                ..inputs(&pos, &tris, &field, &hits)
            })
            .unwrap();
        let lamp = e.iter().find(|l| l.triangles.contains(&2)).unwrap();
        assert_eq!(lamp.sides, vec![EmitSide::Back, EmitSide::Front]);
        ex.config.observed_sides = false;
        let e = ex.extract(&inp).unwrap();
        assert!(e.iter().all(|l| l.sides.is_empty()), "{e:?}");
        let p = 2.0 * pi5;
        assert!(e.iter().all(|l| (l.power[0] / l.area - p).abs() < 1e-3 * p));
        ex.config.observed_sides = true;
        let unknown: Vec<PixelHit> = hits
            .iter()
            .map(|h| PixelHit { front: None, ..*h })
            .collect();
        let e = ex
            .extract(&EmitterInputs {
                pixel_hits: &unknown,
                ..inp
            })
            .unwrap();
        assert!(e.iter().all(|l| l.sides.is_empty()), "{e:?}");
    }

    /// An unseen triangle takes the side of a seen one in its plane, not of a parallel one
    /// across a closed light (the far side of a bulb).
    #[test]
    fn an_unseen_triangle_takes_the_side_of_one_in_its_plane_only() {
        let tri = |o: Vec3| [o, o + Vec3::Z, o + Vec3::X];
        let pos: Vec<Vec3> = [Vec3::ZERO, Vec3::Y, Vec3::new(2.0, 0.0, 0.0)]
            .into_iter()
            .flat_map(tri)
            .collect();
        let tris = vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]];
        let seen = PixelHit {
            front: Some(true),
            ..pixel(0, Vec3::splat(5.0), None)
        };
        let field = BoxMask(Vec3::ZERO, Vec3::ZERO);
        let hits = vec![seen];
        let inp = inputs(&pos, &tris, &field, &hits);
        let obs = HashMap::from([(0u32, vec![hits[0]])]);
        let sides = observed_sides(&inp, &[0, 1, 2], &obs, Vec3::splat(5.0));
        assert_eq!(
            sides,
            vec![EmitSide::Front, EmitSide::Both, EmitSide::Front]
        );
    }

    #[test]
    fn a_masked_surface_within_its_reflectable_radiance_is_not_a_light() {
        let (pos, tris) = scene();
        // The mask covers the floor too (as an under-trained mask does).
        let field = BoxMask(Vec3::splat(-100.0), Vec3::splat(100.0));
        let mut hits = vec![];
        for _ in 0..4 {
            hits.push(pixel(0, Vec3::splat(5.0), Some(Vec3::splat(0.5))));
            hits.push(pixel(4, Vec3::splat(0.3), Some(Vec3::splat(0.5))));
        }
        let mut ex = MaskExtractor::new(MaskExtractorConfig::default());
        let inp = inputs(&pos, &tris, &field, &hits);
        let e = ex.extract(&inp).unwrap();
        assert_eq!(e.len(), 1, "{e:?}");
        assert!(e[0].triangles.contains(&0) && !e[0].triangles.contains(&4));
        // The reference's rule keeps the floor.
        ex.config.require_unexplained = false;
        let e = ex.extract(&inp).unwrap();
        assert!(e.iter().any(|l| l.triangles.contains(&4)));
    }

    #[test]
    fn nothing_emits_when_the_mask_is_empty() {
        let (pos, tris) = scene();
        let field = BoxMask(Vec3::splat(100.0), Vec3::splat(101.0));
        let hits = vec![pixel(0, Vec3::ONE, None)];
        let e = MaskExtractor::new(MaskExtractorConfig::default())
            .extract(&inputs(&pos, &tris, &field, &hits))
            .unwrap();
        assert!(e.is_empty());
    }
}
