//! Tests of `gltf`.

use super::*;
use crate::sampling::Rng;
use crate::scene::material::MaterialDesc;

/// The diffuse-only fast path against the layered evaluation it skips, which a clear
/// coat of weight 10⁻⁹ forces (its attenuation 1 − 10⁻⁹·F_c is far below the 10⁻⁵ bound,
/// which f32 rounding of the longer path sets), and against the Lambertian's closed form.
#[test]
fn lambertian_fast_path_equals_the_layered_model() {
    let desc = MaterialDesc {
        base_color: Vec3::new(0.7, 0.4, 0.1),
        metallic: 0.0,
        roughness: 1.0,
        specular_factor: 0.0,
        ..MaterialDesc::default()
    };
    let matte = desc.to_gpu(&mut Vec::new(), &|_| false);
    let coated = Material { clearcoat: 1e-9, ..matte };
    let mut rng = Rng::new(9, 8, 7, 6);
    for _ in 0..10_000 {
        let wo = crate::sampling::sample_uniform_sphere(rng.next_2d());
        let wi = crate::sampling::sample_uniform_sphere(rng.next_2d());
        let fast = GltfBsdf::new(&matte, wo, true, Vec3::Z);
        let layered = GltfBsdf::new(&coated, wo, true, Vec3::Z);
        // Seen from below its horizon the coat is absent and the coated one is matte too.
        assert!(fast.lambertian && (wo.z <= 0.0 || !layered.lambertian));
        let (f, g) = (fast.eval(wo, wi), layered.eval(wo, wi));
        assert!((f - g).abs().max_element() <= 1e-5 * g.max_element().max(1e-30), "{f} vs {g}");
        let lit = wo.z > 0.0 && wi.z > 0.0;
        assert_eq!(f, if lit { Vec3::new(0.7, 0.4, 0.1) * std::f32::consts::FRAC_1_PI } else { Vec3::ZERO });
        let pdf = fast.pdf(wo, wi);
        assert_eq!(pdf, if wo.z > 0.0 { wi.z.max(0.0) * std::f32::consts::FRAC_1_PI } else { 0.0 });
        if let Some(s) = fast.sample(wo, rng.next_1d(), rng.next_2d()) {
            assert!(wo.z > 0.0 && s.wi.z > 0.0);
            assert_eq!(s.weight, Vec3::new(0.7, 0.4, 0.1));
            assert_eq!(s.pdf_solid_angle, fast.pdf(wo, s.wi));
        } else {
            assert!(wo.z <= 0.0);
        }
    }
}
