"""Mitsuba 3 (`scalar_rgb`, `volpath` with unlimited bounces) on a horizontally homogeneous haze:
the truth for the crate's haze march (`src/reference/haze.rs`, `haze_against_mitsuba`).

    validation/.venv/bin/python validation/haze/make_haze.py [SPP]

writes `validation/haze/mitsuba_haze.csv`: the radiance seen from 300 m up at several elevations
and at 90 and 180 degrees of azimuth from the sun, once under the sun alone (unit irradiance,
45 degrees up, toward -z) and once under the sky alone (an isotropic radiance of 0.05 per unit
sun irradiance above the haze). The haze has an extinction of 1e-4 /m at the ground falling by e
every 1 200 m up to 8 scale heights, albedo 0.9 and a Henyey-Greenstein phase of asymmetry 0.7,
over a black ground, on a flat planet (a box 6 000 km wide).
"""
import csv
import math
import pathlib
import sys
import numpy as np
import mitsuba as mi
mi.set_variant("scalar_rgb")

# The haze: ground extinction (1/m), scale height (m), top, half width of the box (m).

SIGMA0 = 1.0e-4
H = 1200.0
TOP = 8 * H
HALF = 3.0e6
ALBEDO, G = 0.9, 0.7
N = 512
CAM = 300.0
SUN_ELEV = 45.0

def scene(sun, sky, elev, az):
    z = (np.arange(N) + 0.5) / N * TOP
    col = (SIGMA0 * np.exp(-z / H)).astype(np.float32)
    data = np.zeros((2, N, 2, 1), dtype=np.float32)  # z, y, x, channels
    for k in range(2):
        for i in range(2):
            data[k, :, i, 0] = col
    grid = mi.VolumeGrid(data)
    e = math.radians(SUN_ELEV)
    beam = [0.0, -math.sin(e), math.cos(e)]  # sun toward -z, up
    ve, va = math.radians(elev), math.radians(az)
    direction = [math.cos(ve) * math.sin(va), math.sin(ve), -math.cos(ve) * math.cos(va)]
    to_world = mi.ScalarTransform4f.translate([-HALF, 0.0, -HALF]) @ mi.ScalarTransform4f.scale([2 * HALF, TOP, 2 * HALF])
    d = {
        "type": "scene",
        "hazemedium": {"type": "heterogeneous", "albedo": ALBEDO,
                       "phase": {"type": "hg", "g": G},
                       "sigma_t": {"type": "gridvolume", "grid": grid, "to_world": to_world, "filter_type": "trilinear"},
                       "scale": 1.0},
        "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 100000},
        "sensor": {"type": "radiancemeter", "origin": [0.0, CAM, 0.0], "direction": direction,
                   "sampler": {"type": "independent", "sample_count": 1},
                   "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}},
                   "medium": {"type": "ref", "id": "hazemedium"}},
        "haze": {"type": "cube",
                 "to_world": mi.ScalarTransform4f.translate([0.0, 0.5 * TOP, 0.0]) @ mi.ScalarTransform4f.scale([HALF, 0.5 * TOP, HALF]),
                 "bsdf": {"type": "null"},
                 "interior": {"type": "ref", "id": "hazemedium"}},
        "ground": {"type": "rectangle",
                   "to_world": mi.ScalarTransform4f.translate([0.0, -50.0, 0.0]) @ mi.ScalarTransform4f.rotate([1.0, 0.0, 0.0], -90.0) @ mi.ScalarTransform4f.scale(10 * HALF),
                   "bsdf": {"type": "diffuse", "reflectance": 0.0}},
    }
    if sun > 0:
        d["sun"] = {"type": "directional", "direction": beam, "irradiance": sun}
    if sky > 0:
        d["sky"] = {"type": "constant", "radiance": sky}
    return mi.load_dict(d)

OUT = pathlib.Path(__file__).parent / "mitsuba_haze.csv"


def main():
    spp = int(sys.argv[1]) if len(sys.argv) > 1 else 1 << 16
    rows = []
    for sun, sky in [(1.0, 0.0), (0.0, 0.05)]:
        for az in [90.0, 180.0]:
            for elev in [-5.0, -1.0, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0]:
                image = mi.render(scene(sun, sky, elev, az), spp=spp)
                radiance = float(np.array(image).reshape(-1)[1])
                rows.append([sun, sky, elev, az, f"{radiance:.6e}"])
                print(f"sun {sun} sky {sky} elevation {elev:5g} azimuth {az:5g}: {radiance:.5f}", flush=True)
    with OUT.open("w", newline="") as file:
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow(["sun", "sky", "elevation_deg", "azimuth_deg", "radiance"])
        writer.writerows(rows)


if __name__ == "__main__":
    main()
