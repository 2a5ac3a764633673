//! The recording's tests: column and unit guessing, explicit columns, temperature, time checks
//! and the CSV round trip.

use super::*;
use crate::input::table::Table;

fn read(text: &str, map: &ColumnMap) -> Result<Recording, RecordingError> {
    Recording::read_csv(text.as_bytes(), "rec.csv", map)
}

#[test]
fn guesses_columns_and_units_from_header() {
    let r = read(
        "t_ms;ax_g;ay_g;az_g\n0;0;0;1\n10;0.1;0;1\n",
        &ColumnMap::default(),
    )
    .unwrap();
    assert_eq!(r.time_s, [0.0, 0.01]);
    assert!((r.accel_mps2[2][0] - STANDARD_GRAVITY).abs() < 1e-12);
    assert!((r.sample_rate_hz() - 100.0).abs() < 1e-9);
}

#[test]
fn explicit_columns_by_name_and_index() {
    let map = ColumnMap::default().with_columns("4,x,y,z").unwrap();
    let r = read("x y z time\n1 2 3 0\n4 5 6 1\n", &map).unwrap();
    assert_eq!(r.time_s, [0.0, 1.0]);
    assert_eq!(r.accel_mps2[0], [1.0, 4.0]);
    let e = read(
        "x y z time\n1 2 3 0\n",
        &ColumnMap::default().with_columns("t,x,y,z").unwrap(),
    )
    .unwrap_err();
    assert_eq!(e.to_string(), "rec.csv: no column 't' (columns: x, y, z, time)");
}

#[test]
fn temperature_column_by_name_unit_or_position() {
    let r = read(
        "t,ax,ay,az,gx,gy,gz,Temperature\n0,0,0,9.8,0,0,0,24.5\n0.01,0,0,9.8,0,0,0,25\n",
        &ColumnMap::default(),
    )
    .unwrap();
    assert_eq!(r.temperature_c, Some(vec![24.5, 25.0]));
    assert!(r.gyro_radps.is_some());
    let r = read(
        "t,ax,ay,az,temp_f\n0,0,0,9.8,212\n0.01,0,0,9.8,32\n",
        &ColumnMap::default(),
    )
    .unwrap();
    assert_eq!(r.temperature_c, Some(vec![100.0, 0.0]));
    let map = ColumnMap::default().with_columns("time,x,y,z,die").unwrap();
    let r = read(
        "time,x,y,z,die\n0,0,0,9.8,300\n1,0,0,9.8,301\n",
        &ColumnMap {
            temperature_unit: Some(TemperatureUnit::K),
            ..map
        },
    )
    .unwrap();
    assert!((r.temperature_c.as_ref().unwrap()[1] - 27.85).abs() < 1e-9);
    assert!(r.gyro_radps.is_none());
    // Written as temp_c and read back.
    let mut out = Vec::new();
    r.write_csv(&mut out, AccelUnit::Mps2).unwrap();
    let back = read(std::str::from_utf8(&out).unwrap(), &ColumnMap::default()).unwrap();
    assert_eq!(back.temperature_c, r.temperature_c);
    // The MPU-6050 register map: −521 counts is 35 °C.
    assert!((TemperatureUnit::Mpu6050Counts.to_celsius(-521.0) - 35.0).abs() < 0.005);
}

#[test]
fn time_going_backwards_names_the_line() {
    let e = read(
        "t,ax,ay,az\n0,0,0,1\n0.02,0,0,1\n0.01,0,0,1\n",
        &ColumnMap::default(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "rec.csv:4: time goes backwards (0.02 s, then 0.01 s)"
    );
}

#[test]
fn round_trips_through_csv() {
    let r = read(
        "t,ax,ay,az,gx,gy,gz\n0,0.5,0,9.8,0,0,0.1\n0.01,0.25,0,9.7,0,0,0.2\n",
        &ColumnMap::default(),
    )
    .unwrap();
    let mut out = Vec::new();
    r.write_csv(&mut out, AccelUnit::G).unwrap();
    let back = read(std::str::from_utf8(&out).unwrap(), &ColumnMap::default()).unwrap();
    for a in 0..3 {
        for (x, y) in r.accel_mps2[a].iter().zip(&back.accel_mps2[a]) {
            assert!((x - y).abs() < 1e-12);
        }
    }
    assert_eq!(back.gyro_radps, r.gyro_radps);
}

/// Parsing with units applied on the way gives what reading the table and then converting gave:
/// the same bits, and the same first error (a bad cell anywhere before a column problem).
#[test]
fn units_applied_while_parsing_match_the_table_route() {
    let map = |columns: Option<&str>| match columns {
        Some(c) => ColumnMap::default().with_columns(c).unwrap(),
        None => ColumnMap::default(),
    };
    let mut long = String::from("t_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps,temp\n");
    for i in 0..40_000 {
        let x = (i as f64 * 0.37).sin();
        long.push_str(&format!(
            "{},{x},{},{},{},{},{},25.5\n",
            i * 10,
            x / 7.0,
            1.0 - x,
            x * 300.0,
            -x,
            x / 3.0
        ));
    }
    let cases: Vec<(String, ColumnMap)> = vec![
        ("t_ms;ax_g;ay_g;az_g\n0;0;0;1\n10;0.1;0;1\n".into(), map(None)),
        (
            "t,ax,ay,az,gx_dps,gy_dps,gz_dps\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6\n".into(),
            map(None),
        ),
        ("x y z time\n1 2 3 0\n4 5 6 1\n".into(), map(Some("4,x,y,z"))),
        ("t,a\n0,1\n1,2\n".into(), map(Some("t,a,a,a"))),
        ("0,1,2,3\n1,2,3,4\n".into(), map(None)),
        ("0,1,2,3,4,5,6,7\n1,2,3,4,5,6,7,8\n".into(), map(None)),
        ("t,ax,ay,az\n0,1,2,3\n1,x,2,3\n".into(), map(None)),
        ("x y z time\n1 2 3 0\n4 5 q 1\n".into(), map(Some("time,x,y,z"))),
        ("x y z time\n1 2 3 0\n4 5 6 1\n".into(), map(Some("t,x,y,z"))),
        ("t,ax,ay,az\n0,0,0,1\n0.02,0,0,1\n0.01,0,0,1\n".into(), map(None)),
        (long.clone(), map(None)),
        (long.clone(), map(Some("t_ms,temp,ax_g,ax_g"))),
        (long.replace("\n39000,", "\n39000,,"), map(None)),
    ];
    for (text, map) in &cases {
        let table_route = Table::parse(text.as_bytes(), "rec.csv", &map.table)
            .map_err(RecordingError::from)
            .and_then(|t| Recording::from_table(&t, map));
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let parsed = pool.install(|| Recording::parse_csv(text.as_bytes(), "rec.csv", map));
            match (&parsed, &table_route) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(a, b);
                    let bits = |r: &Recording| {
                        let mut v: Vec<u64> = r.time_s.iter().map(|x| x.to_bits()).collect();
                        for axis in r.accel_mps2.iter().chain(r.gyro_radps.iter().flatten()) {
                            v.extend(axis.iter().map(|x| x.to_bits()));
                        }
                        v
                    };
                    assert_eq!(bits(a), bits(b));
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                _ => panic!("{parsed:?} vs {table_route:?}"),
            }
        }
    }
}
