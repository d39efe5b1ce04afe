//! glTF 2.0 (.gltf / .glb) → [`Scene`].
//!
//! Node transforms are read from the JSON as f64 (the `gltf` crate stores them as f32) and
//! composed in f64, so a model placed far from the origin keeps its precision until
//! [`FlatScene`](super::FlatScene) makes it camera-relative.

use std::path::Path;

use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use gltf::json::validation::Validate;

use super::accessor::load_buffers;
use super::camera::{CameraDesc, Projection};
use super::gltf_material::{load_images_and_textures, read_material, read_raw_material};
use super::gltf_mesh::add_mesh;
use super::light::{PunctualKind, PunctualLight};
use super::material::MaterialDesc;
use super::uri::LoadOptions;
use super::Scene;
use crate::error::{Error, Result};

/// Extensions whose meaning pathlight implements.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// Loads a glTF scene under the rule for untrusted input (external URIs stay inside the
/// scene's folder; see [`super::uri`]). Warnings (ignored optional extensions, features not
/// yet rendered, dropped primitives) are returned beside it for the caller to show.
pub fn load(file: &Path) -> Result<(Scene, Vec<String>)> {
    load_with(file, &LoadOptions::default())
}

/// [`load`] with explicit options (e.g. [`LoadOptions::allow_any_path`] for trusted scenes).
pub fn load_with(file: &Path, options: &LoadOptions) -> Result<(Scene, Vec<String>)> {
    let bytes = std::fs::read(file).map_err(|e| Error::io(file, e))?;
    load_from_bytes(&bytes, file, options)
}

/// Loads a glTF scene from bytes; `file` names it in errors and its folder is where relative
/// URIs resolve.
///
/// Malformed input is an error, never a crash: besides our own checks, a panic inside a
/// third-party parser on a hostile file is caught and reported as an error naming the file.
pub fn load_from_bytes(bytes: &[u8], file: &Path, options: &LoadOptions) -> Result<(Scene, Vec<String>)> {
    match std::panic::catch_unwind(|| load_unchecked(bytes, file, options)) {
        Ok(result) => result,
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(Error::scene(file, format!("malformed glTF: the parser failed ({what})")))
        }
    }
}

fn load_unchecked(bytes: &[u8], file: &Path, options: &LoadOptions) -> Result<(Scene, Vec<String>)> {
    let err = |m: String| Error::scene(file, m);
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| err(format!("not a valid glTF file: {e}")))?;
    let mut warnings = Vec::new();

    // Extensions: our own policy, since the gltf crate's list differs from what we render.
    for ext in gltf.extensions_required() {
        if !SUPPORTED_EXTENSIONS.contains(&ext) {
            return Err(err(format!("requires extension {ext}, which pathlight does not support")));
        }
    }
    let ignored: Vec<&str> = gltf.extensions_used().filter(|e| !SUPPORTED_EXTENSIONS.contains(e)).collect();
    if !ignored.is_empty() {
        warnings.push(format!("ignoring optional extensions: {}", ignored.join(", ")));
    }

    // Structural validation (index ranges etc.), minus the crate's own required-extension
    // check, which we replaced above. The validator itself indexes the POSITION accessor
    // without a bounds check, so check that reference first.
    let root = gltf.document.as_json();
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, primitive) in mesh.primitives.iter().enumerate() {
            let pos = gltf::json::validation::Checked::Valid(gltf::json::mesh::Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&pos) {
                if index.value() >= root.accessors.len() {
                    return Err(err(format!(
                        "mesh {mi} primitive {pi}: POSITION refers to accessor {}, but the file has {} accessors",
                        index.value(),
                        root.accessors.len()
                    )));
                }
            }
        }
    }
    let mut problems = Vec::new();
    let mut missing_bounds = 0;
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        let path = path().to_string();
        if path.starts_with("extensionsRequired") {
            return;
        }
        // POSITION min/max are required by the spec but many exporters omit them; pathlight
        // computes its own bounds, so this is only worth a warning.
        if path.contains("POSITION") && (path.ends_with(".min") || path.ends_with(".max")) {
            missing_bounds += 1;
            return;
        }
        problems.push(format!("{path}: {error:?}"));
    });
    if missing_bounds > 0 {
        warnings
            .push("POSITION accessors lack the min/max the spec requires; bounds computed instead".into());
    }
    if !problems.is_empty() {
        let shown: Vec<_> = problems.iter().take(5).cloned().collect();
        return Err(err(format!(
            "invalid glTF ({} problem{}): {}",
            problems.len(),
            if problems.len() == 1 { "" } else { "s" },
            shown.join("; ")
        )));
    }

    let raw_json = raw_json_value(bytes).map_err(|e| err(format!("cannot re-read the JSON: {e}")))?;
    let buffers = load_buffers(&gltf.document, gltf.blob.as_deref(), file, options)?;
    let doc = &gltf.document;
    let (images, textures) = load_images_and_textures(doc, &buffers, file, options, &mut warnings)?;

    let mut scene = Scene { source: file.to_path_buf(), images, textures, ..Scene::default() };
    scene.materials = doc
        .materials()
        .map(|m| {
            let mut desc = read_material(&m, file)?;
            let index = m.index().unwrap_or(0);
            read_raw_material(&raw_json["materials"][index], scene.textures.len(), &mut desc)
                .map_err(|e| err(format!("material {index} '{}': {e}", desc.name)))?;
            Ok(desc)
        })
        .collect::<Result<_>>()?;
    let default_material = scene.materials.len() as u32;
    scene.materials.push(MaterialDesc::default());
    let gltf_scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err("the file has no scene".into()))?;

    let mut stats = LoadStats::default();
    let node_count = doc.nodes().count();
    // Depth-first over the node hierarchy with f64 world transforms. A path longer than the
    // node count must repeat a node: the file has a cycle (forbidden by the spec).
    let mut stack: Vec<(gltf::Node, DMat4, usize)> =
        gltf_scene.nodes().map(|n| (n, DMat4::IDENTITY, 1)).collect();
    stack.reverse();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > node_count {
            return Err(err(format!("the node hierarchy has a cycle through node {}", node.index())));
        }
        let local = node_transform(&raw_json, node.index())
            .map_err(|m| err(format!("node {}: {m}", node.index())))?;
        let world = parent * local;
        if !world.is_finite() {
            return Err(err(format!("node {}: transform is not finite", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            add_mesh(&mut scene, &mut stats, &buffers, &mesh, &world, default_material, file)?;
        }
        if let Some(camera) = node.camera() {
            let (rotation, translation) = decompose(&world);
            let projection = match camera.projection() {
                gltf::camera::Projection::Perspective(p) => Projection::Perspective {
                    yfov: p.yfov() as f64,
                    aspect_ratio: p.aspect_ratio().map(|a| a as f64),
                },
                gltf::camera::Projection::Orthographic(o) => {
                    Projection::Orthographic { xmag: o.xmag().abs() as f64, ymag: o.ymag().abs() as f64 }
                }
            };
            let valid = match projection {
                Projection::Perspective { yfov, aspect_ratio } => {
                    yfov > 0.0
                        && yfov < std::f64::consts::PI
                        && aspect_ratio.is_none_or(|a| a > 0.0 && a.is_finite())
                }
                Projection::Orthographic { xmag, ymag } => xmag > 0.0 && ymag > 0.0,
            };
            let name =
                camera.name().map(str::to_owned).unwrap_or_else(|| format!("camera {}", camera.index()));
            match CameraDesc::from_node(name, projection, rotation, translation) {
                Some(c) if valid => scene.cameras.push(c),
                _ => warnings.push(format!(
                    "camera {} on node {} is degenerate; skipped",
                    camera.index(),
                    node.index()
                )),
            }
        }
        if let Some(light) = node.light() {
            let (rotation, translation) = decompose(&world);
            let color = Vec3::from(light.color());
            let intensity = color * light.intensity();
            if !intensity.is_finite() || intensity.min_element() < 0.0 {
                return Err(err(format!(
                    "light {}: colour × intensity is not a finite non-negative value",
                    light.index()
                )));
            }
            let kind = match light.kind() {
                gltf::khr_lights_punctual::Kind::Point => PunctualKind::Point,
                gltf::khr_lights_punctual::Kind::Directional => PunctualKind::Directional,
                gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                    PunctualKind::Spot {
                        inner_cone_angle: inner_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2),
                        outer_cone_angle: outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2),
                    }
                }
            };
            let direction = (rotation * DVec3::NEG_Z).try_normalize().unwrap_or(DVec3::NEG_Z);
            scene.lights.push(PunctualLight {
                name: light.name().map(str::to_owned).unwrap_or_else(|| format!("light {}", light.index())),
                kind,
                intensity,
                position: translation,
                direction,
            });
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
    }

    if stats.skipped_modes > 0 {
        warnings.push(format!("skipped {} point/line primitive(s)", stats.skipped_modes));
    }
    if stats.generated_tangents > 0 {
        warnings.push(format!(
            "generated MikkTSpace tangents for {} primitive(s) with a normal texture and no TANGENT",
            stats.generated_tangents
        ));
    }
    if stats.degenerate > 0 {
        warnings.push(format!("dropped {} zero-area triangle(s)", stats.degenerate));
    }
    if stats.non_finite > 0 {
        warnings.push(format!("dropped {} triangle(s) with a NaN or infinite vertex", stats.non_finite));
    }
    if stats.bad_normals > 0 {
        warnings.push(format!(
            "{} triangle(s) have a zero or non-finite vertex normal; they use their geometric normal",
            stats.bad_normals
        ));
    }
    if scene.triangle_count() == 0 {
        let dropped: Vec<&str> =
            warnings.iter().filter(|w| w.starts_with("dropped")).map(String::as_str).collect();
        let dropped = if dropped.is_empty() { String::new() } else { format!(" ({})", dropped.join("; ")) };
        return Err(err(format!("the scene has no triangles to render{dropped}")));
    }
    Ok((scene, warnings))
}

#[derive(Default)]
pub(super) struct LoadStats {
    pub(super) skipped_modes: usize,
    pub(super) degenerate: usize,
    /// Triangles dropped for a vertex that is NaN or infinite.
    pub(super) non_finite: usize,
    pub(super) bad_normals: usize,
    /// Primitives whose tangents MikkTSpace generated (a normal texture, no TANGENT).
    pub(super) generated_tangents: usize,
}

/// The JSON document as a generic value, for reading node transforms at full precision.
fn raw_json_value(bytes: &[u8]) -> std::result::Result<serde_json::Value, String> {
    if bytes.starts_with(b"glTF") {
        let glb = gltf::binary::Glb::from_slice(bytes).map_err(|e| e.to_string())?;
        serde_json::from_slice(&glb.json).map_err(|e| e.to_string())
    } else {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

pub(super) fn f64_array<const N: usize>(
    v: Option<&serde_json::Value>,
    default: [f64; N],
    what: &str,
) -> std::result::Result<[f64; N], String> {
    let Some(v) = v else { return Ok(default) };
    let arr = v
        .as_array()
        .filter(|a| a.len() == N)
        .ok_or_else(|| format!("{what} must be an array of {N} numbers"))?;
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(arr) {
        *o = x.as_f64().ok_or_else(|| format!("{what} must contain numbers"))?;
    }
    Ok(out)
}

/// A node's local transform in f64: `matrix`, or T·R·S.
fn node_transform(root: &serde_json::Value, index: usize) -> std::result::Result<DMat4, String> {
    let node = &root["nodes"][index];
    if node.get("matrix").is_some() {
        let m = f64_array::<16>(node.get("matrix"), [0.0; 16], "matrix")?;
        return Ok(DMat4::from_cols_array(&m));
    }
    let t = f64_array::<3>(node.get("translation"), [0.0; 3], "translation")?;
    let r = f64_array::<4>(node.get("rotation"), [0.0, 0.0, 0.0, 1.0], "rotation")?;
    let s = f64_array::<3>(node.get("scale"), [1.0; 3], "scale")?;
    let q = DQuat::from_xyzw(r[0], r[1], r[2], r[3]);
    let q = if q.length_squared() > 0.0 { q.normalize() } else { DQuat::IDENTITY };
    Ok(DMat4::from_scale_rotation_translation(DVec3::from(s), q, DVec3::from(t)))
}

/// Splits an affine matrix into (rotation with scale removed, translation).
pub(super) fn decompose(m: &DMat4) -> (DMat3, DVec3) {
    let linear = DMat3::from_mat4(*m);
    let rotation = DMat3::from_cols(
        linear.x_axis.try_normalize().unwrap_or(DVec3::X),
        linear.y_axis.try_normalize().unwrap_or(DVec3::Y),
        linear.z_axis.try_normalize().unwrap_or(DVec3::Z),
    );
    (rotation, m.w_axis.truncate())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// Checks the collection of unique names used in warnings is stable.
    #[test]
    fn supported_extensions_are_sorted_and_unique() {
        let set: BTreeSet<_> = SUPPORTED_EXTENSIONS.iter().collect();
        assert_eq!(set.len(), SUPPORTED_EXTENSIONS.len());
    }
}
