//! A binary glTF's framing checked before the `gltf` crate reads it: that crate allocates
//! what the header's lengths say, so a corrupt length would ask for gigabytes.
use crate::error::{GeomError, Result};
use std::io::Read;
use std::path::Path;

fn bad(path: &Path, m: String) -> GeomError {
    GeomError::Parse {
        path: path.to_path_buf(),
        message: m,
    }
}

/// Checks that a `.glb`'s declared total length and chunk lengths fit the file (files that do
/// not start with the `glTF` magic are left to the JSON reader).
pub fn check_glb(path: &Path) -> Result<()> {
    let io = |e| GeomError::Io {
        path: path.to_path_buf(),
        source: e,
    };
    let size = std::fs::metadata(path).map_err(io)?.len();
    let mut f = std::fs::File::open(path).map_err(io)?;
    let mut head = [0u8; 12];
    if size < 12 || f.read_exact(&mut head).is_err() || &head[..4] != b"glTF" {
        return Ok(());
    }
    let u = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64;
    let total = u(&head[8..12]);
    if total != size {
        return Err(bad(
            path,
            format!(
                "the header declares {total} bytes but the file has {size} (truncated or corrupt)"
            ),
        ));
    }
    let mut at = 12u64;
    while at + 8 <= size {
        let mut ch = [0u8; 8];
        f.read_exact(&mut ch).map_err(io)?;
        let len = u(&ch[..4]);
        if at + 8 + len > size {
            return Err(bad(
                path,
                format!("a chunk at byte {at} declares {len} bytes past the end of the file"),
            ));
        }
        std::io::copy(&mut (&mut f).take(len), &mut std::io::sink()).map_err(io)?;
        at += 8 + len;
    }
    Ok(())
}

/// Checks that an accessor's elements lie inside its buffer view and buffer, with a stride
/// no shorter than one element, and that its component type is one of `types` (and its
/// dimensions `dims`): the `gltf` readers assume all of it and panic otherwise. `what` names
/// it in the message ("mesh 0 POSITION").
pub fn check_accessor(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    what: &str,
    types: &[gltf::accessor::DataType],
    dims: gltf::accessor::Dimensions,
) -> std::result::Result<(), String> {
    if !types.contains(&acc.data_type()) || acc.dimensions() != dims {
        return Err(format!(
            "{what}: accessor {} holds {:?} {:?}, expected {dims:?} of {types:?}",
            acc.index(),
            acc.dimensions(),
            acc.data_type()
        ));
    }
    let Some(view) = acc.view() else {
        return Ok(()); // all zeros (or sparse): nothing is read from a buffer
    };
    let size = acc.size();
    let stride = view.stride().unwrap_or(size);
    let buffer = view.buffer().index();
    let len = buffers.get(buffer).map_or(0, |b| b.len());
    let last = match acc.count() {
        0 => 0,
        n => acc.offset() + (n - 1) * stride + size,
    };
    if stride < size || last > view.length() || view.offset() + view.length() > len {
        return Err(format!(
            "{what}: accessor {} ({} elements of {size} bytes, stride {stride}, offset {}) \
             does not fit its buffer view {} ({} bytes at {} of buffer {buffer}, {len} bytes)",
            acc.index(),
            acc.count(),
            acc.offset(),
            view.index(),
            view.length(),
            view.offset()
        ));
    }
    Ok(())
}

/// The accessors a primitive's geometry is read from (positions, normals, indices) checked
/// against their buffers before the `gltf` readers touch them (the mesh loader and
/// `fipt-export`'s .glb loader both read these).
pub fn check_primitive_geometry(
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    mesh: usize,
) -> std::result::Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    for (sem, acc) in prim.attributes() {
        if matches!(sem, gltf::Semantic::Positions | gltf::Semantic::Normals) {
            let what = format!("mesh {mesh} {sem:?}");
            check_accessor(&acc, buffers, &what, &[DataType::F32], Dimensions::Vec3)?;
        }
    }
    if let Some(acc) = prim.indices() {
        let types = [DataType::U8, DataType::U16, DataType::U32];
        let what = format!("mesh {mesh} indices");
        check_accessor(&acc, buffers, &what, &types, Dimensions::Scalar)?;
    }
    Ok(())
}

/// Checks that every external file a glTF's buffers (and, with `images`, its images) name
/// lies beside it: the `gltf` crate reports a missing one as a bare "No such file or
/// directory", naming neither the file nor what refers to it. Embedded data (`data:` URIs,
/// a .glb's own chunk) is not checked here.
pub fn check_external_files(doc: &gltf::Document, gltf_path: &Path, images: bool) -> Result<()> {
    let base = gltf_path.parent().unwrap_or(Path::new("."));
    let missing = |what: String, uri: &str| -> Result<()> {
        if uri.starts_with("data:") {
            return Ok(());
        }
        let file = base.join(percent_decoded(uri));
        if file.is_file() {
            return Ok(());
        }
        Err(bad(
            gltf_path,
            format!(
                "{what} refers to `{uri}`, which is not at {}: copy it beside the .gltf file, or save the scene as a .glb, which holds its data",
                file.display()
            ),
        ))
    };
    for b in doc.buffers() {
        if let gltf::buffer::Source::Uri(uri) = b.source() {
            missing(format!("buffer {}", b.index()), uri)?;
        }
    }
    if images {
        for i in doc.images() {
            if let gltf::image::Source::Uri { uri, .. } = i.source() {
                missing(format!("image {}", i.index()), uri)?;
            }
        }
    }
    Ok(())
}

/// A relative URI's path with its %XX escapes decoded (glTF URIs escape spaces and the
/// like); an escape that is not two hex digits is kept as written.
fn percent_decoded(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Runs a `gltf` crate reader, turning its panics on malformed files (it indexes and unwraps
/// unchecked in places) into an error naming the file.
pub fn guarded<T>(path: &Path, read: impl FnOnce() -> std::result::Result<T, String>) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(m)) => Err(bad(path, m)),
        Err(_) => Err(bad(
            path,
            "the glTF reader failed on this file (malformed)".into(),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_length_past_the_end_is_refused_before_reading() {
        let d = std::env::temp_dir().join(format!("fipt-glb-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("a.glb");
        let mut b = b"glTF".to_vec();
        b.extend(2u32.to_le_bytes());
        b.extend(28u32.to_le_bytes());
        b.extend(400_000_000u32.to_le_bytes());
        b.extend(b"JSON");
        b.extend(b"{}  {}  ");
        std::fs::write(&p, &b).unwrap();
        let e = check_glb(&p).unwrap_err().to_string();
        assert!(e.contains("past the end"), "{e}");
        b[8..12].copy_from_slice(&99u32.to_le_bytes());
        std::fs::write(&p, &b).unwrap();
        assert!(check_glb(&p)
            .unwrap_err()
            .to_string()
            .contains("declares 99 bytes"));
        let _ = std::fs::remove_dir_all(&d);
    }
}
