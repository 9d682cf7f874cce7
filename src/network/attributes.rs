//! Road attributes from OpenStreetMap tags: which ways are drivable, their
//! direction of travel, lanes, width, speed limit, tunnels, bridges and layers.
//!
//! The same tag names are read from OSM PBF, OSM XML and GeoJSON properties.

use serde::Serialize;

/// Permitted direction of travel along a road's digitised direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Oneway {
    /// Both directions.
    Both,
    /// Only in the digitised direction (`oneway=yes`, roundabouts, motorways).
    Forward,
    /// Only against the digitised direction (`oneway=-1`).
    Backward,
}

impl Oneway {
    /// Travel in the digitised direction is permitted.
    pub fn allows_forward(self) -> bool {
        matches!(self, Oneway::Both | Oneway::Forward)
    }

    /// Travel against the digitised direction is permitted.
    pub fn allows_backward(self) -> bool {
        matches!(self, Oneway::Both | Oneway::Backward)
    }

    /// One direction only.
    pub fn is_oneway(self) -> bool {
        !matches!(self, Oneway::Both)
    }
}

/// The attributes of one input road (an OSM way or a GeoJSON feature).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RoadAttributes {
    /// The input identifier: the OSM way id, or the GeoJSON feature id.
    pub id: String,
    /// `name`, if any.
    pub name: Option<String>,
    /// `highway` class (`"road"` for GeoJSON features without one).
    pub highway: String,
    /// Direction of travel.
    pub oneway: Oneway,
    /// `lanes` (the first value of a `;` list).
    pub lanes: Option<u32>,
    /// `width` in metres.
    pub width_m: Option<f64>,
    /// `maxspeed` in km/h (mph converted); `None` for symbolic values.
    pub maxspeed_kmh: Option<f64>,
    /// Inside a tunnel or covered passage.
    pub tunnel: bool,
    /// On a bridge.
    pub bridge: bool,
    /// `layer` (0 when absent).
    pub layer: i32,
}

impl RoadAttributes {
    /// A road `id` of class `highway` driven in `oneway`'s directions, with
    /// no other tag: no name, lane count, width or speed limit, at ground
    /// level (for roads built from polylines, `super::model_from_polylines`).
    /// Set the other fields with struct update syntax.
    ///
    /// ```
    /// use waymark::network::{Oneway, RoadAttributes};
    /// let a = RoadAttributes {
    ///     maxspeed_kmh: Some(50.0),
    ///     ..RoadAttributes::new("7", "primary", Oneway::Both)
    /// };
    /// assert_eq!((a.id.as_str(), a.lanes, a.tunnel, a.layer), ("7", None, false, 0));
    /// ```
    pub fn new(id: impl Into<String>, highway: &str, oneway: Oneway) -> Self {
        RoadAttributes {
            id: id.into(),
            name: None,
            highway: highway.into(),
            oneway,
            lanes: None,
            width_m: None,
            maxspeed_kmh: None,
            tunnel: false,
            bridge: false,
            layer: 0,
        }
    }
}

/// Which `highway` classes count as drivable.
#[derive(Debug, Clone, Copy, Default)]
pub struct DrivableFilter {
    /// Also accept `highway=track`.
    pub include_tracks: bool,
}

/// Why a way or feature was not turned into a road.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rejection {
    /// A `highway` class vehicles do not drive on (footway, cycleway, …).
    NotDrivable,
    /// `highway=track`, excluded unless tracks are asked for.
    Track,
    /// `area=yes`: a square or parking area, not a road centre line.
    Area,
}

impl Rejection {
    /// The reason's key in load reports.
    pub fn key(self) -> &'static str {
        match self {
            Rejection::NotDrivable => "not_drivable",
            Rejection::Track => "track_excluded",
            Rejection::Area => "area",
        }
    }
}

const DRIVABLE: &[&str] = &[
    "motorway",
    "trunk",
    "primary",
    "secondary",
    "tertiary",
    "unclassified",
    "residential",
    "service",
    "motorway_link",
    "trunk_link",
    "primary_link",
    "secondary_link",
    "tertiary_link",
    "living_street",
    "road",
];

impl DrivableFilter {
    /// Decides whether a way with this `highway` value and `area` tag is a drivable road.
    pub fn check(&self, highway: &str, area: Option<&str>) -> Result<(), Rejection> {
        if highway == "track" {
            if !self.include_tracks {
                return Err(Rejection::Track);
            }
        } else if !DRIVABLE.contains(&highway) {
            return Err(Rejection::NotDrivable);
        }
        if matches!(area, Some("yes")) {
            return Err(Rejection::Area);
        }
        Ok(())
    }
}

/// Collects the tags Waymark reads from a way and builds [`RoadAttributes`].
#[derive(Debug, Default, Clone)]
#[allow(missing_docs)] // one field per OSM tag of the same name
pub struct TagSet<'a> {
    pub highway: Option<&'a str>,
    pub name: Option<&'a str>,
    pub oneway: Option<&'a str>,
    pub junction: Option<&'a str>,
    pub lanes: Option<&'a str>,
    pub width: Option<&'a str>,
    pub maxspeed: Option<&'a str>,
    pub tunnel: Option<&'a str>,
    pub bridge: Option<&'a str>,
    pub layer: Option<&'a str>,
    pub area: Option<&'a str>,
    pub covered: Option<&'a str>,
}

impl<'a> TagSet<'a> {
    /// Records one tag; tags Waymark does not use are ignored.
    pub fn set(&mut self, key: &str, value: &'a str) {
        let slot = match key {
            "highway" => &mut self.highway,
            "name" => &mut self.name,
            "oneway" => &mut self.oneway,
            "junction" => &mut self.junction,
            "lanes" => &mut self.lanes,
            "width" => &mut self.width,
            "maxspeed" => &mut self.maxspeed,
            "tunnel" => &mut self.tunnel,
            "bridge" => &mut self.bridge,
            "layer" => &mut self.layer,
            "area" => &mut self.area,
            "covered" => &mut self.covered,
            _ => return,
        };
        *slot = Some(value);
    }

    /// The road's attributes; `highway` defaults to `"road"`.
    pub fn attributes(&self, id: String) -> RoadAttributes {
        let highway = self.highway.unwrap_or("road");
        RoadAttributes {
            id,
            name: self.name.map(printable_name),
            highway: highway.to_owned(),
            oneway: parse_oneway(self.oneway, self.junction, highway),
            lanes: self.lanes.and_then(parse_lanes),
            width_m: self.width.and_then(parse_length_m),
            maxspeed_kmh: self.maxspeed.and_then(parse_speed_kmh),
            tunnel: self.tunnel.is_some_and(is_tunnel) || self.covered.is_some_and(|c| c == "yes"),
            bridge: self
                .bridge
                .is_some_and(|b| !matches!(b, "no" | "false" | "0")),
            layer: self
                .layer
                .and_then(|l| l.trim().parse::<i32>().ok())
                .unwrap_or(0),
        }
    }
}

/// A road's name as messages and files print it: each control character
/// (a line break, an escape sequence's ESC) a space. Names are the map's
/// text: a name holding a line break split the one-line error that quotes
/// it, and an ESC sent its terminal colours.
fn printable_name(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}

/// Direction of travel from `oneway`, `junction` and the road class.
///
/// `oneway=yes|true|1` is forward, `-1|reverse` backward, `no|false|0`
/// both; without `oneway`, roundabouts (`junction=roundabout|circular`) and
/// motorways are one-way forward. Other values (`reversible`, `alternating`)
/// are treated as two-way, as their direction changes with time.
pub fn parse_oneway(oneway: Option<&str>, junction: Option<&str>, highway: &str) -> Oneway {
    match oneway.map(str::trim) {
        Some("yes" | "true" | "1") => Oneway::Forward,
        Some("-1" | "reverse") => Oneway::Backward,
        Some("no" | "false" | "0") => Oneway::Both,
        _ => {
            if matches!(junction, Some("roundabout" | "circular")) || highway == "motorway" {
                Oneway::Forward
            } else {
                Oneway::Both
            }
        }
    }
}

fn is_tunnel(value: &str) -> bool {
    matches!(
        value,
        "yes" | "true" | "1" | "building_passage" | "avalanche_protector"
    )
}

/// First value of a `lanes` tag (`"2"`, `"2;3"`).
pub fn parse_lanes(value: &str) -> Option<u32> {
    value
        .split(';')
        .next()?
        .trim()
        .parse::<u32>()
        .ok()
        .filter(|&n| n > 0 && n < 64)
}

/// A length in metres: `"7"`, `"7 m"`, `"3.5m"`, `"12'6\""` (feet and inches).
pub fn parse_length_m(value: &str) -> Option<f64> {
    let v = value.trim();
    if let Some((feet, rest)) = v.split_once('\'') {
        let feet: f64 = feet.trim().parse().ok()?;
        let inches: f64 = rest
            .trim()
            .trim_end_matches('"')
            .trim()
            .parse()
            .unwrap_or(0.0);
        return Some(feet * 0.3048 + inches * 0.0254).filter(|w| *w > 0.0);
    }
    let v = v.trim_end_matches('m').trim();
    v.replace(',', ".")
        .parse::<f64>()
        .ok()
        .filter(|w| w.is_finite() && *w > 0.0 && *w < 200.0)
}

/// A speed limit in km/h: `"50"`, `"50 km/h"`, `"30 mph"`; symbolic values
/// (`"FI:urban"`, `"walk"`, `"none"`) give `None`.
pub fn parse_speed_kmh(value: &str) -> Option<f64> {
    let v = value.split(';').next()?.trim();
    let (number, factor) = if let Some(n) = v.strip_suffix("mph") {
        (n.trim(), 1.609_344)
    } else if let Some(n) = v.strip_suffix("km/h") {
        (n.trim(), 1.0)
    } else if let Some(n) = v.strip_suffix("kmh") {
        (n.trim(), 1.0)
    } else {
        (v, 1.0)
    };
    number
        .parse::<f64>()
        .ok()
        .map(|s| s * factor)
        .filter(|s| s.is_finite() && *s > 0.0 && *s < 400.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn oneway_rules() {
        assert_eq!(
            parse_oneway(Some("yes"), None, "residential"),
            Oneway::Forward
        );
        assert_eq!(parse_oneway(Some("-1"), None, "primary"), Oneway::Backward);
        assert_eq!(
            parse_oneway(None, Some("roundabout"), "primary"),
            Oneway::Forward
        );
        assert_eq!(
            parse_oneway(Some("no"), Some("roundabout"), "primary"),
            Oneway::Both
        );
        assert_eq!(parse_oneway(None, None, "motorway"), Oneway::Forward);
        assert_eq!(parse_oneway(None, None, "motorway_link"), Oneway::Both);
        assert_eq!(
            parse_oneway(Some("reversible"), None, "primary"),
            Oneway::Both
        );
    }

    #[test]
    fn numeric_tags() {
        assert_eq!(parse_speed_kmh("50"), Some(50.0));
        assert!((parse_speed_kmh("30 mph").unwrap() - 48.28).abs() < 0.01);
        assert_eq!(parse_speed_kmh("FI:urban"), None);
        assert_eq!(parse_length_m("3.5 m"), Some(3.5));
        assert_eq!(parse_length_m("7"), Some(7.0));
        assert!((parse_length_m("12'6\"").unwrap() - 3.81).abs() < 1e-9);
        assert_eq!(parse_lanes("2;3"), Some(2));
        assert_eq!(parse_lanes("many"), None);
    }

    #[test]
    fn drivable_classes() {
        let f = DrivableFilter::default();
        assert!(f.check("residential", None).is_ok());
        assert!(f.check("motorway_link", None).is_ok());
        assert_eq!(f.check("footway", None), Err(Rejection::NotDrivable));
        assert_eq!(f.check("track", None), Err(Rejection::Track));
        assert_eq!(f.check("service", Some("yes")), Err(Rejection::Area));
        let t = DrivableFilter {
            include_tracks: true,
        };
        assert!(t.check("track", None).is_ok());
    }
}
