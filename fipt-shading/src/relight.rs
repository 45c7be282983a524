//! A lights file applied to a scene: the scene's emitters scaled or switched off, area lights
//! appended as emitting triangles, point and spot lights returned as delta lights, and lights
//! that cut through the scene's surfaces refused.
use crate::edit::{AddedSurface, EditedSurfaces};
use crate::error::{Result, ShadingError};
use crate::lights::{DeltaLight, EmitterPolicy, LightsFile};
use crate::scene::SurfaceModel;
use fipt_core::materials::SurfacePoint;
use fipt_geom::{BuildQuality, Bvh, Mesh};
use glam::Vec3;
use std::path::Path;

/// Part index of added lights in `part` maps.
pub const LIGHT_PART: u32 = u32::MAX - 1;

fn invalid(path: &Path, message: String) -> ShadingError {
    ShadingError::Invalid {
        path: path.to_path_buf(),
        message,
    }
}

/// Applies `file` (read from `path`) to `surfaces` of `mesh`: `emitters[k]` are the base
/// triangles of emitter id k (as `emitters.json` numbers them), `default` the policy when
/// the file sets none. Returns the point and spot lights.
pub fn apply_lights<S: SurfaceModel>(
    mesh: &mut Mesh,
    surfaces: &mut EditedSurfaces<S>,
    file: &LightsFile,
    path: &Path,
    default: EmitterPolicy,
    emitters: &[Vec<u32>],
) -> Result<Vec<DeltaLight>> {
    if let Some((&id, _)) = file
        .overrides
        .iter()
        .find(|(&id, _)| id as usize >= emitters.len())
    {
        return Err(invalid(
            path,
            format!(
                "emitter_overrides: no emitter {id} (the scene has {}; ids are those of emitters.json)",
                emitters.len()
            ),
        ));
    }
    let policy = file.emitters.unwrap_or(default);
    for (k, tris) in emitters.iter().enumerate() {
        let p = file.overrides.get(&(k as u32)).copied().unwrap_or(policy);
        if p != EmitterPolicy::Keep {
            surfaces.scale_emission(tris.iter().copied(), p.factor());
        }
    }
    let base = Bvh::build(mesh, BuildQuality::Fast);
    let diag = {
        let b = mesh.bounds();
        (b.max - b.min).length().max(1e-6)
    };
    let mut deltas = Vec::new();
    for (k, spec) in file.lights.iter().enumerate() {
        if let Some(d) = spec.delta() {
            if near_surface(&base, d.position, 1e-4 * diag) {
                return Err(invalid(
                    path,
                    format!("light {k}: its position lies on the scene's surface (within {:.1e}); move it into free space", 1e-4 * diag),
                ));
            }
            deltas.push(d);
            continue;
        }
        let area = spec
            .area(&file.dir)
            .map_err(|e| invalid(path, format!("light {k}: {e}")))?;
        let Some((light, le, two_sided)) = area else {
            continue;
        };
        if let Some(t) = crossing_triangle(&base, &light) {
            return Err(invalid(
                path,
                format!("light {k}: it cuts through the scene's surface (its triangle {t} crosses it); move it into free space or shrink it"),
            ));
        }
        let what = AddedSurface {
            surface: SurfacePoint {
                emission: le,
                roughness: 1.0,
                ..Default::default()
            },
            one_sided: !two_sided,
            part: LIGHT_PART,
        };
        surfaces.add(mesh, &light, what);
    }
    Ok(deltas)
}

/// The first triangle of `m` one of whose edges crosses a surface of `bvh`.
fn crossing_triangle(bvh: &Bvh, m: &Mesh) -> Option<usize> {
    (0..m.triangles.len()).find(|&t| {
        let v = m.vertices(t);
        (0..3).any(|i| {
            let (a, b) = (v[i], v[(i + 1) % 3]);
            let d = b - a;
            let len = d.length();
            len > 0.0 && bvh.occluded(a, d / len, len)
        })
    })
}

/// Whether a surface passes within `r` of `p` (segments of length 2r through `p` along 13
/// axes).
fn near_surface(bvh: &Bvh, p: Vec3, r: f32) -> bool {
    let mut dirs = Vec::new();
    for x in -1..=1 {
        for y in -1..=1 {
            for z in 0..=1 {
                let d = Vec3::new(x as f32, y as f32, z as f32);
                if z == 1 || (z == 0 && (y == 1 || (y == 0 && x == 1))) {
                    dirs.push(d.normalize());
                }
            }
        }
    }
    dirs.iter()
        .any(|&d| bvh.closest_hit(p - d * r, d, 0.0, 2.0 * r).is_some())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::LambertSurfaces;

    fn floor() -> (Mesh, EditedSurfaces<LambertSurfaces>) {
        let s = 2.0;
        let mesh = Mesh::from_triangles(
            vec![
                Vec3::new(-s, 0.0, -s),
                Vec3::new(s, 0.0, -s),
                Vec3::new(s, 0.0, s),
                Vec3::new(-s, 0.0, s),
            ],
            None,
            vec![[0, 2, 1], [0, 3, 2]],
        );
        let base = LambertSurfaces {
            albedo: vec![Vec3::splat(0.5); 2],
            emission: vec![Vec3::ZERO, Vec3::ONE],
        };
        let e = EditedSurfaces::new(base, &mesh);
        (mesh, e)
    }

    #[test]
    fn lights_are_added_and_emitters_switched_off() {
        let (mut mesh, mut s) = floor();
        let f = LightsFile::parse(
            r#"{"lights": [{"type": "sphere", "center": [0, 1, 0], "radius": 0.1, "radiance": [5, 5, 5], "subdivisions": 1},
                           {"type": "point", "position": [0, 2, 0], "intensity": [1, 1, 1]}],
                "emitters": "off"}"#,
            Path::new("l.json"),
        )
        .unwrap();
        let d = apply_lights(
            &mut mesh,
            &mut s,
            &f,
            Path::new("l.json"),
            EmitterPolicy::Keep,
            &[vec![1]],
        )
        .unwrap();
        assert_eq!(d.len(), 1);
        assert_eq!(mesh.triangles.len(), 2 + 80);
        assert_eq!(s.emission(1), Vec3::ZERO);
        assert_eq!(s.emission(2), Vec3::splat(5.0));
        assert_eq!(s.emit_side(2), fipt_core::emitter::EmitSide::Front);
    }

    #[test]
    fn lights_through_a_wall_or_on_it_and_unknown_ids_are_refused() {
        let p = Path::new("l.json");
        let cases = [
            (
                r#"{"type": "sphere", "center": [0, 0.05, 0], "radius": 0.1, "radiance": [1, 1, 1]}"#,
                "cuts through",
            ),
            (
                r#"{"type": "point", "position": [0, 0, 0.5], "intensity": [1, 1, 1]}"#,
                "lies on",
            ),
            (
                r#"{"lights": [], "emitter_overrides": {"3": "off"}}"#,
                "no emitter 3",
            ),
        ];
        for (text, want) in cases {
            let (mut mesh, mut s) = floor();
            let f = LightsFile::parse(text, p).unwrap();
            let err = apply_lights(&mut mesh, &mut s, &f, p, EmitterPolicy::Keep, &[vec![1]])
                .unwrap_err()
                .to_string();
            assert!(
                err.contains(want) && err.contains("l.json"),
                "{text}: {err}"
            );
        }
    }
}
