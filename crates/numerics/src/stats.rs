//! Column statistics of row-major sample matrices.

/// Per-column mean and sample standard deviation (divisor `N − 1`; 0 for `N < 2`) of a
/// row-major `rows × cols` matrix.
pub fn mean_std(values: &[f64], cols: usize) -> (Vec<f64>, Vec<f64>) {
    let rows = values.len().checked_div(cols).unwrap_or(0);
    let mut mean = vec![0.0; cols];
    for row in values.chunks(cols.max(1)) {
        for (m, v) in mean.iter_mut().zip(row) {
            *m += v;
        }
    }
    mean.iter_mut().for_each(|m| *m /= rows.max(1) as f64);
    let mut var = vec![0.0; cols];
    for row in values.chunks(cols.max(1)) {
        for ((s, v), m) in var.iter_mut().zip(row).zip(&mean) {
            *s += (v - m) * (v - m);
        }
    }
    let std = var.into_iter().map(|s| if rows < 2 { 0.0 } else { (s / (rows - 1) as f64).sqrt() }).collect();
    (mean, std)
}

#[cfg(test)]
mod tests {
    #[test]
    fn mean_and_sample_std() {
        let (m, s) = super::mean_std(&[1.0, 10.0, 3.0, 10.0], 2);
        assert_eq!(m, vec![2.0, 10.0]);
        assert!((s[0] - 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(s[1], 0.0);
    }
}
