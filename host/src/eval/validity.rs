//! Whether the mesh is a valid solid, beyond its combinatorics: faces that cross or
//! touch, vertices split in place, folds, bubbles, and the genus of each closed part.

use super::intersect::Crossings;
use super::topology::Surface;
use super::{Validity, BUBBLE_FACES, BUBBLE_RATIO};

/// The validity checks of `faces` (indices all `< vertices.len()`), given their
/// [`Surface`] and their self-intersection test's result (see `intersect`).
/// O(F log F).
pub(super) fn validity(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    surface: &Surface,
    crossings: Crossings,
) -> Validity {
    let largest = surface
        .components
        .iter()
        .map(|c| c.faces)
        .max()
        .unwrap_or(0);
    let bubbles: Vec<usize> = surface
        .components
        .iter()
        .filter(|c| {
            c.boundary_edges == 0 && c.faces < BUBBLE_FACES && largest >= BUBBLE_RATIO * c.faces
        })
        .map(|c| c.faces)
        .collect();
    let mut by_size: Vec<_> = surface.components.iter().collect();
    by_size.sort_by_key(|c| std::cmp::Reverse(c.faces));
    Validity {
        self_intersecting_pairs: crossings.pairs,
        self_intersection_stopped: !crossings.complete,
        coincident_vertices: coincident_vertices(vertices, faces),
        folded_edges: surface.folded_edges,
        bubbles: bubbles.len(),
        bubble_faces: bubbles.iter().sum(),
        closed_components: surface
            .components
            .iter()
            .filter(|c| c.boundary_edges == 0)
            .count(),
        genus: by_size.iter().filter_map(|c| c.genus()).collect(),
    }
}

/// Vertices used by a face with three distinct indices that sit at exactly the same
/// finite position as another such vertex, counting all but one per position.
fn coincident_vertices(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> usize {
    let mut used = vec![false; vertices.len()];
    for f in faces {
        if f[0] != f[1] && f[1] != f[2] && f[0] != f[2] {
            f.iter().for_each(|&i| used[i as usize] = true);
        }
    }
    // `+ 0.0` turns -0.0 into 0.0: the same position.
    let mut p: Vec<[f64; 3]> = vertices
        .iter()
        .zip(&used)
        .filter(|(v, &u)| u && v.iter().all(|c| c.is_finite()))
        .map(|(v, _)| v.map(|c| c + 0.0))
        .collect();
    let n = p.len();
    p.sort_unstable_by(|a, b| {
        (0..3)
            .map(|k| a[k].total_cmp(&b[k]))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    p.dedup();
    n - p.len()
}
