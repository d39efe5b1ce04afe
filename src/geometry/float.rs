//! Floating-point error bounds (pbrt-v4, §6.8 "Managing Rounding Error").

/// Half an ulp of 1: the largest relative error of one correctly rounded f32 operation.
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// γₙ = nε / (1 − nε): bounds the relative error of n chained f32 operations
/// (Higham 2002, §3.1; pbrt-v4 eq. 6.19).
pub fn gamma(n: i32) -> f32 {
    let ne = n as f32 * MACHINE_EPSILON;
    ne / (1.0 - ne)
}

/// The next representable f32 above `v` (+∞ stays +∞; −0 and +0 both go to the smallest
/// positive subnormal).
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v >= 0.0 { bits + 1 } else { bits - 1 })
}

/// The next representable f32 below `v`.
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v > 0.0 { bits - 1 } else { bits + 1 })
}

/// `a·b − c·d` with an error of at most 1.5 ulp, by Kahan's FMA algorithm
/// (Jeannerod, Louvet & Muller 2013; pbrt-v4 `DifferenceOfProducts`).
pub fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let diff = a.mul_add(b, -cd);
    let error = (-c).mul_add(d, cd);
    diff + error
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_one_ulp() {
        for v in [1.0f32, -1.0, 1e-30, -1e30, 3.5] {
            assert!(next_float_up(v) > v);
            assert!(next_float_down(v) < v);
            assert_eq!(next_float_down(next_float_up(v)), v);
        }
        assert!(next_float_up(0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
        assert!(next_float_up(-0.0) > 0.0);
    }

    #[test]
    fn difference_of_products_is_accurate_under_cancellation() {
        // 1.000_000_1² − 1.000_000_2 · 1.0 in f32 would cancel catastrophically when
        // evaluated naively; compare with f64.
        let (a, b, c, d) = (1.000_000_1f32, 1.000_000_1f32, 1.000_000_2f32, 1.0f32);
        let exact = a as f64 * b as f64 - c as f64 * d as f64;
        let got = difference_of_products(a, b, c, d) as f64;
        assert!((got - exact).abs() <= 1.5 * f32::EPSILON as f64 * exact.abs().max(1e-30));
    }
}
