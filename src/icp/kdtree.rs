//! A kd-tree over f32 points for nearest and k-nearest queries by Euclidean distance.
//!
//! Flat and implicit (no node structs, no pointers): the points are stored in an order such that
//! every range `[lo, hi)` of more than `LEAF_SIZE` (8) points is split at its median
//! `mid = lo + (hi - lo) / 2` along `axes[mid]`; points in `[lo, mid)` have a coordinate `<=` the
//! median's on that axis, points in `(mid, hi)` `>=`. Smaller ranges are leaves, scanned linearly.
//! Queries and distances are f64; ties are broken by the smaller original index, so results are
//! deterministic and equal to a brute-force search.

/// Ranges of at most this many points are scanned instead of split.
const LEAF_SIZE: usize = 8;

/// One query result: the index of the point in the slice the tree was built from and its
/// squared distance (m^2) to the query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    pub index: usize,
    pub sq_distance: f64,
}

#[derive(Clone, Copy, Debug)]
struct Entry {
    point: [f32; 3],
    index: u32,
}

/// A kd-tree built once over a point slice, then queried many times.
#[derive(Clone, Debug)]
pub struct KdTree {
    entries: Vec<Entry>,
    axes: Vec<u8>,
}

/// Squared Euclidean distance (m^2) between a query and a stored point, in f64.
pub fn sq_distance(q: [f64; 3], p: [f32; 3]) -> f64 {
    let d = [q[0] - p[0] as f64, q[1] - p[1] as f64, q[2] - p[2] as f64];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Orders candidates by distance, then by index.
fn better(d: f64, index: u32, than: (f64, u32)) -> bool {
    d < than.0 || (d == than.0 && index < than.1)
}

impl KdTree {
    /// Builds the tree in O(n log n). Points with a non-finite coordinate are left out and are
    /// never returned. Indices refer to `points`; at most `u32::MAX` points are indexed.
    pub fn new(points: &[[f32; 3]]) -> Self {
        let mut entries: Vec<Entry> = points
            .iter()
            .take(u32::MAX as usize)
            .enumerate()
            .filter(|(_, p)| p.iter().all(|c| c.is_finite()))
            .map(|(i, p)| Entry { point: *p, index: i as u32 })
            .collect();
        let mut axes = vec![0u8; entries.len()];
        build(&mut entries, &mut axes);
        Self { entries, axes }
    }

    /// Number of indexed (finite) points.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Indices of the indexed points in tree order: consecutive points are spatially close.
    pub fn tree_order(&self) -> impl Iterator<Item = usize> + '_ {
        self.entries.iter().map(|e| e.index as usize)
    }

    /// The nearest point to `q`, `None` when the tree is empty or `q` is not finite.
    pub fn nearest(&self, q: [f64; 3]) -> Option<Neighbour> {
        self.nearest_within(q, f64::INFINITY)
    }

    /// The nearest point to `q` within `max_distance` (m, inclusive). A finite bound prunes the
    /// search, so this is faster than [`KdTree::nearest`] when most points are far. A negative
    /// or NaN bound finds nothing.
    pub fn nearest_within(&self, q: [f64; 3], max_distance: f64) -> Option<Neighbour> {
        if !q.iter().all(|c| c.is_finite()) || max_distance.is_nan() || max_distance < 0.0 {
            return None;
        }
        self.nearest_within_sq(q, max_distance * max_distance)
    }

    /// [`KdTree::nearest_within`] with the bound given as a squared distance (m^2), so that a
    /// caller holding a candidate at squared distance `d` can pass `d` exactly.
    pub(crate) fn nearest_within_sq(&self, q: [f64; 3], max_sq_distance: f64) -> Option<Neighbour> {
        let mut best = Nearest { sq_distance: max_sq_distance, index: u32::MAX };
        self.search(&q, &mut best);
        (best.index != u32::MAX)
            .then_some(Neighbour { index: best.index as usize, sq_distance: best.sq_distance })
    }

    /// The `k` nearest points to `q`, closest first (fewer when the tree holds fewer).
    pub fn k_nearest(&self, q: [f64; 3], k: usize) -> Vec<Neighbour> {
        let mut out = Vec::with_capacity(k.min(self.len()));
        self.k_nearest_into(q, k, &mut out);
        out
    }

    /// [`KdTree::k_nearest`] into a reused buffer (cleared first).
    pub fn k_nearest_into(&self, q: [f64; 3], k: usize, out: &mut Vec<Neighbour>) {
        out.clear();
        if k == 0 || !q.iter().all(|c| c.is_finite()) {
            return;
        }
        let mut collector = KNearest { k, max_sq_distance: f64::INFINITY, found: out };
        self.search(&q, &mut collector);
    }

    /// Calls `f(index, neighbours)` with the `k` nearest points of every indexed point
    /// (itself included), as [`KdTree::k_nearest`] would find them. Points are visited in
    /// tree order, so consecutive queries are close, and each search starts bounded by the
    /// previous one's neighbours: they are `k` distinct points, so the farthest of them from
    /// the new query (by the same [`sq_distance`]) bounds its `k`-th distance exactly.
    pub fn for_each_k_nearest(&self, k: usize, mut f: impl FnMut(usize, &[Neighbour])) {
        if k == 0 {
            return;
        }
        // Where each indexed point lies in `entries`, by its index.
        let mut slot =
            vec![u32::MAX; self.entries.iter().map(|e| e.index as usize + 1).max().unwrap_or(0)];
        for (at, e) in self.entries.iter().enumerate() {
            slot[e.index as usize] = at as u32;
        }
        let mut found = Vec::with_capacity(k.min(self.len()));
        for e in &self.entries {
            let q = e.point.map(f64::from);
            let max_sq_distance = match found.len() == k {
                true => found.iter().fold(0.0, |bound: f64, n: &Neighbour| {
                    bound.max(sq_distance(q, self.entries[slot[n.index] as usize].point))
                }),
                false => f64::INFINITY,
            };
            found.clear();
            let mut collector = KNearest { k, max_sq_distance, found: &mut found };
            self.search(&q, &mut collector);
            f(e.index as usize, &found);
        }
    }

    /// Offers every point that may beat `c.bound()` to `c`: descends to the query's leaf,
    /// pushing each far half with the squared distance from `q` to its splitting plane, then
    /// pops the halves that can still hold a point within the bound. The plane distance is a
    /// coordinate difference of [`sq_distance`]'s, so rounding never makes it exceed the distance
    /// of a point behind the plane, and ties are never pruned.
    fn search<C: Collector>(&self, q: &[f64; 3], c: &mut C) {
        let entries = &self.entries[..];
        // One pending far half per level; medians halve ranges, so u32 indices need at most 32.
        let mut stack = [(0u32, 0u32, 0.0f64); 64];
        let mut depth = 0;
        let (mut lo, mut hi) = (0, entries.len());
        loop {
            while hi - lo > LEAF_SIZE {
                let mid = lo + (hi - lo) / 2;
                let e = entries[mid];
                let axis = self.axes[mid] as usize;
                let diff = q[axis] - e.point[axis] as f64;
                c.offer(sq_distance(*q, e.point), e.index);
                if diff < 0.0 {
                    stack[depth] = ((mid + 1) as u32, hi as u32, diff * diff);
                    hi = mid;
                } else {
                    stack[depth] = (lo as u32, mid as u32, diff * diff);
                    lo = mid + 1;
                }
                depth += 1;
            }
            for e in &entries[lo..hi] {
                c.offer(sq_distance(*q, e.point), e.index);
            }
            loop {
                if depth == 0 {
                    return;
                }
                depth -= 1;
                let (far_lo, far_hi, plane) = stack[depth];
                if plane <= c.bound() {
                    (lo, hi) = (far_lo as usize, far_hi as usize);
                    break;
                }
            }
        }
    }
}

/// Collects search results; `bound` is the squared distance a point must not exceed to count.
trait Collector {
    fn bound(&self) -> f64;
    fn offer(&mut self, sq_distance: f64, index: u32);
}

/// The single best point within an initial bound.
struct Nearest {
    sq_distance: f64,
    index: u32,
}

impl Collector for Nearest {
    fn bound(&self) -> f64 {
        self.sq_distance
    }

    #[inline(always)]
    fn offer(&mut self, d: f64, index: u32) {
        if better(d, index, (self.sq_distance, self.index)) {
            (self.sq_distance, self.index) = (d, index);
        }
    }
}

/// The `k` best points within a bound, kept sorted.
struct KNearest<'a> {
    k: usize,
    max_sq_distance: f64,
    found: &'a mut Vec<Neighbour>,
}

impl Collector for KNearest<'_> {
    fn bound(&self) -> f64 {
        if self.found.len() < self.k {
            self.max_sq_distance
        } else {
            self.found[self.k - 1].sq_distance
        }
    }

    #[inline(always)]
    fn offer(&mut self, d: f64, index: u32) {
        let found = &mut *self.found;
        if d > self.max_sq_distance {
            return;
        }
        if found.len() == self.k {
            let last = found[self.k - 1];
            if !better(d, index, (last.sq_distance, last.index as u32)) {
                return;
            }
            found.pop();
        }
        // Insertion from the back (most accepted candidates land near the end): shift the
        // worse entries up one, then write the new one once.
        let new = Neighbour { index: index as usize, sq_distance: d };
        found.push(new);
        let mut i = found.len() - 1;
        while i > 0 && better(d, index, (found[i - 1].sq_distance, found[i - 1].index as u32)) {
            found[i] = found[i - 1];
            i -= 1;
        }
        found[i] = new;
    }
}

/// Recursively orders `entries` around medians; `axes` is the matching slice of split axes.
fn build(entries: &mut [Entry], axes: &mut [u8]) {
    if entries.len() <= LEAF_SIZE {
        return;
    }
    let axis = widest_axis(entries);
    let mid = entries.len() / 2;
    entries.select_nth_unstable_by(mid, |a, b| a.point[axis].total_cmp(&b.point[axis]));
    axes[mid] = axis as u8;
    let (left, rest) = entries.split_at_mut(mid);
    let (left_axes, rest_axes) = axes.split_at_mut(mid);
    build(left, left_axes);
    build(&mut rest[1..], &mut rest_axes[1..]);
}

/// The axis along which the points spread the most.
fn widest_axis(entries: &[Entry]) -> usize {
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for e in entries {
        for i in 0..3 {
            min[i] = min[i].min(e.point[i]);
            max[i] = max[i].max(e.point[i]);
        }
    }
    let spread = [max[0] - min[0], max[1] - min[1], max[2] - min[2]];
    if spread[0] >= spread[1] && spread[0] >= spread[2] {
        0
    } else if spread[1] >= spread[2] {
        1
    } else {
        2
    }
}
