//! The glTF 2.0 metallic-roughness BSDF (glTF 2.0 Appendix B) with
//! KHR_materials_specular, _ior, _transmission, _volume, _sheen and _clearcoat, assembled
//! from the lobes:
//!
//! ```text
//! dielectric = F_d · specular + (1 − max(F_d)) · [(1 − t) · diffuse + t · baseColor · btdf]
//! metal      = F_m · specular,             F_m = baseColor + (1 − baseColor)(1 − |v·h|)⁵
//! base       = (1 − metallic) · dielectric + metallic · metal
//! sheened    = sheenColor · f_sheen + base · (1 − max(sheenColor) · E)       (sheen.rs)
//! bsdf       = c · F_c(|v·h_c|) · coat + (1 − c · F_c(n_c·v)) · sheened
//! ```
//!
//! The coat (KHR_materials_clearcoat) is a GGX reflection of roughness
//! `clearcoatRoughness` about its own normal n_c (the coat's normal map, else the
//! interpolated normal: not the base's normal map), with Schlick's Fresnel F_c at F₀ = 0.04
//! (ior 1.5) and weight c = clearcoat. Its Fresnel is taken at the coat's half vector for the
//! coat lobe and at the view direction for the attenuation of what lies below, as the
//! Khronos sample renderer does. Coat and sheen are outer layers: seen from inside a
//! refracting solid they are absent.
//!
//! `specular` is GGX with height-correlated Smith masking, α = roughness²; each term's
//! Fresnel is evaluated at its own microfacet normal h.
//!
//! The dielectric Fresnel F_d:
//! * opaque materials (t = 0): Schlick with F₀ = min(((ior−1)/(ior+1))² · specularColor, 1)
//!   · specular and F₉₀ = specular, exactly as KHR_materials_specular defines it;
//! * transmissive materials (t > 0): the exact dielectric Fresnel equations at relative
//!   index η, times specular · min(specularColor, 1). This is the refracting interface the
//!   issue asks for: total internal reflection comes out right (F = 1), and with the
//!   default specular parameters it is the physical reflectance.
//!
//! The btdf is rough refraction (Walter et al. 2007) for refracting solids
//! (KHR_materials_volume thickness > 0) and mirrored GGX reflection for thin walls. A
//! roughness of exactly 0 makes the specular and transmission lobes true deltas.
//!
//! Sampling picks one lobe with probabilities estimated from F_d at the macro normal,
//! each present lobe floored at [`LOBE_SELECTION_FLOOR`], then evaluates the full BSDF and
//! the full mixture density for the direction (one-sample MIS over lobes).

use glam::{Vec2, Vec3};

use super::fresnel::{fresnel_dielectric, fresnel_schlick};
use super::lambert::{lambert_eval, lambert_pdf, lambert_sample};
use super::reflection::{reflection_eval, reflection_half_vector, reflection_pdf, reflection_sample};
use super::refract_through;
use super::sheen::{sheen_albedo, sheen_albedo_scaling, sheen_albedo_table, sheen_alpha, sheen_eval};
use super::thin_transmission::{
    thin_transmission_eval, thin_transmission_half_vector, thin_transmission_pdf, thin_transmission_sample,
};
use super::transmission::{
    transmission_eval, transmission_half_vector, transmission_pdf, transmission_sample,
};
use crate::geometry::Frame;
use crate::scene::layout::{
    Material, INVALID_INDEX, MATERIAL_ALPHA_BLEND, MATERIAL_ALPHA_MASK, MATERIAL_VOLUME,
};

/// F₀ of the clear coat: KHR_materials_clearcoat fixes its index at 1.5.
pub const CLEARCOAT_F0: f32 = 0.04;

/// The coat lobe is dropped where the base shading frame's cos θi is below this: there the
/// ratio of the coat's cosine to the base's (see [`GltfBsdf::eval`]) has no f32 meaning, and
/// the directions it drops are a sliver of the hemisphere.
pub const COAT_MIN_BASE_COSINE: f32 = 1e-6;

/// Every lobe that can contribute is chosen with at least this (unnormalised) weight, so
/// an underestimated lobe is never starved into bias.
pub const LOBE_SELECTION_FLOOR: f32 = 0.05;

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Incident direction, local frame.
    pub wi: Vec3,
    /// f · |cos θi| / pdf: the throughput factor of this sample.
    pub weight: Vec3,
    /// Density per solid angle of the non-delta mixture at `wi`; for a delta lobe, the
    /// probability of having chosen it.
    pub pdf_solid_angle: f32,
    /// From a delta lobe (mirror or smooth refraction): no MIS with light sampling.
    pub is_delta: bool,
    /// η² when the sample refracts through a volume boundary (its weight carries the
    /// radiance factor 1/η²), else 1: Russian roulette takes it back out (pbrt-v4
    /// `etaScale`), so paths inside glass are not killed for a factor that leaving undoes.
    pub eta_scale: f32,
}

/// The BSDF at one shading point, for one outgoing direction.
#[derive(Clone, Copy, Debug)]
pub struct GltfBsdf {
    base_color: Vec3,
    metallic: f32,
    alpha: f32,
    transmission: f32,
    specular_factor: f32,
    specular_color: Vec3,
    /// Opaque dielectric F₀ (KHR_materials_specular).
    f0_dielectric: Vec3,
    /// η_transmitted / η_incident across this boundary as seen from `wo`'s side.
    eta: f32,
    volume: bool,
    /// The transmission lobe is a delta (smooth, or an index-matched solid).
    transmission_is_delta: bool,
    p_reflect: f32,
    p_diffuse: f32,
    p_transmit: f32,
    /// Clear-coat weight (0: no coat), GGX α, and frame about the coat normal.
    coat: f32,
    coat_alpha: f32,
    coat_frame: Frame,
    /// 1 − c · F_c(n_c · wo): what the coat lets through to the layers below.
    coat_transmittance: f32,
    /// Sheen colour (black: no sheen), perceptual roughness and Charlie α.
    sheen_color: Vec3,
    sheen_roughness: f32,
    sheen_alpha: f32,
    /// The directional albedo table (`sheen::sheen_albedo_table`).
    sheen_table: &'static [f32],
    p_coat: f32,
    p_sheen: f32,
    /// Nothing but the diffuse lobe (no metal, no specular, no transmission, coat or sheen):
    /// f = baseColor/π, which [`Self::eval`], [`Self::pdf`] and [`Self::sample`] return
    /// without assembling the layers. The general path gives the same values (F_d = 0 when
    /// specular = 0) after more work; matte scenes spend most of their shading time here.
    lambertian: bool,
}

/// The sheen albedo table when a sheen needs it (an empty slice otherwise, never read).
fn sheen_albedo_table_if(needed: bool) -> &'static [f32] {
    if needed {
        sheen_albedo_table()
    } else {
        &[]
    }
}

impl GltfBsdf {
    /// The diffuse lobe alone, its colour still to be set: every other layer absent. The
    /// fields the lambertian path never reads hold the values of an absent layer.
    const MATTE: GltfBsdf = GltfBsdf {
        base_color: Vec3::ZERO,
        metallic: 0.0,
        alpha: 1.0,
        transmission: 0.0,
        specular_factor: 0.0,
        specular_color: Vec3::ONE,
        f0_dielectric: Vec3::ZERO,
        eta: 1.5,
        volume: false,
        transmission_is_delta: false,
        p_reflect: 0.0,
        p_diffuse: 1.0,
        p_transmit: 0.0,
        coat: 0.0,
        coat_alpha: 0.0,
        coat_frame: Frame::IDENTITY,
        coat_transmittance: 1.0,
        sheen_color: Vec3::ZERO,
        sheen_roughness: 0.0,
        sheen_alpha: 0.0,
        sheen_table: &[],
        p_coat: 0.0,
        p_sheen: 0.0,
        lambertian: true,
    };

    /// The BSDF for outgoing direction `wo` (shading frame); `front_face` says whether `wo` is
    /// on the side the geometric normal points to (entering a refracting solid);
    /// `coat_normal` is the clear coat's normal in the shading frame (+z when it has none of
    /// its own).
    ///
    /// Inlined up to the test for a material with nothing but the diffuse lobe, so that a
    /// matte hit builds only the fields it reads (1.8% of a Cornell-box render's
    /// instructions went to the call and its full copy). Materials that fail the test may
    /// still be matte from this direction (a coat seen from below its horizon): the layered
    /// constructor tests again.
    #[inline(always)]
    pub fn new(m: &Material, wo: Vec3, front_face: bool, coat_normal: Vec3) -> GltfBsdf {
        // The coat's weight before its horizon test: zero here means no coat from anywhere.
        if Self::diffuse_only(m, m.clearcoat.max(0.0), Vec3::from(m.sheen_color).max(Vec3::ZERO)) {
            return GltfBsdf { base_color: Vec3::from(m.base_color), ..Self::MATTE };
        }
        Self::new_layered(m, wo, front_face, coat_normal)
    }

    /// Does material `m`, with coat weight `coat` and sheen colour `sheen_color` as seen
    /// from the outgoing direction, have nothing but the diffuse lobe?
    #[inline(always)]
    fn diffuse_only(m: &Material, coat: f32, sheen_color: Vec3) -> bool {
        m.metallic == 0.0
            && m.specular_factor == 0.0
            && m.transmission == 0.0
            && coat == 0.0
            && sheen_color.max_element() <= 0.0
            && Vec3::from(m.base_color).max_element() > 0.0
    }

    /// [`Self::new`] for every other material.
    #[inline(never)]
    fn new_layered(m: &Material, wo: Vec3, front_face: bool, coat_normal: Vec3) -> GltfBsdf {
        let cos_theta_o = wo.z;
        let base_color = Vec3::from(m.base_color);
        let volume = m.flags & MATERIAL_VOLUME != 0 && m.transmission > 0.0;
        // Outer layers are absent from inside a solid.
        let outside = !volume || front_face;
        // Most materials have no coat: skip its frame and Fresnel (as the kernel's
        // FEATURE_CLEARCOAT does for whole scenes).
        let coat_frame = (outside && m.clearcoat > 0.0).then(|| Frame::from_z(coat_normal));
        let coat_cos_o = coat_frame.map_or(0.0, |f| f.to_local(wo).z);
        let coat = if coat_cos_o > 0.0 { m.clearcoat.min(1.0) } else { 0.0 };
        let sheen_color = if outside { Vec3::from(m.sheen_color).max(Vec3::ZERO) } else { Vec3::ZERO };
        // Nothing but the diffuse lobe: returned before the other layers are assembled
        // (assembling them was 5.7% of a Cornell-box render's instructions).
        if Self::diffuse_only(m, coat, sheen_color) {
            return GltfBsdf { base_color, ..Self::MATTE };
        }
        let ior = m.ior;
        let eta = if volume && !front_face { 1.0 / ior } else { ior };
        let r0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
        let specular_color = Vec3::from(m.specular_color);
        let sheen_table = sheen_albedo_table_if(sheen_color.max_element() > 0.0);
        let coat_fresnel_o =
            if coat > 0.0 { fresnel_schlick(Vec3::splat(CLEARCOAT_F0), 1.0, coat_cos_o).x } else { 0.0 };
        let mut b = GltfBsdf {
            base_color,
            metallic: m.metallic,
            alpha: m.alpha_roughness,
            transmission: m.transmission,
            specular_factor: m.specular_factor,
            specular_color,
            f0_dielectric: (r0 * specular_color).min(Vec3::ONE) * m.specular_factor,
            eta,
            volume,
            transmission_is_delta: m.alpha_roughness == 0.0 || (volume && eta == 1.0),
            p_reflect: 0.0,
            p_diffuse: 0.0,
            p_transmit: 0.0,
            coat,
            coat_alpha: super::alpha_from_roughness(m.clearcoat_roughness),
            coat_frame: coat_frame.unwrap_or(Frame::IDENTITY),
            coat_transmittance: 1.0 - coat * coat_fresnel_o,
            sheen_color,
            sheen_roughness: m.sheen_roughness,
            sheen_alpha: sheen_alpha(m.sheen_roughness),
            sheen_table,
            p_coat: 0.0,
            p_sheen: 0.0,
            lambertian: false,
        };
        let f = b.dielectric_fresnel(cos_theta_o).max_element();
        let dielectric = 1.0 - b.metallic;
        let color = base_color.max_element();
        let sheen_reflectance = if b.has_sheen() {
            sheen_color.max_element() * sheen_albedo(sheen_table, cos_theta_o, b.sheen_roughness)
        } else {
            0.0
        };
        // The share of the view direction's light that reaches the base layer.
        let below = b.coat_transmittance * (1.0 - sheen_reflectance).max(0.0);
        let reflect_present = b.metallic > 0.0 || b.specular_factor > 0.0;
        let diffuse_present = dielectric * (1.0 - b.transmission) > 0.0 && color > 0.0;
        let transmit_present = dielectric * b.transmission > 0.0 && color > 0.0;
        let weight = |present: bool, estimate: f32| {
            if present {
                estimate.max(LOBE_SELECTION_FLOOR)
            } else {
                0.0
            }
        };
        let w_c = weight(coat > 0.0, coat * coat_fresnel_o);
        let w_s = weight(b.has_sheen(), b.coat_transmittance * sheen_reflectance);
        let w_r = weight(reflect_present, below * (b.metallic + dielectric * f));
        let w_d = weight(diffuse_present, below * dielectric * (1.0 - b.transmission) * (1.0 - f) * color);
        let w_t = weight(transmit_present, below * dielectric * b.transmission * (1.0 - f) * color);
        let total = w_c + w_s + w_r + w_d + w_t;
        if total > 0.0 {
            b.p_coat = w_c / total;
            b.p_sheen = w_s / total;
            b.p_reflect = w_r / total;
            b.p_diffuse = w_d / total;
            b.p_transmit = w_t / total;
        }
        b
    }

    fn has_sheen(&self) -> bool {
        self.sheen_color.max_element() > 0.0
    }

    /// The scaling of the base layer under the sheen for directions with cosines `mu_o`,
    /// `mu_i` (1 without a sheen).
    fn sheen_scaling(&self, mu_o: f32, mu_i: f32) -> f32 {
        if self.has_sheen() {
            sheen_albedo_scaling(self.sheen_table, self.sheen_color, self.sheen_roughness, mu_o, mu_i)
        } else {
            1.0
        }
    }

    /// The coat lobe (weight and Fresnel included), divided by the base frame's cos θi so
    /// that the integrator's |cos θi| leaves the coat's own cosine: the coat's normal is not
    /// the base's.
    fn coat_eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo_c, wi_c)) = self.coat_directions(wo, wi) else { return 0.0 };
        let Some(h) = reflection_half_vector(wo_c, wi_c) else { return 0.0 };
        let fresnel = fresnel_schlick(Vec3::splat(CLEARCOAT_F0), 1.0, wo_c.dot(h)).x;
        self.coat * fresnel * reflection_eval(wo_c, wi_c, self.coat_alpha) * wi_c.z / wi.z
    }

    fn coat_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.coat_directions(wo, wi).map_or(0.0, |(wo_c, wi_c)| reflection_pdf(wo_c, wi_c, self.coat_alpha))
    }

    /// `wo` and `wi` in the coat's frame, where the rough coat lobe acts on them: a coat,
    /// both directions above it, and `wi` above the base's horizon too.
    fn coat_directions(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
        if self.coat <= 0.0 || self.coat_alpha == 0.0 || wi.z < COAT_MIN_BASE_COSINE {
            return None;
        }
        let (wo_c, wi_c) = (self.coat_frame.to_local(wo), self.coat_frame.to_local(wi));
        (wo_c.z > 0.0 && wi_c.z > 0.0).then_some((wo_c, wi_c))
    }

    /// F_d at `cos_theta` = |wo·h| (see the module comment).
    pub fn dielectric_fresnel(&self, cos_theta: f32) -> Vec3 {
        if self.transmission > 0.0 {
            self.specular_factor
                * self.specular_color.min(Vec3::ONE)
                * fresnel_dielectric(cos_theta, self.eta)
        } else {
            fresnel_schlick(self.f0_dielectric, self.specular_factor, cos_theta)
        }
    }

    fn metal_fresnel(&self, cos_theta: f32) -> Vec3 {
        fresnel_schlick(self.base_color, 1.0, cos_theta)
    }

    /// Can light sampling contribute (is there any non-delta lobe)?
    pub fn has_non_delta(&self) -> bool {
        self.p_diffuse > 0.0
            || self.p_sheen > 0.0
            || (self.p_coat > 0.0 && self.coat_alpha > 0.0)
            || (self.p_reflect > 0.0 && self.alpha > 0.0)
            || (self.p_transmit > 0.0 && !self.transmission_is_delta)
    }

    /// The probability that [`Self::sample`] chooses a non-delta lobe: the mass of the
    /// mixture density [`Self::pdf`] over all directions. A photon-mapping visible point
    /// (`crate::integrator::sppm`) is made where a sample chose one, weighted by its inverse.
    pub fn non_delta_probability(&self) -> f32 {
        if self.lambertian {
            return 1.0;
        }
        let mut p = self.p_diffuse + self.p_sheen;
        if self.coat_alpha > 0.0 {
            p += self.p_coat;
        }
        if self.alpha > 0.0 {
            p += self.p_reflect;
        }
        if !self.transmission_is_delta {
            p += self.p_transmit;
        }
        p
    }

    /// Has it a non-delta transmission lobe (rough glass, a rough thin surface)? Light then
    /// reaches a point from either side of its surface.
    pub fn has_rough_transmission(&self) -> bool {
        self.p_transmit > 0.0 && !self.transmission_is_delta
    }

    /// Has it a diffuse lobe (Lambert or sheen)? Photon mapping gathers photons where it has
    /// (`crate::integrator::sppm`).
    pub fn has_diffuse_lobe(&self) -> bool {
        self.p_diffuse > 0.0 || self.p_sheen > 0.0
    }

    /// Has it a Lambertian lobe (the dielectric base's diffuse term)? The irradiance cache
    /// stands in for that lobe's indirect light (`crate::integrator::irradiance_cache`).
    pub fn has_lambert_lobe(&self) -> bool {
        self.p_diffuse > 0.0
    }

    /// The Lambertian lobe's share of [`Self::eval`], without the cosine: what the coat and
    /// sheen let through, times (1 − metallic)(1 − max F_d(|wo·h|))(1 − transmission)
    /// baseColor/π. Zero below the surface.
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        if self.lambertian {
            return self.base_color * lambert_eval(wi);
        }
        if self.p_diffuse <= 0.0 {
            return Vec3::ZERO;
        }
        let Some(h) = reflection_half_vector(wo, wi) else { return Vec3::ZERO };
        let fd = self.dielectric_fresnel(wo.dot(h));
        let diffuse = self.base_color * (1.0 - self.transmission) * lambert_eval(wi);
        let base = (1.0 - self.metallic) * (1.0 - fd.max_element()) * diffuse;
        base * (self.coat_transmittance * self.sheen_scaling(wo.z, wi.z))
    }

    /// The Lambertian lobe's directional albedo ∫ f_diffuse(wo, ωi) cos θi dωi: baseColor
    /// for a matte BSDF, else a fixed 4 × 4 stratified cosine quadrature of
    /// [`Self::eval_diffuse`] (its Fresnel and sheen factors vary slowly with ωi). Under
    /// light that is the same from every direction, the lobe reflects exactly albedo · E/π.
    pub fn diffuse_albedo(&self, wo: Vec3) -> Vec3 {
        if self.lambertian {
            return if wo.z > 0.0 { self.base_color } else { Vec3::ZERO };
        }
        if self.p_diffuse <= 0.0 {
            return Vec3::ZERO;
        }
        const STRATA: u32 = 4;
        let mut sum = Vec3::ZERO;
        for i in 0..STRATA {
            for j in 0..STRATA {
                let u = Vec2::new((i as f32 + 0.5) / STRATA as f32, (j as f32 + 0.5) / STRATA as f32);
                // f · cos θ / (cos θ / π) for cosine-distributed directions.
                sum += self.eval_diffuse(wo, lambert_sample(u)) * std::f32::consts::PI;
            }
        }
        sum / (STRATA * STRATA) as f32
    }

    /// Is this nothing but the diffuse lobe, f = baseColor/π?
    pub fn is_lambertian(&self) -> bool {
        self.lambertian
    }

    /// Does [`Self::sample`] read its lobe-choice number? A matte BSDF has one lobe and
    /// ignores it.
    pub fn chooses_a_lobe(&self) -> bool {
        !self.lambertian
    }

    /// Lobe selection probabilities (coat, sheen, reflection, diffuse, transmission): all
    /// zero for a material that scatters nothing.
    pub fn lobe_probabilities(&self) -> [f32; 5] {
        [self.p_coat, self.p_sheen, self.p_reflect, self.p_diffuse, self.p_transmit]
    }

    /// The non-delta part of f(wo, wi), without the cosine.
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        if self.lambertian {
            return self.base_color * lambert_eval(wi);
        }
        self.eval_layered(wo, wi)
    }

    /// [`Self::eval`] of a layered BSDF (out of line: the matte path above is inlined).
    #[inline(never)]
    fn eval_layered(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let base = self.base_eval(wo, wi);
        if wi.z > 0.0 {
            let sheen = if self.has_sheen() {
                self.sheen_color * sheen_eval(wo, wi, self.sheen_alpha)
            } else {
                Vec3::ZERO
            };
            let below = sheen + base * self.sheen_scaling(wo.z, wi.z);
            Vec3::splat(self.coat_eval(wo, wi)) + self.coat_transmittance * below
        } else {
            base * (self.coat_transmittance * self.sheen_scaling(wo.z, 0.0))
        }
    }

    /// The base layer (metal, dielectric, transmission) without coat and sheen.
    fn base_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let dielectric = 1.0 - self.metallic;
        if wi.z > 0.0 {
            let Some(h) = reflection_half_vector(wo, wi) else { return Vec3::ZERO };
            let cos_h = wo.dot(h);
            let fd = self.dielectric_fresnel(cos_h);
            let diffuse = self.base_color * (1.0 - self.transmission) * lambert_eval(wi);
            let mut f = dielectric * (1.0 - fd.max_element()) * diffuse;
            if self.alpha > 0.0 && self.p_reflect > 0.0 {
                let spec = reflection_eval(wo, wi, self.alpha);
                f += (dielectric * fd + self.metallic * self.metal_fresnel(cos_h)) * spec;
            }
            f
        } else if wi.z < 0.0 && self.p_transmit > 0.0 && !self.transmission_is_delta {
            let weight = dielectric * self.transmission * self.base_color;
            if self.volume {
                let Some(h) = transmission_half_vector(wo, wi, self.eta) else { return Vec3::ZERO };
                let fd = self.dielectric_fresnel(wo.dot(h));
                weight * (1.0 - fd.max_element()) * transmission_eval(wo, wi, self.alpha, self.eta)
            } else {
                let Some(h) = thin_transmission_half_vector(wo, wi) else { return Vec3::ZERO };
                let fd = self.dielectric_fresnel(wo.dot(h));
                weight * (1.0 - fd.max_element()) * thin_transmission_eval(wo, wi, self.alpha)
            }
        } else {
            Vec3::ZERO
        }
    }

    /// Density per solid angle with which [`Self::sample`] produces `wi` from its non-delta
    /// lobes.
    #[inline(always)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        if self.lambertian {
            return lambert_pdf(wi);
        }
        self.pdf_layered(wo, wi)
    }

    /// [`Self::pdf`] of a layered BSDF.
    #[inline(never)]
    fn pdf_layered(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wi.z > 0.0 {
            let mut p =
                (self.p_diffuse + self.p_sheen) * lambert_pdf(wi) + self.p_coat * self.coat_pdf(wo, wi);
            if self.alpha > 0.0 && self.p_reflect > 0.0 {
                p += self.p_reflect * reflection_pdf(wo, wi, self.alpha);
            }
            p
        } else if wi.z < 0.0 && self.p_transmit > 0.0 && !self.transmission_is_delta {
            self.p_transmit
                * if self.volume {
                    transmission_pdf(wo, wi, self.alpha, self.eta)
                } else {
                    thin_transmission_pdf(wo, wi, self.alpha)
                }
        } else {
            0.0
        }
    }

    /// Samples an incident direction. `u_lobe` picks the lobe, `u` the direction within it.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.lambertian {
            // f·cos θ/pdf = (baseColor/π)·cos θ/(cos θ/π) = baseColor; a direction on the
            // horizon has no density and ends the path, as in the general path.
            let wi = lambert_sample(u);
            let pdf = lambert_pdf(wi);
            return (pdf > 0.0).then_some(BsdfSample {
                wi,
                weight: self.base_color,
                pdf_solid_angle: pdf,
                is_delta: false,
                eta_scale: 1.0,
            });
        }
        self.sample_layered(wo, u_lobe, u)
    }

    /// [`Self::sample`] of a layered BSDF.
    #[inline(never)]
    fn sample_layered(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let dielectric = 1.0 - self.metallic;
        // Lobes in the order coat, sheen, reflection, diffuse, transmission along u_lobe.
        let u_lobe = u_lobe - self.p_coat - self.p_sheen;
        let wi = if u_lobe < -self.p_sheen {
            let wo_c = self.coat_frame.to_local(wo);
            if self.coat_alpha == 0.0 {
                let wi = self.coat_frame.from_local(Vec3::new(-wo_c.x, -wo_c.y, wo_c.z));
                if wi.z <= 0.0 {
                    return None;
                }
                let f = self.coat * fresnel_schlick(Vec3::splat(CLEARCOAT_F0), 1.0, wo_c.z).x;
                return Some(BsdfSample {
                    wi,
                    weight: Vec3::splat(f / self.p_coat),
                    pdf_solid_angle: self.p_coat,
                    is_delta: true,
                    eta_scale: 1.0,
                });
            }
            let wi = self.coat_frame.from_local(reflection_sample(wo_c, self.coat_alpha, u)?);
            if wi.z <= 0.0 {
                return None;
            }
            wi
        } else if u_lobe < 0.0 {
            lambert_sample(u)
        } else if u_lobe < self.p_reflect {
            if self.alpha == 0.0 {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let f = dielectric * self.dielectric_fresnel(wo.z) + self.metallic * self.metal_fresnel(wo.z);
                let below = self.coat_transmittance * self.sheen_scaling(wo.z, wo.z);
                return Some(BsdfSample {
                    wi,
                    weight: f * below / self.p_reflect,
                    pdf_solid_angle: self.p_reflect,
                    is_delta: true,
                    eta_scale: 1.0,
                });
            }
            reflection_sample(wo, self.alpha, u)?
        } else if u_lobe < self.p_reflect + self.p_diffuse {
            lambert_sample(u)
        } else {
            if self.p_transmit <= 0.0 {
                return None;
            }
            if self.transmission_is_delta {
                let (wi, eta2) = if self.volume {
                    (refract_through(wo, Vec3::Z, self.eta)?, self.eta * self.eta)
                } else {
                    (-wo, 1.0)
                };
                let fd = self.dielectric_fresnel(wo.z);
                let below = self.coat_transmittance * self.sheen_scaling(wo.z, 0.0);
                let t = dielectric * self.transmission * self.base_color * (1.0 - fd.max_element()) * below
                    / eta2;
                return Some(BsdfSample {
                    wi,
                    weight: t / self.p_transmit,
                    pdf_solid_angle: self.p_transmit,
                    is_delta: true,
                    eta_scale: eta2,
                });
            }
            if self.volume {
                transmission_sample(wo, self.alpha, self.eta, u)?
            } else {
                thin_transmission_sample(wo, self.alpha, u)?
            }
        };
        let pdf = self.pdf(wo, wi);
        // A density that is not finite and positive is a numerical failure: end the path
        // (the WGSL twin decides the same on the bits).
        if !pdf.is_finite() || pdf <= 0.0 {
            return None;
        }
        let f = self.eval(wo, wi);
        let eta_scale = if self.volume && wi.z < 0.0 { self.eta * self.eta } else { 1.0 };
        Some(BsdfSample {
            wi,
            weight: f * wi.z.abs() / pdf,
            pdf_solid_angle: pdf,
            is_delta: false,
            eta_scale,
        })
    }
}

/// Does material `m` reflect or refract only by delta lobes, from both sides, with nothing
/// that varies over the surface (textures) or lets light through unscattered (alpha)?
/// `crate::scene::FlatScene::build` marks such materials `MATERIAL_DELTA_ONLY`: the camera
/// connections of a view through them are skipped (`crate::integrator::delta_view`) and no
/// photon is stored on them (`crate::integrator::gather_area`).
pub fn is_delta_only(m: &Material) -> bool {
    if m.texture_inputs().iter().any(|&t| t != INVALID_INDEX)
        || m.flags & (MATERIAL_ALPHA_MASK | MATERIAL_ALPHA_BLEND) != 0
    {
        return false;
    }
    [true, false].into_iter().all(|front| {
        let bsdf = GltfBsdf::new(m, Vec3::Z, front, Vec3::Z);
        !bsdf.has_non_delta() && bsdf.lobe_probabilities().iter().any(|&p| p > 0.0)
    })
}

#[cfg(test)]
mod tests;
