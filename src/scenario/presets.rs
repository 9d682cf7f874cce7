//! IMU grade presets (`[imu] grade = "navigation" | "tactical" |
//! "industrial" | "mems"`) and the commented starting scenario that
//! `waymark init` writes.
//!
//! A grade fills the `[imu]` fields the file leaves out with typical
//! figures of its class; every field the file gives overrides the preset.
//! The figures are the ones the bundled scenarios use for these classes
//! (README "IMU grades"): navigation as `helsinki-plan-20m-nav.toml`,
//! tactical as `helsinki-plan-tactical.toml`, industrial as
//! `helsinki-route-map-matching.toml`, MEMS as `demo.toml`.

use super::sections::{DEFAULT_MAP_ERROR_CORRELATION_M, DEFAULT_MAP_GEOMETRY_ERROR_M};
use serde::Deserialize;

/// An IMU class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImuGrade {
    /// Navigation grade (ring-laser or fibre-optic gyros; aircraft and ship INS).
    Navigation,
    /// Tactical grade (fibre-optic or high-end MEMS; missiles, survey, mining).
    Tactical,
    /// Industrial grade (calibrated MEMS units with temperature compensation).
    Industrial,
    /// MEMS (consumer and automotive MEMS chips).
    Mems,
}

impl ImuGrade {
    /// The class's name as written in scenarios.
    pub fn as_str(self) -> &'static str {
        match self {
            ImuGrade::Navigation => "navigation",
            ImuGrade::Tactical => "tactical",
            ImuGrade::Industrial => "industrial",
            ImuGrade::Mems => "mems",
        }
    }

    /// Typical figures of the class: constant gyro bias (deg/h, each axis),
    /// accelerometer bias (µg, each axis), angle random walk (deg/√h),
    /// velocity random walk (µg/√Hz).
    pub fn figures(self) -> [f64; 4] {
        match self {
            ImuGrade::Navigation => [0.01, 25.0, 0.002, 5.0],
            ImuGrade::Tactical => [0.5, 100.0, 0.05, 50.0],
            ImuGrade::Industrial => [1.0, 300.0, 0.05, 50.0],
            ImuGrade::Mems => [10.0, 1000.0, 0.3, 100.0],
        }
    }

    /// The preset as `[imu]` keys and values.
    pub fn table(self) -> toml::Table {
        let [g, a, arw, vrw] = self.figures();
        let mut t = toml::Table::new();
        let three = |x: f64| toml::Value::Array(vec![toml::Value::Float(x); 3]);
        t.insert("gyro_bias_dph".into(), three(g));
        t.insert("accel_bias_ug".into(), three(a));
        t.insert("gyro_arw_dprh".into(), toml::Value::Float(arw));
        t.insert("accel_vrw_ugprhz".into(), toml::Value::Float(vrw));
        t
    }
}

/// The scenario text with the `[imu]` grade's preset filled in where the
/// file leaves a field out. `None` when the file names no grade.
pub(super) fn apply_imu_grade(text: &str) -> Result<Option<toml::Table>, toml::de::Error> {
    let mut doc: toml::Table = toml::from_str(text)?;
    let Some(toml::Value::Table(imu)) = doc.get_mut("imu") else {
        return Ok(None);
    };
    let grade = match imu.get("grade") {
        Some(v) => ImuGrade::deserialize(v.clone())?,
        None => return Ok(None),
    };
    for (k, v) in grade.table() {
        imu.entry(k).or_insert(v);
    }
    Ok(Some(doc))
}

/// What `waymark init` starts from.
#[derive(Debug, Clone)]
pub struct Starter {
    /// The map file, as the scenario should name it (relative to the
    /// scenario's folder, or absolute); `None` for a drive by motion
    /// commands, which needs no map.
    pub map: Option<String>,
    /// Two or more waypoints on the map ([lat, lon] degrees).
    pub waypoints: Vec<[f64; 2]>,
    /// Plan for the whole network (`coverage = "network"`) rather than the route.
    pub network: bool,
    /// The scenario's name.
    pub name: String,
}

/// A commented starting scenario: every section an engineer sets first,
/// with the units and what each key does; it parses as it is.
pub fn starter_scenario(s: &Starter) -> String {
    let mut t = format!(
        "# A starting scenario written by `waymark init`. Edit the values, then:\n\
         #   waymark plan THIS.toml --out plan/        # plan tags ({})\n\
         #   waymark simulate THIS.toml --tags plan/tags.csv --runs 20 --out sim/\n\
         #   waymark report plan/                      # HTML report\n\
         # Every key is described in docs/DESIGN.md (scenario format).\n\
         name = \"{}\"\n\
         # Horizontal position error the vehicle must stay within (m, 95 %).\n\
         requirement_m = 20.0\n\n",
        if s.network {
            "every road of the map, both directions"
        } else {
            "along the route"
        },
        s.name.replace('"', "'")
    );
    match &s.map {
        Some(map) => {
            let wps: Vec<String> = s
                .waypoints
                .iter()
                .map(|w| format!("[{:.6}, {:.6}]", w[0], w[1]))
                .collect();
            t.push_str(&format!(
                "[map]\n\
                 # OpenStreetMap PBF or XML, GeoJSON or shapefile; relative to this file.\n\
                 path = \"{}\"\n\
                 # Terrain heights: a GeoTIFF elevation model (SRTM or Copernicus GLO-30,\n\
                 # WGS-84 degrees) or a list of tiles; without one, heights are 0 m.\n\
                 # elevation = \"dem.tif\"\n\
                 # The map's accuracy, as map matching sees it (the defaults below):\n\
                 # 1 sigma per axis (m; OpenStreetMap's typical offset, 0 a surveyed\n\
                 # map) and the length over which the offset is alike (m).\n\
                 # geometry_error_m = {}\n\
                 # geometry_error_correlation_m = {}\n\n\
                 [[route]]\n\
                 # Waypoints [lat, lon] (degrees) the route is planned through on the map{}.\n\
                 waypoints = [{}]\n\
                 # Cruise speed (km/h); slower where the map's maxspeed says so.\n\
                 speed_kmh = 40\n\n",
                map.replace('\\', "/").replace('"', "\\\""),
                DEFAULT_MAP_GEOMETRY_ERROR_M,
                DEFAULT_MAP_ERROR_CORRELATION_M,
                if s.network {
                    " (network coverage only takes the speed from it)"
                } else {
                    ""
                },
                wps.join(", ")
            ));
        }
        None => t.push_str(
            "[[route]]\n\
             # No map: a drive by motion commands from a start (degrees, m, deg from north).\n\
             start = { lat = 60.17, lon = 24.94, height_m = 10.0, heading_deg = 0.0 }\n\
             motion = [ { kind = \"accelerate\", to_kmh = 40, accel_mps2 = 1.0 },\n\
             \x20          { kind = \"cruise\", distance_m = 3000 },\n\
             \x20          { kind = \"turn\", angle_deg = 90, radius_m = 50 },\n\
             \x20          { kind = \"cruise\", distance_m = 2000 },\n\
             \x20          { kind = \"decelerate\", to_kmh = 0, accel_mps2 = 1.0 } ]\n\n",
        ),
    }
    t.push_str(
        "[navigator]\n\
         # \"integrated\": the Kalman filter with odometer, RFID tag and other aiding.\n\
         mode = \"integrated\"\n\n\
         [imu]\n\
         # A class preset: \"navigation\", \"tactical\", \"industrial\" or \"mems\"\n\
         # (typical figures in the README); any key below overrides it, e.g.\n\
         # gyro_bias_dph = [5, 5, 5], accel_bias_ug = [500, 500, 500],\n\
         # gyro_arw_dprh = 0.2, accel_vrw_ugprhz = 80.\n\
         grade = \"industrial\"\n\
         rate_hz = 100\n\n\
         [odometer]\n\
         # Wheel odometer: scale-factor error (ratio), speed noise (m/s), pulse length (m).\n\
         scale_factor_error = 0.005\n\
         noise_mps = 0.02\n\
         pulse_m = 0.02\n\n\
         [aiding]\n\
         # What the navigator uses besides the IMU.\n\
         odometer = true\n\
         baro = true\n\
         rfid = true\n",
    );
    if s.map.is_some() {
        t.push_str(
            "# Map matching against the map's roads: the position across the matched\n\
             # road, and along it at turns. It is what lets a plan leave most roads\n\
             # without tags; false if the vehicle's navigator does not match a map.\n\
             map_matching = true\n",
        );
    }
    t.push_str(
        "\n\
         [rfid]\n\
         # Chance that a pass by a tag gives a read.\n\
         read_probability = 0.977\n\n\
         [planner]\n",
    );
    if s.network {
        t.push_str(
            "# Tags so that every road, in each permitted direction, keeps the bound.\n\
             coverage = \"network\"\n",
        );
    }
    t.push_str(
        "# Consecutive missed reads the plan must tolerate.\n\
         tolerate_missed_reads = 1\n\
         # Mountings allowed: \"road_surface\", \"roadside\", \"ceiling\".\n\
         mountings = [\"road_surface\", \"roadside\"]\n\
         # Monte Carlo runs that validate the plan.\n\
         validation_runs = 50\n",
    );
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grades_fill_missing_fields_and_given_fields_override() {
        let doc = apply_imu_grade("[imu]\ngrade = \"tactical\"\ngyro_arw_dprh = 0.9\n")
            .unwrap()
            .unwrap();
        let imu = doc["imu"].as_table().unwrap();
        assert_eq!(
            imu["gyro_arw_dprh"].as_float(),
            Some(0.9),
            "given overrides"
        );
        assert_eq!(imu["accel_vrw_ugprhz"].as_float(), Some(50.0));
        assert_eq!(
            imu["gyro_bias_dph"].as_array().unwrap()[2].as_float(),
            Some(0.5)
        );
        assert!(apply_imu_grade("[imu]\nrate_hz = 100\n").unwrap().is_none());
        let e = apply_imu_grade("[imu]\ngrade = \"consumer\"\n").unwrap_err();
        assert!(e.to_string().contains("unknown variant"), "{e}");
    }

    #[test]
    fn grades_are_ordered_by_quality() {
        let all = [
            ImuGrade::Navigation,
            ImuGrade::Tactical,
            ImuGrade::Industrial,
            ImuGrade::Mems,
        ];
        for w in all.windows(2) {
            let (a, b) = (w[0].figures(), w[1].figures());
            assert!(a.iter().zip(&b).all(|(x, y)| x <= y), "{w:?}");
        }
    }
}
