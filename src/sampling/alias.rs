//! Walker's alias method, built by Vose's algorithm (Vose 1991, "A Linear Algorithm for
//! Generating Random Numbers with a Given Distribution", IEEE TSE 17(9)).

/// One alias-table entry: keep index `i` with probability `probability`, else take `alias`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AliasEntry {
    pub probability: f32,
    pub alias: u32,
    /// The normalised probability of choosing `i` overall.
    pub pmf: f32,
}

/// Builds the table for non-negative `weights`; `None` if they sum to zero or are not finite.
/// Built in f64 so tables of millions of entries stay exact to f32 precision.
pub fn build_alias_table(weights: &[f64]) -> Option<Vec<AliasEntry>> {
    let n = weights.len();
    let total: f64 = weights.iter().sum();
    if n == 0 || total.is_nan() || total <= 0.0 || !total.is_finite() || weights.iter().any(|w| *w < 0.0) {
        return None;
    }
    let mut scaled: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
    let mut entries: Vec<AliasEntry> = weights
        .iter()
        .enumerate()
        .map(|(i, w)| AliasEntry { probability: 1.0, alias: i as u32, pmf: (w / total) as f32 })
        .collect();
    let mut small: Vec<usize> = Vec::new();
    let mut large: Vec<usize> = Vec::new();
    for (i, s) in scaled.iter().enumerate() {
        if *s < 1.0 {
            small.push(i);
        } else {
            large.push(i);
        }
    }
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        entries[s].probability = scaled[s] as f32;
        entries[s].alias = l as u32;
        scaled[l] = (scaled[l] + scaled[s]) - 1.0;
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // Whatever remains is 1 up to rounding.
    for i in small.into_iter().chain(large) {
        entries[i].probability = 1.0;
        entries[i].alias = i as u32;
    }
    Some(entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alias_table_reproduces_the_distribution_exactly() {
        let weights = [1.0, 0.0, 3.0, 6.0, 0.5, 1e-9];
        let table = build_alias_table(&weights).unwrap();
        let total: f64 = weights.iter().sum();
        // The exact probability of each outcome: (1/n) Σ over columns of the mass each
        // column sends to it. This must equal w/total up to f32 rounding of the stored
        // probabilities (≤ 1e-6 relative per entry).
        let n = weights.len();
        let mut mass = vec![0.0f64; n];
        for (i, e) in table.iter().enumerate() {
            mass[i] += e.probability as f64 / n as f64;
            mass[e.alias as usize] += (1.0 - e.probability as f64) / n as f64;
        }
        for i in 0..n {
            let expected = weights[i] / total;
            assert!((mass[i] - expected).abs() < 1e-6, "{i}: {} vs {expected}", mass[i]);
            assert!((table[i].pmf as f64 - expected).abs() < 1e-7);
        }
        assert!(build_alias_table(&[0.0, 0.0]).is_none());
        assert!(build_alias_table(&[f64::NAN]).is_none());
    }
}
