//! `fipt degrade`'s mesh: the source's, or subdivided, refined for a ripple, warped and
//! rippled, as a scan gives it.
use crate::bail;
use crate::degrade::DegradeRequest;
use crate::error::Result;
use fipt_core::dataset::Dataset;

/// A ripple's mesh refinement: edges of at most this share of its wavelength.
const RIPPLE_EDGE: f32 = 1.0 / 6.0;

/// Most triangles a rippled copy may have (a scan of a room has about 10⁵ to 10⁶).
const MAX_TRIANGLES: f64 = 4.0e6;

/// The copy's mesh: the source's file as it is, or a mesh made from it.
pub(crate) enum CopyMesh {
    /// The source's file, copied byte for byte; its triangles.
    Same(usize),
    /// Subdivided, refined, warped or rippled: the mesh, its OBJ header and, when refined,
    /// each source face's first triangle.
    Made(fipt_geom::Mesh, String, Option<Vec<u32>>),
}

/// The mesh, subdivided, refined, warped and rippled as asked; refused (before anything is
/// written) when the ripple's refinement would pass [`MAX_TRIANGLES`].
pub(crate) fn prepare_mesh(a: &DegradeRequest, ds: &Dataset) -> Result<CopyMesh> {
    let mesh = fipt_geom::Mesh::load(&ds.mesh)?;
    let ripple = a.ripple_mm > 0.0;
    if a.subdivide == 0 && a.warp_mm == 0.0 && !ripple {
        return Ok(CopyMesh::Same(mesh.triangles.len()));
    }
    let mut m = mesh.subdivided(a.subdivide);
    // Number the triangles as the faces `refined` lists (subdivided(0) keeps the file's).
    m.face_ids = (0..m.triangles.len() as u32).collect();
    m.num_file_faces = m.triangles.len();
    let mut starts = None;
    let mut what = format!("subdivided {}×", a.subdivide);
    let mut ripple_note = String::new();
    if ripple {
        let edge = a.ripple_cm / 100.0 * RIPPLE_EDGE;
        let area: f64 = (0..m.triangles.len()).map(|t| m.area(t) as f64).sum();
        // Refined triangles keep about edge²/6 of area each (atelier: 0.16·edge²); /8 errs
        // towards refusing.
        let estimate = area / (edge as f64 * edge as f64 / 8.0);
        if estimate > MAX_TRIANGLES {
            bail!(
                "--mesh-ripple {},{}: the mesh ({area:.1} m²) would need about {:.1e} triangles of {:.1} cm edges (at most {MAX_TRIANGLES:.0e}); give a longer wavelength",
                a.ripple_mm,
                a.ripple_cm,
                estimate,
                edge * 100.0
            );
        }
        let (fine, s) = m.refined(edge);
        starts = Some(source_face_starts(&mesh, a.subdivide, &s));
        m = fine;
        what = format!("{what}, refined to edges of {:.2} cm", edge * 100.0);
        ripple_note = format!(
            ", rippled by up to {} mm at {} cm",
            a.ripple_mm, a.ripple_cm
        );
    }
    let m = m.warped(a.warp_mm / 1000.0, a.seed).rippled(
        a.ripple_mm / 1000.0,
        a.ripple_cm / 100.0,
        a.seed,
    );
    let header = format!(
        "fipt degrade of {}: {what}, warped by up to {} mm{ripple_note} (seed {})",
        ds.mesh.display(),
        a.warp_mm,
        a.seed
    );
    Ok(CopyMesh::Made(m, header, starts))
}

/// Writes the copy's mesh; its triangle count and, when refined, each source face's first
/// triangle.
pub(crate) fn write_mesh(
    a: &DegradeRequest,
    ds: &Dataset,
    mesh: CopyMesh,
) -> Result<(usize, Option<Vec<u32>>)> {
    match mesh {
        CopyMesh::Same(triangles) => {
            let name = ds.mesh.file_name().unwrap_or_default();
            std::fs::copy(&ds.mesh, a.out.join(name))?;
            Ok((triangles, None))
        }
        CopyMesh::Made(m, header, starts) => {
            m.write_obj(&a.out.join("scene.obj"), &header)?;
            Ok((m.triangles.len(), starts))
        }
    }
}

/// Per file face of `source`, its first triangle in a copy subdivided `levels` times (each kept
/// triangle into 4^levels, in order) and then refined with `refined_starts`; a face the mesh
/// dropped as degenerate starts where the next one does.
fn source_face_starts(source: &fipt_geom::Mesh, levels: u32, refined_starts: &[u32]) -> Vec<u32> {
    let k = 4usize.pow(levels);
    let mut t = 0;
    (0..=source.num_file_faces)
        .map(|f| {
            while t < source.face_ids.len() && (source.face_ids[t] as usize) < f {
                t += 1;
            }
            // t ≤ the kept triangles, so t·k ≤ the subdivided ones: the last entry at most.
            refined_starts[t * k]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_geom::Mesh;
    use glam::Vec3;

    /// Three faces in the file, the middle one degenerate (dropped on load): each kept face's
    /// triangles are found after subdividing 0 or 1 times and refining, and the dropped face's
    /// range is empty.
    #[test]
    fn face_starts_follow_the_faces_the_mesh_kept() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
        let source = Mesh::from_triangles(p, None, vec![[0, 1, 2], [0, 0, 1], [1, 3, 2]]);
        assert_eq!((source.num_file_faces, source.triangles.len()), (3, 2));
        for levels in [0, 1] {
            let mut m = source.subdivided(levels);
            m.face_ids = (0..m.triangles.len() as u32).collect();
            m.num_file_faces = m.triangles.len();
            let (fine, s) = m.refined(0.2);
            let starts = source_face_starts(&source, levels, &s);
            assert_eq!(starts.len(), 4);
            assert_eq!(starts[3] as usize, fine.triangles.len());
            assert_eq!(starts[1], starts[2], "the dropped face has no triangles");
            let area = |f: usize| -> f32 {
                (starts[f] as usize..starts[f + 1] as usize)
                    .map(|t| fine.area(t))
                    .sum()
            };
            assert!(
                (area(0) - 0.5).abs() < 1e-5 && (area(2) - 0.5).abs() < 1e-5,
                "{levels}"
            );
        }
    }
}
