// Twin of src/bsdf/gltf.rs: the glTF 2.0 BSDF with KHR_materials_specular, _ior,
// _transmission, _volume, _clearcoat and _sheen, layered from the lobes of bsdf.wgsl. The
// comments in src/bsdf/gltf.rs define the model; this file mirrors it function by function.

const CLEARCOAT_F0: f32 = 0.04;
const COAT_MIN_BASE_COSINE: f32 = 1e-6;

struct GltfBsdf {
    base_color: vec3<f32>,
    metallic: f32,
    alpha: f32,
    transmission: f32,
    specular_factor: f32,
    specular_color: vec3<f32>,
    f0_dielectric: vec3<f32>,
    eta: f32,
    volume: bool,
    transmission_is_delta: bool,
    p_reflect: f32,
    p_diffuse: f32,
    p_transmit: f32,
    coat: f32,
    coat_alpha: f32,
    coat_frame: Frame,
    coat_transmittance: f32,
    sheen_color: vec3<f32>,
    sheen_roughness: f32,
    sheen_alpha: f32,
    p_coat: f32,
    p_sheen: f32,
    // Diffuse lobe only: f = baseColor/π without assembling the layers (see the CPU twin).
    lambertian: bool,
}

struct BsdfSample {
    wi: vec3<f32>,
    weight: vec3<f32>,
    pdf_solid_angle: f32,
    is_delta: bool,
    valid: bool,
    // η² across a volume boundary, else 1 (see the CPU twin).
    eta_scale: f32,
}

fn no_bsdf_sample() -> BsdfSample {
    return BsdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false, false, 1.0);
}

fn lobe_weight(present: bool, estimate: f32) -> f32 {
    return select(0.0, max(estimate, LOBE_SELECTION_FLOOR), present);
}

fn gltf_bsdf_new(m: Material, wo: vec3<f32>, front_face: bool, coat_normal: vec3<f32>) -> GltfBsdf {
    let cos_theta_o = wo.z;
    let ior = m.ior;
    // Transmission is compiled out of scenes that have none (FEATURE_TRANSMISSION = false);
    // then `transmission` reads as 0 and every transmissive branch below is dead code. The
    // same holds for the coat and the sheen.
    let transmission = select(0.0, m.transmission, FEATURE_TRANSMISSION);
    let volume = FEATURE_VOLUME && (m.flags & MATERIAL_VOLUME) != 0u && transmission > 0.0;
    let eta = select(ior, 1.0 / ior, volume && !front_face);
    let r = (ior - 1.0) / (ior + 1.0);
    let r0 = r * r;
    let outside = !volume || front_face;
    var b: GltfBsdf;
    b.base_color = m.base_color;
    b.metallic = m.metallic;
    b.alpha = m.alpha_roughness;
    b.transmission = transmission;
    b.specular_factor = m.specular_factor;
    b.specular_color = m.specular_color;
    b.f0_dielectric = min(r0 * m.specular_color, vec3<f32>(1.0)) * m.specular_factor;
    b.eta = eta;
    b.volume = volume;
    b.transmission_is_delta = m.alpha_roughness == 0.0 || (volume && eta == 1.0);
    b.coat_transmittance = 1.0;
    var coat_fresnel_o = 0.0;
    if (FEATURE_CLEARCOAT) {
        b.coat_frame = frame_from_z(coat_normal);
        let coat_cos_o = frame_to_local(b.coat_frame, wo).z;
        b.coat = select(0.0, clamp(m.clearcoat, 0.0, 1.0), outside && coat_cos_o > 0.0);
        b.coat_alpha = alpha_from_roughness(m.clearcoat_roughness);
        coat_fresnel_o = fresnel_schlick(vec3<f32>(CLEARCOAT_F0), 1.0, coat_cos_o).x;
        b.coat_transmittance = 1.0 - b.coat * coat_fresnel_o;
    }
    var sheen_reflectance = 0.0;
    if (FEATURE_SHEEN) {
        b.sheen_color = select(vec3<f32>(0.0), max(m.sheen_color, vec3<f32>(0.0)), outside);
        b.sheen_roughness = m.sheen_roughness;
        b.sheen_alpha = sheen_alpha(m.sheen_roughness);
        if (has_sheen(b)) {
            sheen_reflectance = max_element(b.sheen_color) * sheen_albedo(cos_theta_o, b.sheen_roughness);
        }
    }
    b.lambertian = b.metallic == 0.0 && b.specular_factor == 0.0 && b.transmission == 0.0 && b.coat == 0.0
        && max_element(b.sheen_color) <= 0.0 && max_element(b.base_color) > 0.0;
    if (b.lambertian) {
        b.p_diffuse = 1.0;
        return b;
    }
    let f = max_element(dielectric_fresnel(b, cos_theta_o));
    let dielectric = 1.0 - b.metallic;
    let color = max_element(b.base_color);
    let below = b.coat_transmittance * max(1.0 - sheen_reflectance, 0.0);
    let reflect_present = FEATURE_SPECULAR && (b.metallic > 0.0 || b.specular_factor > 0.0);
    let diffuse_present = dielectric * (1.0 - b.transmission) > 0.0 && color > 0.0;
    let transmit_present = dielectric * b.transmission > 0.0 && color > 0.0;
    let w_c = lobe_weight(b.coat > 0.0, b.coat * coat_fresnel_o);
    let w_s = lobe_weight(has_sheen(b), b.coat_transmittance * sheen_reflectance);
    let w_r = lobe_weight(reflect_present, below * (b.metallic + dielectric * f));
    let w_d = lobe_weight(diffuse_present, below * dielectric * (1.0 - b.transmission) * (1.0 - f) * color);
    let w_t = lobe_weight(transmit_present, below * dielectric * b.transmission * (1.0 - f) * color);
    let total = w_c + w_s + w_r + w_d + w_t;
    // `b` is zero-initialised: with no lobe present every probability stays 0.
    if (total > 0.0) {
        b.p_coat = w_c / total;
        b.p_sheen = w_s / total;
        b.p_reflect = w_r / total;
        b.p_diffuse = w_d / total;
        b.p_transmit = w_t / total;
    }
    return b;
}

fn has_sheen(b: GltfBsdf) -> bool {
    return FEATURE_SHEEN && max_element(b.sheen_color) > 0.0;
}

fn sheen_scaling(b: GltfBsdf, mu_o: f32, mu_i: f32) -> f32 {
    if (has_sheen(b)) {
        return sheen_albedo_scaling(b.sheen_color, b.sheen_roughness, mu_o, mu_i);
    }
    return 1.0;
}

// Twin of `coat_directions`: wo and wi in the coat's frame, `valid` where the rough coat
// lobe acts on them.
struct CoatDirections {
    wo: vec3<f32>,
    wi: vec3<f32>,
    valid: bool,
}

fn coat_directions(b: GltfBsdf, wo: vec3<f32>, wi: vec3<f32>) -> CoatDirections {
    var d: CoatDirections;
    if (!FEATURE_CLEARCOAT || b.coat <= 0.0 || b.coat_alpha == 0.0 || wi.z < COAT_MIN_BASE_COSINE) {
        return d;
    }
    d.wo = frame_to_local(b.coat_frame, wo);
    d.wi = frame_to_local(b.coat_frame, wi);
    d.valid = d.wo.z > 0.0 && d.wi.z > 0.0;
    return d;
}

fn coat_eval(b: GltfBsdf, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let d = coat_directions(b, wo, wi);
    if (!d.valid) {
        return 0.0;
    }
    let h = reflection_half_vector(d.wo, d.wi);
    if (h.w == 0.0) {
        return 0.0;
    }
    let fresnel = fresnel_schlick(vec3<f32>(CLEARCOAT_F0), 1.0, dot(d.wo, h.xyz)).x;
    return b.coat * fresnel * reflection_eval(d.wo, d.wi, b.coat_alpha) * d.wi.z / wi.z;
}

fn coat_pdf(b: GltfBsdf, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let d = coat_directions(b, wo, wi);
    if (!d.valid) {
        return 0.0;
    }
    return reflection_pdf(d.wo, d.wi, b.coat_alpha);
}

fn dielectric_fresnel(b: GltfBsdf, cos_theta: f32) -> vec3<f32> {
    if (b.transmission > 0.0) {
        return b.specular_factor * min(b.specular_color, vec3<f32>(1.0)) * fresnel_dielectric(cos_theta, b.eta);
    }
    return fresnel_schlick(b.f0_dielectric, b.specular_factor, cos_theta);
}

fn metal_fresnel(b: GltfBsdf, cos_theta: f32) -> vec3<f32> {
    return fresnel_schlick(b.base_color, 1.0, cos_theta);
}

fn has_non_delta(b: GltfBsdf) -> bool {
    return b.p_diffuse > 0.0 || b.p_sheen > 0.0 || (b.p_coat > 0.0 && b.coat_alpha > 0.0)
        || (b.p_reflect > 0.0 && b.alpha > 0.0) || (b.p_transmit > 0.0 && !b.transmission_is_delta);
}

// Twin of `has_lambert_lobe`.
fn has_lambert_lobe(b: GltfBsdf) -> bool {
    return b.p_diffuse > 0.0;
}

// Twin of `has_diffuse_lobe`: Lambert or sheen (where photon mapping gathers).
fn has_diffuse_lobe(b: GltfBsdf) -> bool {
    return b.p_diffuse > 0.0 || b.p_sheen > 0.0;
}

// Twin of `has_rough_transmission`: light reaches the point from either side.
fn has_rough_transmission(b: GltfBsdf) -> bool {
    return b.p_transmit > 0.0 && !b.transmission_is_delta;
}

// Twin of `non_delta_probability`: the probability that `gltf_bsdf_sample` chooses a
// non-delta lobe.
fn non_delta_probability(b: GltfBsdf) -> f32 {
    if (b.lambertian) {
        return 1.0;
    }
    var p = b.p_diffuse + b.p_sheen;
    if (b.coat_alpha > 0.0) {
        p += b.p_coat;
    }
    if (b.alpha > 0.0) {
        p += b.p_reflect;
    }
    if (!b.transmission_is_delta) {
        p += b.p_transmit;
    }
    return p;
}

// Twin of `eval_diffuse`: the Lambertian lobe's share of the BSDF, without the cosine.
fn gltf_bsdf_eval_diffuse(b: GltfBsdf, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if (wo.z <= 0.0 || wi.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    if (b.lambertian) {
        return b.base_color * lambert_eval(wi);
    }
    if (b.p_diffuse <= 0.0) {
        return vec3<f32>(0.0);
    }
    let h = reflection_half_vector(wo, wi);
    if (h.w == 0.0) {
        return vec3<f32>(0.0);
    }
    let fd = dielectric_fresnel(b, dot(wo, h.xyz));
    let diffuse = b.base_color * (1.0 - b.transmission) * lambert_eval(wi);
    let base = (1.0 - b.metallic) * (1.0 - max_element(fd)) * diffuse;
    return base * (b.coat_transmittance * sheen_scaling(b, wo.z, wi.z));
}

// Twin of `diffuse_albedo`: the Lambertian lobe's directional albedo, by the same 4 × 4
// stratified cosine quadrature.
fn gltf_bsdf_diffuse_albedo(b: GltfBsdf, wo: vec3<f32>) -> vec3<f32> {
    if (b.lambertian) {
        return select(vec3<f32>(0.0), b.base_color, wo.z > 0.0);
    }
    if (b.p_diffuse <= 0.0) {
        return vec3<f32>(0.0);
    }
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < 4u; i += 1u) {
        for (var j = 0u; j < 4u; j += 1u) {
            let u = vec2<f32>((f32(i) + 0.5) / 4.0, (f32(j) + 0.5) / 4.0);
            sum += gltf_bsdf_eval_diffuse(b, wo, lambert_sample(u)) * PI;
        }
    }
    return sum / 16.0;
}

fn gltf_bsdf_eval(b: GltfBsdf, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if (wo.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    if (b.lambertian) {
        return b.base_color * lambert_eval(wi);
    }
    let base = base_eval(b, wo, wi);
    if (wi.z > 0.0) {
        var sheen = vec3<f32>(0.0);
        if (has_sheen(b)) {
            sheen = b.sheen_color * sheen_eval(wo, wi, b.sheen_alpha);
        }
        let below = sheen + base * sheen_scaling(b, wo.z, wi.z);
        return vec3<f32>(coat_eval(b, wo, wi)) + b.coat_transmittance * below;
    }
    return base * (b.coat_transmittance * sheen_scaling(b, wo.z, 0.0));
}

fn base_eval(b: GltfBsdf, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let dielectric = 1.0 - b.metallic;
    if (wi.z > 0.0) {
        let h = reflection_half_vector(wo, wi);
        if (h.w == 0.0) {
            return vec3<f32>(0.0);
        }
        let cos_h = dot(wo, h.xyz);
        let fd = dielectric_fresnel(b, cos_h);
        let diffuse = b.base_color * (1.0 - b.transmission) * lambert_eval(wi);
        var f = dielectric * (1.0 - max_element(fd)) * diffuse;
        if (FEATURE_SPECULAR && b.alpha > 0.0 && b.p_reflect > 0.0) {
            let spec = reflection_eval(wo, wi, b.alpha);
            f += (dielectric * fd + b.metallic * metal_fresnel(b, cos_h)) * spec;
        }
        return f;
    }
    if (FEATURE_TRANSMISSION && wi.z < 0.0 && b.p_transmit > 0.0 && !b.transmission_is_delta) {
        let weight = dielectric * b.transmission * b.base_color;
        if (b.volume) {
            let h = transmission_half_vector(wo, wi, b.eta);
            if (h.w == 0.0) {
                return vec3<f32>(0.0);
            }
            let fd = dielectric_fresnel(b, dot(wo, h.xyz));
            return weight * (1.0 - max_element(fd)) * transmission_eval(wo, wi, b.alpha, b.eta);
        }
        let h = thin_transmission_half_vector(wo, wi);
        if (h.w == 0.0) {
            return vec3<f32>(0.0);
        }
        let fd = dielectric_fresnel(b, dot(wo, h.xyz));
        return weight * (1.0 - max_element(fd)) * thin_transmission_eval(wo, wi, b.alpha);
    }
    return vec3<f32>(0.0);
}

fn gltf_bsdf_pdf(b: GltfBsdf, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    if (wo.z <= 0.0) {
        return 0.0;
    }
    if (b.lambertian) {
        return lambert_pdf(wi);
    }
    if (wi.z > 0.0) {
        var p = (b.p_diffuse + b.p_sheen) * lambert_pdf(wi) + b.p_coat * coat_pdf(b, wo, wi);
        if (FEATURE_SPECULAR && b.alpha > 0.0 && b.p_reflect > 0.0) {
            p += b.p_reflect * reflection_pdf(wo, wi, b.alpha);
        }
        return p;
    }
    if (FEATURE_TRANSMISSION && wi.z < 0.0 && b.p_transmit > 0.0 && !b.transmission_is_delta) {
        if (b.volume) {
            return b.p_transmit * transmission_pdf(wo, wi, b.alpha, b.eta);
        }
        return b.p_transmit * thin_transmission_pdf(wo, wi, b.alpha);
    }
    return 0.0;
}

fn gltf_bsdf_sample(b: GltfBsdf, wo: vec3<f32>, u_lobe: f32, u: vec2<f32>) -> BsdfSample {
    if (wo.z <= 0.0) {
        return no_bsdf_sample();
    }
    if (b.lambertian) {
        let wi = lambert_sample(u);
        let pdf = lambert_pdf(wi);
        if (pdf <= 0.0) {
            return no_bsdf_sample();
        }
        return BsdfSample(wi, b.base_color, pdf, false, true, 1.0);
    }
    let dielectric = 1.0 - b.metallic;
    var wi: vec3<f32>;
    // Lobes in the order coat, sheen, reflection, diffuse, transmission along u_lobe.
    let u_l = u_lobe - b.p_coat - b.p_sheen;
    if (FEATURE_CLEARCOAT && u_l < -b.p_sheen) {
        let wo_c = frame_to_local(b.coat_frame, wo);
        if (b.coat_alpha == 0.0) {
            let wm = frame_from_local(b.coat_frame, vec3<f32>(-wo_c.x, -wo_c.y, wo_c.z));
            if (wm.z <= 0.0) {
                return no_bsdf_sample();
            }
            let f = b.coat * fresnel_schlick(vec3<f32>(CLEARCOAT_F0), 1.0, wo_c.z).x;
            return BsdfSample(wm, vec3<f32>(f / b.p_coat), b.p_coat, true, true, 1.0);
        }
        let s = reflection_sample(wo_c, b.coat_alpha, u);
        if (s.w == 0.0) {
            return no_bsdf_sample();
        }
        wi = frame_from_local(b.coat_frame, s.xyz);
        if (wi.z <= 0.0) {
            return no_bsdf_sample();
        }
    } else if (u_l < 0.0) {
        wi = lambert_sample(u);
    } else if (u_l < b.p_reflect) {
        if (b.alpha == 0.0) {
            let f = dielectric * dielectric_fresnel(b, wo.z) + b.metallic * metal_fresnel(b, wo.z);
            let below = b.coat_transmittance * sheen_scaling(b, wo.z, wo.z);
            return BsdfSample(vec3<f32>(-wo.x, -wo.y, wo.z), f * below / b.p_reflect, b.p_reflect, true, true, 1.0);
        }
        let s = reflection_sample(wo, b.alpha, u);
        if (s.w == 0.0) {
            return no_bsdf_sample();
        }
        wi = s.xyz;
    } else if (u_l < b.p_reflect + b.p_diffuse) {
        wi = lambert_sample(u);
    } else {
        if (!FEATURE_TRANSMISSION || b.p_transmit <= 0.0) {
            return no_bsdf_sample();
        }
        if (b.transmission_is_delta) {
            var wt = -wo;
            var eta2 = 1.0;
            if (b.volume) {
                let r = refract_through(wo, vec3<f32>(0.0, 0.0, 1.0), b.eta);
                if (r.w == 0.0) {
                    return no_bsdf_sample();
                }
                wt = r.xyz;
                eta2 = b.eta * b.eta;
            }
            let fd = dielectric_fresnel(b, wo.z);
            let below = b.coat_transmittance * sheen_scaling(b, wo.z, 0.0);
            let t = dielectric * b.transmission * b.base_color * (1.0 - max_element(fd)) * below / eta2;
            return BsdfSample(wt, t / b.p_transmit, b.p_transmit, true, true, eta2);
        }
        var s: vec4<f32>;
        if (b.volume) {
            s = transmission_sample(wo, b.alpha, b.eta, u);
        } else {
            s = thin_transmission_sample(wo, b.alpha, u);
        }
        if (s.w == 0.0) {
            return no_bsdf_sample();
        }
        wi = s.xyz;
    }
    let pdf = gltf_bsdf_pdf(b, wo, wi);
    if (!is_finite_f32(pdf) || pdf <= 0.0) {
        return no_bsdf_sample();
    }
    let f = gltf_bsdf_eval(b, wo, wi);
    let eta_scale = select(1.0, b.eta * b.eta, b.volume && wi.z < 0.0);
    return BsdfSample(wi, f * abs(wi.z) / pdf, pdf, false, true, eta_scale);
}

// Twin of `alpha_from_roughness` (src/bsdf/mod.rs): GGX α = roughness², 0 exactly for a
// delta lobe, else at least MIN_ALPHA.
fn alpha_from_roughness(roughness: f32) -> f32 {
    let r = clamp(roughness, 0.0, 1.0);
    if (r == 0.0) {
        return 0.0;
    }
    return max(r * r, MIN_ALPHA);
}
