// Twin of src/integrator/interaction.rs: the surface record every integrator builds at a
// path vertex, the side test of a sampled direction, a light sample that reaches the
// surface, and the first-hit AOV's entry point.

struct SurfaceInteraction {
    p: vec3<f32>,
    p_error: vec3<f32>,
    n_geometric: vec3<f32>,
    frame: Frame,
    wo: vec3<f32>,
    wo_world: vec3<f32>,
    front_face: bool,
    material: u32,
    emitter: u32,
    distance: f32,
    // UV sets 0 (xy) and 1 (zw).
    uv: vec4<f32>,
    // Texture level-of-detail bases per UV set (`lod_bases`).
    lod: vec2<f32>,
    // The clear coat's normal in the shading frame (+z without a coat).
    coat_normal: vec3<f32>,
}

fn surface_interaction(ray: Ray, hit: ClosestHit, cone_width: f32) -> SurfaceInteraction {
    let tri = triangles[hit.triangle];
    let b = hit.b;
    let p = b.x * tri.p0 + b.y * tri.p1 + b.z * tri.p2;
    let p_error = triangle_error_bound(b, tri.p0, tri.p1, tri.p2);
    let n_geometric = normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0));
    let wo_world = -ray.direction;
    let front_face = dot(wo_world, n_geometric) > 0.0;
    let ng_facing = select(-n_geometric, n_geometric, front_face);
    let uv = triangle_uv(hit.triangle, b);
    let lod = lod_bases(hit.triangle, length(cross(tri.p1 - tri.p0, tri.p2 - tri.p0)), cone_width, dot(wo_world, n_geometric));
    var n_front = n_geometric;
    if ((tri.flags & TRIANGLE_HAS_NORMALS) != 0u) {
        let n = normals[hit.triangle];
        let interpolated = try_normalize(b.x * oct_decode(n.n0) + b.y * oct_decode(n.n1) + b.z * oct_decode(n.n2));
        if (interpolated.w != 0.0) {
            n_front = select(interpolated.xyz, -interpolated.xyz, dot(interpolated.xyz, n_geometric) < 0.0);
        }
    }
    let material = materials[tri.material];
    // The tangent frame (front side) where a normal map will read it.
    var tangent_frame = Frame(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var has_tangent_frame = false;
    if (FEATURE_NORMAL_MAPS && (tri.flags & TRIANGLE_HAS_TANGENTS) != 0u) {
        let t = tangents[hit.triangle];
        let tangent = b.x * oct_decode(t.t0) + b.y * oct_decode(t.t1) + b.z * oct_decode(t.t2);
        let sign = select(1.0, -1.0, (t.signs & 1u) != 0u);
        let ortho = try_normalize(tangent - n_front * dot(n_front, tangent));
        if (ortho.w != 0.0) {
            tangent_frame = Frame(ortho.xyz, cross(n_front, ortho.xyz) * sign, n_front);
            has_tangent_frame = true;
        }
    }
    var n_mapped = n_front;
    if (has_tangent_frame) {
        n_mapped = map_normal(material.normal_texture, material.normal_scale, uv, lod, tangent_frame, n_geometric);
    }
    let ns = facing_normal(n_mapped, n_front, front_face, wo_world, ng_facing);
    let f = frame_from_z(ns);
    // The clear coat's own normal: its normal map, else the interpolated normal.
    var coat_normal = vec3<f32>(0.0, 0.0, 1.0);
    if (FEATURE_CLEARCOAT && material.clearcoat > 0.0) {
        var n_coat = n_front;
        if (has_tangent_frame) {
            n_coat = map_normal(material.clearcoat_normal_texture, material.clearcoat_normal_scale, uv, lod, tangent_frame, n_geometric);
        }
        coat_normal = normalize(frame_to_local(f, facing_normal(n_coat, n_front, front_face, wo_world, ng_facing)));
    }
    return SurfaceInteraction(p, p_error, n_geometric, f, frame_to_local(f, wo_world), wo_world, front_face, tri.material, tri.emitter, hit.t, uv, lod, coat_normal);
}

// The normal map `texture` (or INVALID_INDEX: none) applied in `tf` (tangent, bitangent,
// interpolated normal; glTF 2.0 §3.9.3), kept on the geometric front side; the interpolated
// normal where there is no map.
fn map_normal(texture: u32, scale: f32, uv: vec4<f32>, lod: vec2<f32>, tf: Frame, n_geometric: vec3<f32>) -> vec3<f32> {
    if (texture == INVALID_INDEX) {
        return tf.z;
    }
    let m = texture_lookup_lod(texture, uv, lod, false).xyz * 2.0 - vec3<f32>(1.0);
    let mapped = try_normalize(tf.x * (m.x * scale) + tf.y * (m.y * scale) + tf.z * m.z);
    if (mapped.w == 0.0) {
        return tf.z;
    }
    return select(mapped.xyz, tf.z, dot(mapped.xyz, n_geometric) < 0.0);
}

// Face the ray; fall back to the interpolated, then the geometric normal where the viewer
// would be below the shading hemisphere (the CPU twin explains the rule).
fn facing_normal(n: vec3<f32>, n_front: vec3<f32>, front_face: bool, wo_world: vec3<f32>, ng_facing: vec3<f32>) -> vec3<f32> {
    let s_n = select(-n, n, front_face);
    let s_front = select(-n_front, n_front, front_face);
    if (dot(s_n, wo_world) > 0.0) {
        return s_n;
    }
    if (dot(s_front, wo_world) > 0.0) {
        return s_front;
    }
    return ng_facing;
}

// Twin of `sides_agree`: reflection by the shading frame must be reflection by the
// geometric normal too (the CPU twin explains the light leak this closes).
fn sides_agree(si: SurfaceInteraction, wi_world: vec3<f32>, wi_local: vec3<f32>) -> bool {
    let wo_side = dot(si.wo_world, si.n_geometric);
    let reflected_geometrically = dot(wi_world, si.n_geometric) * wo_side > 0.0;
    return reflected_geometrically == (wi_local.z > 0.0);
}

// Twin of `unblocked_light_sample`: a light sample at `si` that its BSDF reflects and
// nothing blocks, the part next-event estimation and BDPT's s = 1 strategy share; `valid`
// false where none was sampled, the BSDF does not reflect that way or the shadow ray is
// blocked. The shadow ray, and its alpha number, only where the BSDF reflects.
struct UnblockedLightSample {
    ls: LightSample,
    // The sample's direction in `si`'s shading frame, and the BSDF's value there.
    wi: vec3<f32>,
    f: vec3<f32>,
    valid: bool,
}

fn unblocked_light_sample(si: SurfaceInteraction, bsdf: GltfBsdf, u_light: vec2<f32>) -> UnblockedLightSample {
    var out: UnblockedLightSample;
    out.valid = false;
    out.ls = sample_light(si.p, si.p_error, si.n_geometric, u_light);
    if (!out.ls.valid) {
        return out;
    }
    out.wi = frame_to_local(si.frame, out.ls.wi);
    out.f = vec3<f32>(0.0);
    if (sides_agree(si, out.ls.wi, out.wi)) {
        out.f = gltf_bsdf_eval(bsdf, si.wo, out.wi);
    }
    // Negated so that a NaN value traces no ray, as on the CPU.
    if (!(max_element(out.f) > 0.0)) {
        return out;
    }
    var alpha_seed = 0u;
    if (FEATURE_ALPHA) {
        alpha_seed = rng_next_u32();
    }
    out.valid = !intersect_any(out.ls.shadow_ray, alpha_seed);
    return out;
}

// What the camera ray of sample 0 hits: the first-hit AOV (distance, normal, albedo).
@compute @workgroup_size(8, 8, 1)
fn first_hit(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let x = px.x;
    let y = px.y;
    // Jittered by the independent sampler on both backends (`integrator::first_hit`).
    sampler_start(SAMPLER_INDEPENDENT, x, y, 0u, frame.seed);
    let ray = generate_camera_ray(frame.width, frame.height, x, y, rng_next_2d());
    let hit = intersect_closest(ray, 0u);
    var out = FirstHit(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), INVALID_INDEX);
    if (hit.triangle != INVALID_INDEX) {
        let cone = vec2<f32>(frame.cone_width, frame.cone_spread);
        let si = surface_interaction(ray, hit, cone.x + cone.y * hit.t);
        out = FirstHit(si.frame.z, si.distance, textured_material(materials[si.material], si.uv, si.lod).base_color, hit.triangle);
    }
    first_hits[y * frame.width + x] = out;
}
