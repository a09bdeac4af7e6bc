//! The Pareto front of (cost, error) points: the configurations no other configuration beats in
//! both time and error. Pure; ties and equal points are kept once.

/// Indices of the points on the front, ordered by increasing cost (and so decreasing error).
/// A point is on the front when no other point has cost ≤ and error ≤ with one of them strictly
/// smaller. Points with a NaN coordinate are never on it.
pub fn front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| !points[i].0.is_nan() && !points[i].1.is_nan())
        .collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut out = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            out.push(i);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dominated_points_are_dropped() {
        let pts = [
            (1.0, 5.0),
            (2.0, 3.0),
            (2.5, 4.0),
            (3.0, 1.0),
            (0.5, 9.0),
            (3.0, 2.0),
        ];
        assert_eq!(front(&pts), vec![4, 0, 1, 3]);
    }

    #[test]
    fn equal_cost_keeps_the_lower_error_and_nan_is_ignored() {
        let pts = [(1.0, 2.0), (1.0, 1.0), (f64::NAN, 0.0), (2.0, 1.0)];
        assert_eq!(front(&pts), vec![1]);
    }

    #[test]
    fn front_is_monotone() {
        let pts: Vec<(f64, f64)> = (0..50)
            .map(|i| ((i * 37 % 50) as f64, ((i * 11) % 23) as f64))
            .collect();
        let f = front(&pts);
        for w in f.windows(2) {
            assert!(pts[w[0]].0 <= pts[w[1]].0);
            assert!(pts[w[0]].1 > pts[w[1]].1);
        }
        // Nothing beats a front point in both coordinates.
        for &i in &f {
            assert!(!pts
                .iter()
                .any(|p| p.0 <= pts[i].0 && p.1 <= pts[i].1 && (p.0 < pts[i].0 || p.1 < pts[i].1)));
        }
    }
}
