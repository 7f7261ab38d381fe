//! The crate's solar position against an independent implementation of the same algorithm:
//! pvlib's NREL SPA (`validation/sun/`, which says how the table is made), at 10 000 random
//! places and instants between 1900 and 2100.

use super::solar::{Observer, SolarOptions, solar_position_unix_seconds};

/// The committed table, relative to the crate root.
const TABLE: &str = "validation/sun/pvlib_spa.csv";
/// The columns the table must have, in order.
const HEADER: &str = "unix_s,latitude_deg,longitude_deg,elevation_m,delta_t_s,zenith_deg,\
                      apparent_zenith_deg,azimuth_deg";
/// The largest difference allowed in zenith and azimuth, degrees (the validation target).
const TOLERANCE_DEG: f64 = 0.01;

/// One row of the table.
#[derive(Debug, Clone, Copy)]
struct Case {
    unix_s: f64,
    observer: Observer,
    delta_t_s: f64,
    zenith_deg: f64,
    apparent_zenith_deg: f64,
    azimuth_deg: f64,
}

/// The cases of `text` (the contents of `file`); an error names the file, the row (1 is the
/// header) and what is wrong.
fn parse_table(file: &str, text: &str) -> Result<Vec<Case>, String> {
    crate::reference::table::parse_table(file, text, HEADER, 8, |_, values| {
        let &[unix_s, lat, lon, h, delta_t, zenith, apparent, azimuth] = values else {
            unreachable!("the reader checks the field count");
        };
        Ok(Case {
            unix_s,
            observer: Observer {
                latitude_deg: lat,
                longitude_deg: lon,
                elevation_m: h,
            },
            delta_t_s: delta_t,
            zenith_deg: zenith,
            apparent_zenith_deg: apparent,
            azimuth_deg: azimuth,
        })
    })
}

/// The largest differences to pvlib over `cases`, degrees: geometric zenith, refracted zenith,
/// azimuth (where the sun is more than 1° from the zenith and the nadir, where azimuth has a
/// meaning), and azimuth as an arc on the sky (`Δazimuth · sin zenith`, everywhere).
fn largest_differences(cases: &[Case]) -> [f64; 4] {
    let mut largest = [0.0_f64; 4];
    for case in cases {
        let options = SolarOptions {
            delta_t_s: Some(case.delta_t_s),
            refraction: false,
            pressure_hpa: 1013.25,
            temperature_c: 15.0,
        };
        let geometric = solar_position_unix_seconds(&case.observer, case.unix_s, &options);
        let refracted = solar_position_unix_seconds(
            &case.observer,
            case.unix_s,
            &SolarOptions {
                refraction: true,
                ..options
            },
        );
        let azimuth = (geometric.azimuth_deg - case.azimuth_deg + 540.0).rem_euclid(360.0) - 180.0;
        let zenith = case.zenith_deg;
        let differences = [
            (geometric.zenith_deg - zenith).abs(),
            (refracted.zenith_deg - case.apparent_zenith_deg).abs(),
            if (1.0..=179.0).contains(&zenith) {
                azimuth.abs()
            } else {
                0.0
            },
            (azimuth * zenith.to_radians().sin()).abs(),
        ];
        for (l, d) in largest.iter_mut().zip(differences) {
            *l = l.max(d);
        }
    }
    largest
}

#[test]
fn sun_matches_pvlib_spa_at_ten_thousand_places_and_instants() {
    let cases = crate::reference::table::read_committed(TABLE, parse_table);
    assert_eq!(cases.len(), 10_000, "{TABLE}");
    let [zenith, apparent, azimuth, arc] = largest_differences(&cases);
    println!(
        "largest differences to pvlib, degrees: zenith {zenith:.2e}, refracted zenith \
         {apparent:.2e}, azimuth {azimuth:.2e}, azimuth arc {arc:.2e}"
    );
    for (what, difference) in [
        ("zenith", zenith),
        ("refracted zenith", apparent),
        ("azimuth", azimuth),
    ] {
        assert!(
            difference <= TOLERANCE_DEG,
            "{what} differs from pvlib by {difference}° (at most {TOLERANCE_DEG}°)"
        );
    }
}

#[test]
fn a_broken_table_names_the_file_and_row() {
    let header = HEADER;
    let good = "1000000000,46.9,7.4,540.0,64.0,50.0,49.9,180.0";
    let bad = [
        (String::new(), "empty"),
        ("unix_s,zenith\n1,2".to_owned(), "row 1: header"),
        (format!("{header}\n"), "no cases"),
        (format!("{header}\n{good}\n1,2,3"), "row 3: 3 fields"),
        (
            format!("{header}\n{good}\n{}", good.replace("50.0", "NaN")),
            "row 3: \"NaN\" is not a number",
        ),
        (
            format!("{header}\n{}", good.replace("540.0", "x")),
            "row 2: \"x\" is not a number",
        ),
    ];
    for (text, expected) in bad {
        let error = parse_table("table.csv", &text).expect_err(&text);
        assert!(error.starts_with("table.csv: "), "{error}");
        assert!(error.contains(expected), "{error} lacks {expected:?}");
    }
    assert_eq!(
        parse_table("table.csv", &format!("{header}\n{good}"))
            .unwrap()
            .len(),
        1
    );
}
