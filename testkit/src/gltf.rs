//! A small glTF 2.0 writer for the tests: meshes, accessors and nodes as JSON values over
//! one binary buffer, written as a .gltf with an external .bin, a .gltf with the buffer
//! embedded as a data URI, or a .glb.

use glam::Vec3;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

pub const FLOAT: u32 = 5126;
pub const UNSIGNED_BYTE: u32 = 5121;
pub const UNSIGNED_SHORT: u32 = 5123;
pub const UNSIGNED_INT: u32 = 5125;

#[derive(Default, Clone)]
pub struct GltfBuilder {
    pub bin: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
    pub meshes: Vec<Value>,
    pub nodes: Vec<Value>,
    /// The scene's root nodes.
    pub roots: Vec<usize>,
}

impl GltfBuilder {
    /// A buffer view over `bytes`, appended to the buffer at a 4-byte boundary.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views.push(json!({
            "buffer": 0, "byteOffset": offset, "byteLength": bytes.len()
        }));
        self.views.len() - 1
    }

    pub fn accessor(&mut self, value: Value) -> usize {
        self.accessors.push(value);
        self.accessors.len() - 1
    }

    /// A VEC3 FLOAT accessor of `points` (with the min and max glTF asks for).
    pub fn positions(&mut self, points: &[Vec3]) -> usize {
        let bytes: Vec<u8> = points
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes);
        let min = points.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
        let max = points.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
        self.accessor(json!({
            "bufferView": view, "componentType": FLOAT, "count": points.len(),
            "type": "VEC3", "min": min.to_array(), "max": max.to_array()
        }))
    }

    /// A SCALAR index accessor of component type `component` (bytes, shorts or ints).
    pub fn indices(&mut self, indices: &[u32], component: u32) -> usize {
        let bytes: Vec<u8> = match component {
            UNSIGNED_BYTE => indices.iter().map(|&i| i as u8).collect(),
            UNSIGNED_SHORT => indices
                .iter()
                .flat_map(|&i| (i as u16).to_le_bytes())
                .collect(),
            _ => indices.iter().flat_map(|&i| i.to_le_bytes()).collect(),
        };
        let view = self.view(&bytes);
        self.accessor(json!({
            "bufferView": view, "componentType": component, "count": indices.len(),
            "type": "SCALAR"
        }))
    }

    /// A mesh of triangle primitives, each (positions accessor, indices accessor or none).
    pub fn mesh(&mut self, primitives: &[(usize, Option<usize>)]) -> usize {
        let primitives: Vec<Value> = primitives
            .iter()
            .map(|&(p, i)| match i {
                Some(i) => json!({"attributes": {"POSITION": p}, "indices": i}),
                None => json!({"attributes": {"POSITION": p}}),
            })
            .collect();
        self.meshes.push(json!({ "primitives": primitives }));
        self.meshes.len() - 1
    }

    pub fn node(&mut self, node: Value) -> usize {
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    /// The document, its one buffer at `uri` (none: the GLB's binary chunk).
    pub fn document(&self, uri: Option<String>) -> Value {
        let mut buffer = json!({ "byteLength": self.bin.len() });
        if let Some(uri) = uri {
            buffer["uri"] = Value::String(uri);
        }
        let mut doc = json!({
            "asset": { "version": "2.0" },
            "scene": 0,
            "scenes": [{ "nodes": self.roots }],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [buffer],
        });
        if self.meshes.is_empty() {
            doc.as_object_mut().unwrap().remove("meshes");
        }
        doc
    }

    /// `dir/name.gltf` with its buffer in `dir/name.bin`.
    pub fn write_external(&self, dir: &Path, name: &str) -> PathBuf {
        std::fs::write(dir.join(format!("{name}.bin")), &self.bin).unwrap();
        write_json(dir, name, &self.document(Some(format!("{name}.bin"))))
    }

    /// `dir/name.gltf` with its buffer embedded as a base64 data URI.
    pub fn write_embedded(&self, dir: &Path, name: &str) -> PathBuf {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&self.bin));
        write_json(dir, name, &self.document(Some(uri)))
    }

    /// `dir/name.glb`.
    pub fn write_glb(&self, dir: &Path, name: &str) -> PathBuf {
        let path = dir.join(format!("{name}.glb"));
        std::fs::write(&path, glb(&self.document(None), &self.bin)).unwrap();
        path
    }
}

pub fn write_json(dir: &Path, name: &str, doc: &Value) -> PathBuf {
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec_pretty(doc).unwrap()).unwrap();
    path
}

/// A binary glTF: the 12-byte header, the JSON chunk padded with spaces, the binary chunk
/// padded with zeros (left out when `bin` is empty).
pub fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(json);
    if !bin.is_empty() {
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(0x004E_4942u32.to_le_bytes());
        out.extend(bin);
    }
    out
}

pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
