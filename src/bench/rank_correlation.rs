//! Spearman's rank correlation: how well a predictor (the SAH cost, EPO) orders trees the
//! way their measured cost per ray does, whatever the scale of either. 1 is the same order,
//! −1 the reverse, 0 no relation; tied values share the mean of their ranks.

/// The ranks of `xs` (1 = smallest), ties given the mean of the ranks they span.
pub fn ranks(xs: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..xs.len()).collect();
    order.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
    let mut rank = vec![0.0; xs.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && xs[order[j + 1]] == xs[order[i]] {
            j += 1;
        }
        let mean = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            rank[k] = mean;
        }
        i = j + 1;
    }
    rank
}

/// Spearman's ρ of the pairs (x, y): the Pearson correlation of their ranks. `None` for
/// fewer than three pairs or when either side is all one value (no order to compare).
pub fn spearman(xs: &[f64], ys: &[f64]) -> Option<f64> {
    if xs.len() != ys.len() || xs.len() < 3 {
        return None;
    }
    let (rx, ry) = (ranks(xs), ranks(ys));
    let mean = (xs.len() as f64 + 1.0) / 2.0;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in rx.iter().zip(&ry) {
        let (dx, dy) = (a - mean, b - mean);
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ties_share_their_mean_rank() {
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), [3.5, 1.0, 3.5, 2.0]);
    }

    #[test]
    fn the_same_order_is_one_the_reverse_minus_one() {
        let x = [1.0, 5.0, 2.0, 9.0];
        // Any increasing function keeps the order.
        let y: Vec<f64> = x.iter().map(|v: &f64| v.powi(3) + 7.0).collect();
        assert_eq!(spearman(&x, &y), Some(1.0));
        let reversed: Vec<f64> = x.iter().map(|v| -v).collect();
        assert_eq!(spearman(&x, &reversed), Some(-1.0));
        // One swap among four: 1 − 6·Σd²/(n(n²−1)) = 1 − 6·2/60 = 0.8.
        let swapped = [1.0, 9.0, 2.0, 5.0];
        assert!((spearman(&x, &swapped).unwrap() - 0.8).abs() < 1e-12);
        assert_eq!(spearman(&x, &[1.0; 4]), None);
        assert_eq!(spearman(&x[..2], &y[..2]), None);
    }
}
