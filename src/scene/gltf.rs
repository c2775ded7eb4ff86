//! glTF 2.0 loading (`.gltf` with external or embedded buffers, and `.glb`): the node tree
//! is walked from the scene's roots composing each node's matrix or translation, rotation
//! and scale onto its parent's; every node with a mesh becomes an instance of that mesh, so
//! a mesh used by several nodes is stored once. Only triangle primitives are loaded.
//!
//! The `gltf` crate parses and validates the document; buffers and accessors are read here,
//! with bounds checked, so a broken file is an error naming the file and the node.

use super::{Instance, Mesh, Scene, TransformError};
use crate::geometry::Triangle;
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use glam::{Affine3A, Mat4, Quat, Vec3, Vec4};
use std::path::{Path, PathBuf};

/// Why a glTF file could not be loaded. `node` names a node as `node 3 'Name'`.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    // The cause is said in the message, not chained after it (it would print twice).
    #[error("cannot read {}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{}: not a valid glTF 2.0 file: {reason}", path.display())]
    Parse { path: PathBuf, reason: String },
    #[error("{}: buffer {buffer} cannot be read: {reason}", path.display())]
    MissingBuffer {
        path: PathBuf,
        buffer: usize,
        reason: String,
    },
    #[error("{}: {node}: the scene's node tree has a cycle, or a node with two parents", path.display())]
    NotATree { path: PathBuf, node: String },
    #[error("{}: {node}: the transform has a NaN or infinite entry", path.display())]
    NonFiniteTransform { path: PathBuf, node: String },
    #[error("{}: {node}: the transform is not affine (its last row is not 0 0 0 1)", path.display())]
    ProjectiveTransform { path: PathBuf, node: String },
    #[error("{}: {node}: the transform is singular (it flattens the mesh, so it has no inverse)", path.display())]
    SingularTransform { path: PathBuf, node: String },
    #[error("{}: {node}: mesh {mesh}: {mode} primitives are not supported (only triangles)", path.display())]
    PrimitiveMode {
        path: PathBuf,
        node: String,
        mesh: String,
        mode: &'static str,
    },
    /// `at` names the node and the mesh: `node 3 'Name': mesh 1`.
    #[error("{}: {at}: {problem}", path.display())]
    Accessor {
        path: PathBuf,
        at: String,
        problem: AccessorProblem,
    },
    #[error("{} contains no triangles", path.display())]
    NoTriangles { path: PathBuf },
}

/// What is wrong with the data a primitive points at.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum AccessorProblem {
    #[error("a primitive has no POSITION attribute")]
    NoPositions,
    #[error("{what} accessor {accessor} is {found}, expected {expected}")]
    WrongType {
        what: &'static str,
        accessor: usize,
        found: String,
        expected: &'static str,
    },
    #[error("{what} accessor {accessor} reaches beyond its buffer view or buffer")]
    OutOfBounds { what: &'static str, accessor: usize },
    #[error("{what} accessor {accessor} has no buffer view")]
    NoView { what: &'static str, accessor: usize },
    #[error("{what} accessor {accessor} is sparse, which is not supported")]
    Sparse { what: &'static str, accessor: usize },
    #[error("{count} {what} do not make whole triangles")]
    NotTriangles { what: &'static str, count: usize },
    #[error("index {index} is out of range ({vertices} vertices)")]
    IndexOutOfRange { index: u32, vertices: usize },
    #[error("vertex {vertex} has a NaN or infinite coordinate")]
    NonFiniteVertex { vertex: usize },
}

/// Loads a `.gltf` (buffers next to it or embedded as data URIs) or `.glb` file.
pub fn load_gltf(path: &Path) -> Result<Scene, GltfError> {
    // The JSON or binary, its buffers and the triangles made of them.
    let bytes = crate::input::read(path, 4).map_err(|source| GltfError::Io {
        path: path.to_path_buf(),
        error: source,
    })?;
    parse_gltf(path, &bytes)
}

/// Loads glTF or GLB bytes already in memory; `path` names them in errors, gives the scene
/// its name and locates external buffers.
pub fn parse_gltf(path: &Path, bytes: &[u8]) -> Result<Scene, GltfError> {
    let parse_error = |e: ::gltf::Error| GltfError::Parse {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    // A binary glTF starts with its magic; without it the parser would read the bytes as
    // JSON and say "expected value at line 1".
    let binary = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if binary && !bytes.starts_with(b"glTF") {
        return Err(GltfError::Parse {
            path: path.to_path_buf(),
            reason: "not a binary glTF: a .glb file starts with the bytes 'glTF'".into(),
        });
    }
    let ::gltf::Gltf { document, blob } =
        ::gltf::Gltf::from_slice_without_validation(bytes).map_err(parse_error)?;
    validate(document.as_json()).map_err(|reason| GltfError::Parse {
        path: path.to_path_buf(),
        reason,
    })?;
    let buffers = load_buffers(path, &document, blob)?;
    let name = path
        .file_stem()
        .map_or_else(|| "gltf".into(), |s| s.to_string_lossy().into_owned());
    let mut loader = Loader {
        path,
        buffers: &buffers,
        scene: Scene::new(name),
        mesh_of: vec![None; document.meshes().len()],
    };

    let roots: Vec<::gltf::Node> = match document.default_scene().or(document.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        // No scene: every node that is no other node's child is a root.
        None => {
            let mut child = vec![false; document.nodes().len()];
            for n in document.nodes() {
                for c in n.children() {
                    child[c.index()] = true;
                }
            }
            document.nodes().filter(|n| !child[n.index()]).collect()
        }
    };
    let mut visited = vec![false; document.nodes().len()];
    let mut stack: Vec<(::gltf::Node, Affine3A)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Affine3A::IDENTITY))
        .collect();
    while let Some((node, parent)) = stack.pop() {
        let label = node_label(&node);
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(GltfError::NotATree {
                path: path.to_path_buf(),
                node: label,
            });
        }
        let world = parent * loader.local_transform(&node, &label)?;
        if let Some(mesh) = node.mesh() {
            loader.place(&mesh, world, &label)?;
        }
        // Children pushed in reverse so they are placed in file order.
        let children: Vec<_> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
    }
    if loader.scene.triangles.is_empty() {
        return Err(GltfError::NoTriangles {
            path: path.to_path_buf(),
        });
    }
    Ok(loader.scene)
}

/// The `gltf` crate's validation of the document (every index in range, every enum
/// known), after a check of our own of the one reference that validation follows before
/// checking it: a primitive's attribute accessors (it indexes out of bounds otherwise).
fn validate(root: &::gltf::json::Root) -> Result<(), String> {
    use ::gltf::json::validation::Validate;
    // glTF 1.0 differs in layout; the parser would read it as 2.0 and make nonsense.
    let version = root.asset.version.as_str();
    if version.split('.').next() != Some("2") {
        return Err(format!("glTF {version} is not supported (glTF 2.0 only)"));
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(a) = primitive
                .attributes
                .values()
                .find(|a| a.value() >= root.accessors.len())
            {
                return Err(format!(
                    "mesh {m} primitive {p}: accessor {} does not exist",
                    a.value()
                ));
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, ::gltf::json::Path::new, &mut |path, error| {
        errors.push((path(), error))
    });
    if errors.is_empty() {
        Ok(())
    } else {
        Err(::gltf::Error::Validation(errors).to_string())
    }
}

/// `node 3 'Name'`, or `node 3` for a node without a name.
fn node_label(node: &::gltf::Node) -> String {
    match node.name() {
        Some(name) => format!("node {} '{name}'", node.index()),
        None => format!("node {}", node.index()),
    }
}

fn mesh_label(mesh: &::gltf::Mesh) -> String {
    match mesh.name() {
        Some(name) => format!("{} '{name}'", mesh.index()),
        None => mesh.index().to_string(),
    }
}

/// The data of every buffer: the GLB's binary chunk, a base64 data URI, or a file next to
/// the glTF file; each at least as long as the document says.
fn load_buffers(
    path: &Path,
    document: &::gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, GltfError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let missing = |reason: String| GltfError::MissingBuffer {
            path: path.to_path_buf(),
            buffer: buffer.index(),
            reason,
        };
        let data = match buffer.source() {
            ::gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| missing("the file has no binary chunk".into()))?,
            ::gltf::buffer::Source::Uri(uri) => read_uri(path, uri).map_err(missing)?,
        };
        if data.len() < buffer.length() {
            return Err(missing(format!(
                "it is too short: it holds {} bytes, the file says {}",
                data.len(),
                buffer.length()
            )));
        }
        out.push(data);
    }
    Ok(out)
}

/// A buffer's bytes from a `data:…;base64,` URI or a relative file reference.
fn read_uri(path: &Path, uri: &str) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or("a data URI that is not base64")?;
        return decode_base64(data).ok_or_else(|| "a data URI with bad base64".into());
    }
    if uri.contains(':') {
        return Err(format!("unsupported URI '{}'", shorten(uri)));
    }
    let relative = percent_decode(uri).ok_or_else(|| format!("bad URI '{}'", shorten(uri)))?;
    // A file someone sends must not make the tool read outside its own folder: only a
    // path down from the glTF's folder, never absolute and never up with `..`.
    let outside = || {
        format!(
            "'{}' is outside the glTF file's folder (only files beside it or below it, and \
             data: URIs, are read)",
            shorten(uri)
        )
    };
    let down = Path::new(&relative).components().all(|c| {
        matches!(
            c,
            std::path::Component::Normal(_) | std::path::Component::CurDir
        )
    });
    if !down {
        return Err(outside());
    }
    let folder = path.parent().unwrap_or(Path::new(""));
    let file = folder.join(relative);
    // Only regular files: a URI can name a directory or a device that never ends.
    if !file.is_file() {
        return Err(format!("{} not found", file.display()));
    }
    // Nor through a link that leads out of the folder.
    let real = |p: &Path| {
        std::fs::canonicalize(if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        })
    };
    match (real(folder), real(&file)) {
        (Ok(folder), Ok(file)) if file.starts_with(&folder) => {}
        _ => return Err(outside()),
    }
    crate::input::read(&file, 2).map_err(|e| format!("cannot read {}: {e}", file.display()))
}

fn shorten(s: &str) -> String {
    s.chars().take(60).collect()
}

fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' | b'-' => Some(62),
        b'/' | b'_' => Some(63),
        _ => None,
    };
    let text = text.trim_end_matches('=').as_bytes();
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for &c in text {
        acc = (acc << 6) | value(c)? as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

/// `%20` and friends decoded; `None` if the result is not UTF-8 or an escape is cut short.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

struct Loader<'a> {
    path: &'a Path,
    buffers: &'a [Vec<u8>],
    scene: Scene,
    /// The scene mesh made of each glTF mesh, once loaded.
    mesh_of: Vec<Option<usize>>,
}

impl Loader<'_> {
    /// The node's own transform: its matrix, or translation · rotation · scale.
    fn local_transform(&self, node: &::gltf::Node, label: &str) -> Result<Affine3A, GltfError> {
        let non_finite = || GltfError::NonFiniteTransform {
            path: self.path.to_path_buf(),
            node: label.to_string(),
        };
        match node.transform() {
            ::gltf::scene::Transform::Matrix { matrix } => {
                let m = Mat4::from_cols_array_2d(&matrix);
                if !m.is_finite() {
                    return Err(non_finite());
                }
                if m.row(3) != Vec4::W {
                    return Err(GltfError::ProjectiveTransform {
                        path: self.path.to_path_buf(),
                        node: label.to_string(),
                    });
                }
                Ok(Affine3A::from_mat4(m))
            }
            ::gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                let (t, r, s) = (
                    Vec3::from(translation),
                    Quat::from_array(rotation),
                    Vec3::from(scale),
                );
                if !(t.is_finite() && r.is_finite() && s.is_finite()) {
                    return Err(non_finite());
                }
                // glTF asks for unit quaternions; rounding in writers leaves them close.
                let r = Vec4::from(r)
                    .try_normalize()
                    .map(Quat::from_vec4)
                    .ok_or_else(|| GltfError::SingularTransform {
                        path: self.path.to_path_buf(),
                        node: label.to_string(),
                    })?;
                Ok(Affine3A::from_scale_rotation_translation(s, r, t))
            }
        }
    }

    /// Places `mesh` by `world` as the instance made by node `label`.
    fn place(
        &mut self,
        mesh: &::gltf::Mesh,
        world: Affine3A,
        label: &str,
    ) -> Result<(), GltfError> {
        let index = match self.mesh_of[mesh.index()] {
            Some(i) => i,
            None => {
                let triangles = self.read_mesh(mesh, label)?;
                self.scene.meshes.push(Mesh {
                    name: mesh.name().unwrap_or("").to_string(),
                    triangles,
                });
                let i = self.scene.meshes.len() - 1;
                self.mesh_of[mesh.index()] = Some(i);
                i
            }
        };
        let instance = Instance::new(index, world).map_err(|e| match e {
            TransformError::NonFinite => GltfError::NonFiniteTransform {
                path: self.path.to_path_buf(),
                node: label.to_string(),
            },
            TransformError::Singular => GltfError::SingularTransform {
                path: self.path.to_path_buf(),
                node: label.to_string(),
            },
        })?;
        let color = mesh
            .primitives()
            .next()
            .map(|p| {
                let c = p.material().pbr_metallic_roughness().base_color_factor();
                Vec3::new(c[0], c[1], c[2])
            })
            .filter(|c| c.is_finite())
            .map_or(super::obj::DEFAULT_COLOR, |c| {
                c.clamp(Vec3::ZERO, Vec3::ONE)
            });
        let name = match (mesh.name(), label) {
            (Some(m), l) => format!("{l}: {m}"),
            (None, l) => l.to_string(),
        };
        self.scene.push_instance(name, color, instance);
        Ok(())
    }

    /// The triangles of every primitive of `mesh`, primitive after primitive.
    fn read_mesh(&self, mesh: &::gltf::Mesh, label: &str) -> Result<Vec<Triangle>, GltfError> {
        let mut triangles = Vec::new();
        for primitive in mesh.primitives() {
            let mode = match primitive.mode() {
                Mode::Triangles => None,
                Mode::Points => Some("point"),
                Mode::Lines => Some("line"),
                Mode::LineLoop => Some("line loop"),
                Mode::LineStrip => Some("line strip"),
                Mode::TriangleStrip => Some("triangle strip"),
                Mode::TriangleFan => Some("triangle fan"),
            };
            if let Some(mode) = mode {
                return Err(GltfError::PrimitiveMode {
                    path: self.path.to_path_buf(),
                    node: label.to_string(),
                    mesh: mesh_label(mesh),
                    mode,
                });
            }
            read_primitive(&primitive, self.buffers, &mut triangles).map_err(|problem| {
                GltfError::Accessor {
                    path: self.path.to_path_buf(),
                    at: format!("{label}: mesh {}", mesh_label(mesh)),
                    problem,
                }
            })?;
        }
        Ok(triangles)
    }
}

/// Appends a triangle primitive's triangles: its indices taken three at a time, or its
/// vertices three at a time when it has no indices.
fn read_primitive(
    primitive: &::gltf::Primitive,
    buffers: &[Vec<u8>],
    out: &mut Vec<Triangle>,
) -> Result<(), AccessorProblem> {
    let positions = primitive
        .get(&::gltf::Semantic::Positions)
        .ok_or(AccessorProblem::NoPositions)?;
    if positions.dimensions() != Dimensions::Vec3
        || positions.data_type() != DataType::F32
        || positions.normalized()
    {
        return Err(wrong_type("POSITION", &positions, "VEC3 of FLOAT"));
    }
    let (data, stride) = accessor_bytes("POSITION", &positions, buffers)?;
    let vertices: Vec<Vec3> = (0..positions.count())
        .map(|i| {
            let at = |k: usize| {
                let o = i * stride + 4 * k;
                f32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]])
            };
            Vec3::new(at(0), at(1), at(2))
        })
        .collect();
    if let Some(vertex) = vertices.iter().position(|v| !v.is_finite()) {
        return Err(AccessorProblem::NonFiniteVertex { vertex });
    }
    let corners: Vec<u32> = match primitive.indices() {
        None => (0..vertices.len() as u32).collect(),
        Some(indices) => {
            let size = match indices.data_type() {
                DataType::U8 => 1,
                DataType::U16 => 2,
                DataType::U32 => 4,
                _ => 0,
            };
            if indices.dimensions() != Dimensions::Scalar || size == 0 {
                return Err(wrong_type(
                    "indices",
                    &indices,
                    "SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                ));
            }
            let (data, stride) = accessor_bytes("indices", &indices, buffers)?;
            (0..indices.count())
                .map(|i| {
                    let o = i * stride;
                    match size {
                        1 => data[o] as u32,
                        2 => u16::from_le_bytes([data[o], data[o + 1]]) as u32,
                        _ => u32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]]),
                    }
                })
                .collect()
        }
    };
    if !corners.len().is_multiple_of(3) {
        return Err(AccessorProblem::NotTriangles {
            what: if primitive.indices().is_some() {
                "indices"
            } else {
                "vertices"
            },
            count: corners.len(),
        });
    }
    if let Some(&index) = corners.iter().find(|&&i| i as usize >= vertices.len()) {
        return Err(AccessorProblem::IndexOutOfRange {
            index,
            vertices: vertices.len(),
        });
    }
    out.extend(corners.chunks_exact(3).map(|c| {
        Triangle::new(
            vertices[c[0] as usize],
            vertices[c[1] as usize],
            vertices[c[2] as usize],
        )
    }));
    Ok(())
}

fn wrong_type(
    what: &'static str,
    accessor: &::gltf::Accessor,
    expected: &'static str,
) -> AccessorProblem {
    AccessorProblem::WrongType {
        what,
        accessor: accessor.index(),
        found: format!(
            "{} of {}{}",
            dimensions_name(accessor.dimensions()),
            component_name(accessor.data_type()),
            if accessor.normalized() {
                " (normalized)"
            } else {
                ""
            }
        ),
        expected,
    }
}

/// An accessor's `type` as glTF spells it.
fn dimensions_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

/// An accessor's `componentType` as glTF spells it.
fn component_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

/// The bytes from the accessor's first element to the end of its last, and the stride
/// between elements, checked to lie within its buffer view and buffer.
fn accessor_bytes<'b>(
    what: &'static str,
    accessor: &::gltf::Accessor,
    buffers: &'b [Vec<u8>],
) -> Result<(&'b [u8], usize), AccessorProblem> {
    let index = accessor.index();
    if accessor.sparse().is_some() {
        return Err(AccessorProblem::Sparse {
            what,
            accessor: index,
        });
    }
    let view = accessor.view().ok_or(AccessorProblem::NoView {
        what,
        accessor: index,
    })?;
    let out_of_bounds = AccessorProblem::OutOfBounds {
        what,
        accessor: index,
    };
    let size = accessor.size();
    let stride = view.stride().unwrap_or(size);
    let count = accessor.count();
    if stride < size || count == 0 {
        return Err(out_of_bounds);
    }
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or(AccessorProblem::OutOfBounds {
            what,
            accessor: index,
        })?;
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&end| end <= buffer.len())
        .ok_or(AccessorProblem::OutOfBounds {
            what,
            accessor: index,
        })?;
    let view_bytes = &buffer[view.offset()..view_end];
    let end = (count - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(size))
        .and_then(|x| x.checked_add(accessor.offset()))
        .filter(|&end| end <= view_bytes.len())
        .ok_or(out_of_bounds)?;
    Ok((&view_bytes[accessor.offset()..end], stride))
}
