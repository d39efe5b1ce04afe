//! Multiple importance sampling: the weights that combine the strategies of one integrator
//! (light sampling against BSDF sampling in the path tracer; every (s, t) connection in the
//! bidirectional ones) so that each path is counted once (Veach 1997, ch. 9).
//!
//! WGSL twin: `shaders/mis.wgsl`.

/// The power heuristic with β = 2 for two strategies of one sample each (Veach 1997,
/// §9.2.4): pdf_this² / (pdf_this² + pdf_other²), evaluated through the ratio of the smaller
/// density to the larger so that nothing is squared past f32's range (tiny bright lights
/// have solid-angle densities above 1e19).
pub fn power_heuristic(pdf_this: f32, pdf_other: f32) -> f32 {
    if pdf_this <= 0.0 {
        return 0.0;
    }
    if pdf_this >= pdf_other {
        let r = pdf_other / pdf_this;
        1.0 / (1.0 + r * r)
    } else {
        let r = pdf_this / pdf_other;
        r * r / (1.0 + r * r)
    }
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn power_heuristic_is_stable_at_extremes() {
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-7);
        assert!((power_heuristic(2.0, 1.0) - 0.8).abs() < 1e-7);
        assert!((power_heuristic(1e30, 1e29) + power_heuristic(1e29, 1e30) - 1.0).abs() < 1e-6);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
    }
}
