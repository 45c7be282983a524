//! Malformed mesh files end in an error naming the file and what is wrong, never a panic, an
//! endless loop or an allocation the file cannot back.
use fipt_geom::Mesh;
use std::path::PathBuf;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fipt-malformed-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A one-triangle glTF (positions then u32 indices in `t.bin`) with the JSON edited by `edit`.
fn gltf(name: &str, edit: impl Fn(&mut serde_json::Value)) -> PathBuf {
    let d = dir(name);
    let mut bin = vec![];
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        v.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    }
    [0u32, 1, 2]
        .iter()
        .for_each(|i| bin.extend(i.to_le_bytes()));
    std::fs::write(d.join("t.bin"), &bin).unwrap();
    let mut j = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"uri": "t.bin", "byteLength": 48}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}
        ]
    });
    edit(&mut j);
    let p = d.join("t.gltf");
    std::fs::write(&p, serde_json::to_vec(&j).unwrap()).unwrap();
    p
}

fn error_of(p: &std::path::Path) -> String {
    match Mesh::load(p) {
        Ok(m) => panic!("{}: loaded {} triangles", p.display(), m.triangles.len()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_well_formed_gltf_loads() {
    let m = Mesh::load(&gltf("good", |_| {})).unwrap();
    assert_eq!(m.triangles.len(), 1);
}

#[test]
fn gltf_accessors_that_do_not_fit_are_errors_naming_the_file() {
    let cases: [(&str, fn(&mut serde_json::Value), &str); 3] = [
        (
            "float-indices",
            |j| j["accessors"][1]["componentType"] = 5126.into(),
            "expected Scalar",
        ),
        (
            "short-stride",
            |j| j["bufferViews"][0]["byteStride"] = 4.into(),
            "does not fit",
        ),
        (
            "count-past-view",
            |j| j["accessors"][0]["count"] = 1_000_000.into(),
            "does not fit",
        ),
    ];
    for (name, edit, says) in cases {
        let e = error_of(&gltf(name, edit));
        assert!(e.contains("t.gltf") && e.contains(says), "{name}: {e}");
    }
    // An index past the vertices.
    let p = gltf("index-past-vertices", |_| {});
    let bin = p.with_file_name("t.bin");
    let mut b = std::fs::read(&bin).unwrap();
    b[44..48].copy_from_slice(&7u32.to_le_bytes());
    std::fs::write(&bin, b).unwrap();
    let e = error_of(&p);
    assert!(e.contains("index 7 beyond its 3 vertices"), "{e}");
}

#[test]
fn a_gltf_whose_buffer_file_is_missing_names_that_file() {
    let e = error_of(&gltf("nobin", |j| {
        j["buffers"][0]["uri"] = "gone.bin".into()
    }));
    assert!(
        e.contains("t.gltf") && e.contains("buffer 0") && e.contains("gone.bin"),
        "{e}"
    );
    // An escaped name is looked up decoded.
    let p = gltf("escaped", |j| j["buffers"][0]["uri"] = "t%20b.bin".into());
    std::fs::rename(p.with_file_name("t.bin"), p.with_file_name("t b.bin")).unwrap();
    assert_eq!(Mesh::load(&p).unwrap().triangles.len(), 1);
}

#[test]
fn a_gltf_node_that_is_its_own_child_is_an_error_not_an_endless_walk() {
    let p = gltf("cycle", |j| {
        j["nodes"][0]["children"] = serde_json::json!([0])
    });
    let e = error_of(&p);
    assert!(e.contains("reached twice"), "{e}");
}

#[test]
fn a_ply_header_declaring_more_than_the_file_holds_is_refused_before_reading() {
    let d = dir("ply");
    let p = d.join("huge.ply");
    let text = "ply\nformat ascii 1.0\nelement vertex 100000000000\nproperty float x\n\
                property float y\nproperty float z\nelement face 1\n\
                property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    std::fs::write(&p, text).unwrap();
    let e = error_of(&p);
    assert!(
        e.contains("huge.ply") && e.contains("more than the file"),
        "{e}"
    );
    // A vertex element without coordinates.
    let q = d.join("nocoords.ply");
    std::fs::write(
        &q,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float u\nend_header\n0\n1\n2\n",
    )
    .unwrap();
    assert!(error_of(&q).contains("no x, y, z"));
}
