//! The map of the area as SVG in the network's metric (local ENU) frame:
//! roads (tunnels highlighted), the route coloured by navigation error, and
//! tags coloured by mounting.

use crate::geodesy::Geodetic;
use crate::network::Network;
use crate::tags::Mounting;
use std::fmt::Write;

/// What to draw on the map besides the roads.
#[derive(Debug, Clone, Default)]
pub struct MapOverlay {
    /// Route points (latitude, longitude in degrees) with the horizontal error there (m).
    pub route: Vec<([f64; 2], f64)>,
    /// Tags (latitude, longitude) and their mounting.
    pub tags: Vec<([f64; 2], Mounting)>,
    /// The requirement the error colours are scaled to (m); without one, to the largest error.
    pub requirement_m: Option<f64>,
}

/// Colour of a tag mounting.
pub fn mounting_colour(m: Mounting) -> &'static str {
    match m {
        Mounting::RoadSurface => "#f39c12",
        Mounting::Roadside => "#27ae60",
        Mounting::Ceiling => "#8e44ad",
    }
}

/// Error colour: green at zero through yellow to red at (and above) `scale`.
pub fn error_colour(error: f64, scale: f64) -> String {
    let r = if scale > 0.0 {
        (error / scale).clamp(0.0, 1.0)
    } else {
        0.0
    };
    format!("hsl({:.0},85%,42%)", 120.0 * (1.0 - r))
}

/// Renders the map; `width_px` sets the displayed width (the height follows the area's shape).
pub fn map_svg(net: &Network, overlay: &MapOverlay, width_px: u32) -> String {
    let bb = net
        .bounding_rect()
        .unwrap_or_else(|| geo::Rect::new([0.0, 0.0], [0.0, 0.0]));
    let margin = 0.03 * bb.width().max(bb.height()).max(1.0);
    let (x0, y0) = (bb.min().x - margin, bb.min().y - margin);
    let (w, h) = (bb.width() + 2.0 * margin, bb.height() + 2.0 * margin);
    let height_px = (f64::from(width_px) * h / w).round().max(50.0) as u32;
    let px = |p: [f64; 2]| (p[0] - x0, y0 + h - p[1]);
    let mut s = String::with_capacity(64 * net.segments.len() + 4096);
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {w:.1} {h:.1}\" width=\"{width_px}\" height=\"{height_px}\" \
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
            "<g stroke=\"{colour}\" stroke-width=\"{width}\" vector-effect=\"non-scaling-stroke\"{dash}>"
        );
        for (i, sec) in net.sections.iter().enumerate() {
            if net.roads[sec.road as usize].attributes.tunnel != pass {
                continue;
            }
            let segs = net.model.section_segments(i as u32);
            s.push_str("<polyline vector-effect=\"non-scaling-stroke\" points=\"");
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
    // The route, coloured by error.
    if overlay.route.len() >= 2 {
        let scale = overlay
            .requirement_m
            .unwrap_or_else(|| overlay.route.iter().map(|r| r.1).fold(0.0, f64::max));
        let enu: Vec<[f64; 2]> = overlay
            .route
            .iter()
            .map(|(ll, _)| {
                let p = net.frame.to_enu(&Geodetic::from_degrees(ll[0], ll[1], 0.0));
                [p[0], p[1]]
            })
            .collect();
        s.push_str("<g stroke-width=\"4\">");
        for (k, w2) in enu.windows(2).enumerate() {
            let (a, b) = (px(w2[0]), px(w2[1]));
            let err = 0.5 * (overlay.route[k].1 + overlay.route[k + 1].1);
            let _ = write!(
                s,
                "<line vector-effect=\"non-scaling-stroke\" x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{}\"/>",
                a.0,
                a.1,
                b.0,
                b.1,
                error_colour(err, scale)
            );
        }
        s.push_str("</g>");
    }
    s.push_str("</g>");
    // Tags.
    let r = 0.006 * w.max(h);
    for (ll, m) in &overlay.tags {
        let p = net.frame.to_enu(&Geodetic::from_degrees(ll[0], ll[1], 0.0));
        let (x, y) = px([p[0], p[1]]);
        let _ = write!(
            s,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"{r:.1}\" fill=\"{}\" stroke=\"#fff\" stroke-width=\"1\" vector-effect=\"non-scaling-stroke\"><title>{m}</title></circle>",
            mounting_colour(*m)
        );
    }
    // Scale bar: a round length near a fifth of the width.
    let target = w / 5.0;
    let mag = 10f64.powf(target.log10().floor());
    let bar = [1.0, 2.0, 5.0]
        .iter()
        .map(|k| k * mag)
        .filter(|l| *l <= target)
        .fold(mag, f64::max);
    let (bx, by) = (0.03 * w, h - 0.03 * h);
    let _ = write!(
        s,
        "<line x1=\"{bx:.1}\" y1=\"{by:.1}\" x2=\"{:.1}\" y2=\"{by:.1}\" stroke=\"#222\" stroke-width=\"3\" vector-effect=\"non-scaling-stroke\"/>\
         <text x=\"{bx:.1}\" y=\"{:.1}\" font-size=\"{:.1}\" font-family=\"sans-serif\" fill=\"#222\">{}</text>",
        bx + bar,
        by - 0.012 * h,
        0.025 * w.max(h),
        if bar >= 1000.0 { format!("{} km", bar / 1000.0) } else { format!("{bar} m") }
    );
    s.push_str("</svg>");
    s
}
