//! OBJ + MTL writer, and the OBJ meshes and PNG textures the Mitsuba scene shares.
use crate::textures::MaterialTextures;
use crate::{png, write_atomic, Prepared, Primitive, Result};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// OBJ text of `objects` (name, primitive, material); vertex indices continue across objects.
/// Texture coordinates are written with v up (OBJ's convention: v = 1 − glTF's v).
pub(crate) fn obj_text(
    header: &str,
    mtllib: Option<&str>,
    objects: &[(String, &Primitive, &str)],
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# {header}");
    if let Some(m) = mtllib {
        let _ = writeln!(s, "mtllib {m}");
    }
    let (mut base, mut base_t) = (1usize, 1usize);
    for (name, p, mtl) in objects {
        let _ = writeln!(s, "o {name}");
        for v in &p.positions {
            let _ = writeln!(s, "v {} {} {}", v.x, v.y, v.z);
        }
        for n in &p.normals {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
        for t in &p.uvs {
            let _ = writeln!(s, "vt {} {}", t.x, 1.0 - t.y);
        }
        let _ = writeln!(s, "usemtl {mtl}");
        let textured = !p.uvs.is_empty();
        for f in p.indices.chunks(3) {
            let c = |i: u32| {
                let v = base + i as usize;
                if textured {
                    format!("{v}/{}/{v}", base_t + i as usize)
                } else {
                    format!("{v}//{v}")
                }
            };
            let _ = writeln!(s, "f {} {} {}", c(f[0]), c(f[1]), c(f[2]));
        }
        base += p.positions.len();
        base_t += p.uvs.len();
    }
    s
}

/// `textures/base_color.png` (sRGB), `roughness.png` and `metallic.png` (linear, 8-bit).
pub(crate) fn write_textures(t: &MaterialTextures, dir: &Path) -> Result<Vec<PathBuf>> {
    let d = dir.join("textures");
    let rgb = image::ExtendedColorType::Rgb8;
    let l8 = image::ExtendedColorType::L8;
    let base = t.base_color_srgb8();
    let r = MaterialTextures::grey8(&t.roughness, t.width, t.height);
    let m = MaterialTextures::grey8(&t.metallic, t.width, t.height);
    Ok(vec![
        write_atomic(
            &d.join("base_color.png"),
            &png(base.as_raw(), t.width, t.height, rgb),
        )?,
        write_atomic(
            &d.join("roughness.png"),
            &png(r.as_raw(), t.width, t.height, l8),
        )?,
        write_atomic(
            &d.join("metallic.png"),
            &png(m.as_raw(), t.width, t.height, l8),
        )?,
    ])
}

/// `scene.obj`, `scene.mtl` and the textures.
pub(crate) fn write(p: &Prepared, dir: &Path) -> Result<Vec<PathBuf>> {
    let t = p.textures.as_ref().expect("textured");
    let mut files = write_textures(t, dir)?;
    let mut mtl =
        String::from("# fipt-rs recovered materials (PBR extension: Pr roughness, Pm metallic)\n");
    mtl += "newmtl recovered\nKd 1 1 1\nKs 0 0 0\nmap_Kd textures/base_color.png\nPr 1\nmap_Pr textures/roughness.png\nPm 1\nmap_Pm textures/metallic.png\n";
    let names: Vec<String> = p
        .emitters
        .iter()
        .map(|e| format!("emitter_{}", e.id))
        .collect();
    let mut objects = vec![("recovered".to_string(), &p.surface, "recovered")];
    for (e, n) in p.emitters.iter().zip(&names) {
        let _ = write!(
            mtl,
            "\nnewmtl {n}\nKd 0 0 0\nKs 0 0 0\nKe {} {} {}\n",
            e.radiance.x, e.radiance.y, e.radiance.z
        );
        objects.push((n.clone(), &e.primitive, n.as_str()));
    }
    files.push(write_atomic(&dir.join("scene.mtl"), mtl.as_bytes())?);
    let text = obj_text("fipt-rs recovered scene", Some("scene.mtl"), &objects);
    files.push(write_atomic(&dir.join("scene.obj"), text.as_bytes())?);
    Ok(files)
}
