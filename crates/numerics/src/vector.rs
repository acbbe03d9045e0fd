//! Euclidean lengths of `f64` slices.

/// $\lVert a\rVert_2$.
pub fn norm(a: &[f64]) -> f64 {
    a.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// $\lVert a - b\rVert_2$ over the shorter of the two.
pub fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_3_4_5_triangle() {
        assert_eq!(norm(&[3.0, 4.0]), 5.0);
        assert_eq!(dist(&[1.0, 1.0], &[4.0, 5.0]), 5.0);
        assert_eq!(dist(&[], &[]), 0.0);
    }
}
