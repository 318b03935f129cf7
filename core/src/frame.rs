//! The coordinate contract of core (its points lie in `[-1, 1]^3`): centre the
//! bounding box at the origin and scale uniformly so the largest half-extent is
//! 1, in `f64`, hand `f32` to core and map results back with the same
//! transform. One home for the CLI and the C library, so both give the same
//! coordinates, and so the same mesh, for the same points.

use crate::math::V3;

/// A uniform scale and translation: `core = (file - centre) / scale`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Centre of the input's bounding box.
    pub centre: [f64; 3],
    /// Largest half-extent of the bounding box (1 when the points coincide).
    pub scale: f64,
}

impl Frame {
    /// The frame that maps `points` into `[-1, 1]^3`. `points` must be finite.
    /// `O(n)`.
    pub fn fit<'p>(points: impl IntoIterator<Item = &'p [f64; 3]>) -> Frame {
        Frame::fit_each(points.into_iter().copied())
    }

    /// [`Frame::fit`] of points given by value (e.g. `f32` points widened).
    pub fn fit_each(points: impl IntoIterator<Item = [f64; 3]>) -> Frame {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let mut empty = true;
        for p in points {
            empty = false;
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        if empty {
            return Frame {
                centre: [0.0; 3],
                scale: 1.0,
            };
        }
        let centre = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
        let half = (0..3).map(|a| 0.5 * (hi[a] - lo[a])).fold(0.0f64, f64::max);
        // Coincident points: keep scale 1 so core sees them (and says so).
        let scale = if half > 0.0 && half.is_finite() {
            half
        } else {
            1.0
        };
        Frame { centre, scale }
    }

    /// File coordinates to core coordinates.
    pub fn to_core(&self, p: [f64; 3]) -> V3 {
        [0, 1, 2].map(|a| ((p[a] - self.centre[a]) / self.scale) as f32)
    }

    /// Core coordinates back to file coordinates.
    pub fn to_file(&self, p: V3) -> [f64; 3] {
        [0, 1, 2].map(|a| p[a] as f64 * self.scale + self.centre[a])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use libm::fabs;

    #[test]
    fn far_offset_large_scale_inputs_land_in_the_unit_cube_and_map_back() {
        let pts = [
            [5e5 + 1.0, -3e5, 7.0],
            [5e5 + 3.0, -3e5 + 4.0, 9.0],
            [5e5 + 2.0, -3e5 + 1.0, 8.0],
        ];
        let f = Frame::fit(&pts);
        for p in pts {
            let c = f.to_core(p);
            assert!(c.iter().all(|v| (-1.0..=1.0).contains(v)), "{c:?}");
            let back = f.to_file(c);
            for a in 0..3 {
                assert!(
                    fabs(back[a] - p[a]) < 1e-6 * f.scale + 1e-9,
                    "{back:?} vs {p:?}"
                );
            }
        }
        assert_eq!(f.scale, 2.0);
    }

    #[test]
    fn coincident_points_keep_a_unit_scale() {
        let f = Frame::fit(&[[1.0, 2.0, 3.0]; 4]);
        assert_eq!(f.scale, 1.0);
        assert_eq!(f.to_core([1.0, 2.0, 3.0]), [0.0; 3]);
    }
}
