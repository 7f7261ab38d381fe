"""Sun positions from pvlib's NREL SPA for random places and instants, the reference the crate's
own SPA (`bevy_cloudscape::sky::solar`) is tested against (`cargo test sun_matches_pvlib`).

    validation/.venv/bin/python validation/sun/make_table.py

writes `validation/sun/pvlib_spa.csv`: one row per case with the inputs (Unix time in seconds,
latitude and longitude in degrees, elevation in metres, ΔT in seconds) and pvlib's topocentric
zenith and azimuth in degrees, geometric and refracted at 1013.25 hPa and 15 °C. The cases are
drawn with a fixed seed, so the file is the same on every run with the pinned pvlib.
"""

import csv
import pathlib

import numpy as np
import pandas as pd
import pvlib

CASES = 10_000
SEED = 20261201
PRESSURE_PA = 101_325.0
TEMPERATURE_C = 15.0
OUT = pathlib.Path(__file__).with_name("pvlib_spa.csv")


def main() -> None:
    rng = np.random.default_rng(SEED)
    start = pd.Timestamp("1900-01-01T00:00:00Z").value // 10**9
    end = pd.Timestamp("2100-01-01T00:00:00Z").value // 10**9
    unix_s = rng.integers(start, end, CASES)
    # Uniform over the sphere: latitude from the sine.
    latitude = np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, CASES)))
    longitude = rng.uniform(-180.0, 180.0, CASES)
    elevation = rng.uniform(0.0, 3000.0, CASES)
    # The inputs as the table writes them, so the crate reads exactly what pvlib was given.
    latitude, longitude, elevation = latitude.round(6), longitude.round(6), elevation.round(1)
    rows = []
    for t, lat, lon, h in zip(unix_s, latitude, longitude, elevation):
        time = pd.DatetimeIndex([pd.Timestamp(int(t), unit="s", tz="UTC")])
        delta_t = float(pvlib.spa.calculate_deltat(time.year, time.month)[0])
        sun = pvlib.solarposition.spa_python(
            time,
            lat,
            lon,
            altitude=h,
            pressure=PRESSURE_PA,
            temperature=TEMPERATURE_C,
            delta_t=delta_t,
        ).iloc[0]
        rows.append(
            [
                int(t),
                f"{lat:.6f}",
                f"{lon:.6f}",
                f"{h:.1f}",
                f"{delta_t:.3f}",
                f"{sun['zenith']:.7f}",
                f"{sun['apparent_zenith']:.7f}",
                f"{sun['azimuth']:.7f}",
            ]
        )
    with OUT.open("w", newline="") as file:
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow(
            [
                "unix_s",
                "latitude_deg",
                "longitude_deg",
                "elevation_m",
                "delta_t_s",
                "zenith_deg",
                "apparent_zenith_deg",
                "azimuth_deg",
            ]
        )
        writer.writerows(rows)
    print(f"wrote {len(rows)} cases to {OUT} with pvlib {pvlib.__version__}")


if __name__ == "__main__":
    main()
