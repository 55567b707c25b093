//! The nearest-point fallback of GDAL 3.6.2's `gdal_grid -a linear:radius=R`, bit for bit.
//!
//! Outside every triangle, gdal_grid gives a cell the z of a "nearest" point, and which point
//! that is depends on details that this module reproduces for compatibility:
//!
//! - 3.6.2 searches a square box, `[x - r, x + r] × [y - r, y + r]` with its edges, and has no
//!   circle test: with `radius = R > 0` a point beyond R (in the box's corners, up to R√2)
//!   can win over a nearer one just outside the box. With `R < 0` the box starts at the
//!   points' typical spacing, `sqrt(bbox area / n)`, and doubles until it holds a point.
//! - Among the points in the box, the smallest `dx * dx + dy * dy` (as f64, in that order)
//!   wins, and of equal ones the *last* in the order of GDAL's search (`<=`). That order is
//!   the pre-order of GDAL's point quadtree (CPLQuadTree: buckets of 8, 0.55 split ratio, no
//!   maximum depth), so the tree is rebuilt here exactly as GDAL builds it, with every input
//!   point (duplicates too) in input order, to number the points in that order.
//!
//! The queries themselves run on a balanced k-d tree over the distinct positions (of points at
//! the same x, y only the one last in GDAL's order can win), as a branch-and-bound search for
//! the smallest distance in the box, which gives the same point as GDAL's scan of the box.

/// gdal_grid's nearest-point search over a point set, as its `linear` algorithm falls back to
/// outside the TIN.
///
/// Build once with all the points, then call [`NearestPoints::value`] per cell; it takes
/// `&self` and the type is `Sync`, so cells can be done from many threads.
#[derive(Debug, Clone)]
pub struct NearestPoints {
    /// One site per distinct (x, y), in k-d tree order.
    sites: Vec<Site>,
    /// The k-d tree over `sites`; node 0 is the root (absent when there are no points).
    nodes: Vec<KdNode>,
    /// GDAL's first box half-size for negative radii: `sqrt((maxx - minx) * (maxy - miny) / n)`.
    initial_radius: f64,
}

#[derive(Debug, Clone, Copy)]
struct Site {
    x: f64,
    y: f64,
    z: f64,
    /// 1 + the point's position in GDAL's search order (0 means "none" in the search).
    rank: u32,
}

#[derive(Debug, Clone, Copy)]
struct KdNode {
    rect: Rect,
    start: u32,
    end: u32,
    /// Children (node indices), or `LEAF` for a leaf.
    children: [u32; 2],
}

/// CPLRectObj: the same four doubles, compared as GDAL compares them.
#[derive(Debug, Clone, Copy)]
struct Rect {
    minx: f64,
    miny: f64,
    maxx: f64,
    maxy: f64,
}

impl Rect {
    /// CPL_RectOverlap (edges included; written as GDAL writes it, so NaN overlaps).
    fn overlaps(&self, o: &Rect) -> bool {
        !(self.minx > o.maxx || self.maxx < o.minx || self.miny > o.maxy || self.maxy < o.miny)
    }

    /// A point's bounds overlap `self`: how GDAL decides that a point is in the search box.
    fn has(&self, x: f64, y: f64) -> bool {
        !(x > self.maxx || x < self.minx || y > self.maxy || y < self.miny)
    }

    /// CPL_RectContained for a point's bounds.
    fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.minx && x <= self.maxx && y >= self.miny && y <= self.maxy
    }

    /// `memcmp(a, b, sizeof(CPLRectObj)) == 0`.
    fn same_bits(&self, o: &Rect) -> bool {
        self.minx.to_bits() == o.minx.to_bits()
            && self.miny.to_bits() == o.miny.to_bits()
            && self.maxx.to_bits() == o.maxx.to_bits()
            && self.maxy.to_bits() == o.maxy.to_bits()
    }
}

/// What a search of one box found.
enum Scan {
    /// No site in the box: GDAL doubles the box (radius < 0) or gives nodata.
    Empty,
    /// Sites in the box; the one GDAL picks, if any qualifies.
    Nonempty(Option<usize>),
}

const LEAF: u32 = u32::MAX;
const KD_LEAF_SIZE: usize = 8;

impl NearestPoints {
    /// Prepares the search over `points` (x, y, z): all of them, duplicates included, in input
    /// order, as gdal_grid reads them. Coordinates are expected to be finite (non-finite ones
    /// do not panic, but their behaviour is not GDAL's guaranteed).
    ///
    /// # Panics
    /// With `u32::MAX` points or more (GDAL counts them in 32 bits).
    pub fn new(points: &[[f64; 3]]) -> NearestPoints {
        assert!(points.len() < u32::MAX as usize, "gdal_grid counts points in 32 bits: {} is too many", points.len());
        if points.is_empty() {
            return NearestPoints { sites: Vec::new(), nodes: Vec::new(), initial_radius: 0.0 };
        }
        NearestPoints::with_order(points, &gdal_search_order(points))
    }

    /// `new`, with ties going to the point with the highest `rank` (a permutation of
    /// `0..points.len()`) instead of the last in GDAL's order.
    fn with_order(points: &[[f64; 3]], rank: &[u32]) -> NearestPoints {
        let bounds = point_bounds(points);
        let initial_radius = ((bounds.maxx - bounds.minx) * (bounds.maxy - bounds.miny) / points.len() as f64).sqrt();

        // Of the points at one (x, y), only the last in the search order can win: they tie, and
        // are in or out of a box together. `+ 0.0` makes -0.0 and 0.0 one position (they give
        // the same distances and box tests).
        let key = |i: usize| ((points[i][0] + 0.0).to_bits(), (points[i][1] + 0.0).to_bits());
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        order.sort_unstable_by_key(|&i| key(i as usize));
        let mut sites: Vec<Site> = order
            .chunk_by(|&a, &b| key(a as usize) == key(b as usize))
            .map(|run| {
                let i = *run.iter().max_by_key(|&&i| rank[i as usize]).unwrap() as usize;
                Site { x: points[i][0] + 0.0, y: points[i][1] + 0.0, z: points[i][2], rank: rank[i] + 1 }
            })
            .collect();
        drop(order);
        let mut nodes = Vec::with_capacity(2 * sites.len() / KD_LEAF_SIZE + 1);
        build_kd(&mut sites, 0, &mut nodes);
        NearestPoints { sites, nodes, initial_radius }
    }

    /// The z of the point gdal_grid's `linear:radius=radius` fallback picks for a cell centred
    /// at (x, y), or `None` where it writes nodata:
    ///
    /// - `radius > 0`: the nearest point in the square box of half-size `radius`; `None` if
    ///   the box is empty.
    /// - `radius < 0` (or NaN, as in GDAL): unbounded, the nearest point in the first box of
    ///   GDAL's doubling sequence that holds a point. (`None` only where the points' bounding
    ///   box has no area, e.g. a single point: GDAL's first box then has size 0 and it stops.)
    /// - `radius == 0`: always `None`.
    ///
    /// Ties go to the point last in GDAL's search order.
    pub fn value(&self, x: f64, y: f64, radius: f64) -> Option<f64> {
        if radius == 0.0 || self.sites.is_empty() {
            return None;
        }
        let bounded = radius > 0.0;
        let mut half = if bounded { radius } else { self.initial_radius };
        while half > 0.0 {
            let aoi = Rect { minx: x - half, miny: y - half, maxx: x + half, maxy: y + half };
            if let Scan::Nonempty(site) = self.nearest_in(&aoi, x, y) {
                return site.map(|s| self.sites[s].z);
            }
            if bounded {
                break;
            }
            half *= 2.0;
        }
        None
    }

    /// The site GDAL's scan of the box `aoi` ends on: the smallest `dx * dx + dy * dy` that is
    /// at most `f64::MAX`, ties to the highest rank. A box with sites but none that qualifies
    /// (only possible when every distance overflows) still ends GDAL's search, with nodata.
    fn nearest_in(&self, aoi: &Rect, x: f64, y: f64) -> Scan {
        let mut best = f64::MAX;
        // Whether a site in the box was seen, and whether a node was skipped (its distances
        // all overflow) before any site qualified, which leaves the box's emptiness open.
        let mut seen = false;
        let mut skipped_unseen = false;
        let mut best_rank = 0u32;
        let mut best_site = None;
        // Depth first; the tree is balanced, so its depth is below 64 for any u32 count.
        let mut stack = [0u32; 128];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if !node.rect.overlaps(aoi) {
                continue;
            }
            if lower_bound(&node.rect, x, y) > best {
                skipped_unseen |= best_site.is_none();
                continue;
            }
            if node.children[0] == LEAF {
                for (i, s) in self.sites[node.start as usize..node.end as usize].iter().enumerate() {
                    if !aoi.has(s.x, s.y) {
                        continue;
                    }
                    seen = true;
                    let dx = s.x - x;
                    let dy = s.y - y;
                    let d = dx * dx + dy * dy;
                    if d < best || (d == best && s.rank > best_rank) {
                        best = d;
                        best_rank = s.rank;
                        best_site = Some(node.start as usize + i);
                    }
                }
            } else {
                // Nearer child last, so that it is searched first.
                let [a, b] = node.children;
                let (near, far) =
                    if lower_bound(&self.nodes[a as usize].rect, x, y) <= lower_bound(&self.nodes[b as usize].rect, x, y) { (a, b) } else { (b, a) };
                stack[top] = far;
                stack[top + 1] = near;
                top += 2;
            }
        }
        if best_site.is_some() || seen || (skipped_unseen && self.any_in(aoi)) { Scan::Nonempty(best_site) } else { Scan::Empty }
    }

    /// Whether any site lies in the box `aoi`.
    fn any_in(&self, aoi: &Rect) -> bool {
        let mut stack = [0u32; 128];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if !node.rect.overlaps(aoi) {
                continue;
            }
            if node.children[0] == LEAF {
                if self.sites[node.start as usize..node.end as usize].iter().any(|s| aoi.has(s.x, s.y)) {
                    return true;
                }
            } else {
                stack[top] = node.children[1];
                stack[top + 1] = node.children[0];
                top += 2;
            }
        }
        false
    }
}

/// A lower bound on `dx * dx + dy * dy`, as rounded in f64, for any site in `rect`: the same
/// operations on the nearest coordinates of the rectangle (rounding is monotonic).
fn lower_bound(rect: &Rect, x: f64, y: f64) -> f64 {
    let dx = if x < rect.minx {
        rect.minx - x
    } else if x > rect.maxx {
        x - rect.maxx
    } else {
        0.0
    };
    let dy = if y < rect.miny {
        rect.miny - y
    } else if y > rect.maxy {
        y - rect.maxy
    } else {
        0.0
    };
    dx * dx + dy * dy
}

/// Builds the k-d tree over `sites` (which it reorders) and returns the index of its root.
/// Median splits along the wider side: balanced, so the depth is about log2(n / 8).
fn build_kd(sites: &mut [Site], offset: usize, nodes: &mut Vec<KdNode>) -> u32 {
    let mut rect = Rect { minx: f64::INFINITY, miny: f64::INFINITY, maxx: f64::NEG_INFINITY, maxy: f64::NEG_INFINITY };
    for s in sites.iter() {
        rect.minx = rect.minx.min(s.x);
        rect.miny = rect.miny.min(s.y);
        rect.maxx = rect.maxx.max(s.x);
        rect.maxy = rect.maxy.max(s.y);
    }
    if sites.iter().any(|s| s.x.is_nan() || s.y.is_nan()) {
        // Never pruned: NaN positions are "in" every box, as in GDAL.
        rect = Rect { minx: f64::NAN, miny: f64::NAN, maxx: f64::NAN, maxy: f64::NAN };
    }
    let index = nodes.len() as u32;
    nodes.push(KdNode { rect, start: offset as u32, end: (offset + sites.len()) as u32, children: [LEAF; 2] });
    if sites.len() > KD_LEAF_SIZE {
        let mid = sites.len() / 2;
        if rect.maxx - rect.minx >= rect.maxy - rect.miny {
            sites.select_nth_unstable_by(mid, |a, b| a.x.total_cmp(&b.x));
        } else {
            sites.select_nth_unstable_by(mid, |a, b| a.y.total_cmp(&b.y));
        }
        let (low, high) = sites.split_at_mut(mid);
        let a = build_kd(low, offset, nodes);
        let b = build_kd(high, offset + mid, nodes);
        nodes[index as usize].children = [a, b];
    }
    index
}

/// The points' bounding box as GDALGridContextCreateQuadTree computes it.
fn point_bounds(points: &[[f64; 3]]) -> Rect {
    let mut r = Rect { minx: points[0][0], miny: points[0][1], maxx: points[0][0], maxy: points[0][1] };
    for p in &points[1..] {
        if p[0] < r.minx {
            r.minx = p[0];
        }
        if p[1] < r.miny {
            r.miny = p[1];
        }
        if p[0] > r.maxx {
            r.maxx = p[0];
        }
        if p[1] > r.maxy {
            r.maxy = p[1];
        }
    }
    r
}

// ---- GDAL's CPLQuadTree (port/cpl_quad_tree.cpp), only to number the points in its order ----

/// CPLQuadTreeCreate's defaults, which gdal_grid keeps.
const BUCKET_CAPACITY: u32 = 8;
const SPLIT_RATIO: f64 = 0.55;
const NONE: u32 = u32::MAX;

struct QuadNode {
    rect: Rect,
    /// The first of its four consecutive children, or `NONE`.
    first_child: u32,
    /// Its own points, a list in insertion order through `QuadTree::next`.
    head: u32,
    tail: u32,
    count: u32,
}

struct QuadTree<'a> {
    points: &'a [[f64; 3]],
    nodes: Vec<QuadNode>,
    next: Vec<u32>,
}

/// CPLQuadTreeSplitBounds.
fn split_bounds(r: &Rect) -> (Rect, Rect) {
    let (mut a, mut b) = (*r, *r);
    if (r.maxx - r.minx) > (r.maxy - r.miny) {
        let range = r.maxx - r.minx;
        a.maxx = r.minx + range * SPLIT_RATIO;
        b.minx = r.maxx - range * SPLIT_RATIO;
    } else {
        let range = r.maxy - r.miny;
        a.maxy = r.miny + range * SPLIT_RATIO;
        b.miny = r.maxy - range * SPLIT_RATIO;
    }
    (a, b)
}

impl QuadTree<'_> {
    fn push_item(&mut self, node: u32, item: u32) {
        let n = &mut self.nodes[node as usize];
        if n.count == 0 {
            n.head = item;
        } else {
            self.next[n.tail as usize] = item;
        }
        n.tail = item;
        n.count += 1;
        self.next[item as usize] = NONE;
    }

    /// CPLQuadTreeInsert → CPLQuadTreeNodeAddFeatureAlg1 (no maximum depth), with its
    /// recursion turned into a stack of pending insertions in the same order.
    fn insert(&mut self, item: u32, pending: &mut Vec<(u32, u32)>) {
        pending.push((0, item));
        while let Some((mut node, item)) = pending.pop() {
            let [x, y, _] = self.points[item as usize];
            loop {
                let n = &self.nodes[node as usize];
                if n.first_child == NONE {
                    if n.count >= BUCKET_CAPACITY {
                        let (half1, half2) = split_bounds(&n.rect);
                        let (q1, q2) = split_bounds(&half1);
                        let (q3, q4) = split_bounds(&half2);
                        let quads = [q1, q2, q3, q4];
                        if quads.iter().all(|q| !q.same_bits(&n.rect)) && quads.iter().any(|q| q.contains(x, y)) {
                            // Split, then re-add the node's points (now going to the children
                            // where they fit) in their order, then this one.
                            let first = self.nodes.len() as u32;
                            for q in quads {
                                self.nodes.push(QuadNode { rect: q, first_child: NONE, head: NONE, tail: NONE, count: 0 });
                            }
                            let n = &mut self.nodes[node as usize];
                            n.first_child = first;
                            let (mut old, count) = (n.head, n.count);
                            n.count = 0;
                            n.head = NONE;
                            n.tail = NONE;
                            pending.push((node, item));
                            let at = pending.len();
                            for _ in 0..count {
                                pending.push((node, old));
                                old = self.next[old as usize];
                            }
                            pending[at..].reverse();
                            break;
                        }
                    }
                    self.push_item(node, item);
                    break;
                }
                let first = n.first_child;
                match (first..first + 4).find(|&c| self.nodes[c as usize].rect.contains(x, y)) {
                    Some(child) => node = child,
                    None => {
                        self.push_item(node, item);
                        break;
                    }
                }
            }
        }
    }
}

/// Each point's position (0-based) in the order in which CPLQuadTreeSearch lists the points
/// of gdal_grid's quadtree: a node's own points in insertion order, then its four children
/// depth first, in order. A search box only drops points from this order, never reorders them.
fn gdal_search_order(points: &[[f64; 3]]) -> Vec<u32> {
    let mut tree = QuadTree {
        points,
        nodes: vec![QuadNode { rect: point_bounds(points), first_child: NONE, head: NONE, tail: NONE, count: 0 }],
        next: vec![NONE; points.len()],
    };
    let mut pending = Vec::new();
    for item in 0..points.len() as u32 {
        tree.insert(item, &mut pending);
    }
    let mut rank = vec![0u32; points.len()];
    let mut position = 0u32;
    let mut stack = vec![0u32];
    while let Some(node) = stack.pop() {
        let n = &tree.nodes[node as usize];
        let mut item = n.head;
        for _ in 0..n.count {
            rank[item as usize] = position;
            position += 1;
            item = tree.next[item as usize];
        }
        if n.first_child != NONE {
            stack.extend((n.first_child..n.first_child + 4).rev());
        }
    }
    rank
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use std::process::Command;

    /// A small deterministic generator (SplitMix64), so the tests need no dependency.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in [lo, hi), rounded to `decimals` decimals (exact ties and short CSV text).
        fn uniform(&mut self, lo: f64, hi: f64, decimals: i32) -> f64 {
            let u = (self.next() >> 11) as f64 / (1u64 << 53) as f64;
            let scale = 10f64.powi(decimals);
            ((lo + u * (hi - lo)) * scale).round() / scale
        }
    }

    /// GDAL's loop written out plainly: the points in GDAL's search order, the same boxes, the
    /// same `<=` scan.
    fn reference(points: &[[f64; 3]], order: &[usize], initial_radius: f64, x: f64, y: f64, radius: f64) -> Option<f64> {
        if radius == 0.0 {
            return None;
        }
        let mut half = if radius > 0.0 { radius } else { initial_radius };
        while half > 0.0 {
            let aoi = Rect { minx: x - half, miny: y - half, maxx: x + half, maxy: y + half };
            let inside: Vec<usize> = order.iter().copied().filter(|&i| aoi.has(points[i][0], points[i][1])).collect();
            if !inside.is_empty() {
                let mut best = f64::MAX;
                let mut value = None;
                for i in inside {
                    let dx = points[i][0] - x;
                    let dy = points[i][1] - y;
                    let d = dx * dx + dy * dy;
                    if d <= best {
                        best = d;
                        value = Some(points[i][2]);
                    }
                }
                return value;
            }
            if radius > 0.0 {
                break;
            }
            half *= 2.0;
        }
        None
    }

    fn search_order(points: &[[f64; 3]]) -> Vec<usize> {
        let rank = gdal_search_order(points);
        let mut order: Vec<usize> = (0..points.len()).collect();
        order.sort_by_key(|&i| rank[i]);
        order
    }

    fn bits(v: Option<f64>) -> Option<u64> {
        v.map(f64::to_bits)
    }

    fn check_against_reference(points: &[[f64; 3]], queries: &[(f64, f64)], radii: &[f64]) {
        let nearest = NearestPoints::new(points);
        let order = search_order(points);
        for &(x, y) in queries {
            for &r in radii {
                let want = reference(points, &order, nearest.initial_radius, x, y, r);
                assert_eq!(bits(nearest.value(x, y, r)), bits(want), "({x}, {y}) radius {r}: got {:?}, want {want:?}", nearest.value(x, y, r));
            }
        }
    }

    /// A regular lattice with z = input index.
    fn lattice(nx: usize, ny: usize, step: f64) -> Vec<[f64; 3]> {
        (0..nx * ny).map(|k| [(k % nx) as f64 * step, (k / nx) as f64 * step, k as f64]).collect()
    }

    #[test]
    fn the_search_order_is_a_permutation_and_follows_gdals_tree() {
        // Up to 8 points: one node, input order.
        let few = lattice(2, 4, 1.0);
        assert_eq!(gdal_search_order(&few), (0..8).collect::<Vec<u32>>());
        // The 9th point splits the root ([0, 2] × [0, 2] splits along y first, as x is not
        // wider): the children are y in [0, 1.1] and [0.9, 2], each then split in x.
        let nine = lattice(3, 3, 1.0);
        let order = search_order(&nine);
        // quad1 = x [0, 1.1] × y [0, 1.1]: (0,0) (1,0) (0,1) (1,1) = 0 1 3 4; quad2 = x [0.9, 2]
        // × y [0, 1.1]: 2 5; quad3 = x [0, 1.1] × y [0.9, 2]: 6 7; quad4: 8.
        assert_eq!(order, vec![0, 1, 3, 4, 2, 5, 6, 7, 8]);
        let mut rng = Rng(7);
        let points: Vec<[f64; 3]> = (0..5000).map(|_| [rng.uniform(0.0, 10.0, 2), rng.uniform(0.0, 10.0, 2), 0.0]).collect();
        let mut rank = gdal_search_order(&points);
        rank.sort_unstable();
        assert_eq!(rank, (0..5000).collect::<Vec<u32>>());
    }

    #[test]
    fn matches_a_plain_scan_in_gdals_order() {
        let mut rng = Rng(1);
        let mut queries: Vec<(f64, f64)> = (0..400).map(|_| (rng.uniform(-40.0, 140.0, 1), rng.uniform(-40.0, 140.0, 1))).collect();
        queries.extend((0..200).map(|_| (rng.uniform(-5.0, 105.0, 0) + 0.5, rng.uniform(-5.0, 105.0, 0))));
        let radii = [-1.0, f64::NAN, 0.0, 0.5, 3.0, 10.0, 1e9, f64::INFINITY];

        let random: Vec<[f64; 3]> = (0..1500).map(|_| [rng.uniform(0.0, 100.0, 3), rng.uniform(0.0, 100.0, 3), rng.uniform(0.0, 1000.0, 2)]).collect();
        check_against_reference(&random, &queries, &radii);
        // Coarse coordinates: many exact ties and repeated positions with other z.
        let coarse: Vec<[f64; 3]> = (0..1500).map(|k| [rng.uniform(0.0, 100.0, -1), rng.uniform(0.0, 100.0, -1), k as f64]).collect();
        check_against_reference(&coarse, &queries, &radii);
        let mut grid = lattice(21, 21, 5.0);
        let again: Vec<[f64; 3]> = grid.iter().map(|p| [p[0], p[1], p[2] + 1000.0]).collect();
        grid.extend(again);
        check_against_reference(&grid, &queries, &radii);
        // -0.0 and 0.0 are one position.
        let signed = [[0.0, 0.0, 1.0], [-0.0, 0.0, 2.0], [0.0, -0.0, 3.0], [1.0, 1.0, 4.0]];
        check_against_reference(&signed, &[(-1.0, -1.0), (-0.0, 0.0), (0.5, 0.5), (2.0, 2.0)], &radii);
    }

    #[test]
    fn edge_cases() {
        fn shareable<T: Send + Sync>() {}
        shareable::<NearestPoints>();
        assert_eq!(NearestPoints::new(&[]).value(0.0, 0.0, -1.0), None);
        let one = NearestPoints::new(&[[1.0, 2.0, 3.0]]);
        // One point: the bounding box has no area, so GDAL's first box is empty-sized and its
        // doubling loop never runs.
        assert_eq!(one.value(1.0, 2.0, -1.0), None);
        assert_eq!(one.value(5.0, 5.0, 4.0), Some(3.0));
        // The box's edges count; its corners too (no circle test in 3.6.2).
        assert_eq!(one.value(5.0, 6.0, 4.0), Some(3.0));
        assert_eq!(one.value(5.0, 6.0, 3.999), None);
        assert_eq!(one.value(1.0, 2.0, 0.0), None);
        // A square box can prefer a farther point: (3, 3) at distance 4.24 is in the box of
        // half-size 3, (0, 3.5) at distance 3.5 is not.
        let two = NearestPoints::new(&[[3.0, 3.0, 1.0], [0.0, 3.5, 2.0], [10.0, 10.0, 3.0]]);
        assert_eq!(two.value(0.0, 0.0, 3.0), Some(1.0));
    }

    #[test]
    fn ten_thousand_identical_points_give_gdals_winner() {
        let (points, _) = duplicates_case();
        let start = std::time::Instant::now();
        let nearest = NearestPoints::new(&points);
        assert!(start.elapsed().as_secs_f64() < 5.0, "building took {:?}", start.elapsed());
        assert_eq!(nearest.sites.len(), 5);
        let order = search_order(&points);
        for (x, y) in [(5.0, -1.0), (5.2, -3.0), (4.5, -0.5)] {
            for r in [-1.0, 2.0, 5.0] {
                assert_eq!(bits(nearest.value(x, y, r)), bits(reference(&points, &order, nearest.initial_radius, x, y, r)));
            }
        }
        // The winner among the identical points, as gdal_grid 3.6.2 picks it (confirmed by
        // running it; `matches_gdal_grid` checks it again where gdal_grid is installed).
        assert_eq!(nearest.value(5.0, -1.0, 2.0), Some(DUPLICATES_WINNER));
        assert_eq!(nearest.value(5.0, -1.0, -1.0), Some(DUPLICATES_WINNER));
    }

    /// The z that gdal_grid picks among the 10,000 points at (5, 0) of `duplicates_case`.
    const DUPLICATES_WINNER: f64 = 10_000.0;

    /// 10,000 points at (5, 0) with z = 1, 2, ..., on the hull of a 10 × 10 square.
    fn duplicates_case() -> (Vec<[f64; 3]>, &'static str) {
        let mut points = vec![[0.0, 0.0, -1.0], [10.0, 0.0, -2.0], [10.0, 10.0, -3.0], [0.0, 10.0, -4.0]];
        points.extend((0..10_000).map(|k| [5.0, 0.0, (k + 1) as f64]));
        (points, "dup")
    }

    /// The 11 × 11 unit lattice listed backwards (from (10, 10) down to (0, 0)), z = input
    /// index: GDAL's search order then differs from the input order, and so do tie winners.
    fn reversed_lattice() -> Vec<[f64; 3]> {
        let mut points: Vec<[f64; 3]> = lattice(11, 11, 1.0).into_iter().rev().collect();
        for (k, p) in points.iter_mut().enumerate() {
            p[2] = k as f64;
        }
        points
    }

    /// (x, y, radius, the value gdal_grid 3.6.2 gives there) on `reversed_lattice`, each cell
    /// midway between two lattice points outside the hull; read off gdal_grid run on a 1 × 1
    /// grid centred on (x, y). Where the winner is not the later point in input order
    /// (e.g. (1.5, 20): (2, 10) is input 8, (1, 10) input 9), only GDAL's quadtree order
    /// explains it.
    const TIE_CASES: &[(f64, f64, f64, f64)] = &[
        (1.5, 20.0, -1.0, 8.0),
        (3.5, 20.0, -1.0, 6.0),
        (5.5, 20.0, -1.0, 4.0),
        (1.5, 10.5, 0.5, 8.0),
        (3.5, 10.5, 0.5, 6.0),
        (5.5, 11.0, 1.0, 4.0),
        (1.5, 12.5, 2.5, 8.0),
        (5.5, 16.0, 6.0, 4.0),
        (-1.0, 4.5, -1.0, 76.0),
        (-1.0, 4.5, 2.0, 76.0),
    ];

    #[test]
    fn ties_go_where_gdal_grid_puts_them() {
        let points = reversed_lattice();
        let nearest = NearestPoints::new(&points);
        for &(x, y, r, want) in TIE_CASES {
            assert_eq!(nearest.value(x, y, r), Some(want), "({x}, {y}) radius {r}");
        }
        // The same cases by input order alone would differ: this is the quadtree's order.
        let input_order: Vec<usize> = (0..points.len()).collect();
        let by_input = reference(&points, &input_order, nearest.initial_radius, 1.5, 20.0, -1.0);
        assert_eq!(by_input, Some(9.0));
    }

    // ---- against gdal_grid itself ----

    /// Runs `gdal_grid -a linear:radius=R:nodata=-9999` on `points` over the given grid and
    /// compares every cell strictly outside the points' bounding box (there gdal_grid falls
    /// back to its nearest point: the bounding box is the hull of the point sets used, or
    /// the cell is outside the hull anyway) with `NearestPoints::value`. Returns the number
    /// of cells compared, and of those where ties by input order would have differed.
    fn compare_with_gdal_grid(dir: &Path, name: &str, points: &[[f64; 3]], extent: [f64; 4], size: [usize; 2], radius: f64) -> (usize, usize) {
        let csv = dir.join(format!("{name}.csv"));
        let mut text = String::from("x,y,z\n");
        for p in points {
            text += &format!("{:?},{:?},{:?}\n", p[0], p[1], p[2]);
        }
        std::fs::write(&csv, text).unwrap();
        let vrt = dir.join(format!("{name}.vrt"));
        std::fs::write(
            &vrt,
            format!(
                "<OGRVRTDataSource><OGRVRTLayer name=\"{name}\"><SrcDataSource>{}</SrcDataSource><GeometryType>wkbPoint</GeometryType>\
                 <GeometryField encoding=\"PointFromColumns\" x=\"x\" y=\"y\" z=\"z\"/></OGRVRTLayer></OGRVRTDataSource>",
                csv.display()
            ),
        )
        .unwrap();
        let out = dir.join(format!("{name}.img"));
        let [xmin, xmax, ymin, ymax] = extent;
        let [nx, ny] = size;
        let status = Command::new("gdal_grid")
            .env("GDAL_NUM_THREADS", "1")
            .args(["-q", "-a", &format!("linear:radius={radius:?}:nodata=-9999"), "-ot", "Float64", "-of", "ENVI"])
            .args(["-txe", &format!("{xmin:?}"), &format!("{xmax:?}"), "-tye", &format!("{ymin:?}"), &format!("{ymax:?}")])
            .args(["-outsize", &nx.to_string(), &ny.to_string(), "-l", name])
            .arg(&vrt)
            .arg(&out)
            .status()
            .expect("running gdal_grid");
        assert!(status.success(), "gdal_grid failed on {name} (radius {radius})");
        let bytes = std::fs::read(&out).unwrap();
        assert_eq!(bytes.len(), nx * ny * 8, "{name}: unexpected ENVI output size");
        let grid: Vec<f64> = bytes.as_chunks::<8>().0.iter().map(|b| f64::from_le_bytes(*b)).collect();

        // Cell centres as gdal_grid computes them for a single block (north up, row 0 on top).
        let dx = (xmax - xmin) / nx as f64;
        let dy = (ymin - ymax) / ny as f64;
        let dxb = ((xmin + dx * nx as f64) - xmin) / nx as f64;
        let dyb = ((ymax + dy * ny as f64) - ymax) / ny as f64;
        let b = point_bounds(points);
        let nearest = NearestPoints::new(points);
        let by_input = NearestPoints::with_order(points, &(0..points.len() as u32).collect::<Vec<u32>>());
        let (mut compared, mut order_mattered) = (0, 0);
        for j in 0..ny {
            let y = ymax + (j as f64 + 0.5) * dyb;
            for i in 0..nx {
                let x = xmin + (i as f64 + 0.5) * dxb;
                if x >= b.minx && x <= b.maxx && y >= b.miny && y <= b.maxy {
                    continue;
                }
                let gdal = grid[j * nx + i];
                let ours = nearest.value(x, y, radius).unwrap_or(-9999.0);
                assert_eq!(ours.to_bits(), gdal.to_bits(), "{name} radius {radius}: cell ({i}, {j}) at ({x:?}, {y:?}): ours {ours:?}, gdal_grid {gdal:?}");
                compared += 1;
                order_mattered += usize::from(by_input.value(x, y, radius).unwrap_or(-9999.0).to_bits() != gdal.to_bits());
            }
        }
        (compared, order_mattered)
    }

    #[test]
    fn matches_gdal_grid() {
        let version = Command::new("gdal_grid").arg("--version").output().ok().filter(|o| o.status.success());
        let Some(version) = version.map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string()) else {
            if std::env::var("TILERASTER_SKIP_GDAL").as_deref() == Ok("1") {
                eprintln!("matches_gdal_grid: SKIPPED (gdal_grid not found, TILERASTER_SKIP_GDAL=1)");
                return;
            }
            panic!("gdal_grid (GDAL 3.6.2, package gdal-bin) is not on PATH: install it, or set TILERASTER_SKIP_GDAL=1 to skip this comparison");
        };
        // The reproduced behaviour is 3.6.2's; another version may legitimately differ.
        eprintln!("matches_gdal_grid: {version}");
        if !version.contains("GDAL 3.6.") {
            eprintln!("matches_gdal_grid: warning: this is not GDAL 3.6.x, whose behaviour is the one reproduced");
        }
        /// Removes the scratch folder also when a comparison fails.
        struct Scratch(std::path::PathBuf);
        impl Drop for Scratch {
            fn drop(&mut self) {
                std::fs::remove_dir_all(&self.0).ok();
            }
        }
        let scratch = Scratch(std::env::temp_dir().join(format!("tileraster-nearest-{}", std::process::id())));
        let dir = scratch.0.clone();
        std::fs::create_dir_all(&dir).unwrap();
        let mut rng = Rng(2024);
        let (mut total, mut total_mattered) = (0, 0);
        let mut run = |name: &str, points: &[[f64; 3]], extent: [f64; 4], size: [usize; 2], radii: &[f64]| {
            for &r in radii {
                let (n, mattered) = compare_with_gdal_grid(&dir, name, points, extent, size, r);
                eprintln!("gdal_grid {name}: {} points, radius {r}: {n} cells equal ({mattered} decided by GDAL's tree order)", points.len());
                total += n;
                total_mattered += mattered;
            }
        };

        // The 4 corners make the bounding box the hull.
        let corners = [[0.0, 0.0, 1.5], [100.0, 0.0, 2.5], [100.0, 100.0, 3.5], [0.0, 100.0, 4.5]];
        let mut random: Vec<[f64; 3]> = corners.to_vec();
        random.extend((0..300).map(|_| [rng.uniform(0.0, 100.0, 3), rng.uniform(0.0, 100.0, 3), rng.uniform(0.0, 1000.0, 3)]));
        run("random", &random, [-150.0, 250.0, -150.0, 250.0], [160, 160], &[-1.0, 0.0, 7.5, 40.0]);

        let mut many: Vec<[f64; 3]> = corners.to_vec();
        many.extend((0..3000).map(|_| [rng.uniform(0.0, 100.0, 2), rng.uniform(0.0, 100.0, 2), rng.uniform(-50.0, 50.0, 6)]));
        run("many", &many, [-60.3, 170.1, -80.7, 130.9], [231, 197], &[-1.0, 2.0, 25.0]);

        // Lattice with exact ties: cell centres at multiples of 0.5; every position twice,
        // with different z.
        let mut grid = lattice(11, 11, 1.0);
        let again: Vec<[f64; 3]> = grid.iter().map(|p| [p[0], p[1], p[2] + 1000.0]).collect();
        grid.extend(again);
        run("lattice", &grid, [-10.25, 20.25, -10.25, 20.25], [61, 61], &[-1.0, 0.0, 0.5, 1.0, 2.5, 6.0]);

        let small = lattice(4, 4, 1.0);
        run("small", &small, [-2.25, 5.25, -2.25, 5.25], [15, 15], &[-1.0, 1.0, 1.5]);
        run("reversed", &reversed_lattice(), [-10.25, 20.25, -10.25, 20.25], [61, 61], &[-1.0, 0.5, 1.0, 2.5, 6.0]);

        // Integer positions in random order: ties and repeated positions everywhere.
        let mut coarse: Vec<[f64; 3]> = vec![[0.0, 0.0, 0.25], [30.0, 0.0, 0.5], [30.0, 30.0, 0.75], [0.0, 30.0, 1.25]];
        coarse.extend((0..600).map(|k| [rng.uniform(0.0, 30.0, 0), rng.uniform(0.0, 30.0, 0), k as f64]));
        coarse.swap(0, 300);
        run("coarse", &coarse, [-20.25, 50.25, -20.25, 50.25], [141, 141], &[-1.0, 0.5, 1.0, 3.0]);

        let (dups, name) = duplicates_case();
        run(name, &dups, [-5.5, 15.5, -5.5, 15.5], [42, 42], &[-1.0, 2.0, 5.0]);

        drop(scratch);
        eprintln!("matches_gdal_grid: {total} cells compared, all bit-identical; {total_mattered} of them decided by GDAL's tree order");
        assert!(total_mattered > 0, "no cell exercised GDAL's tie order");
    }
}
