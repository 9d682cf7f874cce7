//! The Hilbert grid index of PAPERS.md §3.2.
//!
//! The network's bounding box is divided into N×N cells (N a power of two);
//! every segment is registered in every cell its bounding box overlaps; the
//! cell table is stored in Hilbert-code order (a compressed row table indexed
//! by the code), so neighbouring cells' segment lists lie close in memory.
//!
//! Queries return each matching segment once: a segment found in several
//! visited cells is reported only from the first visited cell that its bounding
//! box overlaps (no hash set, no sort).

use super::geometry::{closest_on_segment, coord, line, norm_sq, rect};
use super::hilbert::xy_to_code;
use super::model::{Segment, SegmentId};
use crate::error::{Error, Result};
use geo::{BoundingRect, Intersects, Line};

/// Largest permitted N (4 M cells; the offset table is then 16 MiB).
pub const MAX_GRID_N: u32 = 2048;
/// Target cell side when N is chosen automatically (m).
pub const AUTO_CELL_M: f64 = 100.0;

/// Hilbert-ordered uniform grid over the network's segments.
#[derive(Debug, Clone)]
pub struct GridIndex {
    n: u32,
    min: [f64; 2],
    cell: [f64; 2],
    inv_cell: [f64; 2],
    /// `cell_start[code]..cell_start[code + 1]` indexes `items` for the cell with that code.
    cell_start: Vec<u32>,
    /// Registrations in Hilbert-code order of their cells.
    items: Vec<Entry>,
    /// Hilbert code of each cell, row-major (`x * n + y`): a look-up table so a
    /// query does not recompute codes.
    code_of: Vec<u32>,
    /// `home_start[x * n + y]..home_start[x * n + y + 1]` indexes `home`
    /// for the cell (x, y).
    home_start: Vec<u32>,
    /// Each segment's registration in its first cell (lowest x, lowest y of
    /// its bounding box) alone, cells in row-major order (`x * n + y`: a
    /// column's cells one after another), in the order of `items` within a
    /// cell: all a query reports from a cell past its first row and column.
    home: Vec<Entry>,
}

/// One registration of a segment in a cell, with the geometry inline so a
/// query scans a cell's entries without chasing ids.
#[derive(Debug, Clone, Copy)]
struct Entry {
    line: Line<f64>,
    id: SegmentId,
    /// The first cell (lowest x, lowest y) of the segment's bounding box.
    cx0: u16,
    cy0: u16,
}

/// Most cells per segment when N is chosen automatically: a denser grid
/// holds only empty cells, yet costs memory and time in proportion to its
/// cells (a few roads spread over a large box — two short ways 1,000 km
/// apart — built a 2048 × 2048 grid, 48 MB and 0.2 s). The bundled and
/// shared real maps have 0.5–3.8 cells per segment at ~100 m cells, so the
/// cap leaves their grids unchanged.
pub const MAX_CELLS_PER_SEGMENT: usize = 8;

/// N for a bounding box: cells of about [`AUTO_CELL_M`], a power of two in 1..=[`MAX_GRID_N`].
pub fn auto_grid_n(bbox: [f64; 4]) -> u32 {
    let extent = (bbox[2] - bbox[0]).max(bbox[3] - bbox[1]).max(1.0);
    let cells = (extent / AUTO_CELL_M).ceil().max(1.0) as u32;
    cells.next_power_of_two().min(MAX_GRID_N)
}

/// N for `segments` segments in a bounding box: [`auto_grid_n`], lowered
/// to the largest power of two whose N² cells are at most
/// [`MAX_CELLS_PER_SEGMENT`] per segment.
pub fn auto_grid_n_for(bbox: [f64; 4], segments: usize) -> u32 {
    let cells = MAX_CELLS_PER_SEGMENT.saturating_mul(segments.max(1));
    let mut cap = 1u32;
    while cap < MAX_GRID_N && (2 * cap as usize).pow(2) <= cells {
        cap *= 2;
    }
    auto_grid_n(bbox).min(cap)
}

impl GridIndex {
    /// Builds the index over `segments` inside `bbox` (min e, min n, max e, max n).
    /// `n` must be a power of two between 1 and [`MAX_GRID_N`]; `None` chooses it
    /// from the map's size and its number of segments ([`auto_grid_n_for`]).
    pub fn build(segments: &[Segment], bbox: [f64; 4], n: Option<u32>) -> Result<Self> {
        let n = n.unwrap_or_else(|| auto_grid_n_for(bbox, segments.len()));
        if n == 0 || !n.is_power_of_two() || n > MAX_GRID_N {
            return Err(Error::InvalidParameter(format!(
                "grid size N={n} must be a power of two between 1 and {MAX_GRID_N}"
            )));
        }
        // A tiny margin keeps points on the box's max edge inside the last cell.
        let w = (bbox[2] - bbox[0]).max(1e-6) * (1.0 + 1e-9);
        let h = (bbox[3] - bbox[1]).max(1e-6) * (1.0 + 1e-9);
        let cell = [w / f64::from(n), h / f64::from(n)];
        let mut grid = GridIndex {
            n,
            min: [bbox[0], bbox[1]],
            cell,
            inv_cell: [1.0 / cell[0], 1.0 / cell[1]],
            cell_start: Vec::new(),
            items: Vec::new(),
            code_of: Vec::new(),
            home_start: Vec::new(),
            home: Vec::new(),
        };
        let cells = (n as usize) * (n as usize);
        let mut code_of = vec![0u32; cells];
        for x in 0..n {
            for y in 0..n {
                code_of[(x * n + y) as usize] = xy_to_code(n, x, y) as u32;
            }
        }
        let ranges: Vec<[u32; 4]> = segments.iter().map(|s| grid.seg_cells(&s.line())).collect();
        let mut counts = vec![0u32; cells + 1];
        for r in &ranges {
            for cx in r[0]..=r[2] {
                for cy in r[1]..=r[3] {
                    counts[code_of[(cx * n + cy) as usize] as usize + 1] += 1;
                }
            }
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        let blank = Entry {
            line: line([0.0; 2], [0.0; 2]),
            id: 0,
            cx0: 0,
            cy0: 0,
        };
        let mut items = vec![blank; counts[cells] as usize];
        for (id, (r, s)) in ranges.iter().zip(segments).enumerate() {
            for cx in r[0]..=r[2] {
                for cy in r[1]..=r[3] {
                    let code = code_of[(cx * n + cy) as usize] as usize;
                    items[fill[code] as usize] = Entry {
                        line: s.line(),
                        id: id as SegmentId,
                        cx0: r[0] as u16,
                        cy0: r[1] as u16,
                    };
                    fill[code] += 1;
                }
            }
        }
        // Each segment once, in its first cell (segments in id order, as in
        // `items`); cells row-major.
        let mut home_start = vec![0u32; cells + 1];
        for r in &ranges {
            home_start[(r[0] * n + r[1]) as usize + 1] += 1;
        }
        for i in 1..home_start.len() {
            home_start[i] += home_start[i - 1];
        }
        let mut fill = home_start.clone();
        let mut home = vec![blank; segments.len()];
        for (id, (r, s)) in ranges.iter().zip(segments).enumerate() {
            let code = (r[0] * n + r[1]) as usize;
            home[fill[code] as usize] = Entry {
                line: s.line(),
                id: id as SegmentId,
                cx0: r[0] as u16,
                cy0: r[1] as u16,
            };
            fill[code] += 1;
        }
        grid.cell_start = counts;
        grid.items = items;
        grid.code_of = code_of;
        grid.home_start = home_start;
        grid.home = home;
        Ok(grid)
    }

    /// N: cells per side.
    pub fn n(&self) -> u32 {
        self.n
    }

    /// Cell size (m): east, north.
    pub fn cell_size(&self) -> [f64; 2] {
        self.cell
    }

    /// Number of cells holding at least one segment.
    pub fn occupied_cells(&self) -> usize {
        self.cell_start.windows(2).filter(|w| w[1] > w[0]).count()
    }

    /// Total segment registrations (a segment counts once per cell).
    pub fn registrations(&self) -> usize {
        self.items.len()
    }

    /// Segments registered in the cell with Hilbert code `code`.
    pub fn cell_segments(&self, code: u64) -> Vec<SegmentId> {
        self.cell_entries(code as usize)
            .iter()
            .map(|e| e.id)
            .collect()
    }

    #[inline]
    fn cell_entries(&self, code: usize) -> &[Entry] {
        &self.items[self.cell_start[code] as usize..self.cell_start[code + 1] as usize]
    }

    /// The registrations in cells `y0..=y1` of column `x` of the segments
    /// whose first cell each is: cell by cell, each in the order of
    /// [`Self::cell_entries`].
    #[inline]
    fn home_entries(&self, x: u32, y0: u32, y1: u32) -> &[Entry] {
        let row = (x * self.n) as usize;
        &self.home[self.home_start[row + y0 as usize] as usize
            ..self.home_start[row + y1 as usize + 1] as usize]
    }

    #[inline]
    fn cell_x(&self, x: f64) -> u32 {
        // Clamped, then truncated: the floor's cell for every value (within
        // the grid, truncation is the floor; below it both give 0, above it
        // both n − 1; NaN gives 0 either way), without a call to `floor`
        // (not inlined on the baseline x86-64 target: 2 % of matching).
        ((x - self.min[0]) * self.inv_cell[0]).clamp(0.0, f64::from(self.n - 1)) as u32
    }

    #[inline]
    fn cell_y(&self, y: f64) -> u32 {
        // Clamped, then truncated: the floor's cell for every value (within
        // the grid, truncation is the floor; below it both give 0, above it
        // both n − 1; NaN gives 0 either way), without a call to `floor`
        // (not inlined on the baseline x86-64 target: 2 % of matching).
        ((y - self.min[1]) * self.inv_cell[1]).clamp(0.0, f64::from(self.n - 1)) as u32
    }

    /// The cell of a point (clamped to the grid).
    pub fn cell_of(&self, p: [f64; 2]) -> (u32, u32) {
        (self.cell_x(p[0]), self.cell_y(p[1]))
    }

    /// The cells (x0, y0, x1, y1) a segment's bounding box spans.
    #[inline]
    fn seg_cells(&self, l: &Line<f64>) -> [u32; 4] {
        let r = l.bounding_rect();
        [
            self.cell_x(r.min().x),
            self.cell_y(r.min().y),
            self.cell_x(r.max().x),
            self.cell_y(r.max().y),
        ]
    }

    /// Visits every segment whose bounding box's cells meet the query box's
    /// cells, once each (from the first visited cell it is registered in),
    /// in the order of the cells and their entries.
    #[inline]
    fn visit_entries(&self, min: [f64; 2], max: [f64; 2], mut f: impl FnMut(&Entry)) {
        if max[0] < self.min[0]
            || max[1] < self.min[1]
            || min[0] > self.min[0] + self.cell[0] * f64::from(self.n)
            || min[1] > self.min[1] + self.cell[1] * f64::from(self.n)
        {
            return;
        }
        let (qx0, qy0) = (self.cell_x(min[0]), self.cell_y(min[1]));
        let (qx1, qy1) = (self.cell_x(max[0]), self.cell_y(max[1]));
        for cx in qx0..=qx1 {
            let row = &self.code_of[(cx * self.n) as usize..((cx + 1) * self.n) as usize];
            // The first column whole, then the first row's cell of each
            // column, with the first-cell test; past the first column and
            // row, the first visited cell of a segment in a cell is that
            // cell exactly when it is the segment's own first cell: the
            // column's home entries, cell by cell in the same order, in one
            // run. (One loop calling `f`, so it is inlined once.)
            let edge_y1 = if cx == qx0 { qy1 } else { qy0 };
            let home = cx != qx0 && qy1 > qy0;
            let mut cy = qy0;
            loop {
                let check = cy <= edge_y1;
                let entries = if check {
                    self.cell_entries(row[cy as usize] as usize)
                } else if home {
                    self.home_entries(cx, qy0 + 1, qy1)
                } else {
                    break;
                };
                for e in entries {
                    // Report from the first visited cell the segment is in.
                    if check && (cx != u32::from(e.cx0).max(qx0) || cy != u32::from(e.cy0).max(qy0))
                    {
                        continue;
                    }
                    f(e);
                }
                if !check {
                    break;
                }
                cy += 1;
            }
        }
    }

    /// [`Self::visit_entries`], the segments `keep` accepts appended to `out`.
    #[inline]
    fn visit(
        &self,
        min: [f64; 2],
        max: [f64; 2],
        out: &mut Vec<SegmentId>,
        keep: impl Fn(&Line<f64>) -> bool,
    ) {
        self.visit_entries(min, max, |e| {
            if keep(&e.line) {
                out.push(e.id);
            }
        });
    }

    /// Segments within `radius` metres of point `p` (distance to the segment
    /// itself, not its box), appended to `out` in no particular order.
    pub fn within_radius_into(&self, p: [f64; 2], radius: f64, out: &mut Vec<SegmentId>) {
        let min = [p[0] - radius, p[1] - radius];
        let max = [p[0] + radius, p[1] + radius];
        let r2 = radius * radius;
        let pc = coord(p);
        // The closest point is `geo`'s (`LineLocatePoint`); the squared norm
        // is hand-written (see `geometry`). Against the former all-hand
        // kernel: equal wall time on 2 M point–segment tests (17.4 vs
        // 17.5 ms), 8 % more instructions for whole queries (callgrind).
        // `geo`'s own point–segment distance (`hypot`) was 8–10× slower here.
        self.visit(min, max, out, |l| {
            let (_, q) = closest_on_segment(l, pc);
            norm_sq(pc.x - q.x, pc.y - q.y) <= r2
        });
    }

    /// Distance (m) from `p` to its nearest segment when that is at most
    /// `radius`, else `None`: the segments [`Self::within_radius_into`] would
    /// report, by the same point–segment distance, in one pass (no list
    /// built, no distance computed twice).
    pub fn nearest_within(&self, p: [f64; 2], radius: f64) -> Option<f64> {
        let min = [p[0] - radius, p[1] - radius];
        let max = [p[0] + radius, p[1] + radius];
        let r2 = radius * radius;
        let pc = coord(p);
        let mut best = f64::INFINITY;
        self.visit_entries(min, max, |e| {
            let (_, q) = closest_on_segment(&e.line, pc);
            let d2 = norm_sq(pc.x - q.x, pc.y - q.y);
            if d2 <= r2 && d2 < best {
                best = d2;
            }
        });
        (best <= r2).then(|| best.sqrt())
    }

    /// Each segment within `radius` metres of `p`, in the order
    /// [`Self::within_radius_into`] lists them, with the fraction along it
    /// (0 at its start) of its point closest to `p` and the distance (m) to
    /// that point: `f(id, t, distance)`. The closest point and the distance
    /// are the ones the radius test computes (one pass: a caller that needs
    /// them does not project the listed segments again).
    pub fn for_each_within(
        &self,
        p: [f64; 2],
        radius: f64,
        mut f: impl FnMut(SegmentId, f64, f64),
    ) {
        let min = [p[0] - radius, p[1] - radius];
        let max = [p[0] + radius, p[1] + radius];
        let r2 = radius * radius;
        let pc = coord(p);
        self.visit_entries(min, max, |e| {
            let (t, q) = closest_on_segment(&e.line, pc);
            let d2 = norm_sq(pc.x - q.x, pc.y - q.y);
            if d2 <= r2 {
                f(e.id, t, d2.sqrt());
            }
        });
    }

    /// Segments within `radius` metres of `p`.
    pub fn within_radius(&self, p: [f64; 2], radius: f64) -> Vec<SegmentId> {
        let mut out = Vec::new();
        self.within_radius_into(p, radius, &mut out);
        out
    }

    /// Segments touching the box `min`–`max`, appended to `out`.
    pub fn in_box_into(&self, min: [f64; 2], max: [f64; 2], out: &mut Vec<SegmentId>) {
        let r = rect(min, max);
        self.visit(min, max, out, |l| r.intersects(l));
    }

    /// Segments touching the box `min`–`max`.
    pub fn in_box(&self, min: [f64; 2], max: [f64; 2]) -> Vec<SegmentId> {
        let mut out = Vec::new();
        self.in_box_into(min, max, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::Network;

    /// A coordinate's cell is the floor's, clamped to the grid, for values
    /// inside, on the edges of, below and above the grid and for NaN.
    #[test]
    fn cells_are_the_clamped_floor() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let g = &net.grid;
        let floor_cell = |v: f64| v.floor().clamp(0.0, f64::from(g.n - 1)) as u32;
        let ([x0, y0], [x1, y1]) = net.enu_bounds().unwrap();
        let mut checked = 0;
        for i in -300..=1300 {
            let f = f64::from(i) / 1000.0;
            for (x, y) in [
                (x0 + (x1 - x0) * f, y0 + (y1 - y0) * f),
                // Exactly on cell edges, and just either side of them.
                (
                    g.min[0] + f64::from(i) * g.cell[0],
                    g.min[1] + f64::from(i) * g.cell[1],
                ),
                (
                    g.min[0] + f64::from(i) * g.cell[0] * (1.0 - 1e-15),
                    g.min[1] + f64::from(i) * g.cell[1] * (1.0 + 1e-15),
                ),
            ] {
                let want = (
                    floor_cell((x - g.min[0]) * g.inv_cell[0]),
                    floor_cell((y - g.min[1]) * g.inv_cell[1]),
                );
                assert_eq!(g.cell_of([x, y]), want, "({x}, {y})");
                checked += 1;
            }
        }
        assert_eq!(g.cell_of([f64::NAN, f64::NAN]), (0, 0));
        assert!(checked > 4000);
    }

    /// `for_each_within` reports the segments `within_radius` lists, in
    /// the same order, each with the closest point's fraction and the
    /// distance a projection onto the segment gives, bit for bit.
    #[test]
    fn for_each_within_lists_the_radius_query_with_its_projection() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let ([x0, y0], [x1, y1]) = net.enu_bounds().unwrap();
        let mut listed = 0;
        for i in 0..=30 {
            for j in 0..=30 {
                let p = [
                    x0 + (x1 - x0) * (-0.3 + 1.6 * f64::from(i) / 30.0),
                    y0 + (y1 - y0) * (-0.3 + 1.6 * f64::from(j) / 30.0),
                ];
                for r in [15.0, 80.0, 279.0] {
                    let want: Vec<_> = net
                        .grid
                        .within_radius(p, r)
                        .into_iter()
                        .map(|s| {
                            let (t, q) =
                                closest_on_segment(&net.segments[s as usize].line(), coord(p));
                            (
                                s,
                                t.to_bits(),
                                norm_sq(p[0] - q.x, p[1] - q.y).sqrt().to_bits(),
                            )
                        })
                        .collect();
                    let mut got = Vec::new();
                    net.grid
                        .for_each_within(p, r, |s, t, d| got.push((s, t.to_bits(), d.to_bits())));
                    assert_eq!(got, want, "{p:?} {r}");
                    listed += got.len();
                }
            }
        }
        assert!(listed > 1000, "{listed}");
    }
}

#[cfg(test)]
mod home_tests {
    use super::*;

    /// The box visitor as it was before the home entries: every entry of
    /// every cell tested against the first-cell rule (kept as the
    /// reference).
    fn visit_reference(g: &GridIndex, min: [f64; 2], max: [f64; 2], mut f: impl FnMut(&Entry)) {
        if max[0] < g.min[0]
            || max[1] < g.min[1]
            || min[0] > g.min[0] + g.cell[0] * f64::from(g.n)
            || min[1] > g.min[1] + g.cell[1] * f64::from(g.n)
        {
            return;
        }
        let (qx0, qy0) = (g.cell_x(min[0]), g.cell_y(min[1]));
        let (qx1, qy1) = (g.cell_x(max[0]), g.cell_y(max[1]));
        for cx in qx0..=qx1 {
            for cy in qy0..=qy1 {
                for e in g.cell_entries(g.code_of[(cx * g.n + cy) as usize] as usize) {
                    if cx != u32::from(e.cx0).max(qx0) || cy != u32::from(e.cy0).max(qy0) {
                        continue;
                    }
                    f(e);
                }
            }
        }
    }

    /// Every query (the radius list, its one-pass form with the
    /// projection, the nearest, the box) gives what the reference visitor
    /// gives: the same segments in the same order, every number bit for
    /// bit. On the real maps, a bundled one on their own grids and on grids
    /// of 1 × 1 and 4 × 4 cells, points on a lattice over and beyond each map (up to
    /// half its box each side) and on every node, radii from 1 m to 1 km
    /// (boxes from one cell to the whole grid); each segment's home entry
    /// is in its first cell, once.
    #[test]
    fn home_entries_give_the_reference_visit() {
        let (mut queries, mut listed) = (0usize, 0usize);
        for (map, net) in crate::network::fixtures::query_maps() {
            let one = GridIndex::build(&net.segments, net.model.bbox, Some(1)).unwrap();
            let four = GridIndex::build(&net.segments, net.model.bbox, Some(4)).unwrap();
            for g in [&net.grid, &one, &four] {
                assert_eq!(g.home.len(), net.segments.len());
                for x in 0..g.n {
                    for y in 0..g.n {
                        for e in g.home_entries(x, y, y) {
                            assert_eq!((u32::from(e.cx0), u32::from(e.cy0)), (x, y));
                        }
                    }
                }
                let mut points: Vec<[f64; 2]> = net.nodes.iter().map(|n| n.enu).collect();
                points.extend(crate::network::fixtures::lattice(
                    &net,
                    20,
                    0.5,
                    [0.31, -0.17],
                ));
                for p in points {
                    for r in [1.0, 16.0, 64.0, 102.5, 279.0, 1000.0] {
                        let (min, max) = ([p[0] - r, p[1] - r], [p[0] + r, p[1] + r]);
                        let mut want = Vec::new();
                        visit_reference(g, min, max, |e| want.push(e.id));
                        let mut got = Vec::new();
                        g.visit_entries(min, max, |e| got.push(e.id));
                        assert_eq!(got, want, "{map} {p:?} {r}");
                        let pc = coord(p);
                        let measured: Vec<_> = want
                            .iter()
                            .filter_map(|&id| {
                                let (t, q) =
                                    closest_on_segment(&net.segments[id as usize].line(), pc);
                                let d2 = norm_sq(pc.x - q.x, pc.y - q.y);
                                (d2 <= r * r).then_some((id, t.to_bits(), d2))
                            })
                            .collect();
                        let mut within = Vec::new();
                        g.within_radius_into(p, r, &mut within);
                        let ids: Vec<_> = measured.iter().map(|m| m.0).collect();
                        assert_eq!(within, ids, "{map} {p:?} {r}");
                        let mut each = Vec::new();
                        g.for_each_within(p, r, |id, t, d| {
                            each.push((id, t.to_bits(), d.to_bits()))
                        });
                        let want_each: Vec<_> = measured
                            .iter()
                            .map(|&(id, t, d2)| (id, t, d2.sqrt().to_bits()))
                            .collect();
                        assert_eq!(each, want_each, "{map} {p:?} {r}");
                        let nearest = measured.iter().map(|m| m.2).min_by(f64::total_cmp);
                        assert_eq!(
                            g.nearest_within(p, r).map(f64::to_bits),
                            nearest.map(|d2| d2.sqrt().to_bits()),
                            "{map} {p:?} {r}"
                        );
                        let r = rect(min, max);
                        let boxed: Vec<_> = want
                            .iter()
                            .copied()
                            .filter(|&id| r.intersects(&net.segments[id as usize].line()))
                            .collect();
                        assert_eq!(g.in_box(min, max), boxed, "{map} {p:?}");
                        queries += 1;
                        listed += want.len();
                    }
                }
            }
        }
        assert!(queries > 10_000 && listed > 100_000, "{queries} {listed}");
    }
}
