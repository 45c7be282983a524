//! glTF 2.0 binary writer.
use crate::{png, write_atomic, Prepared, Primitive, Result};
use glam::Vec3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

const FLOAT: u32 = 5126;
const UINT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary chunk and the JSON arrays that point into it.
#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while self.data.len() % 4 != 0 {
            self.data.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    /// A float accessor of `comps` components per element.
    fn floats(&mut self, v: &[f32], comps: usize, with_bounds: bool) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let ty = match comps {
            1 => "SCALAR",
            2 => "VEC2",
            _ => "VEC3",
        };
        let mut a = json!({"bufferView": view, "componentType": FLOAT, "count": v.len() / comps, "type": ty});
        if with_bounds && !v.is_empty() {
            let (mut lo, mut hi) = (vec![f32::INFINITY; comps], vec![f32::NEG_INFINITY; comps]);
            for e in v.chunks(comps) {
                for c in 0..comps {
                    lo[c] = lo[c].min(e[c]);
                    hi[c] = hi[c].max(e[c]);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn indices(&mut self, v: &[u32]) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(
            json!({"bufferView": view, "componentType": UINT, "count": v.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }
}

fn flat3(v: &[Vec3]) -> Vec<f32> {
    v.iter().flat_map(|p| p.to_array()).collect()
}

fn primitive(bin: &mut Bin, p: &Primitive, material: usize) -> Value {
    let mut attrs = json!({
        "POSITION": bin.floats(&flat3(&p.positions), 3, true),
        "NORMAL": bin.floats(&flat3(&p.normals), 3, false),
    });
    if !p.uvs.is_empty() {
        let uv: Vec<f32> = p.uvs.iter().flat_map(|u| u.to_array()).collect();
        attrs["TEXCOORD_0"] = json!(bin.floats(&uv, 2, false));
    }
    if !p.colors.is_empty() {
        attrs["COLOR_0"] = json!(bin.floats(&flat3(&p.colors), 3, false));
        attrs["_ROUGHNESS"] = json!(bin.floats(&p.roughness, 1, false));
        attrs["_METALLIC"] = json!(bin.floats(&p.metallic, 1, false));
    }
    json!({"attributes": attrs, "indices": bin.indices(&p.indices), "material": material})
}

/// Writes `prepared` as `path` (a `.glb`).
pub fn write_glb(prepared: &Prepared, path: &Path) -> Result<PathBuf> {
    let mut bin = Bin::default();
    let mut materials = Vec::new();
    let mut images = Vec::new();
    let surface_material = match &prepared.textures {
        Some(t) => {
            let base = t.base_color_srgb8();
            let mr = t.metallic_roughness8();
            for img in [base.as_raw(), mr.as_raw()] {
                let bytes = png(img, t.width, t.height, image::ExtendedColorType::Rgb8);
                let view = bin.view(&bytes, None);
                images.push(json!({"bufferView": view, "mimeType": "image/png"}));
            }
            json!({"name": "recovered", "doubleSided": true, "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1},
                "metallicFactor": 1.0, "roughnessFactor": 1.0}})
        }
        None => {
            let n = prepared.surface.roughness.len().max(1) as f32;
            let r: f32 = prepared.surface.roughness.iter().sum::<f32>() / n;
            let m: f32 = prepared.surface.metallic.iter().sum::<f32>() / n;
            json!({"name": "recovered (per-vertex: COLOR_0, _ROUGHNESS, _METALLIC)", "doubleSided": true,
                   "pbrMetallicRoughness": {"metallicFactor": m, "roughnessFactor": r}})
        }
    };
    materials.push(surface_material);
    let mut prims = vec![primitive(&mut bin, &prepared.surface, 0)];
    for e in &prepared.emitters {
        let strength = e.radiance.max_element().max(0.0);
        let factor = if strength > 0.0 {
            e.radiance / strength
        } else {
            Vec3::ZERO
        };
        materials.push(json!({
            "name": format!("emitter_{}", e.id), "doubleSided": e.two_sided,
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "emissiveFactor": factor.to_array(),
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": strength}},
        }));
        let m = materials.len() - 1;
        prims.push(primitive(&mut bin, &e.primitive, m));
    }
    while bin.data.len() % 4 != 0 {
        bin.data.push(0);
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": concat!("fipt-rs ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "recovered scene"}],
        "meshes": [{"primitives": prims}],
        "materials": materials,
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{"byteLength": bin.data.len()}],
    });
    if !prepared.emitters.is_empty() {
        doc["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    }
    if !images.is_empty() {
        doc["images"] = json!(images);
        doc["samplers"] =
            json!([{"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}]);
        doc["textures"] = json!([{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}]);
    }
    let mut js = serde_json::to_vec(&doc).expect("JSON");
    while js.len() % 4 != 0 {
        js.push(b' ');
    }
    let total = 12 + 8 + js.len() + 8 + bin.data.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    out.extend_from_slice(&(bin.data.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin.data);
    write_atomic(path, &out)
}
