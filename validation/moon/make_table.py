"""Moon positions and phases from PyEphem (XEphem's libastro), the published ephemeris the crate's
own lunar position (`bevy_cloudscape::sky::moon`) is tested against (`cargo test
moon_matches_ephem`).

    validation/.venv/bin/python validation/moon/make_table.py

writes `validation/moon/ephem_moon.csv`: one row per case with the inputs (Unix time in seconds,
latitude and longitude in degrees, elevation in metres) and PyEphem's topocentric apparent
altitude and azimuth of the moon's centre without refraction (pressure 0), in degrees, its
illuminated fraction (0 new to 1 full) and its distance from the Earth's centre in kilometres. The cases are
drawn with a fixed seed, so the file is the same on every run with the pinned PyEphem.
"""

import csv
import datetime
import math
import pathlib
import random

import ephem

CASES = 1_000
SEED = 20261206
AU_KM = 149_597_870.7
OUT = pathlib.Path(__file__).with_name("ephem_moon.csv")


def main() -> None:
    rng = random.Random(SEED)
    start = int(datetime.datetime(1900, 1, 1, tzinfo=datetime.timezone.utc).timestamp())
    end = int(datetime.datetime(2100, 1, 1, tzinfo=datetime.timezone.utc).timestamp())
    rows = []
    for _ in range(CASES):
        unix_s = rng.randrange(start, end)
        # Uniform over the sphere: latitude from the sine.
        latitude = round(math.degrees(math.asin(rng.uniform(-1.0, 1.0))), 6)
        longitude = round(rng.uniform(-180.0, 180.0), 6)
        elevation = round(rng.uniform(0.0, 3000.0), 1)
        observer = ephem.Observer()
        observer.lat = math.radians(latitude)
        observer.lon = math.radians(longitude)
        observer.elevation = elevation
        observer.pressure = 0.0  # no refraction: the geometric direction
        instant = datetime.datetime.fromtimestamp(unix_s, tz=datetime.timezone.utc)
        observer.date = ephem.Date(instant.replace(tzinfo=None))
        moon = ephem.Moon(observer)
        # Computed for a date alone, a body's distance is the geocentric one.
        geocentric = ephem.Moon(observer.date)
        rows.append(
            [
                unix_s,
                f"{latitude:.6f}",
                f"{longitude:.6f}",
                f"{elevation:.1f}",
                f"{math.degrees(moon.alt):.6f}",
                f"{math.degrees(moon.az):.6f}",
                f"{moon.moon_phase:.6f}",
                f"{geocentric.earth_distance * AU_KM:.1f}",
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
                "altitude_deg",
                "azimuth_deg",
                "illuminated_fraction",
                "distance_km",
            ]
        )
        writer.writerows(rows)
    print(f"wrote {len(rows)} cases to {OUT} with PyEphem {ephem.__version__}")


if __name__ == "__main__":
    main()
