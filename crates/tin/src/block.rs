//! A block's share of the TIN, proven to be the whole point set's there, from the points of
//! the block's window and a buffer around it only.
//!
//! A triangle of the points in a region `R` is a triangle of all the points when no point
//! outside `R` can change it: its closed circumdisc holds no point of the whole set but the
//! region's (an empty circle, and the perturbation that breaks cocircular ties, `canonical`,
//! looks only at the points on the circle). All points lie in their convex hull `H`, known
//! beforehand ([`Hull`]: cheap, and small, to compute from every point or from each file's
//! hull), so it is enough that the disc meets no part of `H` outside `R`. An edge of the
//! region's hull is an edge of the whole TIN's hull exactly when it lies on `H`'s boundary.
//!
//! [`triangulate_block`] keeps the region's triangles that meet the window (exactly),
//! and proves each of them, and that each edge of the region's hull that faces the window lies
//! on `H`'s boundary. Then the kept triangles are exactly the whole TIN's triangles over the
//! window: a point of the window inside a triangle `T` of the whole TIN is either inside the
//! region's hull, in a kept triangle, which is a triangle of the whole TIN and so is `T`; or
//! outside an edge of the region's hull that faces the window, and so outside `H`, which `T`
//! is not. Where a proof fails the buffer doubles, until the region holds `H` and the TIN is
//! the whole one.
//!
//! The hull tests are exact (robust's orientation predicate on input points). The disc test
//! is evaluated in `f64` with an error bound at least four times the first-order bound of each
//! step, and counts as failed when the bound leaves the answer open: it may grow a buffer
//! needlessly, never accept a triangle wrongly.

use crate::{COORDINATE_LIMIT, Tin, TinError, triangulate_with_hull};
use robust::{Coord, orient2d};

/// A closed rectangle of the plane, `[x0, x1] × [y0, y1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Rect {
    /// The rectangle that holds and meets nothing.
    pub const EMPTY: Rect = Rect { x0: f64::INFINITY, y0: f64::INFINITY, x1: f64::NEG_INFINITY, y1: f64::NEG_INFINITY };

    /// The least rectangle holding the points' x and y; `None` for no points.
    pub fn around<const N: usize>(points: &[[f64; N]]) -> Option<Rect> {
        let (first, rest) = points.split_first()?;
        let start = Rect { x0: first[0], y0: first[1], x1: first[0], y1: first[1] };
        Some(rest.iter().fold(start, |r, p| Rect { x0: r.x0.min(p[0]), y0: r.y0.min(p[1]), x1: r.x1.max(p[0]), y1: r.y1.max(p[1]) }))
    }

    /// Whether `(x, y)` lies in the rectangle or on its edges.
    pub fn holds(&self, x: f64, y: f64) -> bool {
        (self.x0..=self.x1).contains(&x) && (self.y0..=self.y1).contains(&y)
    }

    /// Whether `other` lies wholly inside this rectangle.
    pub fn covers(&self, other: &Rect) -> bool {
        self.x0 <= other.x0 && other.x1 <= self.x1 && self.y0 <= other.y0 && other.y1 <= self.y1
    }

    /// Whether the two rectangles share a point.
    pub fn meets(&self, other: &Rect) -> bool {
        self.x0 <= other.x1 && other.x0 <= self.x1 && self.y0 <= other.y1 && other.y0 <= self.y1
    }

    /// The rectangle with `by` more on every side.
    pub fn grown(&self, by: f64) -> Rect {
        Rect { x0: self.x0 - by, y0: self.y0 - by, x1: self.x1 + by, y1: self.y1 + by }
    }

    /// Whether the segment `a`–`b` meets the rectangle (Liang and Barsky's clip, in `f64`).
    fn crossed_by(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        let (mut enter, mut exit) = (0.0f64, 1.0f64);
        for (axis, lo, hi) in [(0, self.x0, self.x1), (1, self.y0, self.y1)] {
            let d = b[axis] - a[axis];
            if d == 0.0 {
                if a[axis] < lo || a[axis] > hi {
                    return false;
                }
                continue;
            }
            let (t0, t1) = ((lo - a[axis]) / d, (hi - a[axis]) / d);
            enter = enter.max(t0.min(t1));
            exit = exit.min(t0.max(t1));
        }
        enter <= exit
    }

    /// Whether the triangle `t` (x and y of its corners) and the rectangle share a point:
    /// exact (orientation predicates on the input coordinates).
    pub fn meets_triangle(&self, t: [[f64; 3]; 3]) -> bool {
        let at = |p: [f64; 3]| Coord { x: p[0], y: p[1] };
        let ccw = orient2d(at(t[0]), at(t[1]), at(t[2])) > 0.0;
        // Separated when all four corners lie strictly outside one of the triangle's edges.
        let separated = (0..3).any(|k| {
            let (p, q) = (at(t[k]), at(t[(k + 1) % 3]));
            self.corners().iter().all(|&w| {
                let side = orient2d(p, q, w);
                if ccw { side < 0.0 } else { side > 0.0 }
            })
        });
        Rect::around(&t).is_some_and(|b| b.meets(self)) && !separated
    }

    fn corners(&self) -> [Coord<f64>; 4] {
        [Coord { x: self.x0, y: self.y0 }, Coord { x: self.x1, y: self.y0 }, Coord { x: self.x1, y: self.y1 }, Coord { x: self.x0, y: self.y1 }]
    }
}

/// The convex hull of a point set's x and y: its corners, counter-clockwise, without
/// collinear ones; exact (robust's predicates on the input's own coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct Hull {
    corners: Vec<[f64; 2]>,
}

impl Hull {
    /// The hull of `points` (x, y first; non-finite points are left out).
    pub fn of<const N: usize>(points: &[[f64; N]]) -> Hull {
        Hull::around(points.iter().map(|p| [p[0] + 0.0, p[1] + 0.0]).filter(|p| p[0].is_finite() && p[1].is_finite()).collect())
    }

    /// The hull of several hulls: of a point set whose parts (files) have these hulls.
    pub fn of_hulls(hulls: &[Hull]) -> Hull {
        Hull::around(hulls.iter().flat_map(|h| h.corners.iter().copied()).collect())
    }

    /// Andrew's monotone chain, with exact turns.
    fn around(mut points: Vec<[f64; 2]>) -> Hull {
        points.sort_by(|a, b| a.partial_cmp(b).expect("finite"));
        points.dedup();
        if points.len() < 3 {
            return Hull { corners: points };
        }
        let turn = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| orient2d(Coord { x: a[0], y: a[1] }, Coord { x: b[0], y: b[1] }, Coord { x: c[0], y: c[1] });
        let half = |ordered: &mut dyn Iterator<Item = [f64; 2]>| {
            let mut chain: Vec<[f64; 2]> = Vec::new();
            for p in ordered {
                while chain.len() >= 2 && turn(chain[chain.len() - 2], chain[chain.len() - 1], p) <= 0.0 {
                    chain.pop();
                }
                chain.push(p);
            }
            // Its last corner is the other half's first.
            chain.pop();
            chain
        };
        let mut chain = half(&mut points.iter().copied());
        chain.extend(half(&mut points.iter().rev().copied()));
        Hull { corners: chain }
    }

    /// The corners, counter-clockwise.
    pub fn corners(&self) -> &[[f64; 2]] {
        &self.corners
    }

    /// The least rectangle holding the hull.
    pub fn bounds(&self) -> Option<Rect> {
        Rect::around(&self.corners)
    }

    /// Whether `(x, y)` lies in the closed hull (exactly).
    pub fn holds(&self, x: f64, y: f64) -> bool {
        let p = Coord { x, y };
        match self.corners.len() {
            0 => false,
            1 => self.corners[0] == [x, y],
            // A segment's two edges hold its whole line: its box bounds it.
            2 => self.edges().all(|(a, b)| orient2d(a, b, p) == 0.0) && self.bounds().is_some_and(|r| r.holds(x, y)),
            _ => self.edges().all(|(a, b)| orient2d(a, b, p) >= 0.0),
        }
    }

    /// Whether `rect` lies inside the hull, off its boundary (exactly): no point of `rect`
    /// can be a corner of the hull or move it.
    pub fn surrounds(&self, rect: &Rect) -> bool {
        let corners = [[rect.x0, rect.y0], [rect.x1, rect.y0], [rect.x1, rect.y1], [rect.x0, rect.y1]];
        self.corners.len() >= 3 && corners.iter().all(|&[x, y]| self.edges().all(|(a, b)| orient2d(a, b, Coord { x, y }) > 0.0))
    }

    /// Whether the segment `p`–`q` lies on the hull's boundary (exactly).
    fn bears(&self, p: Coord<f64>, q: Coord<f64>) -> bool {
        self.edges().any(|(a, b)| {
            let span = Rect { x0: a.x.min(b.x), y0: a.y.min(b.y), x1: a.x.max(b.x), y1: a.y.max(b.y) };
            orient2d(a, b, p) == 0.0 && orient2d(a, b, q) == 0.0 && span.holds(p.x, p.y) && span.holds(q.x, q.y)
        })
    }

    fn edges(&self) -> impl Iterator<Item = (Coord<f64>, Coord<f64>)> + '_ {
        let at = |p: [f64; 2]| Coord { x: p[0], y: p[1] };
        (0..self.corners.len()).map(move |k| (at(self.corners[k]), at(self.corners[(k + 1) % self.corners.len()])))
    }

    /// Bands of `width` along every edge of the hull, and no rectangle: where the blocks at
    /// the hull find their bands' points.
    pub fn strip(&self, width: f64) -> Region {
        let n = self.corners.len();
        let bands = if n < 3 { Vec::new() } else { (0..n).map(|k| Band::new(self.corners[k], self.corners[(k + 1) % n], width)).collect() };
        Region { rect: Rect::EMPTY, bands, discs: Vec::new() }
    }

    /// `rect` with bands of `width` along the hull's edges that cross it (a rectangle inside
    /// the hull has none: no thin triangle along an edge reaches its window).
    fn region(&self, rect: Rect, width: f64, discs: &[Disc]) -> Region {
        let bands = match self.corners.len() {
            0..=2 => Vec::new(),
            n => (0..n)
                .map(|k| (self.corners[k], self.corners[(k + 1) % n]))
                .filter(|&(a, b)| rect.crossed_by(a, b))
                .map(|(a, b)| Band::new(a, b, width))
                .collect(),
        };
        Region { rect, bands, discs: discs.to_vec() }
    }

    /// Where points of the hull may lie that `region` does not hold: the hull less half of
    /// each band (the other half is margin for the rounding of both), cut beyond each side of
    /// the rectangle (west, east, south, north: closed, empty where nothing reaches past the
    /// side; intersections rounded, which the disc test's slack covers).
    fn outside(&self, region: &Region) -> [Vec<[f64; 2]>; 4] {
        let inner = region.bands.iter().fold(self.corners.clone(), |polygon, band| band.clip(&polygon, band.width / 2.0));
        let r = region.rect;
        [(0, r.x0, true), (0, r.x1, false), (1, r.y0, true), (1, r.y1, false)].map(|(axis, at, below)| cut(&inner, axis, at, below))
    }
}

/// The part of a block's plane whose points it reads: a rectangle around its window, and
/// bands inside the hull along the hull's edges that pass near it. The triangles along a hull
/// edge are thin and may reach as far as the edge does; a band holds their corners (and, being
/// thin, little else), where a rectangle would have to grow along the whole edge.
#[derive(Debug, Clone)]
pub struct Region {
    pub rect: Rect,
    bands: Vec<Band>,
    discs: Vec<Disc>,
}

impl Region {
    /// Whether the region holds `(x, y)`: rounding may add points near its borders, never
    /// leave one out by more than a band's half.
    pub fn holds(&self, x: f64, y: f64) -> bool {
        self.rect.holds(x, y) || self.bands.iter().any(|band| band.holds([x, y])) || self.discs.iter().any(|disc| disc.holds(x, y))
    }

    /// Whether the region may hold points of `rect` (a file's bounds, say).
    pub fn meets(&self, rect: &Rect) -> bool {
        let corners = [[rect.x0, rect.y0], [rect.x1, rect.y0], [rect.x1, rect.y1], [rect.x0, rect.y1]];
        self.rect.meets(rect) || self.bands.iter().any(|band| corners.iter().any(|&c| band.holds(c))) || self.discs.iter().any(|disc| disc.meets(rect))
    }

    /// The rectangle alone.
    pub fn rect(rect: Rect) -> Region {
        Region { rect, bands: Vec::new(), discs: Vec::new() }
    }

    /// Its discs alone, without its rectangle and bands.
    pub fn discs_only(&self) -> Region {
        Region { rect: Rect::EMPTY, bands: Vec::new(), discs: self.discs.clone() }
    }

    /// Whether it has discs.
    pub fn has_discs(&self) -> bool {
        !self.discs.is_empty()
    }

    /// The widest band (0 without bands).
    pub fn band_width(&self) -> f64 {
        self.bands.iter().fold(0.0, |w, band| w.max(band.width))
    }
}

/// The hull's points within `width` of the line of its edge `a` → `b`.
#[derive(Debug, Clone, Copy)]
struct Band {
    a: [f64; 2],
    b: [f64; 2],
    width: f64,
    /// `width` times the edge's length: [`Band::holds`] compares it with a cross product,
    /// which saves a root a point.
    reach: f64,
}

impl Band {
    fn new(a: [f64; 2], b: [f64; 2], width: f64) -> Band {
        Band { a, b, width, reach: width * (b[0] - a[0]).hypot(b[1] - a[1]) }
    }

    /// Whether `p` lies within the band's width inside the edge's line (or beyond the line).
    fn holds(&self, p: [f64; 2]) -> bool {
        (self.b[0] - self.a[0]) * (p[1] - self.a[1]) - (self.b[1] - self.a[1]) * (p[0] - self.a[0]) <= self.reach
    }

    /// How far `p` lies inside the edge's line (the hull is counter-clockwise), in `f64`.
    fn depth(&self, p: [f64; 2]) -> f64 {
        let (ex, ey) = (self.b[0] - self.a[0], self.b[1] - self.a[1]);
        (ex * (p[1] - self.a[1]) - ey * (p[0] - self.a[0])) / ex.hypot(ey)
    }

    /// The convex `polygon` cut to the points at least `depth` inside the edge's line.
    fn clip(&self, polygon: &[[f64; 2]], depth: f64) -> Vec<[f64; 2]> {
        clip(polygon, |p| self.depth(p) - depth)
    }
}

/// The convex polygon `polygon` cut to `p[axis] ≤ at` (`below`) or `≥ at`.
fn cut(polygon: &[[f64; 2]], axis: usize, at: f64, below: bool) -> Vec<[f64; 2]> {
    clip(polygon, |p| if below { at - p[axis] } else { p[axis] - at })
}

/// The convex `polygon` cut to where the affine function `side` is at least 0 (Sutherland and
/// Hodgman's step); the crossings are interpolated, so rounded.
fn clip(polygon: &[[f64; 2]], side: impl Fn([f64; 2]) -> f64) -> Vec<[f64; 2]> {
    let mut part = Vec::new();
    for k in 0..polygon.len() {
        let (a, b) = (polygon[k], polygon[(k + 1) % polygon.len()]);
        let (sa, sb) = (side(a), side(b));
        if sa >= 0.0 {
            part.push(a);
        }
        if (sa >= 0.0) != (sb >= 0.0) {
            let t = sa / (sa - sb);
            part.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    part
}

/// A block's triangles of the whole point set's TIN ([`triangulate_block`]).
#[derive(Debug, Clone)]
pub struct BlockTin {
    /// The region's points (the first at each position, in input order) and, of their
    /// triangles, those that meet the window, in the whole TIN's order;
    /// `tin.source` indexes the whole point set.
    pub tin: Tin,
    /// The rectangle whose points were triangulated: the window and the buffer that proved it.
    pub region: Rect,
    /// The width of the bands along the hull's edges whose points were triangulated too (0
    /// when none was needed).
    pub band: f64,
    /// The region's points, repeats included.
    pub points: usize,
    /// Regions triangulated, the last one included (1 when the first buffer sufficed).
    pub attempts: u32,
    /// Discs read around circles too wide for the rectangle (0 for none).
    pub discs: usize,
}

/// Where a block's points come from: the whole point set, which [`triangulate_block_from`]
/// asks for a region's share at a time (all of it in memory, or files read as a region
/// reaches them).
pub trait BlockSource {
    /// What reading points may fail with; a refused triangulation is one too.
    type Error: From<TinError>;

    /// How many points the whole set has, repeats included.
    fn total(&self) -> usize;

    /// The whole set's points that `region` holds (all of them for `None`), in the set's
    /// order, each with its index in the set; more may come, never fewer.
    fn within(&mut self, region: Option<&Region>) -> Result<Vec<(usize, [f64; 3])>, Self::Error>;

    /// About how many points `region` holds (more rather than fewer): what reading it costs,
    /// to choose between ways to grow a region.
    fn estimate(&self, region: &Region) -> usize;
}

/// A point set in memory is its own source.
struct InMemory<'a>(&'a [[f64; 3]]);

impl BlockSource for InMemory<'_> {
    type Error = TinError;

    fn total(&self) -> usize {
        self.0.len()
    }

    fn within(&mut self, region: Option<&Region>) -> Result<Vec<(usize, [f64; 3])>, TinError> {
        let inside = |p: &[f64; 3]| region.is_none_or(|r| r.holds(p[0], p[1]));
        Ok(self.0.iter().copied().enumerate().filter(|(_, p)| inside(p)).collect())
    }

    fn estimate(&self, region: &Region) -> usize {
        self.0.iter().filter(|p| region.holds(p[0], p[1])).count()
    }
}

/// The triangles of `points`' TIN (as [`crate::triangulate`] makes it) over `window`, from
/// the points of the window and a buffer around it ([`triangulate_block_from`]).
pub fn triangulate_block(points: &[[f64; 3]], hull: &Hull, window: Rect) -> Result<BlockTin, TinError> {
    // Every point is checked, as the whole triangulation checks them, not only a region's.
    for (index, &[x, y, z]) in points.iter().enumerate() {
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return Err(TinError::NonFinite { index, x, y, z });
        }
    }
    triangulate_block_from(&mut InMemory(points), hull, window)
}

/// The buffer a block's first region has beyond its window, for `total` points in `hull`:
/// 16 mean spacings, which hold the circumcircles of most blocks' triangles at once. The
/// bands along the hull's edges start at an eighth of it, and double.
pub fn first_buffer(hull: &Hull, total: usize) -> f64 {
    let Some(b) = hull.bounds() else { return 0.0 };
    let spacing = ((b.x1 - b.x0) * (b.y1 - b.y0) / total.max(1) as f64).sqrt();
    16.0 * if spacing > 0.0 { spacing } else { (b.x1 - b.x0).max(b.y1 - b.y0) }
}

/// The triangles of the TIN of `source`'s whole point set over `window`, from the points of
/// the window and a buffer around it, grown until the module's proof holds (or until it holds
/// a quarter of the points: then all of them). `hull` must hold every point: a point of a
/// region outside it is [`TinError::OutsideHull`].
pub fn triangulate_block_from<S: BlockSource>(source: &mut S, hull: &Hull, window: Rect) -> Result<BlockTin, S::Error> {
    let total = source.total();
    let bounds = hull.bounds().ok_or(TinError::TooFew { distinct: 0 })?;
    let mut buffer = [first_buffer(hull, total); 4];
    // Bands start thin: the triangles along a hull edge lie within about a spacing of it.
    let mut band = buffer[0] / 8.0;
    let first = buffer[0];
    let mut discs: Vec<Disc> = Vec::new();
    let mut attempts = 0;
    loop {
        attempts += 1;
        let rect = Rect { x0: window.x0 - buffer[0], x1: window.x1 + buffer[1], y0: window.y0 - buffer[2], y1: window.y1 + buffer[3] };
        let region = hull.region(rect, band, &discs);
        let mut whole = rect.covers(&bounds) || buffer.iter().any(|b| *b >= COORDINATE_LIMIT);
        let mut chosen = source.within((!whole).then_some(&region))?;
        // A region of more than a quarter of the points costs about the whole TIN: take it all,
        // so that a block never costs much more than the whole.
        if !whole && chosen.len() > total / 4 {
            whole = true;
            chosen = source.within(None)?;
        }
        if let Some(&(index, [x, y, z])) = chosen.iter().find(|(_, p)| !p.iter().all(|c| c.is_finite())) {
            return Err(TinError::NonFinite { index, x, y, z }.into());
        }
        if let Some(&(index, [x, y, _])) = chosen.iter().find(|(_, p)| !hull.holds(p[0] + 0.0, p[1] + 0.0)) {
            return Err(TinError::OutsideHull { index, x, y }.into());
        }
        let local: Vec<[f64; 3]> = chosen.iter().map(|&(_, p)| p).collect();
        let outside = hull.outside(&region);
        let unproven = match triangulate_with_hull(&local) {
            Ok((mut tin, local_hull)) => {
                let vertices = &tin.scene.vertices;
                let kept: Vec<[u32; 3]> = tin.scene.triangles.iter().copied().filter(|t| window.meets_triangle(t.map(|v| vertices[v as usize]))).collect();
                // Circles wider than the first buffer (across a lake, a removed building) may be
                // read as discs, when that costs fewer points than growing the rectangle.
                let wide = if discs.len() < MAX_DISCS { first } else { f64::INFINITY };
                let Unproven { mut sides, wide_sides, wide_circles } =
                    if whole { Unproven::default() } else { unproven_sides(&tin, &kept, &local_hull, hull, &region, &outside, &window, wide) };
                if !wide_circles.is_empty() {
                    let mut with_discs = discs.clone();
                    with_discs.extend(wide_circles.iter().map(|c| c.read_as(first / 8.0)));
                    let grown = grown_sides(buffer, sides | wide_sides, &outside);
                    let rect_grown = Rect { x0: window.x0 - grown[0], x1: window.x1 + grown[1], y0: window.y0 - grown[2], y1: window.y1 + grown[3] };
                    if source.estimate(&hull.region(rect, band, &with_discs)) <= source.estimate(&hull.region(rect_grown, band, &discs)) {
                        discs = with_discs;
                        if sides == 0 {
                            continue;
                        }
                    } else {
                        sides |= wide_sides;
                    }
                }
                let unproven = sides;
                if unproven == 0 {
                    tin.scene.triangles = kept;
                    tin.source.iter_mut().for_each(|s| *s = chosen[*s].0);
                    let (region, band) = match whole {
                        true => (Rect { x0: rect.x0.min(bounds.x0), y0: rect.y0.min(bounds.y0), x1: rect.x1.max(bounds.x1), y1: rect.y1.max(bounds.y1) }, 0.0),
                        false => (rect, region.band_width()),
                    };
                    return Ok(BlockTin { tin, region, band, discs: if whole { 0 } else { discs.len() }, points: chosen.len(), attempts });
                }
                unproven
            }
            // Too few points, or all on a line: a larger region has more.
            Err(TinError::TooFew { .. } | TinError::Collinear { .. }) if !whole => ALL_SIDES,
            Err(TinError::OutOfRange { index, x, y, limit }) => return Err(TinError::OutOfRange { index: chosen[index].0, x, y, limit }.into()),
            Err(e) => return Err(e.into()),
        };
        buffer = grown_sides(buffer, unproven, &outside);
        // A triangle along a hull edge whose disc reaches deeper than the bands: wider bands.
        if unproven & BANDS != 0 {
            band *= 2.0;
        }
    }
}

/// Sides of a region, as bits (west, east, south, north), and its bands.
type Sides = u8;
const ALL_SIDES: Sides = 0b1111;
const BANDS: Sides = 0b10000;

/// At most this many discs a block reads ([`Disc`]); beyond, its rectangle grows.
const MAX_DISCS: usize = 64;

/// The buffers with the sides the proof failed on doubled, of those the hull reaches past (all
/// of those when it failed on none of them).
fn grown_sides(mut buffer: [f64; 4], unproven: Sides, outside: &[Vec<[f64; 2]>; 4]) -> [f64; 4] {
    let reaching = (0..4).filter(|&k| !outside[k].is_empty()).fold(0, |m, k| m | 1 << k);
    let grow = if unproven & reaching != 0 { unproven & reaching } else { reaching };
    (0..4).filter(|&k| grow & 1 << k != 0).for_each(|k| buffer[k] *= 2.0);
    buffer
}

/// What a region left unproven ([`unproven_sides`]).
#[derive(Default)]
struct Unproven {
    /// Sides (and bands) to grow.
    sides: Sides,
    /// The sides the wide circles failed on, should the rectangle grow for them instead.
    wide_sides: Sides,
    /// Circles wider than asked that failed, one for each that nearly coincide.
    wide_circles: Vec<Circle>,
}

/// The sides (bits of [`Sides`]) beyond which a point could change the kept triangles: where
/// a kept triangle's circumdisc may meet the hull's part beyond the side (`outside`), or an
/// edge of the region's hull (`local_hull`) that faces the window is not on the whole hull's
/// boundary (the hull's parts it faces); 0 when the block is proven.
/// A kept triangle with a corner in a band whose disc is unclear adds [`BANDS`].
/// A kept triangle whose circle lies inside one of the region's discs is proven; one whose
/// unclear circle is wider than `wide` is returned apart.
#[allow(clippy::too_many_arguments)]
fn unproven_sides(
    tin: &Tin,
    kept: &[[u32; 3]],
    local_hull: &[[u32; 2]],
    hull: &Hull,
    region: &Region,
    outside: &[Vec<[f64; 2]>; 4],
    window: &Rect,
    wide: f64,
) -> Unproven {
    let at = |v: u32| {
        let p = tin.scene.vertices[v as usize];
        Coord { x: p[0] + 0.0, y: p[1] + 0.0 }
    };
    let mut unproven = 0;
    for &[p, q] in local_hull {
        let (p, q) = (at(p), at(q));
        let faces_window = window.corners().iter().any(|&w| orient2d(p, q, w) < 0.0);
        if faces_window && !hull.bears(p, q) {
            let beyond = |part: &Vec<[f64; 2]>| part.iter().any(|&[x, y]| orient2d(p, q, Coord { x, y }) <= 0.0);
            unproven |= (0..4).filter(|&k| beyond(&outside[k])).fold(0, |m, k| m | 1 << k);
            unproven |= ALL_SIDES * u8::from(unproven == 0);
        }
    }
    let bounds = outside.each_ref().map(|part| Rect::around(part));
    let in_band = |c: Coord<f64>| region.bands.iter().any(|band| band.holds([c.x, c.y]));
    let mut result = Unproven { sides: unproven, ..Unproven::default() };
    for t in kept {
        let corners = t.map(at);
        let circle = Circle::through(corners);
        if circle.is_some_and(|c| region.discs.iter().any(|disc| c.inside(disc))) {
            continue;
        }
        let unclear = disc_unclear(corners, outside, &bounds);
        match circle {
            _ if unclear == 0 => {}
            Some(c) if c.r_hi > wide => {
                result.wide_sides |= unclear;
                // One disc for circles that nearly coincide (a round lake's shore).
                if !result.wide_circles.iter().any(|w| c.inside(&w.read_as(0.0))) {
                    result.wide_circles.push(c);
                }
            }
            _ => result.sides |= unclear | if corners.iter().any(|&c| in_band(c)) { BANDS } else { 0 },
        }
    }
    result
}

/// A triangle's circumcircle as `f64` computes it, with rigorous bounds: the true centre lies
/// within `centre_err` of `centre`, and the true radius is at most `r_hi`.
#[derive(Debug, Clone, Copy)]
struct Circle {
    centre: [f64; 2],
    centre_err: f64,
    r_hi: f64,
}

impl Circle {
    /// `None` for a triangle too thin for the bounds to be useful.
    fn through([a, b, c]: [Coord<f64>; 3]) -> Option<Circle> {
        // Unit roundoff; each bound below is at least four times the first-order error of the
        // operations it covers (relative errors of `u` per rounding, on the magnitudes bounded).
        const U: f64 = f64::EPSILON / 2.0;
        let (bx, by, cx, cy) = (b.x - a.x, b.y - a.y, c.x - a.x, c.y - a.y);
        let l = bx.abs().max(by.abs()).max(cx.abs()).max(cy.abs());
        // Twice the signed area, and the circumcentre relative to `a`: `u = n / d`.
        let d = 2.0 * (bx * cy - by * cx);
        let d_err = 64.0 * U * l * l;
        if d.is_nan() || d.abs() <= 2.0 * d_err {
            return None;
        }
        let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
        let (ux, uy) = ((cy * b2 - by * c2) / d, (bx * c2 - cx * b2) / d);
        let u = ux.abs().max(uy.abs());
        let n_err = 256.0 * U * l * l * l;
        // |n/d − ñ/d̃| ≤ (|n − ñ| + |u|·|d − d̃|) / (|d̃| − |d − d̃|), and |d̃| > 2·d_err.
        let u_err = 2.0 * (n_err + 2.0 * u * d_err) / d.abs() + 8.0 * U * u;
        let centre = [a.x + ux, a.y + uy];
        let centre_err = u_err + 8.0 * U * (a.x.abs().max(a.y.abs()) + u);
        let r_hi = ux.hypot(uy) * (1.0 + 16.0 * U) + 2.0 * u_err;
        Some(Circle { centre, centre_err, r_hi })
    }

    /// Whether every point of the closed disc lies in `disc`, by a margin that covers the
    /// rounding of `disc`'s own test ([`Disc::holds`]).
    fn inside(&self, disc: &Disc) -> bool {
        let gap = (self.centre[0] - disc.centre[0]).hypot(self.centre[1] - disc.centre[1]);
        gap + self.centre_err + self.r_hi <= disc.radius * (1.0 - 1e-9)
    }

    /// The disc a block reads around it: a quarter wider, and `margin` more.
    fn read_as(&self, margin: f64) -> Disc {
        Disc { centre: self.centre, radius: 1.25 * self.r_hi + self.centre_err + margin }
    }
}

/// A disc whose points a block reads: around a triangle's circumcircle too wide for the
/// rectangle, such as one across a lake, whose disc is empty but for its shore.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    pub centre: [f64; 2],
    pub radius: f64,
}

impl Disc {
    /// Whether `(x, y)` lies in the closed disc (in `f64`).
    pub fn holds(&self, x: f64, y: f64) -> bool {
        let (dx, dy) = (x - self.centre[0], y - self.centre[1]);
        dx * dx + dy * dy <= self.radius * self.radius
    }

    /// Whether the disc meets `rect`.
    pub fn meets(&self, rect: &Rect) -> bool {
        let (gx, gy) = ((rect.x0 - self.centre[0]).max(self.centre[0] - rect.x1).max(0.0), (rect.y0 - self.centre[1]).max(self.centre[1] - rect.y1).max(0.0));
        gx * gx + gy * gy <= self.radius * self.radius
    }
}

/// The sides whose part of the hull (`parts`) the closed circumdisc of the corners may meet:
/// where the `f64` evaluation's error bound leaves it open (a thin triangle, a disc grazing a
/// part) too.
fn disc_unclear([a, b, c]: [Coord<f64>; 3], parts: &[Vec<[f64; 2]>; 4], bounds: &[Option<Rect>; 4]) -> Sides {
    let reaching = (0..4).filter(|&k| !parts[k].is_empty()).fold(0, |m, k| m | 1 << k);
    if reaching == 0 {
        return 0;
    }
    let Some(Circle { centre, centre_err, r_hi }) = Circle::through([a, b, c]) else { return reaching };
    let clear = |part: &Vec<[f64; 2]>, bounds: &Option<Rect>| {
        let Some(b) = bounds else { return true };
        // The parts' cut corners are rounded, and the distances below take a few roundings
        // of magnitudes up to `size`: 2^-40 of it is far more than either.
        let size = (centre[0].abs().max(centre[1].abs()) + r_hi).max(b.x0.abs()).max(b.x1.abs()).max(b.y0.abs()).max(b.y1.abs());
        let margin = centre_err + size * 2f64.powi(-40) + r_hi;
        // The part lies in its bounds: a disc clear of them is clear of it, and most are.
        let (gx, gy) = ((b.x0 - centre[0]).max(centre[0] - b.x1).max(0.0), (b.y0 - centre[1]).max(centre[1] - b.y1).max(0.0));
        gx.hypot(gy) > margin || distance(centre, part) > margin
    };
    (0..4).filter(|&k| !clear(&parts[k], &bounds[k])).fold(0, |m, k| m | 1 << k)
}

/// The distance from `p` to the convex polygon `polygon` (counter-clockwise; 0 inside).
fn distance(p: [f64; 2], polygon: &[[f64; 2]]) -> f64 {
    let n = polygon.len();
    let to_segment = |a: [f64; 2], b: [f64; 2]| {
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let length2 = ex * ex + ey * ey;
        let t = if length2 > 0.0 { (((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / length2).clamp(0.0, 1.0) } else { 0.0 };
        (p[0] - (a[0] + t * ex)).hypot(p[1] - (a[1] + t * ey))
    };
    let inside = n >= 3
        && (0..n).all(|k| {
            let (a, b) = (polygon[k], polygon[(k + 1) % n]);
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0.0
        });
    if inside {
        return 0.0;
    }
    (0..n).map(|k| to_segment(polygon[k], polygon[(k + 1) % n])).fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangulate;
    use tileraster_testkit::scenes::TWELVE_ON_A_CIRCLE;

    /// A hash-based generator: the tests' points without a dependency.
    fn random(seed: u64) -> impl FnMut() -> f64 {
        let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Triangles as their corners' positions, in order: comparable between TINs of other
    /// point sets.
    fn by_position(tin: &Tin) -> Vec<[[u64; 2]; 3]> {
        tin.scene.triangles.iter().map(|t| t.map(|v| tin.scene.vertices[v as usize]).map(|p| [p[0].to_bits(), p[1].to_bits()])).collect()
    }

    /// That the block's triangles are the whole TIN's over the window: a part of the whole
    /// TIN's, in its order, with each of its triangles that meets the window.
    fn assert_whole_over(points: &[[f64; 3]], block: &Tin, window: &Rect, what: &str) {
        let whole = triangulate(points).unwrap();
        let (mine, all) = (by_position(block), by_position(&whole));
        let mut rest = all.iter();
        for t in &mine {
            assert!(rest.any(|u| u == t), "{what}: {t:?} is not the whole TIN's, or out of its order");
        }
        for (t, key) in whole.scene.triangles.iter().zip(&all) {
            if window.meets_triangle(t.map(|v| whole.scene.vertices[v as usize])) {
                assert!(mine.contains(key), "{what}: the whole TIN's {key:?} meets the window and is missing");
            }
        }
    }

    /// Terrain-like points: random, with a lattice patch (cocircular squares), a ring of
    /// twelve cocircular points, a hole with no points and repeats.
    fn terrain(n: usize, seed: u64) -> Vec<[f64; 3]> {
        let mut r = random(seed);
        let mut points: Vec<[f64; 3]> = (0..n).map(|_| [r() * 1000.0, r() * 600.0, r() * 50.0]).filter(|p| (p[0] - 700.0).hypot(p[1] - 300.0) > 80.0).collect();
        points.extend((0..30 * 30).map(|k| [100.0 + (k % 30) as f64 * 4.0, 200.0 + (k / 30) as f64 * 4.0, k as f64]));
        points.extend(TWELVE_ON_A_CIRCLE.iter().map(|&(x, y)| [400.0 + x * 3.0, 450.0 + y * 3.0, 7.0]));
        let repeats: Vec<[f64; 3]> = points.iter().step_by(97).map(|p| [p[0], p[1], p[2] + 1.0]).collect();
        points.extend(repeats);
        points
    }

    #[test]
    fn a_block_has_the_whole_tins_triangles_over_its_window() {
        let points = terrain(20_000, 1);
        let hull = Hull::of(&points);
        let bounds = hull.bounds().unwrap();
        let windows = [
            Rect { x0: 0.0, y0: 0.0, x1: 1000.0, y1: 600.0 },
            Rect { x0: 90.0, y0: 190.0, x1: 130.0, y1: 260.0 },
            Rect { x0: 600.0, y0: 200.0, x1: 800.0, y1: 400.0 },
            Rect { x0: 380.0, y0: 430.0, x1: 420.0, y1: 470.0 },
            Rect { x0: -50.0, y0: -50.0, x1: 10.0, y1: 10.0 },
            Rect { x0: 990.0, y0: 0.0, x1: 1200.0, y1: 600.0 },
            Rect { x0: 2000.0, y0: 2000.0, x1: 2100.0, y1: 2100.0 },
        ];
        let mut grew = 0;
        for window in windows {
            let block = triangulate_block(&points, &hull, window).unwrap();
            assert_whole_over(&points, &block.tin, &window, &format!("window {window:?}"));
            for (v, &s) in block.tin.source.iter().enumerate() {
                assert_eq!(block.tin.scene.vertices[v], points[s], "a vertex's source is its point");
            }
            grew += block.attempts - 1;
            let interior = window.x0 > bounds.x0 + 50.0 && window.x1 < bounds.x1 - 50.0 && window.y0 > bounds.y0 + 50.0 && window.y1 < bounds.y1 - 50.0;
            let small = (window.x1 - window.x0) * (window.y1 - window.y0) < 0.1 * (bounds.x1 - bounds.x0) * (bounds.y1 - bounds.y0);
            let on_hull = hull.corners().iter().any(|&[x, y]| window.grown(20.0).holds(x, y));
            if small && window.meets(&bounds) {
                // At the hull too: the thin triangles along its edges come from bands, and a
                // rectangle need not grow along the edges.
                assert!(block.points < points.len() / 5, "a small window reads a small share: {} of {} ({window:?})", block.points, points.len());
                assert_eq!(block.band > 0.0, !interior && on_hull, "bands where the region crosses the hull ({window:?})");
            }
        }
        assert!(grew > 0, "the hole makes some buffer grow");
    }

    /// A block by a lake reads the shore across it as discs where they hold fewer points than
    /// a rectangle that holds the lake's circles, and still has the whole TIN's triangles.
    #[test]
    fn a_block_by_a_lake_reads_the_far_shore_as_discs() {
        let mut r = random(5);
        let points: Vec<[f64; 3]> =
            (0..40_000).map(|_| [r() * 1000.0, r() * 1000.0, r() * 10.0]).filter(|p| (p[0] - 500.0).hypot(p[1] - 500.0) > 200.0).collect();
        let hull = Hull::of(&points);
        let window = Rect { x0: 290.0, y0: 480.0, x1: 310.0, y1: 520.0 };
        let block = triangulate_block(&points, &hull, window).unwrap();
        assert_whole_over(&points, &block.tin, &window, "by the lake");
        assert!(block.discs > 0, "the lake's circles are read as discs");
        assert!(block.points < points.len() / 5, "{} of {} points", block.points, points.len());
    }

    /// Bands and a grid of blocks together give each whole-TIN triangle that meets the area
    /// to a block, with the same corners in the same order.
    #[test]
    fn blocks_tile_the_tin() {
        let points = terrain(5_000, 2);
        let hull = Hull::of(&points);
        for (nx, ny) in [(1, 4), (3, 3), (7, 2)] {
            for j in 0..ny {
                for i in 0..nx {
                    let window = Rect {
                        x0: 1000.0 * i as f64 / nx as f64,
                        x1: 1000.0 * (i + 1) as f64 / nx as f64,
                        y0: 600.0 * j as f64 / ny as f64,
                        y1: 600.0 * (j + 1) as f64 / ny as f64,
                    };
                    let block = triangulate_block(&points, &hull, window).unwrap();
                    assert_whole_over(&points, &block.tin, &window, &format!("block {i}, {j} of {nx} × {ny}"));
                }
            }
        }
    }

    #[test]
    fn a_lattice_window_keeps_the_whole_lattices_diagonals() {
        let n = 200;
        let points: Vec<[f64; 3]> = (0..n * n).map(|k| [(k % n) as f64, (k / n) as f64, ((k * 7919) % 101) as f64]).collect();
        let hull = Hull::of(&points);
        assert_eq!(hull.corners(), [[0.0, 0.0], [199.0, 0.0], [199.0, 199.0], [0.0, 199.0]]);
        for window in [Rect { x0: 50.5, y0: 60.0, x1: 70.0, y1: 90.5 }, Rect { x0: 0.0, y0: 0.0, x1: 3.0, y1: 199.0 }] {
            let block = triangulate_block(&points, &hull, window).unwrap();
            assert_whole_over(&points, &block.tin, &window, "lattice");
            assert_eq!(block.attempts, 1, "a lattice's circles are small");
        }
    }

    /// Whether the disc is proven clear of one part (given as the west part).
    fn disc_clear(corners: [Coord<f64>; 3], part: &[Vec<[f64; 2]>; 1]) -> bool {
        let parts = [part[0].clone(), vec![], vec![], vec![]];
        disc_unclear(corners, &parts, &parts.each_ref().map(|p| Rect::around(p))) == 0
    }

    #[test]
    fn the_disc_test_refuses_what_it_cannot_prove() {
        let at = |x: f64, y: f64| Coord { x, y };
        let square = |x0: f64, y0: f64, x1: f64, y1: f64| vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        // The unit circle through three points; parts just beyond it and just inside it.
        let (a, b, c) = (at(1.0, 0.0), at(0.0, 1.0), at(-1.0, 0.0));
        assert!(disc_clear([a, b, c], &[square(1.0 + 1e-9, -1.0, 2.0, 1.0)]));
        assert!(!disc_clear([a, b, c], &[square(1.0, -1.0, 2.0, 1.0)]), "a part on the circle meets the closed disc");
        assert!(!disc_clear([a, b, c], &[square(0.9, -1.0, 2.0, 1.0)]));
        // Beside the disc's box corner, but clear of the disc; and a triangle reaching into it.
        assert!(disc_clear([a, b, c], &[square(0.75, 0.75, 2.0, 2.0)]));
        assert!(!disc_clear([a, b, c], &[vec![[0.7, 0.7], [2.0, 0.5], [2.0, 2.0]]]));
        // A sliver: its circumcentre is far and uncertain; nothing near is proven clear of it.
        let sliver = [at(0.0, 0.0), at(1.0, 1e-17), at(2.0, 0.0)];
        assert!(!disc_clear(sliver, &[square(5.0, 5.0, 6.0, 6.0)]));
        // Far from the origin, as UTM coordinates are.
        let (e, n) = (500_000.0, 5_000_000.0);
        let utm = [at(e + 1.0, n), at(e, n + 1.0), at(e - 1.0, n)];
        assert!(disc_clear(utm, &[square(e + 1.001, n - 1.0, e + 2.0, n + 1.0)]));
        assert!(!disc_clear(utm, &[square(e + 0.999, n - 1.0, e + 2.0, n + 1.0)]));
    }

    #[test]
    fn hulls_are_exact_and_merge() {
        let points = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 0.0]];
        let hull = Hull::of(&points);
        assert_eq!(hull.corners(), [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]], "counter-clockwise, no collinear corners");
        assert!(hull.holds(1.0, 0.0) && hull.holds(1.0, 1.0) && !hull.holds(2.0, 2.0 + 1e-15));
        assert!(hull.bears(Coord { x: 0.0, y: 0.0 }, Coord { x: 1.0, y: 0.0 }) && !hull.bears(Coord { x: 0.0, y: 0.0 }, Coord { x: 1.0, y: 1.0 }));
        let (left, right) = (Hull::of(&points[..3]), Hull::of(&points[3..]));
        assert_eq!(Hull::of_hulls(&[left, right]), hull);
    }

    #[test]
    fn a_point_outside_the_hull_is_refused() {
        let points = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 0.0]];
        let hull = Hull::of(&points[..3]);
        let window = Rect { x0: 0.0, y0: 0.0, x1: 10.0, y1: 10.0 };
        let err = triangulate_block(&points, &hull, window).unwrap_err();
        assert!(matches!(err, TinError::OutsideHull { index: 3, .. }), "{err}");
        let err = triangulate_block(&[[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0]], &hull, window).unwrap_err();
        assert!(matches!(err, TinError::NonFinite { index: 1, .. }), "{err}");
    }
}
