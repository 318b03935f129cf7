//! Candidate edges and facets (seed section 3.5).
//!
//! Two clusters are joined by a candidate edge when a point of one and a point of
//! the other are neighbours (the seed's rule), and across every 4-cycle of that
//! graph without a diagonal (where four clusters meet around one spot) both
//! diagonals are added: without them the quad's edges would have a single
//! candidate facet each and the surface a hole there. Candidate facets are the
//! 3-cycles of that graph. (Joining every pair of labels that meet in one point's
//! neighbourhood instead gives about 2.5 candidates per output facet rather than
//! 1.3, and a selection problem several times harder.) Generators closer than `1e-6` of the diagonal are merged first (two
//! clusters converging onto one corner would otherwise give zero-length edges and
//! duplicate faces), and facets of near-zero area are dropped before scoring.
//!
//! Output is sorted: edges `(a, b)` with `a < b` ascending, facets `(a, b, c)` with
//! `a < b < c` ascending, so everything downstream is deterministic.
//!
//! Memory: member lists 4 bytes per point plus O(clusters), then about 20 bytes
//! per edge and 24 per facet. Cost: O(n k) for the adjacency, one sorted-list
//! intersection per pair of a cluster's neighbours for the diagonals and one per
//! edge for the facets.

use crate::arena::Alloc;
use crate::clustering::knn::Neighbours;
use crate::error::Result;
use crate::math::{cross, dist2, dot, norm, perpendicular, sub, V3};
use crate::parallel;
use crate::progress::Progress;
use crate::union_find::{self, UnionFind};

/// Points of each cluster, contiguous.
#[derive(Clone, Copy)]
pub struct Members<'a> {
    /// `list[start[j] .. start[j+1]]` are the points of cluster `j`, ascending.
    pub start: &'a [u32],
    /// Point indices grouped by cluster.
    pub list: &'a [u32],
}

impl<'a> Members<'a> {
    /// The points of cluster `j`.
    pub fn of(&self, j: usize) -> &'a [u32] {
        &self.list[self.start[j] as usize..self.start[j + 1] as usize]
    }

    /// Number of clusters.
    pub fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// Whether there are no clusters.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Group points by the representative of their label (counting sort): a merged
/// cluster's points belong to its representative. Labels `>= rep.len()` are
/// skipped.
pub fn try_members_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    labels: &[u32],
    rep: &[u32],
) -> Result<Members<'a>> {
    let m = rep.len();
    let group = |l: u32| rep.get(l as usize).map(|&r| r as usize);
    let start = arena.try_alloc_slice::<u32>(m + 1, 0)?;
    for &l in labels {
        if let Some(r) = group(l) {
            start[r + 1] += 1;
        }
    }
    for j in 0..m {
        start[j + 1] += start[j];
    }
    let list = arena.try_alloc_slice::<u32>(start[m] as usize, 0)?;
    arena.scratch(|s| -> Result<()> {
        let cursor = s.try_alloc_copy::<u32>(&start[..m])?;
        for (i, &l) in labels.iter().enumerate() {
            if let Some(r) = group(l) {
                let c = &mut cursor[r];
                list[*c as usize] = i as u32;
                *c += 1;
            }
        }
        Ok(())
    })?;
    Ok(Members { start, list })
}

/// Candidate edges and facets over the clusters.
#[derive(Clone, Copy)]
pub struct Candidates<'a> {
    /// Representative of each cluster after merging coincident generators (a
    /// cluster is its own representative unless merged into a lower one).
    pub rep: &'a [u32],
    /// Candidate edges `(a, b)`, `a < b`, between representatives, ascending.
    pub edges: &'a [[u32; 2]],
    /// `edges[edge_start[a] .. edge_start[a+1]]` are the edges `(a, *)`.
    pub edge_start: &'a [u32],
    /// Candidate facets `(a, b, c)`, `a < b < c`, ascending.
    pub facets: &'a [[u32; 3]],
    /// Ids of the edges `(a,b)`, `(a,c)`, `(b,c)` of each facet.
    pub facet_edges: &'a [[u32; 3]],
    /// Generators merged into another (coincident).
    pub merged: u32,
    /// Facets dropped as degenerate.
    pub degenerate: u32,
}

impl Candidates<'_> {
    /// Id of edge `(a, b)`, `a < b`, if it is a candidate.
    pub fn edge_id(&self, a: u32, b: u32) -> Option<u32> {
        let lo = *self.edge_start.get(a as usize)? as usize;
        let hi = *self.edge_start.get(a as usize + 1)? as usize;
        self.edges[lo..hi]
            .binary_search_by(|e| e[1].cmp(&b))
            .ok()
            .map(|i| (lo + i) as u32)
    }
}

/// Whether the triangle is degenerate: an edge shorter than `tol` or an area
/// below `tol²` (both absolute).
pub fn degenerate(a: V3, b: V3, c: V3, tol: f32) -> bool {
    let t2 = tol * tol;
    if dist2(a, b) <= t2 || dist2(b, c) <= t2 || dist2(a, c) <= t2 {
        return true;
    }
    0.5 * norm(cross(sub(b, a), sub(c, a))) <= t2
}

/// Generators closer than this fraction of the diagonal are merged.
pub const COINCIDENT: f32 = 1e-6;

/// Representative of each cluster: the lowest-index cluster whose generator is
/// within `COINCIDENT * diag` (transitively). Returns the map and the number of
/// merges.
pub fn try_merge_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    generators: &[V3],
    diag: f32,
) -> Result<(&'a [u32], u32)> {
    let rep = arena.try_alloc_slice::<u32>(generators.len(), 0)?;
    let merged = merge_coincident(arena, generators, COINCIDENT * diag, rep)?;
    Ok((rep, merged))
}

/// Candidate facets on each candidate edge (index as in `cand.edges`), counted
/// up to 2: fewer than two means nothing lies on one side of the edge (the end
/// of the data, a missing candidate). Used by border detection and the edge
/// penalties of the selection.
pub fn try_facets_per_edge_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    cand: &Candidates,
) -> Result<&'a [u8]> {
    let count = arena.try_alloc_slice::<u8>(cand.edges.len(), 0)?;
    for fe in cand.facet_edges {
        for &e in fe {
            if let Some(c) = count.get_mut(e as usize) {
                *c = c.saturating_add(1).min(2);
            }
        }
    }
    Ok(count)
}

/// The piece of the data each cluster lies in (`rep.len()` clusters): two are
/// linked when a point of one has a point of the other among its k nearest
/// (`nb`), and a merged cluster lies in its representative's. Each piece is
/// named by its lowest cluster; labels `>= rep.len()` are skipped. With two
/// threads or more in `hooks` and at least 4,096 points a thread, the
/// points are cut into contiguous parts, one a thread, each joining its
/// points' links in sets of its own; the calling thread then joins the parts'
/// sets. The sets are the same whatever the cut, and so are their lowest
/// clusters. O(n k) time, `rep.len()` scratch a part.
pub fn try_pieces_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    nb: &Neighbours,
    labels: &[u32],
    rep: &[u32],
    hooks: &dyn Progress,
) -> Result<&'a [u32]> {
    let m = rep.len();
    let n = labels.len();
    let group = |i: u32| {
        labels
            .get(i as usize)
            .and_then(|&l| rep.get(l as usize))
            .copied()
    };
    let piece = arena.try_alloc_slice::<u32>(m, 0)?;
    arena.scratch(|s| -> Result<()> {
        let parts = union_find::parts_of(hooks, n);
        let roots = s.try_alloc_slice::<u32>(parts * m, 0)?;
        if m > 0 {
            parallel::rows(hooks, roots, m, |items, rows: &mut [u32]| {
                for (part, row) in items.zip(rows.chunks_exact_mut(m)) {
                    let mut sets = UnionFind::new(row);
                    for i in part * n / parts..(part + 1) * n / parts {
                        let Some(a) = group(i as u32) else { continue };
                        // Most neighbours lie in the point's own cluster: no
                        // find for those (the sets, and so the roots, are the
                        // same).
                        let others = nb.of(i).iter().filter_map(|&q| group(q));
                        sets.union_all(a, others.filter(|&b| b != a));
                    }
                    sets.into_roots();
                }
            });
        }
        let (first, rest) = roots.split_at_mut(m);
        let mut sets = UnionFind::from_roots(first);
        for row in rest.chunks_exact(m.max(1)) {
            for (i, &r) in row.iter().enumerate() {
                if r != i as u32 {
                    sets.union(i as u32, r);
                }
            }
        }
        for (x, &r) in piece.iter_mut().zip(rep) {
            *x = sets.find(r);
        }
        Ok(())
    })?;
    Ok(piece)
}

/// Neighbour links (a point of one cluster, a point of the other, neighbours)
/// two clusters need to be candidate-adjacent.
pub const MIN_LINKS: u32 = 2;

/// Neighbouring clusters whose links a cluster counts in a table of its own
/// ([`LinkTable`]), in parallel tasks; a cluster with more is counted on the
/// calling thread, over an array of a slot per cluster.
const LINKS_CAP: usize = 32;
/// Slots of a [`LinkTable`]: at most half of them in use.
const LINK_SLOTS: usize = 2 * LINKS_CAP;
/// Marks a cluster with more than [`LINKS_CAP`] neighbouring clusters.
const LARGE: u32 = u32::MAX;

/// Links from one cluster to each of its neighbouring clusters: an
/// open-addressing table of at most [`LINKS_CAP`] clusters.
struct LinkTable {
    cluster: [u32; LINK_SLOTS],
    links: [u32; LINK_SLOTS],
    len: usize,
    /// Clusters it may hold, at most [`LINKS_CAP`].
    cap: usize,
}

impl LinkTable {
    fn new(cap: usize) -> Self {
        LinkTable {
            cluster: [u32::MAX; LINK_SLOTS],
            links: [0; LINK_SLOTS],
            len: 0,
            cap: cap.min(LINKS_CAP),
        }
    }

    fn slot(&self, b: u32) -> usize {
        let mut i = (b.wrapping_mul(0x9E37_79B9) >> 25) as usize % LINK_SLOTS;
        while self.cluster[i] != b && self.cluster[i] != u32::MAX {
            i = (i + 1) % LINK_SLOTS;
        }
        i
    }

    /// One more link to `b`; `None` when `b` would be one cluster too many.
    fn add(&mut self, b: u32) -> Option<()> {
        let i = self.slot(b);
        if self.cluster[i] == u32::MAX {
            if self.len == self.cap {
                return None;
            }
            self.cluster[i] = b;
            self.len += 1;
        }
        self.links[i] = self.links[i].saturating_add(1);
        Some(())
    }

    /// Links to `b` (0 for a cluster not in the table).
    fn links(&self, b: u32) -> u32 {
        let i = self.slot(b);
        if self.cluster[i] == b {
            self.links[i]
        } else {
            0
        }
    }

    /// The clusters in the table.
    fn clusters(&self) -> impl Iterator<Item = u32> + '_ {
        self.cluster.iter().copied().filter(|&b| b != u32::MAX)
    }
}

/// Build the candidates from the cluster representatives `rep` (see
/// [`try_merge_in`]) and `members` grouped by them; `generators[j]` is cluster
/// `j`'s vertex and `diag` the bounding-box diagonal. The links between
/// clusters are counted cluster by cluster in parallel tasks of `hooks` (a
/// cluster with more than 32 neighbouring clusters on the calling
/// thread); the candidates do not depend on how the tasks run.
#[allow(clippy::too_many_arguments)]
pub fn try_candidates_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    hooks: &dyn Progress,
    nb: &Neighbours,
    labels: &[u32],
    rep: &'a [u32],
    merged: u32,
    members: &Members,
    generators: &[V3],
    diag: f32,
) -> Result<Candidates<'a>> {
    candidates_counting_in(
        arena, hooks, nb, labels, rep, merged, members, generators, diag, LINKS_CAP,
    )
}

/// [`try_candidates_in`], the links of a cluster with more than `links_cap`
/// neighbouring clusters counted on the calling thread.
#[allow(clippy::too_many_arguments)]
fn candidates_counting_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    hooks: &dyn Progress,
    nb: &Neighbours,
    labels: &[u32],
    rep: &'a [u32],
    merged: u32,
    members: &Members,
    generators: &[V3],
    diag: f32,
    links_cap: usize,
) -> Result<Candidates<'a>> {
    let m = generators.len();
    let tol = COINCIDENT * diag;
    // 1. The seed's rule: a ~ b when a point of a and a point of b are neighbours.
    //    Upper adjacency (b > a) of every representative, sorted.
    //    Under noise, or with few points per cluster, clusters interleave at
    //    their borders and single stray links join clusters two apart. A pair
    //    joined by one link only is kept when it is a Gabriel pair among the
    //    clusters around `a`: no generator of a more strongly linked cluster lies
    //    inside the sphere on the segment between the two generators.
    let up_start = arena.try_alloc_slice::<u32>(m + 1, 0)?;
    // Whether `a`, linked `links(b)` times to each of `near`, keeps its pair
    // with `b` (see above).
    let keeps =
        |a: usize, b: u32, near: &mut dyn Iterator<Item = u32>, links: &dyn Fn(u32) -> u32| {
            links(b) >= MIN_LINKS || {
                let (ga, gb) = (generators[a], generators[b as usize]);
                let mid = [0, 1, 2].map(|i| 0.5 * (ga[i] + gb[i]));
                let r2 = 0.25 * dist2(ga, gb);
                !Iterator::any(&mut &mut *near, |c| {
                    c != b && links(c) >= MIN_LINKS && dist2(generators[c as usize], mid) < r2
                })
            }
        };
    // Every representative's upper neighbours that it keeps, given to `f`:
    // the links counted in a small table of its own (`None` when it has more
    // than `LINKS_CAP` neighbouring clusters, for the pass below), so that
    // clusters are independent tasks.
    let kept_small = |a: usize, f: &mut dyn FnMut(u32)| -> Option<()> {
        let mut table = LinkTable::new(links_cap);
        for &p in members.of(a) {
            for row in nb.rows(p as usize) {
                for &q in row {
                    if let Some(&b) = rep.get(labels[q as usize] as usize) {
                        if b as usize != a {
                            table.add(b)?;
                        }
                    }
                }
            }
        }
        for b in table.clusters() {
            if b as usize > a && keeps(a, b, &mut table.clusters(), &|c| table.links(c)) {
                f(b);
            }
        }
        Some(())
    };
    // The same over arrays of a slot per cluster, on the calling thread.
    let kept_large = |a: usize, links: &mut [u32], touched: &mut [u32], f: &mut dyn FnMut(u32)| {
        let mut t = 0;
        for &p in members.of(a) {
            for q in nb.symmetric(p as usize) {
                let Some(&b) = rep.get(labels[q as usize] as usize) else {
                    continue;
                };
                if b as usize != a {
                    if links[b as usize] == 0 && t < touched.len() {
                        touched[t] = b;
                        t += 1;
                    }
                    links[b as usize] = links[b as usize].saturating_add(1);
                }
            }
        }
        for &b in &touched[..t] {
            let links = &*links;
            if b as usize > a
                && keeps(a, b, &mut touched[..t].iter().copied(), &|c| {
                    links[c as usize]
                })
            {
                f(b);
            }
        }
        for &b in &touched[..t] {
            links[b as usize] = 0;
        }
    };
    let ours = |a: usize| rep[a] as usize == a;
    parallel::rows(hooks, &mut up_start[1..], 1, |clusters, out: &mut [u32]| {
        for (a, count) in clusters.zip(out.iter_mut()) {
            *count = 0;
            if ours(a) && kept_small(a, &mut |_| *count += 1).is_none() {
                *count = LARGE;
            }
        }
    });
    let large = up_start[1..].contains(&LARGE);
    arena.scratch(|s| -> Result<()> {
        let links = s.try_alloc_slice::<u32>(if large { m } else { 0 }, 0)?;
        let touched = s.try_alloc_slice::<u32>(if large { m } else { 0 }, 0)?;
        for a in 0..m {
            if up_start[a + 1] == LARGE {
                let mut count = 0u32;
                kept_large(a, links, touched, &mut |_| count += 1);
                up_start[a + 1] = count;
            }
        }
        for a in 0..m {
            up_start[a + 1] += up_start[a];
        }
        Ok(())
    })?;
    let up = arena.try_alloc_slice::<u32>(up_start[m] as usize, 0)?;
    let up_start = &*up_start;
    let at = |a: usize| up_start[a.min(m)] as usize;
    let done = parallel::segments(hooks, up, m, at, |clusters, part: &mut [u32]| {
        let base = at(clusters.start);
        let mut large = false;
        for a in clusters {
            let lo = at(a) - base;
            let mut w = lo;
            if ours(a)
                && kept_small(a, &mut |b| {
                    if let Some(slot) = part.get_mut(w) {
                        *slot = b;
                    }
                    w += 1;
                })
                .is_none()
            {
                large = true;
                continue;
            }
            let end = w.min(part.len());
            part[lo..end].sort_unstable();
        }
        large
    });
    if done.contains(&true) {
        arena.scratch(|s| -> Result<()> {
            let links = s.try_alloc_slice::<u32>(m, 0)?;
            let touched = s.try_alloc_slice::<u32>(m, 0)?;
            // Only the tasks that met such a cluster are looked at again.
            let ranges = (0..parallel::TASKS).filter(|&t| done[t]);
            for a in ranges.flat_map(|t| parallel::range(m, t)) {
                if !ours(a) || kept_small(a, &mut |_| {}).is_some() {
                    continue;
                }
                let (lo, mut w) = (at(a), at(a));
                kept_large(a, links, touched, &mut |b| {
                    up[w] = b;
                    w += 1;
                });
                up[lo..w].sort_unstable();
            }
            Ok(())
        })?;
    }
    // 2. Both directions, each list ascending (lower neighbours arrive first, in
    //    order, then the upper ones).
    let full_start = arena.try_alloc_slice::<u32>(m + 1, 0)?;
    for a in 0..m {
        full_start[a + 1] += up_start[a + 1] - up_start[a];
        for &b in &up[up_start[a] as usize..up_start[a + 1] as usize] {
            full_start[b as usize + 1] += 1;
        }
    }
    for a in 0..m {
        full_start[a + 1] += full_start[a];
    }
    let full = arena.try_alloc_slice::<u32>(full_start[m] as usize, 0)?;
    arena.scratch(|s| -> Result<()> {
        let cursor = s.try_alloc_copy::<u32>(&full_start[..m])?;
        for a in 0..m {
            for &b in &up[up_start[a] as usize..up_start[a + 1] as usize] {
                full[cursor[a] as usize] = b;
                cursor[a] += 1;
                full[cursor[b as usize] as usize] = a as u32;
                cursor[b as usize] += 1;
            }
        }
        Ok(())
    })?;
    let around =
        |a: u32| &full[full_start[a as usize] as usize..full_start[a as usize + 1] as usize];
    let adjacent = |a: u32, b: u32| around(a).binary_search(&b).is_ok();
    // 3. Where four clusters meet around a point, the neighbour pairs may join them
    //    in a 4-cycle without a diagonal; both diagonals become candidates (the
    //    selection picks one, or neither), else the quad's edges would have a
    //    single candidate facet each and the surface a hole there.
    //    A cluster joined to two clusters only (a strip at the ragged edge of a
    //    scan) is in no 3-cycle and could never be covered: the edge between its
    //    two neighbours closes its triangle.
    let diagonals_of = |a: u32, f: &mut dyn FnMut(u32, u32)| {
        let ring = around(a);
        if let [b, d] = *ring {
            if !adjacent(b, d) {
                f(b, d);
            }
        }
        for (i, &b) in ring.iter().enumerate() {
            for &d in &ring[i + 1..] {
                if adjacent(b, d) {
                    continue;
                }
                let (mut x, mut y) = (around(b), around(d));
                while let (Some(&c1), Some(&c2)) = (x.first(), y.first()) {
                    if c1 < c2 {
                        x = &x[1..];
                    } else if c2 < c1 {
                        y = &y[1..];
                    } else {
                        if c1 > a && !adjacent(a, c1) {
                            f(a, c1);
                            f(b, d);
                        }
                        x = &x[1..];
                        y = &y[1..];
                    }
                }
            }
        }
    };
    // Each cluster's diagonals counted, then listed, in parallel tasks over
    // the clusters: the list of one pass over them, in order.
    let diagonal_start = arena.try_alloc_slice::<u32>(m + 1, 0)?;
    parallel::rows(
        hooks,
        &mut diagonal_start[1..],
        1,
        |clusters, out: &mut [u32]| {
            for (a, count) in clusters.zip(out.iter_mut()) {
                diagonals_of(a as u32, &mut |_, _| *count += 1);
            }
        },
    );
    for a in 0..m {
        diagonal_start[a + 1] += diagonal_start[a];
    }
    let nd = diagonal_start[m] as usize;
    let diagonals = arena.try_alloc_slice::<[u32; 2]>(nd, [0, 0])?;
    let diagonal_start = &*diagonal_start;
    let at = |a: usize| diagonal_start[a.min(m)] as usize;
    parallel::segments(
        hooks,
        diagonals,
        m,
        at,
        |clusters, part: &mut [[u32; 2]]| {
            let mut w = 0;
            for a in clusters {
                diagonals_of(a as u32, &mut |x, y| {
                    if let Some(slot) = part.get_mut(w) {
                        *slot = if x < y { [x, y] } else { [y, x] };
                    }
                    w += 1;
                });
            }
        },
    );
    diagonals.sort_unstable();
    let mut unique = 0;
    for i in 0..nd {
        if i == 0 || diagonals[i] != diagonals[unique - 1] {
            diagonals[unique] = diagonals[i];
            unique += 1;
        }
    }
    let diagonals = &diagonals[..unique];
    // 4. Edges: the neighbour pairs and the diagonals, sorted.
    let edge_start = arena.try_alloc_slice::<u32>(m + 1, 0)?;
    for a in 0..m {
        edge_start[a + 1] = up_start[a + 1] - up_start[a];
    }
    for &[a, _] in diagonals {
        edge_start[a as usize + 1] += 1;
    }
    for a in 0..m {
        edge_start[a + 1] += edge_start[a];
    }
    let edges = arena.try_alloc_slice::<[u32; 2]>(edge_start[m] as usize, [0, 0])?;
    let mut next_diagonal = 0;
    for a in 0..m {
        let lo = edge_start[a] as usize;
        let mut w = lo;
        for &b in &up[up_start[a] as usize..up_start[a + 1] as usize] {
            edges[w] = [a as u32, b];
            w += 1;
        }
        while next_diagonal < diagonals.len() && diagonals[next_diagonal][0] as usize == a {
            edges[w] = diagonals[next_diagonal];
            w += 1;
            next_diagonal += 1;
        }
        edges[lo..w].sort_unstable();
    }
    let edges: &'a [[u32; 2]] = edges;
    let edge_start: &'a [u32] = edge_start;
    // Facets: for each edge (a, b), the c > b adjacent to both.
    let upper =
        |a: u32| &edges[edge_start[a as usize] as usize..edge_start[a as usize + 1] as usize];
    let for_each_facet = |f: &mut dyn FnMut(u32, u32, u32, u32)| {
        for (e, &[a, b]) in edges.iter().enumerate() {
            let (mut i, mut j) = (upper(a), upper(b));
            // Both lists ascending by second endpoint: merge-intersect, c > b.
            while let (Some(x), Some(y)) = (i.first(), j.first()) {
                if x[1] <= b || x[1] < y[1] {
                    i = &i[1..];
                } else if y[1] < x[1] {
                    j = &j[1..];
                } else {
                    f(a, b, x[1], e as u32);
                    i = &i[1..];
                    j = &j[1..];
                }
            }
        }
    };
    let keep = |a: u32, b: u32, c: u32| {
        !degenerate(
            generators[a as usize],
            generators[b as usize],
            generators[c as usize],
            tol,
        )
    };
    let mut count = 0usize;
    let mut dropped = 0u32;
    for_each_facet(&mut |a, b, c, _| {
        if keep(a, b, c) {
            count += 1;
        } else {
            dropped += 1;
        }
    });
    let facets = arena.try_alloc_slice::<[u32; 3]>(count, [0; 3])?;
    let facet_edges = arena.try_alloc_slice::<[u32; 3]>(count, [0; 3])?;
    let mut w = 0usize;
    let find = |a: u32, b: u32| -> u32 {
        let lo = edge_start[a as usize] as usize;
        let list = upper(a);
        // Present by construction (c came from both lists).
        lo as u32 + list.binary_search_by(|e| e[1].cmp(&b)).unwrap_or(0) as u32
    };
    for_each_facet(&mut |a, b, c, e_ab| {
        if keep(a, b, c) {
            facets[w] = [a, b, c];
            facet_edges[w] = [e_ab, find(a, c), find(b, c)];
            w += 1;
        }
    });
    Ok(Candidates {
        rep,
        edges,
        edge_start,
        facets,
        facet_edges,
        merged,
        degenerate: dropped,
    })
}

/// `rep[j]`: the lowest-index cluster whose generator lies within `tol` of `j`'s
/// (transitively via sorting on x). Returns how many were merged.
fn merge_coincident<'b, A: Alloc<'b>>(
    arena: &A,
    generators: &[V3],
    tol: f32,
    rep: &mut [u32],
) -> Result<u32> {
    let m = generators.len();
    let mut sets = UnionFind::new(rep);
    let t2 = tol * tol;
    arena.scratch(|s| -> Result<u32> {
        let order = s.try_alloc_slice::<u32>(m, 0)?;
        for (i, o) in order.iter_mut().enumerate() {
            *o = i as u32;
        }
        order.sort_unstable_by(|&a, &b| {
            generators[a as usize][0]
                .total_cmp(&generators[b as usize][0])
                .then(a.cmp(&b))
        });
        let mut merged = 0;
        for i in 0..m {
            let a = order[i] as usize;
            let mut k = i + 1;
            while k < m && generators[order[k] as usize][0] - generators[a][0] <= tol {
                let b = order[k] as usize;
                if dist2(generators[a], generators[b]) <= t2 && sets.union(a as u32, b as u32) {
                    merged += 1;
                }
                k += 1;
            }
        }
        sets.into_roots();
        Ok(merged)
    })
}

/// Sides of the candidate edges: around each edge, facets whose wings (the
/// half-planes from the edge to their third vertex) lie within 45 degrees of each
/// other form a *fold group*, of which a surface can use at most one facet.
/// (45 degrees: a surface's two facets at one edge make the edge's interior
/// angle, 90 degrees on a box, far more on smooth parts; with 20 degrees a fold
/// across a box edge went unseen and left twisted, non-orientable patches.)
#[derive(Clone, Copy)]
pub struct FoldGroups<'a> {
    /// For each facet and each of its three edges (in `facet_edges` order), the
    /// fold group it belongs to there, or `u32::MAX` when it is alone on its side.
    pub facet_groups: &'a [[u32; 3]],
    /// Number of groups (each with at least two facets).
    pub count: u32,
}

/// Group the facets around every edge by the angle of their wings: sorted
/// around the edge, consecutive wings closer than 45 degrees share a group
/// (chains included). Cost: O(Σ facets per edge · log).
pub fn try_fold_groups_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    cand: &Candidates,
    generators: &[V3],
) -> Result<FoldGroups<'a>> {
    let nf = cand.facets.len();
    let ne = cand.edges.len();
    let facet_groups = arena.try_alloc_slice::<[u32; 3]>(nf, [u32::MAX; 3])?;
    let count = arena.scratch(|s| -> Result<u32> {
        // Edge -> facets incidence (CSR) with the slot of the edge in the facet.
        let start = s.try_alloc_slice::<u32>(ne + 1, 0)?;
        for fe in cand.facet_edges {
            for &e in fe {
                start[e as usize + 1] += 1;
            }
        }
        for e in 0..ne {
            start[e + 1] += start[e];
        }
        let inc = s.try_alloc_slice::<(u32, u8)>(start[ne] as usize, (0, 0))?;
        let cursor = s.try_alloc_copy::<u32>(&start[..ne])?;
        for (f, fe) in cand.facet_edges.iter().enumerate() {
            for (k, &e) in fe.iter().enumerate() {
                inc[cursor[e as usize] as usize] = (f as u32, k as u8);
                cursor[e as usize] += 1;
            }
        }
        let largest = (0..ne)
            .map(|e| (start[e + 1] - start[e]) as usize)
            .max()
            .unwrap_or(0);
        let ang = s.try_alloc_slice::<(f32, u32, u8)>(largest, (0.0, 0, 0))?;
        let limit = 45.0f32.to_radians();
        let mut groups = 0u32;
        for e in 0..ne {
            let list = &inc[start[e] as usize..start[e + 1] as usize];
            if list.len() < 2 {
                continue;
            }
            let [a, b] = cand.edges[e];
            let (pa, pb) = (generators[a as usize], generators[b as usize]);
            let t = sub(pb, pa);
            let lt = norm(t);
            if lt <= 0.0 {
                continue;
            }
            let t = t.map(|x| x / lt);
            // A frame (u, v) perpendicular to the edge.
            let u = perpendicular(t);
            let lu = norm(u);
            let u = u.map(|x| x / lu);
            let v = cross(t, u);
            for (i, &(f, k)) in list.iter().enumerate() {
                let c = cand.facets[f as usize]
                    .iter()
                    .copied()
                    .find(|&x| x != a && x != b)
                    .unwrap_or(a);
                let w = sub(generators[c as usize], pa);
                ang[i] = (libm::atan2f(dot(w, v), dot(w, u)), f, k);
            }
            let ang = &mut ang[..list.len()];
            ang.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            // Start the circular sweep after the widest gap, so no group wraps.
            let n = ang.len();
            let gap = |i: usize| {
                let (x, y) = (ang[i].0, ang[(i + 1) % n].0);
                if i + 1 == n {
                    y + core::f32::consts::TAU - x
                } else {
                    y - x
                }
            };
            let widest = (0..n)
                .max_by(|&i, &j| gap(i).total_cmp(&gap(j)).then(j.cmp(&i)))
                .unwrap_or(0);
            let mut run_start = 0;
            for step in 0..n {
                let i = (widest + 1 + step) % n;
                let ends = step + 1 == n || gap(i) >= limit;
                if ends {
                    let len = step + 1 - run_start;
                    if len >= 2 {
                        for r in run_start..=step {
                            let (_, f, k) = ang[(widest + 1 + r) % n];
                            facet_groups[f as usize][k as usize] = groups;
                        }
                        groups += 1;
                    }
                    run_start = step + 1;
                }
            }
        }
        Ok(groups)
    })?;
    Ok(FoldGroups {
        facet_groups,
        count,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arena::Arena;
    use crate::clustering::knn::try_neighbours_in;
    use crate::params::Params;
    use crate::progress::Silent;
    use core::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// A hub: a disc of one cluster on a 61 x 61 plate of spacing 1, ringed
    /// by 80 wedge clusters, the rest of the plate in 6 x 6 blocks. The hub
    /// touches more clusters than a table of [`LINKS_CAP`] holds, the others
    /// fewer: counted in parallel tasks and on the calling thread, with every
    /// cluster counted on the calling thread, the candidates are the same.
    #[test]
    fn links_counted_in_tables_and_in_arrays_give_the_same_candidates() {
        let side = 61;
        let points: Vec<V3> = (0..side * side)
            .map(|i| [(i % side) as f32, (i / side) as f32, 0.0])
            .collect();
        let c = (side / 2) as f32;
        let labels: Vec<u32> = points
            .iter()
            .map(|p| {
                let (dx, dy) = (p[0] - c, p[1] - c);
                let r = libm::sqrtf(dx * dx + dy * dy);
                if r <= 8.0 {
                    0
                } else if r <= 14.0 {
                    let turn = (libm::atan2f(dy, dx) / core::f32::consts::TAU + 1.0).fract();
                    1 + ((turn * 80.0) as u32).min(79)
                } else {
                    81 + (p[1] as u32 / 6) * 11 + p[0] as u32 / 6
                }
            })
            .collect();
        let m = *labels.iter().max().unwrap() as usize + 1;
        let mut generators = vec![[0.0f32; 3]; m];
        let mut count = vec![0.0f32; m];
        for (p, &l) in points.iter().zip(&labels) {
            for a in 0..3 {
                generators[l as usize][a] += p[a];
            }
            count[l as usize] += 1.0;
        }
        for (g, &n) in generators.iter_mut().zip(&count) {
            *g = g.map(|v| v / n.max(1.0));
        }
        let mut buf = vec![MaybeUninit::<u8>::uninit(); 1 << 24];
        let arena = Arena::new(&mut buf);
        let nb = try_neighbours_in(&arena, &points, Params::default().k, &mut Silent).unwrap();
        let diag = 60.0 * core::f32::consts::SQRT_2;
        let (rep, merged) = try_merge_in(&arena, &generators, diag).unwrap();
        let members = try_members_in(&arena, &labels, rep).unwrap();
        let run = |cap| {
            candidates_counting_in(
                &arena,
                &Silent,
                &nb,
                &labels,
                rep,
                merged,
                &members,
                &generators,
                diag,
                cap,
            )
            .unwrap()
        };
        let (tables, arrays) = (run(LINKS_CAP), run(0));
        let hub = tables.edges.iter().filter(|e| e[0] == 0).count();
        assert!(hub > LINKS_CAP, "the hub has {hub} upper neighbours");
        assert!(tables.edges.len() > 2 * m, "{} edges", tables.edges.len());
        assert_eq!(tables.edges, arrays.edges);
        assert_eq!(tables.edge_start, arrays.edge_start);
        assert_eq!(tables.facets, arrays.facets);
        assert_eq!(tables.facet_edges, arrays.facet_edges);
    }
}
