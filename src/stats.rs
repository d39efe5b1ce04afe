//! Statistical tests for Monte Carlo results: chi-square goodness of fit (sampling routines)
//! and per-pixel z-tests (comparing renders), with Šidák correction for many tests.
//!
//! The special functions follow Numerical Recipes (Press et al. 2007, §6.1–6.2).

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, n = 9; relative error < 1e-15).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularised upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        1.0 - gamma_p_series(a, x)
    } else {
        gamma_q_continued_fraction(a, x)
    }
}

fn gamma_p_series(a: f64, x: f64) -> f64 {
    let mut ap = a;
    let mut sum = 1.0 / a;
    let mut del = sum;
    for _ in 0..10_000 {
        ap += 1.0;
        del *= x / ap;
        sum += del;
        if del.abs() < sum.abs() * 1e-15 {
            break;
        }
    }
    sum * (-x + a * x.ln() - ln_gamma(a)).exp()
}

fn gamma_q_continued_fraction(a: f64, x: f64) -> f64 {
    // Modified Lentz's method.
    let tiny = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..10_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < tiny {
            d = tiny;
        }
        c = b + an / c;
        if c.abs() < tiny {
            c = tiny;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    (-x + a * x.ln() - ln_gamma(a)).exp() * h
}

/// P(χ²_dof ≥ chi2): the p-value of a chi-square statistic.
pub fn chi2_survival(chi2: f64, dof: f64) -> f64 {
    gamma_q(0.5 * dof, 0.5 * chi2)
}

/// erfc(x) = Q(½, x²) for x ≥ 0, and 2 − erfc(−x) below.
pub fn erfc(x: f64) -> f64 {
    if x >= 0.0 {
        gamma_q(0.5, x * x)
    } else {
        2.0 - gamma_q(0.5, x * x)
    }
}

/// Two-sided p-value of a standard normal z-score.
pub fn normal_two_sided_p(z: f64) -> f64 {
    erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// The |z| beyond which a two-sided standard-normal test rejects at level `alpha`.
pub fn normal_two_sided_threshold(alpha: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if normal_two_sided_p(mid) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Šidák correction: the per-test level that keeps the family-wise error of `tests`
/// independent tests at `alpha`: 1 − (1 − α)^(1/n).
pub fn sidak_alpha(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests.max(1) as f64)
}

/// Result of a chi-square goodness-of-fit test.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Result {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Cells merged because their expected count was small.
    pub pooled_cells: usize,
    /// Observations in cells whose expected count is exactly zero. A numerically integrated
    /// density can miss a sliver of its support (a triangle edge crossing a cell), so these
    /// are pooled rather than failing outright; callers bound this count, which a sampler
    /// that puts real mass where its density is zero would blow up.
    pub observed_where_expected_zero: f64,
}

/// Pearson's chi-square test of observed against expected counts. Cells whose expected count
/// is below `min_expected` are pooled into one (as pbrt-v4's and Mitsuba 3's tests do), since
/// the χ² approximation needs enough expected mass per cell. Observations in cells with zero
/// expected mass are pooled too and counted in
/// [`Chi2Result::observed_where_expected_zero`]; if the pool has no expected mass at all but
/// holds observations, the test fails outright (p = 0).
pub fn chi2_test(observed: &[f64], expected: &[f64], min_expected: f64) -> Chi2Result {
    assert_eq!(observed.len(), expected.len());
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_obs, mut pool_exp, mut pooled) = (0.0, 0.0, 0);
    let (mut chi2, mut cells) = (0.0, 0usize);
    let mut observed_where_expected_zero = 0.0;
    for &i in &order {
        if expected[i] == 0.0 {
            observed_where_expected_zero += observed[i];
        }
        // Cells in ascending order of expectation: pool every small cell, and keep pooling
        // until the pool itself has enough expected mass.
        if pool_exp < min_expected || expected[i] < min_expected {
            pool_obs += observed[i];
            pool_exp += expected[i];
            pooled += 1;
            continue;
        }
        chi2 += (observed[i] - expected[i]).powi(2) / expected[i];
        cells += 1;
    }
    if pool_exp > 0.0 {
        chi2 += (pool_obs - pool_exp).powi(2) / pool_exp;
        cells += 1;
    } else if pool_obs > 0.0 {
        return Chi2Result {
            chi2: f64::INFINITY,
            dof: 0,
            p_value: 0.0,
            pooled_cells: pooled,
            observed_where_expected_zero,
        };
    }
    let dof = cells.saturating_sub(1).max(1);
    Chi2Result {
        chi2,
        dof,
        p_value: chi2_survival(chi2, dof as f64),
        pooled_cells: pooled,
        observed_where_expected_zero,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_functions_match_tables() {
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        // χ² table: P(χ²₁₀ ≥ 18.307) = 0.05, P(χ²₁ ≥ 6.635) = 0.01.
        assert!((chi2_survival(18.307, 10.0) - 0.05).abs() < 1e-4);
        assert!((chi2_survival(6.635, 1.0) - 0.01).abs() < 1e-4);
        // Large dof (continued-fraction branch): median of χ²₁₀₀₀ ≈ 999.33.
        assert!((chi2_survival(999.333, 1000.0) - 0.5).abs() < 1e-3);
        assert!((erfc(1.0) - 0.157_299_207_050_285_1).abs() < 1e-12);
        assert!((normal_two_sided_threshold(0.05) - 1.959_964).abs() < 1e-5);
        assert!((sidak_alpha(0.01, 1) - 0.01).abs() < 1e-15);
    }
}
