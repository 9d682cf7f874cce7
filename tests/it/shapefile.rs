//! The shapefile loader on a directed-edge export written here (the layout
//! OSMnx produces: every two-way street twice, `u`→`v` and `v`→`u`).

use shapefile::dbase::{FieldName, FieldValue, Record, TableWriterBuilder};
use shapefile::{Point, Polyline};
use std::path::Path;
use waymark::network::{LoadOptions, Network, Oneway};

/// (osmid, oneway, highway, u, v, points)
type Edge = (&'static str, f64, &'static str, f64, f64, Vec<Point>);

fn write_edges(path: &Path) {
    let fields = TableWriterBuilder::new()
        .add_character_field(FieldName::try_from("osmid").unwrap(), 40)
        .add_numeric_field(FieldName::try_from("oneway").unwrap(), 9, 0)
        .add_character_field(FieldName::try_from("highway").unwrap(), 40)
        .add_character_field(FieldName::try_from("maxspeed").unwrap(), 40)
        .add_numeric_field(FieldName::try_from("u").unwrap(), 18, 0)
        .add_numeric_field(FieldName::try_from("v").unwrap(), 18, 0)
        .add_numeric_field(FieldName::try_from("key").unwrap(), 18, 0);
    let mut w = shapefile::Writer::from_path(path, fields).unwrap();
    let p = |lon: f64, lat: f64| Point::new(lon, lat);
    let edges: Vec<Edge> = vec![
        (
            "11",
            0.0,
            "residential",
            1.0,
            2.0,
            vec![p(18.0, 59.0), p(18.001, 59.0)],
        ),
        (
            "11",
            0.0,
            "residential",
            2.0,
            1.0,
            vec![p(18.001, 59.0), p(18.0, 59.0)],
        ),
        (
            "12",
            1.0,
            "primary",
            2.0,
            3.0,
            vec![p(18.001, 59.0), p(18.001, 59.0005), p(18.002, 59.001)],
        ),
        (
            "13",
            0.0,
            "footway",
            3.0,
            1.0,
            vec![p(18.002, 59.001), p(18.0, 59.0)],
        ),
    ];
    for (osmid, oneway, highway, u, v, pts) in edges {
        let mut r = Record::default();
        r.insert("osmid".into(), FieldValue::Character(Some(osmid.into())));
        r.insert("oneway".into(), FieldValue::Numeric(Some(oneway)));
        r.insert(
            "highway".into(),
            FieldValue::Character(Some(highway.into())),
        );
        r.insert("maxspeed".into(), FieldValue::Character(Some("50".into())));
        r.insert("u".into(), FieldValue::Numeric(Some(u)));
        r.insert("v".into(), FieldValue::Numeric(Some(v)));
        r.insert("key".into(), FieldValue::Numeric(Some(0.0)));
        w.write_shape_and_record(&Polyline::new(pts), &r).unwrap();
    }
}

#[test]
fn directed_export_becomes_one_road_per_street() {
    let dir = tempfile::tempdir().unwrap();
    let shp = dir.path().join("edges.shp");
    write_edges(&shp);
    let net = Network::load(&shp, &LoadOptions::default()).unwrap();
    assert_eq!(net.report.format, "shapefile");
    assert_eq!(net.report.features_read, 4);
    assert_eq!(net.report.skipped.get("reverse_duplicate"), Some(&1));
    assert_eq!(net.report.skipped.get("not_drivable"), Some(&1));
    assert_eq!(net.roads.len(), 2);
    let primary = net.roads.iter().find(|r| r.attributes.id == "12").unwrap();
    assert_eq!(primary.attributes.oneway, Oneway::Forward);
    assert_eq!(primary.attributes.maxspeed_kmh, Some(50.0));
    let street = net.roads.iter().find(|r| r.attributes.id == "11").unwrap();
    assert_eq!(street.attributes.oneway, Oneway::Both);
    // The two roads meet at (18.001, 59.0).
    assert_eq!(net.topology.weak_components, 1);
    assert_eq!(net.nodes.len(), 3);
}

#[test]
fn projected_shapefile_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let shp = dir.path().join("edges.shp");
    write_edges(&shp);
    std::fs::write(
        dir.path().join("edges.prj"),
        r#"PROJCS["SWEREF99_TM",GEOGCS["GCS_SWEREF99",DATUM["D_SWEREF99",SPHEROID["GRS_1980",6378137.0,298.257222101]]]]"#,
    )
    .unwrap();
    let err = Network::load(&shp, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("edges.shp") && err.contains("projected"),
        "{err}"
    );
}

#[test]
fn missing_dbf_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let shp = dir.path().join("edges.shp");
    write_edges(&shp);
    std::fs::remove_file(dir.path().join("edges.dbf")).unwrap();
    let err = Network::load(&shp, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("edges.shp") && err.contains("shapefile"),
        "{err}"
    );
}
