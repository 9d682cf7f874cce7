//! The map of the area as SVG in the network's metric (local ENU) frame:
//! roads (tunnels highlighted), directed road pieces coloured by a
//! predicted bound (network plans), the route coloured by navigation error
//! with start and end markers, and tags coloured by mounting (tags closer
//! would overlap moved to the nearest free place with a leader to their true
//! place).
//! The view is fitted to the route (or to the tags and pieces of an area
//! plan) with the network around it; the north arrow, the scale bar and the
//! colour bar are drawn outside the data by [`map_legend`] and the page's
//! own script pans and zooms the map (`report/map.js`).

use crate::geodesy::Geodetic;
use crate::network::Network;
use crate::tags::Mounting;
use quick_xml::escape::escape;
use std::fmt::Write;

/// A tag on the map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapTag {
    /// Latitude, longitude (degrees).
    pub lat_lon: [f64; 2],
    /// Mounting (its colour).
    pub mounting: Mounting,
    /// Shown on hover (id, road, chainage, reason...).
    pub info: String,
}

/// A directed road piece with its predicted bound (an area plan's
/// `coverage.geojson`).
#[derive(Debug, Clone, PartialEq)]
pub struct CoveragePiece {
    /// The piece's points (latitude, longitude in degrees).
    pub line: Vec<[f64; 2]>,
    /// The value it is coloured by (m).
    pub value_m: f64,
    /// Shown on hover.
    pub info: String,
}

/// What to draw on the map besides the roads.
#[derive(Debug, Clone, Default)]
pub struct MapOverlay {
    /// Route points (latitude, longitude in degrees) with the horizontal error there (m).
    pub route: Vec<([f64; 2], f64)>,
    /// Tags.
    pub tags: Vec<MapTag>,
    /// Road pieces coloured by a bound (drawn over the grey roads).
    pub coverage: Vec<CoveragePiece>,
    /// The requirement the colours are scaled to (m); without one, to the largest value.
    pub requirement_m: Option<f64>,
    /// Fit the view to the whole network (an area plan) rather than to the
    /// route and tags.
    pub fit_network: bool,
}

/// Colour of a tag mounting.
pub fn mounting_colour(m: Mounting) -> &'static str {
    match m {
        Mounting::RoadSurface => "#f39c12",
        Mounting::Roadside => "#27ae60",
        Mounting::Ceiling => "#8e44ad",
    }
}

/// Colour beyond the top of the scale (above the requirement).
pub const OVER_COLOUR: &str = "#4a0033";

/// Error colour: green at zero through yellow to red at `scale`, dark
/// purple above it (so exceeding the requirement is never mistaken for
/// reaching it).
pub fn error_colour(error: f64, scale: f64) -> String {
    if scale > 0.0 && error > scale {
        return OVER_COLOUR.to_string();
    }
    let r = if scale > 0.0 {
        (error / scale).clamp(0.0, 1.0)
    } else {
        0.0
    };
    format!("hsl({:.0},85%,42%)", 120.0 * (1.0 - r))
}

/// The scale the colours run to: the requirement, else the largest value.
fn colour_scale(overlay: &MapOverlay) -> f64 {
    overlay.requirement_m.unwrap_or_else(|| {
        overlay
            .route
            .iter()
            .map(|r| r.1)
            .chain(overlay.coverage.iter().map(|c| c.value_m))
            .fold(0.0, f64::max)
    })
}

/// The view: a rectangle in ENU metres.
#[derive(Debug, Clone, Copy)]
struct View {
    x0: f64,
    y0: f64,
    w: f64,
    h: f64,
}

fn view_of(net: &Network, overlay: &MapOverlay, enu: &dyn Fn([f64; 2]) -> [f64; 2]) -> View {
    let mut b = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
    let mut add = |p: [f64; 2]| {
        b = [
            b[0].min(p[0]),
            b[1].min(p[1]),
            b[2].max(p[0]),
            b[3].max(p[1]),
        ];
    };
    if !overlay.fit_network {
        for (ll, _) in &overlay.route {
            add(enu(*ll));
        }
        for t in &overlay.tags {
            add(enu(t.lat_lon));
        }
        for c in &overlay.coverage {
            for ll in &c.line {
                add(enu(*ll));
            }
        }
    }
    if b[0] > b[2] {
        if let Some(r) = net.bounding_rect() {
            b = [r.min().x, r.min().y, r.max().x, r.max().y];
        } else {
            b = [0.0, 0.0, 1.0, 1.0];
        }
    }
    // The network around: a margin of a tenth of the larger side, at least 150 m.
    let margin = (0.1 * (b[2] - b[0]).max(b[3] - b[1])).max(150.0);
    View {
        x0: b[0] - margin,
        y0: b[1] - margin,
        w: b[2] - b[0] + 2.0 * margin,
        h: b[3] - b[1] + 2.0 * margin,
    }
}

/// Renders the map; `width_px` sets the displayed width (the height
/// follows the view's shape). Roads within three view sizes of the view are
/// drawn, so panning out shows the network around.
pub fn map_svg(net: &Network, overlay: &MapOverlay, width_px: u32) -> String {
    let enu = |ll: [f64; 2]| {
        let p = net.frame.to_enu(&Geodetic::from_degrees(ll[0], ll[1], 0.0));
        [p[0], p[1]]
    };
    let v = view_of(net, overlay, &enu);
    let (w, h) = (v.w, v.h);
    let height_px = (f64::from(width_px) * h / w).round().clamp(200.0, 1400.0) as u32;
    // y grows downwards in SVG; the frame's origin is the view's top left.
    let px = |p: [f64; 2]| (p[0] - v.x0, v.y0 + h - p[1]);
    let keep = |p: [f64; 2]| {
        p[0] > v.x0 - w && p[0] < v.x0 + 2.0 * w && p[1] > v.y0 - h && p[1] < v.y0 + 2.0 * h
    };
    let mut s = String::with_capacity(64 * net.segments.len() + 4096);
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"wm-map\" viewBox=\"0 0 {w:.1} {h:.1}\" \
         width=\"{width_px}\" height=\"{height_px}\" data-m-per-unit=\"1\" \
         role=\"img\" aria-label=\"map of the area\" style=\"background:#fbfbf8\">"
    );
    s.push_str("<g fill=\"none\" stroke-linecap=\"round\" stroke-linejoin=\"round\">");
    // Roads: one polyline per section; tunnels after the rest so they stay visible.
    for pass in [false, true] {
        let (colour, width, dash) = if pass {
            ("#1f78b4", 2.4, " stroke-dasharray=\"5 3\"")
        } else {
            ("#9aa3ad", 1.2, "")
        };
        let _ = write!(
            s,
            "<g class=\"roads\" stroke=\"{colour}\" stroke-width=\"{width}\"{dash}>"
        );
        for (i, sec) in net.sections.iter().enumerate() {
            let attrs = &net.roads[sec.road as usize].attributes;
            if attrs.tunnel != pass {
                continue;
            }
            let segs = net.model.section_segments(i as u32);
            if !segs.iter().any(|g| keep(g.a) || keep(g.b)) {
                continue;
            }
            let name = attrs.name.as_deref().unwrap_or("");
            let _ = write!(
                s,
                "<polyline vector-effect=\"non-scaling-stroke\" data-info=\"{}{}{}\" points=\"",
                escape(name),
                if name.is_empty() { "" } else { " · " },
                escape(&attrs.id)
            );
            let (x, y) = px(segs[0].a);
            let _ = write!(s, "{x:.1},{y:.1}");
            for seg in segs {
                let (x, y) = px(seg.b);
                let _ = write!(s, " {x:.1},{y:.1}");
            }
            s.push_str("\"/>");
        }
        s.push_str("</g>");
    }
    street_names(&mut s, net, &v, &px);
    let scale = colour_scale(overlay);
    // Directed pieces coloured by their bound.
    if !overlay.coverage.is_empty() {
        s.push_str("<g class=\"coverage\" stroke-width=\"3\">");
        for c in &overlay.coverage {
            if c.line.len() < 2 {
                continue;
            }
            let _ = write!(
                s,
                "<polyline vector-effect=\"non-scaling-stroke\" stroke=\"{}\" data-info=\"{}\" points=\"",
                error_colour(c.value_m, scale),
                escape(&c.info)
            );
            for (k, ll) in c.line.iter().enumerate() {
                let (x, y) = px(enu(*ll));
                let _ = write!(s, "{}{x:.1},{y:.1}", if k > 0 { " " } else { "" });
            }
            s.push_str("\"/>");
        }
        s.push_str("</g>");
    }
    // The route, coloured by error.
    if overlay.route.len() >= 2 {
        let pts: Vec<(f64, f64)> = overlay.route.iter().map(|(ll, _)| px(enu(*ll))).collect();
        s.push_str("<g class=\"route\" stroke-width=\"4\">");
        for (k, w2) in pts.windows(2).enumerate() {
            let err = 0.5 * (overlay.route[k].1 + overlay.route[k + 1].1);
            let _ = write!(
                s,
                "<line vector-effect=\"non-scaling-stroke\" x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{}\"/>",
                w2[0].0,
                w2[0].1,
                w2[1].0,
                w2[1].1,
                error_colour(err, scale)
            );
        }
        s.push_str("</g>");
    }
    s.push_str("</g>");
    // Tags: smaller dots when there are many; a dot that would overlap one
    // already drawn moves to the nearest free place on rings around its
    // true place, with a leader back to it.
    let n_tags = overlay.tags.len();
    let r = w.max(h) * if n_tags <= 60 { 0.006 } else { 0.003 };
    let spots: Vec<(f64, f64)> = overlay.tags.iter().map(|t| px(enu(t.lat_lon))).collect();
    let placed = spread(&spots, r);
    s.push_str("<g class=\"tags\">");
    for (i, t) in overlay.tags.iter().enumerate() {
        let (x, y) = spots[i];
        let (cx, cy) = placed[i];
        if (cx, cy) != (x, y) {
            let _ = write!(
                s,
                "<line class=\"leader\" x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{cx:.1}\" y2=\"{cy:.1}\" \
                 stroke=\"#333\" stroke-width=\"1\" vector-effect=\"non-scaling-stroke\"/>"
            );
        }
        let _ = write!(
            s,
            "<circle class=\"tag\" cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"{r:.1}\" fill=\"{}\" stroke=\"#fff\" \
             stroke-width=\"1\" vector-effect=\"non-scaling-stroke\" data-info=\"{}\"><title>{}</title></circle>",
            mounting_colour(t.mounting),
            escape(&t.info),
            escape(&t.info)
        );
    }
    s.push_str("</g>");
    // Start and end of the route.
    if let (Some(a), Some(b)) = (overlay.route.first(), overlay.route.last()) {
        for (ll, label, fill, side) in [(a.0, "start", "#1b9e3a", 1.0), (b.0, "end", "#222", -1.0)]
        {
            let (x, y) = px(enu(ll));
            // The start's label above right, the end's below left: apart
            // when a route ends where it began.
            let (tx, ty) = if side > 0.0 {
                (x + 1.8 * r, y - 1.6 * r)
            } else {
                (x - 1.8 * r - 5.5 * r, y + 3.6 * r)
            };
            let _ = write!(
                s,
                "<g class=\"marker\" data-info=\"{label}\"><rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" \
                 fill=\"{fill}\" stroke=\"#fff\" stroke-width=\"1.5\" vector-effect=\"non-scaling-stroke\"/>\
                 <text x=\"{:.1}\" y=\"{:.1}\" font-size=\"{:.1}\" font-family=\"sans-serif\" font-weight=\"bold\" \
                 fill=\"{fill}\" stroke=\"#fff\" stroke-width=\"0.3\">{label}</text></g>",
                x - 1.3 * r,
                y - 1.3 * r,
                2.6 * r,
                2.6 * r,
                tx,
                ty,
                3.2 * r,
            );
        }
    }
    s.push_str("</svg>");
    s
}

/// Street names where they fit: each named road's name along its longest
/// section inside the view (a text path, read left to right) when the
/// section is nearly straight and longer than the name; at most 40 names,
/// none over another.
fn street_names(s: &mut String, net: &Network, v: &View, px: &dyn Fn([f64; 2]) -> (f64, f64)) {
    let font = 0.009 * v.w.max(v.h);
    let inside = |p: [f64; 2]| p[0] > v.x0 && p[0] < v.x0 + v.w && p[1] > v.y0 && p[1] < v.y0 + v.h;
    // The longest section inside the view, per name.
    let mut best: std::collections::HashMap<&str, (usize, f64)> = Default::default();
    for (i, sec) in net.sections.iter().enumerate() {
        let Some(name) = net.roads[sec.road as usize].attributes.name.as_deref() else {
            continue;
        };
        let segs = net.model.section_segments(i as u32);
        if !segs.iter().all(|g| inside(g.a) && inside(g.b)) {
            continue;
        }
        if best.get(name).is_none_or(|b| b.1 < sec.length_m) {
            best.insert(name, (i, sec.length_m));
        }
    }
    let mut names: Vec<(&str, (usize, f64))> = best.into_iter().collect();
    names.sort_by(|a, b| b.1 .1.total_cmp(&a.1 .1).then(a.0.cmp(b.0)));
    let mut taken: Vec<(f64, f64, f64)> = Vec::new();
    s.push_str(
        "<g class=\"names\" font-family=\"sans-serif\" fill=\"#555\" text-anchor=\"middle\">",
    );
    let mut drawn = 0;
    for (name, (i, len)) in names {
        let width = 0.55 * font * name.chars().count() as f64;
        if len < 1.2 * width || drawn >= 40 {
            continue;
        }
        let segs = net.model.section_segments(i as u32);
        let mut pts: Vec<(f64, f64)> = std::iter::once(px(segs[0].a))
            .chain(segs.iter().map(|g| px(g.b)))
            .collect();
        // Nearly straight sections only: a name round a corner is unreadable.
        let (a, b) = (pts[0], pts[pts.len() - 1]);
        if (b.0 - a.0).hypot(b.1 - a.1) < 0.9 * len {
            continue;
        }
        // Read left to right.
        if pts[pts.len() - 1].0 < pts[0].0 {
            pts.reverse();
        }
        let mid = pts[pts.len() / 2];
        if taken
            .iter()
            .any(|&(x, y, w)| (x - mid.0).hypot(y - mid.1) < 0.5 * (w + width))
        {
            continue;
        }
        let _ = write!(s, "<path id=\"wm-name-{i}\" fill=\"none\" d=\"M");
        for (k, p) in pts.iter().enumerate() {
            let _ = write!(s, "{}{:.1},{:.1}", if k > 0 { " L" } else { "" }, p.0, p.1);
        }
        let _ = write!(
            s,
            "\"/><text font-size=\"{font:.1}\" dy=\"{:.1}\" stroke=\"#fbfbf8\" stroke-width=\"{:.1}\" \
             paint-order=\"stroke\"><textPath href=\"#wm-name-{i}\" startOffset=\"50%\">{}</textPath></text>",
            -0.4 * font,
            0.25 * font,
            escape(name)
        );
        taken.push((mid.0, mid.1, width));
        drawn += 1;
    }
    s.push_str("</g>");
}

/// Where to draw dots of radius `r` at points `p` (map units) so that
/// none overlaps another: each in turn at its place when free, else at the
/// first free place on rings of 2.2 r, 4.4 r, ... around it (8, 16, ...
/// places per ring). A grid of 2r cells keeps it linear.
fn spread(p: &[(f64, f64)], r: f64) -> Vec<(f64, f64)> {
    let cell = 2.0 * r;
    let key = |q: (f64, f64)| ((q.0 / cell).floor() as i64, (q.1 / cell).floor() as i64);
    let mut grid: std::collections::HashMap<(i64, i64), Vec<(f64, f64)>> = Default::default();
    let free = |grid: &std::collections::HashMap<(i64, i64), Vec<(f64, f64)>>, q: (f64, f64)| {
        let (kx, ky) = key(q);
        (-1..=1).all(|dx| {
            (-1..=1).all(|dy| {
                grid.get(&(kx + dx, ky + dy)).is_none_or(|v| {
                    v.iter()
                        .all(|o| (o.0 - q.0).powi(2) + (o.1 - q.1).powi(2) >= (1.9 * r).powi(2))
                })
            })
        })
    };
    let mut out = Vec::with_capacity(p.len());
    for &q in p {
        let mut at = q;
        'rings: for ring in 0..6 {
            if ring == 0 {
                if free(&grid, q) {
                    break;
                }
                continue;
            }
            let n = 8 * ring;
            for k in 0..n {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                let c = (
                    q.0 + 2.2 * r * ring as f64 * a.cos(),
                    q.1 + 2.2 * r * ring as f64 * a.sin(),
                );
                if free(&grid, c) {
                    at = c;
                    break 'rings;
                }
            }
        }
        grid.entry(key(at)).or_default().push(at);
        out.push(at);
    }
    out
}

/// The legend under the map: a colour bar (0 to the requirement, and
/// "over"), the mountings, start and end, and a scale bar the page's script
/// keeps true when zooming. `what`: what the colours show.
pub fn map_legend(overlay: &MapOverlay, what: &str, view_width_m: Option<f64>) -> String {
    let scale = colour_scale(overlay);
    let mut s = String::from("<div class=\"map-legend\">");
    if scale > 0.0 && (!overlay.route.is_empty() || !overlay.coverage.is_empty()) {
        let _ = write!(
            s,
            "<svg class=\"colour-bar\" width=\"330\" height=\"36\" viewBox=\"0 0 330 36\" role=\"img\" aria-label=\"colour bar\">\
             <defs><linearGradient id=\"wm-grad\">"
        );
        for k in 0..=6 {
            let f = f64::from(k) / 6.0;
            let _ = write!(
                s,
                "<stop offset=\"{:.3}\" stop-color=\"{}\"/>",
                f,
                error_colour(f * scale, scale)
            );
        }
        let _ = write!(
            s,
            "</linearGradient></defs><rect x=\"5\" y=\"4\" width=\"260\" height=\"14\" fill=\"url(#wm-grad)\"/>\
             <rect x=\"270\" y=\"4\" width=\"30\" height=\"14\" fill=\"{OVER_COLOUR}\"/>\
             <g font-size=\"11\" font-family=\"sans-serif\" fill=\"#333\">\
             <text x=\"5\" y=\"31\">0</text><text x=\"135\" y=\"31\" text-anchor=\"middle\">{:.3}</text>\
             <text x=\"265\" y=\"31\" text-anchor=\"end\">{:.3} m</text><text x=\"285\" y=\"31\" text-anchor=\"middle\">over</text>\
             </g></svg><span class=\"bar-label\">{}</span>",
            trim(scale / 2.0),
            trim(scale),
            escape(what)
        );
    }
    s.push_str("<span class=\"keys\">");
    for m in [Mounting::RoadSurface, Mounting::Roadside, Mounting::Ceiling] {
        let _ = write!(
            s,
            "<span><span style=\"color:{}\">●</span> {}</span>",
            mounting_colour(m),
            m.as_str().replace('_', " ")
        );
    }
    s.push_str(
        "<span><span style=\"color:#9aa3ad\">━</span> road</span>\
         <span><span style=\"color:#1f78b4\">┅</span> tunnel</span>",
    );
    if !overlay.route.is_empty() {
        s.push_str(
            "<span><span style=\"color:#1b9e3a\">■</span> start</span><span><span style=\"color:#222\">■</span> end</span>",
        );
    }
    s.push_str(
        "<span>rings: tags within a few pixels of each other, leaders to their places</span>",
    );
    if let Some(wm) = view_width_m {
        let _ = write!(
            s,
            "<span class=\"scale-bar\" data-view-m=\"{wm:.1}\"><span class=\"bar\"></span> <span class=\"len\"></span></span>"
        );
    }
    s.push_str("</span></div>");
    s
}

/// A number with its trailing zeros dropped (`20`, `12.5`).
fn trim(x: f64) -> String {
    let t = format!("{x:.3}");
    t.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The view's width in metres, for the scale bar.
pub fn map_view_width_m(net: &Network, overlay: &MapOverlay) -> f64 {
    let enu = |ll: [f64; 2]| {
        let p = net.frame.to_enu(&Geodetic::from_degrees(ll[0], ll[1], 0.0));
        [p[0], p[1]]
    };
    view_of(net, overlay, &enu).w
}

/// The north arrow drawn over the map's top right corner (the map is in a
/// local east-north frame: north is up).
pub const NORTH_ARROW: &str = "<svg class=\"north\" width=\"28\" height=\"42\" viewBox=\"0 0 28 42\" role=\"img\" \
     aria-label=\"north arrow\"><path d=\"M14 2 L24 30 L14 24 L4 30 Z\" fill=\"#222\" stroke=\"#fff\"/>\
     <text x=\"14\" y=\"41\" text-anchor=\"middle\" font-size=\"12\" font-family=\"sans-serif\" \
     font-weight=\"bold\">N</text></svg>";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_dots_do_not_overlap_and_lone_dots_stay() {
        let r = 1.0;
        let p = [
            (0.0, 0.0),
            (0.5, 0.2),
            (100.0, 0.0),
            (0.3, -0.4),
            (0.0, 0.0),
        ];
        let q = spread(&p, r);
        assert_eq!(q[0], p[0]);
        assert_eq!(q[2], p[2], "a lone dot stays at its place");
        for i in 0..q.len() {
            for j in 0..i {
                let d = ((q[i].0 - q[j].0).powi(2) + (q[i].1 - q[j].1).powi(2)).sqrt();
                assert!(d >= 1.9 * r - 1e-9, "{i} {j}: {d}");
            }
            // Each moved dot stays near its place (first ring).
            let d = ((q[i].0 - p[i].0).powi(2) + (q[i].1 - p[i].1).powi(2)).sqrt();
            assert!(d <= 2.2 * r * 2.0 + 1e-9, "{i}: moved {d}");
        }
    }

    #[test]
    fn colours_mark_exceeding_apart_from_reaching() {
        assert_eq!(error_colour(0.0, 20.0), "hsl(120,85%,42%)");
        assert_eq!(error_colour(20.0, 20.0), "hsl(0,85%,42%)");
        assert_eq!(error_colour(20.5, 20.0), OVER_COLOUR);
    }
}
