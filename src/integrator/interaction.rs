//! The surface a path meets: the interaction record every integrator builds at a hit (the
//! path vertex of Veach 1997 §8.2, with its shading frame), the side test every sampled
//! direction passes, a light sample that reaches the surface, and the first-hit AOV.
//!
//! WGSL twin: `shaders/interaction.wgsl`, with the same names.

use glam::{Vec2, Vec3};

use crate::bsdf::GltfBsdf;
use crate::bvh::ClosestHit;
use crate::geometry::{triangle_error_bound, Frame, Ray};
use crate::light::{sample_light, LightArrays, LightSample};
use crate::sampling::{PathSampler, SamplerKind};
use crate::scene::layout::{FirstHit, INVALID_INDEX, TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_TANGENTS};
use crate::scene::texture::{textured_material, LOD_FINEST};
use crate::scene::{oct_decode, FlatScene};

/// A light sample at `si` that its BSDF reflects and nothing blocks: the part next-event
/// estimation (`super::path::next_event`) and bidirectional path tracing's s = 1 strategy
/// share. Returns the sample, its direction in `si`'s shading frame and the BSDF's value
/// there; `None` where no light was sampled, the BSDF does not reflect that way, or
/// something blocks the shadow ray. The shadow ray is traced, and `alpha_seed` asked for
/// its stochastic-alpha number, only where the BSDF reflects, as the WGSL twin does, so
/// that the numbers a path draws stay in step on both backends.
#[inline(always)]
pub(crate) fn unblocked_light_sample(
    scene: &FlatScene,
    lights: LightArrays,
    si: &SurfaceInteraction,
    bsdf: &GltfBsdf,
    u_light: Vec2,
    alpha_seed: impl FnOnce() -> u32,
    rays: &mut u64,
) -> Option<(LightSample, Vec3, Vec3)> {
    let ls = sample_light(lights, si.p, si.p_error, si.n_geometric, u_light)?;
    let wi = si.frame.to_local(ls.wi);
    let f = if sides_agree(si, ls.wi, wi) { bsdf.eval(si.wo, wi) } else { Vec3::ZERO };
    // Written so that a NaN value traces no ray.
    if f.max_element() > 0.0 {
        *rays += 1;
        let seed = if scene.features.alpha { alpha_seed() } else { 0 };
        (!scene.intersect_any(&ls.shadow_ray, seed)).then_some((ls, wi, f))
    } else {
        None
    }
}

/// Everything about a ray's hit the integrator needs.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    pub p: Vec3,
    /// Conservative absolute error of `p`.
    pub p_error: Vec3,
    /// Unit geometric normal from the winding (front face side).
    pub n_geometric: Vec3,
    /// Shading frame, flipped to face the incoming ray.
    pub frame: Frame,
    /// Outgoing direction (towards the ray origin) in the shading frame; `wo.z > 0` unless
    /// the hit is exactly edge-on.
    pub wo: Vec3,
    /// The same direction in world space.
    pub wo_world: Vec3,
    /// Did the ray arrive on the geometric front side?
    pub front_face: bool,
    pub material: u32,
    pub emitter: u32,
    /// Distance along the ray (unit direction).
    pub distance: f32,
    /// UV sets 0 and 1 at the hit (zero without textures).
    pub uv: (Vec2, Vec2),
    /// Texture level-of-detail bases per UV set (`texture::lod_bases`).
    pub lod: Vec2,
    /// The clear coat's normal in the shading frame (+z without a coat).
    pub coat_normal: Vec3,
}

/// Builds the interaction for `hit` of `ray` (`ray.direction` unit length), whose ray cone
/// is `cone_width` wide at the hit (texture level of detail, `src/scene/texture.rs`).
///
/// Inlined, so that the fields a scene does not use are never stored (out of line, the
/// call and its 150-byte result were 2.2% of a Cornell-box render's instructions).
#[inline(always)]
pub fn surface_interaction(
    scene: &FlatScene,
    ray: &Ray,
    hit: &ClosestHit,
    cone_width: f32,
) -> SurfaceInteraction {
    let tri = &scene.triangles[hit.triangle as usize];
    let (p0, p1, p2) = (Vec3::from(tri.p0), Vec3::from(tri.p1), Vec3::from(tri.p2));
    let h = &hit.hit;
    let p = h.b0 * p0 + h.b1 * p1 + h.b2 * p2;
    let p_error = triangle_error_bound(h, p0, p1, p2);
    let n_geometric = (p1 - p0).cross(p2 - p0).normalize();
    let wo_world = -ray.direction;
    let front_face = wo_world.dot(n_geometric) > 0.0;
    let ng_facing = if front_face { n_geometric } else { -n_geometric };
    let b = Vec3::new(h.b0, h.b1, h.b2);
    let textures = scene.texture_arrays();
    let (uv, lod) = if scene.features.textures {
        let cos_theta = wo_world.dot(n_geometric);
        (textures.uv(hit.triangle, b), textures.lod_bases(hit.triangle, [p0, p1, p2], cone_width, cos_theta))
    } else {
        ((Vec2::ZERO, Vec2::ZERO), Vec2::splat(LOD_FINEST))
    };
    // The shading normal on the geometric front side: interpolated vertex normals, then the
    // normal map in their tangent frame (glTF 2.0 §3.9.3: n = T·x + B·y + N·z with
    // B = (N × T)·w, the map's x and y scaled by normalTexture.scale).
    let mut n_front = n_geometric;
    if tri.flags & TRIANGLE_HAS_NORMALS != 0 {
        let n = &scene.normals[hit.triangle as usize];
        let interpolated = h.b0 * oct_decode(n.n0) + h.b1 * oct_decode(n.n1) + h.b2 * oct_decode(n.n2);
        if let Some(s) = interpolated.try_normalize() {
            // The file's normals may disagree with its winding: put them on the front side.
            n_front = if s.dot(n_geometric) < 0.0 { -s } else { s };
        }
    }
    let material = &scene.materials[tri.material as usize];
    // The tangent frame (front side) where a normal map will read it.
    let tangent_frame = if tri.flags & TRIANGLE_HAS_TANGENTS != 0 {
        let t = &scene.tangents[hit.triangle as usize];
        let tangent = h.b0 * oct_decode(t.t0) + h.b1 * oct_decode(t.t1) + h.b2 * oct_decode(t.t2);
        let sign = if t.signs & 1 != 0 { -1.0 } else { 1.0 };
        // Gram–Schmidt: the interpolated tangent is only nearly orthogonal to N.
        (tangent - n_front * n_front.dot(tangent))
            .try_normalize()
            .map(|tangent| (tangent, n_front.cross(tangent) * sign))
    } else {
        None
    };
    let map_normal = |texture: u32, scale: f32| -> Option<Vec3> {
        let (tangent, bitangent) = tangent_frame?;
        let texel = textures.lookup_lod(texture, uv, lod, false)?;
        let m = texel.truncate() * 2.0 - Vec3::ONE;
        let mapped = (tangent * (m.x * scale) + bitangent * (m.y * scale) + n_front * m.z).try_normalize()?;
        Some(if mapped.dot(n_geometric) < 0.0 { n_front } else { mapped })
    };
    // Most materials have no normal map: no call of the closure for them (0.8% of a
    // Cornell-box render's instructions).
    let n_mapped = if material.normal_texture == INVALID_INDEX {
        n_front
    } else {
        map_normal(material.normal_texture, material.normal_scale).unwrap_or(n_front)
    };
    // Face the incoming ray, and fall back where the shading normal would put the viewer
    // below its hemisphere (silhouettes of coarse meshes, steep normal-map texels): first to
    // the interpolated normal, then to the geometric one. This is the usual shading-normal
    // guard (Veach 1997 §5.3 discusses why such normals are asymmetric), not a microfacet
    // normal-mapping model (Schüßler et al. 2017).
    let flip = |n: Vec3| if front_face { n } else { -n };
    let facing =
        |n: Vec3| [flip(n), flip(n_front)].into_iter().find(|n| n.dot(wo_world) > 0.0).unwrap_or(ng_facing);
    let frame = Frame::from_z(facing(n_mapped));
    // The clear coat's own normal: its normal map, else the interpolated normal (never the
    // base's normal map), under the same guard.
    let coat_normal = if material.clearcoat > 0.0 {
        let n =
            map_normal(material.clearcoat_normal_texture, material.clearcoat_normal_scale).unwrap_or(n_front);
        frame.to_local(facing(n)).normalize()
    } else {
        Vec3::Z
    };
    SurfaceInteraction {
        p,
        p_error,
        n_geometric,
        frame,
        wo: frame.to_local(wo_world),
        wo_world,
        front_face,
        material: tri.material,
        emitter: tri.emitter,
        distance: h.t,
        uv,
        lod,
        coat_normal,
    }
}

/// Does direction `wi` (world `wi_world`, shading frame `wi_local`) leave the surface on the
/// side its shading says? Reflection in the shading frame (`wi_local.z > 0`, as `wo.z > 0`)
/// must also be reflection about the geometric normal, and transmission transmission.
/// Where smooth normals tilt far from the faces (averaged corner normals of a box), a
/// direction can be reflected for the BSDF yet pass through the geometric surface; its ray
/// would be spawned on the far side and carry light through a closed wall (issue 11's sealed
/// room). Such directions are dropped, as pbrt-v3's `BSDF::f` does by classifying
/// reflection with the geometric normal (Veach 1997 §5.3 discusses these normals).
pub fn sides_agree(si: &SurfaceInteraction, wi_world: Vec3, wi_local: Vec3) -> bool {
    let wo_side = si.wo_world.dot(si.n_geometric);
    let reflected_geometrically = wi_world.dot(si.n_geometric) * wo_side > 0.0;
    reflected_geometrically == (wi_local.z > 0.0)
}

/// What the camera ray of sample 0 of pixel `(x, y)` hits (the first-hit AOV), its jitter
/// drawn by the independent sampler on both backends.
/// The first-hit AOV reads textures at the level of detail of a one-sample render.
pub fn first_hit(scene: &FlatScene, width: u32, height: u32, x: u32, y: u32, seed: u32) -> FirstHit {
    let mut rng = PathSampler::new(SamplerKind::Independent, x, y, 0, seed);
    let ray = crate::scene::camera::generate_camera_ray(&scene.camera, width, height, x, y, rng.next_2d());
    let cone = crate::scene::camera::camera_ray_cone(&scene.camera, height, 1);
    match scene.intersect_closest(&ray, 0) {
        Some(hit) => {
            let si = surface_interaction(scene, &ray, &hit, cone.width_at(hit.hit.t));
            FirstHit {
                normal: si.frame.z.to_array(),
                distance: si.distance,
                albedo: textured_material(
                    &scene.materials[si.material as usize],
                    &scene.texture_arrays(),
                    si.uv,
                    si.lod,
                )
                .base_color,
                triangle: hit.triangle,
            }
        }
        None => FirstHit { triangle: INVALID_INDEX, ..Default::default() },
    }
}
