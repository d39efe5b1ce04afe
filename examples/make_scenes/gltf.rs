//! The glTF writer the scene generator builds with: a document with one embedded buffer,
//! meshes (boxes, quads, spheres) and the materials the scenes use.

use std::collections::BTreeSet;
use std::path::Path;

use base64::Engine;
use serde_json::{json, Value};

/// Assembles one glTF document.
#[derive(Default)]
pub(crate) struct Gltf {
    pub(crate) buffer: Vec<u8>,
    pub(crate) views: Vec<Value>,
    pub(crate) accessors: Vec<Value>,
    pub(crate) meshes: Vec<Value>,
    pub(crate) materials: Vec<Value>,
    pub(crate) nodes: Vec<Value>,
    pub(crate) cameras: Vec<Value>,
    pub(crate) lights: Vec<Value>,
    pub(crate) extensions: BTreeSet<&'static str>,
    /// When set, every node is placed under one root node with this transform (its
    /// `translation`, `rotation`, `scale`), composed by the loader in f64.
    pub(crate) root: Option<Value>,
}

pub(crate) fn bounds(points: &[[f32; 3]]) -> (Vec<f32>, Vec<f32>) {
    let mut lo = vec![f32::INFINITY; 3];
    let mut hi = vec![f32::NEG_INFINITY; 3];
    // Non-finite vertices (the degenerate-input scene has some) stay out of the bounds.
    for p in points.iter().filter(|p| p.iter().all(|c| c.is_finite())) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

impl Gltf {
    pub(crate) fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while self.buffer.len() % 4 != 0 {
            self.buffer.push(0);
        }
        let offset = self.buffer.len();
        self.buffer.extend_from_slice(bytes);
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}));
        self.views.len() - 1
    }

    pub(crate) fn vec3_accessor(&mut self, data: &[[f32; 3]], with_bounds: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&bytes, 34962);
        let mut acc = json!({"bufferView": view, "componentType": 5126, "count": data.len(), "type": "VEC3"});
        if with_bounds {
            let (lo, hi) = bounds(data);
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    pub(crate) fn index_accessor(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&bytes, 34963);
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }

    pub(crate) fn material(&mut self, m: Value) -> usize {
        if let Some(ext) = m.get("extensions").and_then(|e| e.as_object()) {
            for k in ext.keys() {
                self.extensions.insert(match k.as_str() {
                    "KHR_materials_emissive_strength" => "KHR_materials_emissive_strength",
                    "KHR_materials_specular" => "KHR_materials_specular",
                    "KHR_materials_transmission" => "KHR_materials_transmission",
                    "KHR_materials_volume" => "KHR_materials_volume",
                    "KHR_materials_ior" => "KHR_materials_ior",
                    other => panic!("unexpected extension {other}"),
                });
            }
        }
        self.materials.push(m);
        self.materials.len() - 1
    }

    /// A mesh node; `normals` may be empty for flat shading.
    pub(crate) fn mesh(&mut self, name: &str, mesh: &Mesh, material: usize) -> usize {
        let pos = self.vec3_accessor(&mesh.positions, true);
        let mut attributes = json!({"POSITION": pos});
        if !mesh.normals.is_empty() {
            attributes["NORMAL"] = json!(self.vec3_accessor(&mesh.normals, false));
        }
        let idx = self.index_accessor(&mesh.indices);
        self.meshes.push(json!({"name": name, "primitives": [{"attributes": attributes, "indices": idx, "material": material}]}));
        self.nodes.push(json!({"name": name, "mesh": self.meshes.len() - 1}));
        self.nodes.len() - 1
    }

    pub(crate) fn perspective_camera(
        &mut self,
        name: &str,
        yfov: f64,
        translation: [f64; 3],
        rotation: [f64; 4],
    ) {
        self.cameras.push(
            json!({"type": "perspective", "perspective": {"yfov": yfov, "aspectRatio": 1.0, "znear": 0.01}}),
        );
        self.nodes.push(json!({"name": name, "camera": self.cameras.len() - 1, "translation": translation, "rotation": rotation}));
    }

    /// An orthographic camera at `translation` looking down −Z, showing ±`mag` units.
    pub(crate) fn orthographic_camera(&mut self, name: &str, mag: f64, translation: [f64; 3]) {
        self.cameras.push(json!({"type": "orthographic",
            "orthographic": {"xmag": mag, "ymag": mag, "znear": 0.01, "zfar": 100.0}}));
        self.nodes.push(json!({"name": name, "camera": self.cameras.len() - 1, "translation": translation}));
    }

    pub(crate) fn light(&mut self, light: Value, translation: [f64; 3], rotation: [f64; 4]) {
        self.extensions.insert("KHR_lights_punctual");
        self.lights.push(light);
        let name = format!("light {}", self.lights.len() - 1);
        self.nodes.push(json!({"name": name, "translation": translation, "rotation": rotation,
            "extensions": {"KHR_lights_punctual": {"light": self.lights.len() - 1}}}));
    }

    pub(crate) fn write(self, path: &Path, description: &str) {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.buffer)
        );
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "pathlight examples/make_scenes.rs", "extras": {"description": description}},
            "scene": 0,
            "scenes": [{"nodes": match &self.root {
                Some(_) => vec![self.nodes.len()],
                None => (0..self.nodes.len()).collect::<Vec<_>>(),
            }}],
            "nodes": match &self.root {
                Some(t) => {
                    let mut root = t.clone();
                    root["name"] = json!("root");
                    root["children"] = json!((0..self.nodes.len()).collect::<Vec<_>>());
                    let mut nodes = self.nodes.clone();
                    nodes.push(root);
                    nodes
                }
                None => self.nodes.clone(),
            },
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": self.buffer.len(), "uri": uri}],
        });
        if !self.cameras.is_empty() {
            doc["cameras"] = json!(self.cameras);
        }
        if !self.lights.is_empty() {
            doc["extensions"] = json!({"KHR_lights_punctual": {"lights": self.lights}});
        }
        if !self.extensions.is_empty() {
            doc["extensionsUsed"] = json!(self.extensions.iter().collect::<Vec<_>>());
        }
        let text = serde_json::to_string_pretty(&doc).unwrap() + "\n";
        std::fs::write(path, text).unwrap();
        println!("wrote {}", path.display());
    }
}

/// Triangle geometry.
#[derive(Default, Clone)]
pub(crate) struct Mesh {
    pub(crate) positions: Vec<[f32; 3]>,
    pub(crate) normals: Vec<[f32; 3]>,
    pub(crate) indices: Vec<u32>,
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}
pub(crate) fn f32x3(a: [f64; 3]) -> [f32; 3] {
    [a[0] as f32, a[1] as f32, a[2] as f32]
}

impl Mesh {
    /// Adds a planar quad (corners in order around it), wound so its front faces `toward`:
    /// a point the front side must see.
    pub(crate) fn quad(&mut self, corners: [[f64; 3]; 4], toward: [f64; 3]) {
        let n = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]));
        let center = [0, 1, 2].map(|k| corners.iter().map(|c| c[k]).sum::<f64>() / 4.0);
        let c = if dot(n, sub(toward, center)) >= 0.0 {
            corners
        } else {
            [corners[3], corners[2], corners[1], corners[0]]
        };
        let base = self.positions.len() as u32;
        self.positions.extend(c.iter().map(|p| f32x3(*p)));
        self.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    /// Adds a triangle, wound so its front faces `toward`.
    pub(crate) fn triangle(&mut self, corners: [[f64; 3]; 3], toward: [f64; 3]) {
        let n = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]));
        let center = [0, 1, 2].map(|k| corners.iter().map(|c| c[k]).sum::<f64>() / 3.0);
        let c =
            if dot(n, sub(toward, center)) >= 0.0 { corners } else { [corners[2], corners[1], corners[0]] };
        let base = self.positions.len() as u32;
        self.positions.extend(c.iter().map(|p| f32x3(*p)));
        self.indices.extend([base, base + 1, base + 2]);
    }

    /// An axis-aligned box from `lo` to `hi`, faces outward.
    pub(crate) fn cuboid(&mut self, lo: [f64; 3], hi: [f64; 3]) {
        let c = [0, 1, 2].map(|k| (lo[k] + hi[k]) / 2.0);
        let p = |x: usize, y: usize, z: usize| [[lo[0], hi[0]][x], [lo[1], hi[1]][y], [lo[2], hi[2]][z]];
        for axis in 0..3 {
            for side in 0..2 {
                // The four corners of the face where coordinate `axis` is at `side`.
                let corner = |a: usize, b: usize| {
                    let mut i = [0; 3];
                    i[axis] = side;
                    i[(axis + 1) % 3] = a;
                    i[(axis + 2) % 3] = b;
                    p(i[0], i[1], i[2])
                };
                let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                let mut away = c;
                away[axis] = [lo[axis], hi[axis]][side] * 2.0 - c[axis];
                self.quad(q, away);
            }
        }
    }

    /// A geodesic sphere: an icosahedron subdivided `level` times, projected onto the
    /// sphere. Faces point outward, or inward with `inward`; smooth normals if `smooth`.
    pub(crate) fn icosphere(center: [f64; 3], radius: f64, level: u32, inward: bool, smooth: bool) -> Mesh {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut verts: Vec<[f64; 3]> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|v| normalize(*v))
        .collect();
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..level {
            let mut cache = std::collections::HashMap::new();
            let mut mid = |a: u32, b: u32, verts: &mut Vec<[f64; 3]>| -> u32 {
                *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (va, vb) = (verts[a as usize], verts[b as usize]);
                    verts.push(normalize([
                        (va[0] + vb[0]) / 2.0,
                        (va[1] + vb[1]) / 2.0,
                        (va[2] + vb[2]) / 2.0,
                    ]));
                    verts.len() as u32 - 1
                })
            };
            let mut next = Vec::with_capacity(faces.len() * 4);
            for [a, b, c] in faces {
                let ab = mid(a, b, &mut verts);
                let bc = mid(b, c, &mut verts);
                let ca = mid(c, a, &mut verts);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            faces = next;
        }
        let mut mesh = Mesh {
            positions: verts
                .iter()
                .map(|v| {
                    f32x3([center[0] + radius * v[0], center[1] + radius * v[1], center[2] + radius * v[2]])
                })
                .collect(),
            ..Mesh::default()
        };
        if smooth {
            mesh.normals =
                verts.iter().map(|v| f32x3(if inward { [-v[0], -v[1], -v[2]] } else { *v })).collect();
        }
        for [a, b, c] in faces {
            mesh.indices.extend(if inward { [a, c, b] } else { [a, b, c] });
        }
        mesh
    }
}

// ---------------------------------------------------------------------------------------
// Materials

pub(crate) fn lambert(name: &str, rgb: [f64; 3]) -> Value {
    json!({"name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}})
}

pub(crate) fn emitter(name: &str, radiance: [f64; 3], reflectance: f64) -> Value {
    let strength = radiance.iter().cloned().fold(0.0, f64::max);
    let mut m = lambert(name, [reflectance; 3]);
    m["emissiveFactor"] = json!(radiance.map(|r| r / strength));
    m["extensions"]["KHR_materials_emissive_strength"] = json!({"emissiveStrength": strength});
    m
}

pub(crate) fn metal(name: &str, rgb: [f64; 3], roughness: f64) -> Value {
    json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 1.0, "roughnessFactor": roughness}})
}

pub(crate) fn plastic(name: &str, rgb: [f64; 3], roughness: f64) -> Value {
    json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": roughness}})
}

/// Glass: a refracting solid with absorption when `attenuation` is given, else thin-walled.
pub(crate) fn glass(name: &str, roughness: f64, attenuation: Option<([f64; 3], f64)>) -> Value {
    let mut m = json!({"name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": roughness},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}}});
    if let Some((color, distance)) = attenuation {
        m["extensions"]["KHR_materials_volume"] =
            json!({"thicknessFactor": 0.1, "attenuationColor": color, "attenuationDistance": distance});
    }
    m
}

// ---------------------------------------------------------------------------------------
// Scenes

/// glTF rotation (x, y, z, w) of `angle` radians about +Y.
pub(crate) fn rot_y(angle: f64) -> [f64; 4] {
    [0.0, (angle / 2.0).sin(), 0.0, (angle / 2.0).cos()]
}

/// glTF rotation (x, y, z, w) turning a camera by `pitch` about +X, then `yaw` about +Y:
/// q = yaw(Y) · pitch(X).
pub(crate) fn rot_yaw_pitch(yaw: f64, pitch: f64) -> [f64; 4] {
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [cy * sp, sy * cp, -sy * sp, cy * cp]
}
