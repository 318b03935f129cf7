//! Propagation of the edge masks to a fixpoint, and the components it leaves at
//! the root. Cost: O(incidences of the edges queued) per propagation; O(F + E)
//! for the components, plus sorting them.

use super::solver::{Solver, UNDECIDED};
use crate::arena::Alloc;
use crate::error::Result;

/// Degrees allowed by `mask` and reachable from `selected` selected and
/// `undecided` undecided facets, as a mask (bit d: degree d).
fn reachable_degrees(selected: u32, undecided: u32, mask: u8) -> u8 {
    let mut bits = 0u8;
    for d in 0..3u32 {
        if (mask >> d) & 1 == 1 && d >= selected && d <= selected.saturating_add(undecided) {
            bits |= 1 << d;
        }
    }
    bits
}

/// Where one component's facets and edges lie in [`Components`].
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ComponentSpan {
    /// Position of its first facet in [`Components::facets`].
    pub(super) first_facet: u32,
    /// Its number of facets.
    pub(super) facet_count: u32,
    /// Position of its first edge in [`Components::edges`].
    pub(super) first_edge: u32,
    /// Its number of edges.
    pub(super) edge_count: u32,
}

/// The components of the undecided facets after root propagation: facets linked
/// through shared edges.
pub(super) struct Components<'a> {
    /// The facets of each component, ascending within a component.
    facets: &'a mut [u32],
    /// The edges of each component, ascending within a component.
    edges: &'a mut [u32],
    /// One span per component, smallest component first (ties: lowest first facet).
    pub(super) spans: &'a mut [ComponentSpan],
}

impl<'a> Components<'a> {
    /// Room for the components of `facets` facets and `edges` edges, in `scratch`.
    pub(super) fn try_new_in<'b, A: Alloc<'b>>(
        scratch: &'a A,
        facets: usize,
        edges: usize,
    ) -> Result<Self> {
        Ok(Components {
            facets: scratch.try_alloc_slice(facets, 0u32)?,
            edges: scratch.try_alloc_slice(edges, 0u32)?,
            spans: scratch.try_alloc_slice(facets, ComponentSpan::default())?,
        })
    }

    /// The facets of the component at `span`.
    pub(super) fn facets_of(&self, span: &ComponentSpan) -> &[u32] {
        let first = span.first_facet as usize;
        &self.facets[first..first + span.facet_count as usize]
    }

    /// The edges of the component at `span`.
    pub(super) fn edges_of(&self, span: &ComponentSpan) -> &[u32] {
        let first = span.first_edge as usize;
        &self.edges[first..first + span.edge_count as usize]
    }
}

impl Solver<'_> {
    /// Propagate the queued edges to a fixpoint. `false`: some edge cannot reach
    /// an allowed degree (the queue is then empty again).
    pub(super) fn propagate(&mut self) -> bool {
        while let Some(e) = self.edge_queue.pop() {
            let (selected, undecided) = (self.selected_count[e], self.undecided_count[e]);
            let reachable = reachable_degrees(selected, undecided, self.edge_mask(e));
            if reachable == 0 {
                self.edge_queue.clear();
                return false;
            }
            if undecided == 0 {
                continue;
            }
            // reachable != 0 implies selected <= 2.
            let on = if reachable == 1 << selected {
                false
            } else if selected + undecided <= 2 && reachable == 1 << (selected + undecided) {
                true
            } else {
                continue;
            };
            for k in self.edge_span(e) {
                let f = self.facet_of(self.edge_incidences[k]);
                if self.facet_state[f] == UNDECIDED {
                    self.assign(f, on);
                }
            }
        }
        true
    }

    /// Propagate every edge of a fresh solver; returns the facets decided. Only
    /// "off" can be forced here (0 is always allowed and nothing is selected), so
    /// it never conflicts.
    pub(super) fn propagate_root(&mut self) -> u32 {
        for e in 0..self.undecided_count.len() {
            self.edge_queue.push(e);
        }
        let _always_feasible = self.propagate();
        self.trail_len as u32
    }

    /// Fill `out` with the components of the undecided facets (facets linked
    /// through shared edges) and return how many there are. Leaves `visited` set
    /// for the undecided facets.
    pub(super) fn find_components(&mut self, out: &mut Components<'_>) -> usize {
        let (mut count, mut facets_end, mut edges_end) = (0usize, 0usize, 0usize);
        for root in 0..self.facet_state.len() {
            if self.facet_state[root] != UNDECIDED || self.visited[root] {
                continue;
            }
            self.visited[root] = true;
            out.facets[facets_end] = root as u32;
            // An edge's undecided facets all join the component that meets it
            // first, so components share no edge.
            let (facet_count, edge_count) = self.walk_connected(
                &mut out.facets[facets_end..],
                &mut out.edges[edges_end..],
                usize::MAX,
                |solver, g| {
                    let new = !solver.visited[g];
                    solver.visited[g] = true;
                    new
                },
            );
            out.spans[count] = ComponentSpan {
                first_facet: facets_end as u32,
                facet_count: facet_count as u32,
                first_edge: edges_end as u32,
                edge_count: edge_count as u32,
            };
            facets_end += facet_count;
            edges_end += edge_count;
            count += 1;
        }
        let facets: &[u32] = &*out.facets;
        out.spans[..count]
            .sort_unstable_by_key(|s| (s.facet_count, facets[s.first_facet as usize]));
        count
    }
}
