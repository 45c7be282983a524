//! Mitsuba 3 scene writer: `scene.xml`, OBJ meshes, PNG textures.
use crate::obj::{obj_text, write_textures};
use crate::{write_atomic, Prepared, Result};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// `scene.xml` with a `principled` BSDF on the textured surface and an area emitter per light.
pub(crate) fn write(p: &Prepared, dir: &Path) -> Result<Vec<PathBuf>> {
    let t = p.textures.as_ref().expect("textured");
    let mut files = write_textures(t, dir)?;
    let surface = obj_text(
        "fipt-rs recovered surface",
        None,
        &[("recovered".into(), &p.surface, "recovered")],
    );
    files.push(write_atomic(
        &dir.join("meshes/recovered.obj"),
        surface.as_bytes(),
    )?);
    let mut xml = String::from(
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- fipt-rs recovered scene: principled BSDF from the atlas textures, area emitters -->\n<scene version=\"3.0.0\">\n",
    );
    xml += "    <bsdf type=\"twosided\" id=\"recovered\">\n        <bsdf type=\"principled\">\n";
    xml += "            <texture type=\"bitmap\" name=\"base_color\">\n                <string name=\"filename\" value=\"textures/base_color.png\"/>\n            </texture>\n";
    for name in ["roughness", "metallic"] {
        let _ = write!(
            xml,
            "            <texture type=\"bitmap\" name=\"{name}\">\n                <string name=\"filename\" value=\"textures/{name}.png\"/>\n                <boolean name=\"raw\" value=\"true\"/>\n            </texture>\n"
        );
    }
    xml += "        </bsdf>\n    </bsdf>\n";
    xml += "    <shape type=\"obj\">\n        <string name=\"filename\" value=\"meshes/recovered.obj\"/>\n        <ref id=\"recovered\"/>\n    </shape>\n";
    for e in &p.emitters {
        let name = format!("emitter_{}", e.id);
        let text = obj_text(
            "fipt-rs emitter",
            None,
            &[(name.clone(), &e.primitive, "emitter")],
        );
        files.push(write_atomic(
            &dir.join(format!("meshes/{name}.obj")),
            text.as_bytes(),
        )?);
        let r = e.radiance;
        let _ = write!(
            xml,
            "    <shape type=\"obj\">\n        <string name=\"filename\" value=\"meshes/{name}.obj\"/>\n        <emitter type=\"area\">\n            <rgb name=\"radiance\" value=\"{}, {}, {}\"/>\n        </emitter>\n        <bsdf type=\"diffuse\">\n            <rgb name=\"reflectance\" value=\"0\"/>\n        </bsdf>\n    </shape>\n",
            r.x, r.y, r.z
        );
    }
    xml += "</scene>\n";
    files.push(write_atomic(&dir.join("scene.xml"), xml.as_bytes())?);
    Ok(files)
}
