//! The procedural scenes' subdivision (for scaling measurements): the same surfaces and
//! materials with 4^K times the triangles.
use fipt_synth::build;

#[test]
fn subdivision_keeps_area_materials_and_orientation() {
    let base = build("room").unwrap();
    let n = base.mesh.triangles.len();
    let area = |m: &fipt_geom::Mesh, i: usize| m.area(i) as f64;
    let table = base
        .materials
        .face_table(n, std::path::Path::new("scene_gt.json"))
        .unwrap();
    let fine = build("room").unwrap().subdivided(2);
    assert_eq!(fine.mesh.triangles.len(), 16 * n);
    let fine_table = fine
        .materials
        .face_table(16 * n, std::path::Path::new("scene_gt.json"))
        .unwrap();
    for i in 0..n {
        let parts = 16 * i..16 * (i + 1);
        // Same material, same total area, same geometric normal on every child.
        assert!(parts.clone().all(|j| fine_table[j] == table[i]), "face {i}");
        let a: f64 = parts.clone().map(|j| area(&fine.mesh, j)).sum();
        // f32 midpoints of coordinates of a few metres: ~1e-7 m of rounding per vertex.
        let b = area(&base.mesh, i);
        assert!(
            (a - b).abs() <= 1e-3 * b + 1e-9,
            "face {i}: {a} against {b}"
        );
        let ng = base.mesh.face_normal(i);
        for j in parts {
            assert!(
                fine.mesh.face_normal(j).dot(ng) > 0.999,
                "face {i} child {j}"
            );
        }
    }
    // Welded: a shared midpoint is one vertex (Euler: far fewer than 3 per triangle).
    assert!(fine.mesh.positions.len() < fine.mesh.triangles.len());
}
