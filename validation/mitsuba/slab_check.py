"""Mitsuba 3 against DISORT on the homogeneous decks of `validation/disort/slabs.csv`: the
check that the Mitsuba scenes (units, sun, phase, sky) describe the same problem as the crate,
before they stand in for the truth of heterogeneous clouds.

    validation/.venv/bin/python validation/mitsuba/slab_check.py

prints, for some decks, Mitsuba's radiance (a radiance meter, unlimited bounces) against
DISORT's and writes `validation/mitsuba/slab_check.csv`.
"""

import csv
import math
import pathlib

import mitsuba as mi

mi.set_variant("scalar_rgb")

HERE = pathlib.Path(__file__).parent
TABLE = HERE.parent / "disort" / "slabs.csv"
OUT = HERE / "slab_check.csv"
BASE_M, TOP_M = 1000.0, 2000.0
HALF_WIDTH_M = 200_000.0
G_FORWARD, G_BACK, BACK_WEIGHT = 0.8, -0.3, 0.2
SAMPLES = 1 << 18
CASES = [(2.0, 40.0), (8.0, 0.0), (30.0, 40.0), (8.0, 70.0)]


def scene(optical_depth, sun_zenith_deg, sky, looking_up, view_zenith_deg):
    zenith = math.radians(sun_zenith_deg)
    # Toward the sun: up and toward -z; the beam travels the other way.
    beam = [0.0, -math.cos(zenith), math.sin(zenith)]
    v = math.radians(view_zenith_deg)
    direction = [math.sin(v), math.cos(v) if looking_up else -math.cos(v), 0.0]
    origin = [0.0, 0.0 if looking_up else 3000.0, 0.0]
    medium = {
        "type": "homogeneous",
        "sigma_t": optical_depth / (TOP_M - BASE_M),
        "albedo": 1.0,
        "phase": {
            "type": "blendphase",
            "weight": BACK_WEIGHT,
            "phase1": {"type": "hg", "g": G_FORWARD},
            "phase2": {"type": "hg", "g": G_BACK},
        },
    }
    deck = {
        "type": "cube",
        "to_world": mi.ScalarTransform4f.translate([0.0, 0.5 * (BASE_M + TOP_M), 0.0])
        @ mi.ScalarTransform4f.scale([HALF_WIDTH_M, 0.5 * (TOP_M - BASE_M), HALF_WIDTH_M]),
        "bsdf": {"type": "null"},
        "interior": medium,
    }
    ground = {
        "type": "rectangle",
        "to_world": mi.ScalarTransform4f.translate([0.0, -1.0, 0.0])
        @ mi.ScalarTransform4f.rotate([1.0, 0.0, 0.0], -90.0)
        @ mi.ScalarTransform4f.scale(10.0 * HALF_WIDTH_M),
        "bsdf": {"type": "diffuse", "reflectance": 0.0},
    }
    description = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 100_000},
        "sensor": {
            "type": "radiancemeter",
            "origin": origin,
            "direction": direction,
            "sampler": {"type": "independent", "sample_count": SAMPLES},
            "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}},
        },
        "sun": {"type": "directional", "direction": beam, "irradiance": 1.0},
        "deck": deck,
        "ground": ground,
    }
    if sky > 0.0:
        description["sky"] = {"type": "constant", "radiance": sky}
    return mi.load_dict(description)


def main():
    disort = {
        (float(r["optical_depth"]), float(r["sun_zenith_deg"]), float(r["sky_radiance"])): r
        for r in csv.DictReader(TABLE.open())
    }
    rows = []
    for tau, zenith in CASES:
        for sky in (0.0, 0.05):
            for name, up, view in [("below_zenith", True, 0.0), ("above_nadir", False, 0.0)]:
                image = mi.render(scene(tau, zenith, sky, up, view), spp=SAMPLES)
                ours = float(mi.TensorXf(image).numpy().reshape(-1)[1])
                reference = float(disort[(tau, zenith, sky)][name])
                rows.append([tau, zenith, sky, name, f"{ours:.6e}", f"{reference:.6e}"])
                print(f"{tau:5g} {zenith:3g}° {sky:4g} {name:13}: Mitsuba {ours:.5f} DISORT {reference:.5f} ({100 * (ours / reference - 1):+.1f} %)")
    with OUT.open("w", newline="") as file:
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow(["optical_depth", "sun_zenith_deg", "sky_radiance", "view", "mitsuba", "disort"])
        writer.writerows(rows)


if __name__ == "__main__":
    main()
