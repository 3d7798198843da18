//! A small glTF 2.0 writer for [`Character`]s: `.glb`, or `.gltf` with its buffer in a
//! data URI or beside it in a `.bin` file.
//!
//! It writes what the importer reads back (one skinned mesh, its skeleton, clips, materials
//! and PNG textures) and is deterministic: the same character always gives the same bytes.
//! The default character generator stores its output with it; tests use it to build files
//! that exercise every import path.

use serde_json::{Value, json};

use crate::character::{ChannelValues, Character, Interpolation};

/// Where the binary data of a `.gltf` goes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BufferStorage {
    /// Inside the JSON as a base64 `data:` URI.
    DataUri,
    /// In a separate file with this (relative) name.
    External(String),
}

/// The output of [`write_gltf`].
pub struct GltfFiles {
    /// The `.gltf` document as pretty-printed JSON text; its one buffer's `uri` is the data URI
    /// or the external file name.
    pub json: String,
    /// The external buffer, for [`BufferStorage::External`].
    pub bin: Option<Vec<u8>>,
}

#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn align(&mut self) {
        while self.data.len() % 4 != 0 {
            self.data.push(0);
        }
    }

    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        self.align();
        let mut v = json!({ "buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor_f32(&mut self, values: &[f32], ty: &str, comps: usize, minmax: bool, target: Option<u32>) -> usize {
        let view = self.view(bytemuck::cast_slice(values), target);
        let count = values.len() / comps;
        let mut a = json!({ "bufferView": view, "componentType": 5126, "count": count, "type": ty });
        if minmax && count > 0 {
            let mut min = vec![f32::INFINITY; comps];
            let mut max = vec![f32::NEG_INFINITY; comps];
            for e in values.chunks_exact(comps) {
                for k in 0..comps {
                    min[k] = min[k].min(e[k]);
                    max[k] = max[k].max(e[k]);
                }
            }
            a["min"] = json!(min);
            a["max"] = json!(max);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn accessor_u16(&mut self, values: &[u16], ty: &str, comps: usize, target: Option<u32>) -> usize {
        let view = self.view(bytemuck::cast_slice(values), target);
        self.accessors
            .push(json!({ "bufferView": view, "componentType": 5123, "count": values.len() / comps, "type": ty }));
        self.accessors.len() - 1
    }

    fn accessor_u32(&mut self, values: &[u32], target: Option<u32>) -> usize {
        let view = self.view(bytemuck::cast_slice(values), target);
        self.accessors
            .push(json!({ "bufferView": view, "componentType": 5125, "count": values.len(), "type": "SCALAR" }));
        self.accessors.len() - 1
    }
}

fn build(c: &Character) -> Result<(Value, Vec<u8>), String> {
    let mut bin = Bin::default();
    const ARRAY: Option<u32> = Some(34962);
    const ELEMENTS: Option<u32> = Some(34963);

    let pos: Vec<f32> = c.vertices.iter().flat_map(|v| v.position.to_array()).collect();
    let nrm: Vec<f32> = c.vertices.iter().flat_map(|v| v.normal.to_array()).collect();
    let uv: Vec<f32> = c.vertices.iter().flat_map(|v| v.uv).collect();
    let joints: Vec<u16> = c.vertices.iter().flat_map(|v| v.bones).collect();
    let weights: Vec<f32> = c.vertices.iter().flat_map(|v| v.weights).collect();
    let has_colors = c.vertices.iter().any(|v| v.color != [1.0; 4]);
    let a_pos = bin.accessor_f32(&pos, "VEC3", 3, true, ARRAY);
    let a_nrm = bin.accessor_f32(&nrm, "VEC3", 3, false, ARRAY);
    let a_uv = bin.accessor_f32(&uv, "VEC2", 2, false, ARRAY);
    let a_joints = bin.accessor_u16(&joints, "VEC4", 4, ARRAY);
    let a_weights = bin.accessor_f32(&weights, "VEC4", 4, false, ARRAY);
    let mut attributes = json!({
        "POSITION": a_pos, "NORMAL": a_nrm, "TEXCOORD_0": a_uv, "JOINTS_0": a_joints, "WEIGHTS_0": a_weights
    });
    if has_colors {
        let col: Vec<f32> = c.vertices.iter().flat_map(|v| v.color).collect();
        attributes["COLOR_0"] = json!(bin.accessor_f32(&col, "VEC4", 4, false, ARRAY));
    }

    let mut primitives = Vec::new();
    for s in &c.submeshes {
        let range = s.first_index as usize..(s.first_index + s.index_count) as usize;
        let idx = c.indices.get(range).ok_or("submesh index range out of bounds")?;
        let a = bin.accessor_u32(idx, ELEMENTS);
        primitives.push(json!({ "attributes": attributes, "indices": a, "material": s.material }));
    }

    let mut images = Vec::new();
    for t in &c.textures {
        let mut png = Vec::new();
        let img = image::RgbaImage::from_raw(t.width, t.height, t.rgba8.clone()).ok_or("texture size mismatch")?;
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| e.to_string())?;
        let view = bin.view(&png, None);
        images.push(json!({ "name": t.name, "bufferView": view, "mimeType": "image/png" }));
    }
    // glTF keeps wrap modes on a texture's sampler: one texture per image with the default
    // repeating sampler, and one more per image and other wrap pair a material uses.
    let mut textures: Vec<Value> = (0..c.textures.len())
        .map(|i| json!({ "source": i, "sampler": 0 }))
        .collect();
    let mut samplers: Vec<Value> =
        vec![json!({ "magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497 })];
    let mut wrapped: Vec<((usize, [crate::character::TextureWrap; 2]), usize)> = Vec::new();
    let materials: Vec<Value> = c
        .materials
        .iter()
        .map(|m| {
            let mut pbr =
                json!({ "baseColorFactor": m.base_color_factor, "metallicFactor": 0.0, "roughnessFactor": 0.8 });
            if let Some(t) = m.base_color_texture {
                let index = if m.wrap == [crate::character::TextureWrap::Repeat; 2] {
                    t
                } else if let Some(&(_, k)) = wrapped.iter().find(|(key, _)| *key == (t, m.wrap)) {
                    k
                } else {
                    samplers.push(json!({ "magFilter": 9729, "minFilter": 9987,
                        "wrapS": m.wrap[0].gltf(), "wrapT": m.wrap[1].gltf() }));
                    textures.push(json!({ "source": t, "sampler": samplers.len() - 1 }));
                    wrapped.push(((t, m.wrap), textures.len() - 1));
                    textures.len() - 1
                };
                pbr["baseColorTexture"] = json!({ "index": index });
            }
            let mut mat = json!({ "name": m.name, "pbrMetallicRoughness": pbr, "doubleSided": m.double_sided });
            if m.alpha_cutoff > 0.0 {
                mat["alphaMode"] = json!("MASK");
                mat["alphaCutoff"] = json!(m.alpha_cutoff);
            }
            mat
        })
        .collect();

    // Nodes: skeleton nodes first, then the mesh node.
    let mut nodes: Vec<Value> = c
        .skeleton
        .nodes
        .iter()
        .map(|n| {
            json!({
                "name": n.name,
                "translation": n.rest.translation.to_array(),
                "rotation": n.rest.rotation.to_array(),
                "scale": n.rest.scale.to_array(),
            })
        })
        .collect();
    for (i, n) in c.skeleton.nodes.iter().enumerate() {
        if let Some(p) = n.parent {
            let children = nodes[p].get("children").cloned().unwrap_or_else(|| json!([]));
            let mut children: Vec<Value> = serde_json::from_value(children).unwrap_or_default();
            children.push(json!(i));
            nodes[p]["children"] = json!(children);
        }
    }
    let mesh_node = nodes.len();
    nodes.push(json!({ "name": c.name, "mesh": 0, "skin": 0 }));
    let roots: Vec<usize> = c
        .skeleton
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.parent.is_none())
        .map(|(i, _)| i)
        .chain([mesh_node])
        .collect();

    let ibm: Vec<f32> = c.bones.iter().flat_map(|b| b.inverse_bind.to_cols_array()).collect();
    let a_ibm = bin.accessor_f32(&ibm, "MAT4", 16, false, None);
    let skin = json!({ "joints": c.bones.iter().map(|b| b.node).collect::<Vec<_>>(), "inverseBindMatrices": a_ibm });

    let mut animations = Vec::new();
    for clip in &c.clips {
        let mut samplers = Vec::new();
        let mut channels = Vec::new();
        for ch in &clip.channels {
            let input = bin.accessor_f32(&ch.times, "SCALAR", 1, true, None);
            let (path, output) = match &ch.values {
                ChannelValues::Translation(v) => (
                    "translation",
                    bin.accessor_f32(
                        &v.iter().flat_map(|x| x.to_array()).collect::<Vec<_>>(),
                        "VEC3",
                        3,
                        false,
                        None,
                    ),
                ),
                ChannelValues::Scale(v) => (
                    "scale",
                    bin.accessor_f32(
                        &v.iter().flat_map(|x| x.to_array()).collect::<Vec<_>>(),
                        "VEC3",
                        3,
                        false,
                        None,
                    ),
                ),
                ChannelValues::Rotation(v) => (
                    "rotation",
                    bin.accessor_f32(
                        &v.iter().flat_map(|x| x.to_array()).collect::<Vec<_>>(),
                        "VEC4",
                        4,
                        false,
                        None,
                    ),
                ),
            };
            let interpolation = match ch.interpolation {
                Interpolation::Step => "STEP",
                Interpolation::Linear => "LINEAR",
                Interpolation::CubicSpline => "CUBICSPLINE",
            };
            channels.push(json!({ "sampler": samplers.len(), "target": { "node": ch.node, "path": path } }));
            samplers.push(json!({ "input": input, "output": output, "interpolation": interpolation }));
        }
        animations.push(json!({ "name": clip.name, "samplers": samplers, "channels": channels }));
    }

    bin.align();
    let mut root = json!({
        "asset": { "version": "2.0", "generator": concat!("Polypostor Studio ", env!("CARGO_PKG_VERSION")) },
        "scene": 0,
        "scenes": [{ "name": c.name, "nodes": roots }],
        "nodes": nodes,
        "meshes": [{ "name": c.name, "primitives": primitives }],
        "skins": [skin],
        "materials": materials,
        "bufferViews": bin.views,
        "accessors": bin.accessors,
        "buffers": [{ "byteLength": bin.data.len() }],
    });
    if !c.textures.is_empty() {
        root["images"] = json!(images);
        root["textures"] = json!(textures);
        root["samplers"] = json!(samplers);
    }
    if !animations.is_empty() {
        root["animations"] = json!(animations);
    }
    Ok((root, bin.data))
}

/// Writes a binary `.glb`.
pub fn write_glb(c: &Character) -> Result<Vec<u8>, String> {
    let (root, bin) = build(c)?;
    glb_container(&root, &bin)
}

/// A GLB container of a glTF JSON document and its binary chunk (each padded to four bytes:
/// the JSON with spaces, the binary chunk with zeros).
pub fn glb_container(root: &Value, bin: &[u8]) -> Result<Vec<u8>, String> {
    let mut json = serde_json::to_vec(root).map_err(|e| e.to_string())?;
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let pad = (4 - bin.len() % 4) % 4;
    let total = 12 + 8 + json.len() + 8 + bin.len() + pad;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&((bin.len() + pad) as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out.resize(total, 0);
    Ok(out)
}

/// The JSON document and binary chunk of a GLB written by [`glb_container`] (a JSON chunk
/// first, then an optional BIN chunk); `None` if it is not one.
pub fn glb_parts(glb: &[u8]) -> Option<(Value, Vec<u8>)> {
    let u32_at = |at: usize| Some(u32::from_le_bytes(glb.get(at..at + 4)?.try_into().ok()?) as usize);
    if glb.get(0..4)? != b"glTF" || glb.get(16..20)? != b"JSON" {
        return None;
    }
    let json_len = u32_at(12)?;
    let json = serde_json::from_slice(glb.get(20..20 + json_len)?).ok()?;
    let bin = match u32_at(20 + json_len) {
        Some(n) => glb.get(28 + json_len..28 + json_len + n)?.to_vec(),
        None => Vec::new(),
    };
    Some((json, bin))
}

/// Writes a text `.gltf` whose buffer is a data URI or an external file.
pub fn write_gltf(c: &Character, storage: &BufferStorage) -> Result<GltfFiles, String> {
    let (mut root, bin) = build(c)?;
    let bin = match storage {
        BufferStorage::DataUri => {
            use base64::Engine;
            let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
            root["buffers"][0]["uri"] = json!(format!("data:application/octet-stream;base64,{b64}"));
            None
        }
        BufferStorage::External(name) => {
            root["buffers"][0]["uri"] = json!(name);
            Some(bin)
        }
    };
    let json = serde_json::to_string_pretty(&root).map_err(|e| e.to_string())?;
    Ok(GltfFiles { json, bin })
}
