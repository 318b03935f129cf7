//! Triangle quality: the distribution of each face's minimum angle.

use super::distance::percentile;
use super::{zero_area, Quality};
use crate::geom::{cross, dot, sub};

/// The smallest interior angle of `t`, in degrees (0 when it has zero area).
pub fn min_angle_deg(t: &[[f64; 3]; 3]) -> f64 {
    if zero_area(t) {
        return 0.0;
    }
    (0..3)
        .map(|i| {
            let (u, v) = (sub(t[(i + 1) % 3], t[i]), sub(t[(i + 2) % 3], t[i]));
            let c = cross(u, v);
            dot(c, c).sqrt().atan2(dot(u, v)).to_degrees()
        })
        .fold(f64::INFINITY, f64::min)
}

pub(super) fn quality(tris: &[[[f64; 3]; 3]]) -> Quality {
    let mut a: Vec<f64> = tris.iter().map(min_angle_deg).collect();
    a.sort_unstable_by(f64::total_cmp);
    Quality {
        min: a.first().copied().unwrap_or(f64::NAN),
        p1: percentile(&a, 1.0),
        p5: percentile(&a, 5.0),
        p50: percentile(&a, 50.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_angle_of_a_right_isosceles_triangle_is_45() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!((min_angle_deg(&t) - 45.0).abs() < 1e-12);
        let flat = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(min_angle_deg(&flat), 0.0);
    }
}
