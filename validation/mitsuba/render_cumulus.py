"""Path-traced truth for heterogeneous cumulus: Mitsuba 3 renders the crate's own density field
(exported on a grid by `cargo test --lib export_mitsuba_volumes -- --ignored`, which also writes
`scenes.json`) with unlimited bounces, the scene setup `slab_check.py` checks against DISORT.

    validation/.venv/bin/python validation/mitsuba/render_cumulus.py [--spp N]

writes `validation/mitsuba/<scene>.csv`: the radiance per unit sun irradiance of each pixel
(1/sr, the green channel of a white sun and sky), one line per image row from the top. The crate
is compared with them by
`cargo test --lib cumulus_base_to_top_ratio_matches_mitsuba -- --nocapture`.
"""

import argparse
import json
import pathlib

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

HERE = pathlib.Path(__file__).parent
T = mi.ScalarTransform4f


def scene(setup, view):
    lower, upper = np.array(setup["lower"]), np.array(setup["upper"])
    centre, half = 0.5 * (lower + upper), 0.5 * (upper - lower)
    phase = setup["phase"]
    medium = {
        "type": "heterogeneous",
        "albedo": 1.0,
        "scale": 1.0,
        "sigma_t": {
            "type": "gridvolume",
            "filename": str(HERE / setup["volume"]),
            "to_world": T.translate(lower.tolist()) @ T.scale((upper - lower).tolist()),
            "filter_type": "trilinear",
        },
        "phase": {
            "type": "blendphase",
            "weight": phase["back_weight"],
            "phase1": {"type": "hg", "g": phase["g_forward"]},
            "phase2": {"type": "hg", "g": phase["g_back"]},
        },
    }
    sun = np.array(view["sun"])
    return mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 100_000},
            "sensor": {
                "type": "perspective",
                "fov": setup["fov_deg"],
                "fov_axis": "x",
                "to_world": T.look_at(origin=view["origin"], target=view["target"], up=[0, 1, 0]),
                "film": {
                    "type": "hdrfilm",
                    "width": setup["width"],
                    "height": setup["height"],
                    "rfilter": {"type": "box"},
                },
                "sampler": {"type": "independent"},
            },
            "sun": {"type": "directional", "direction": (-sun).tolist(), "irradiance": 1.0},
            "sky": {"type": "constant", "radiance": setup["sky"]},
            "clouds": {
                "type": "cube",
                "to_world": T.translate(centre.tolist()) @ T.scale(half.tolist()),
                "bsdf": {"type": "null"},
                "interior": medium,
            },
            "ground": {
                "type": "rectangle",
                "to_world": T.translate([0.0, -1.0, 0.0])
                @ T.rotate([1.0, 0.0, 0.0], -90.0)
                @ T.scale(1.0e6),
                "bsdf": {"type": "diffuse", "reflectance": 0.0},
            },
        }
    )


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--spp", type=int, default=1024)
    args = parser.parse_args()
    setup = json.loads((HERE / "scenes.json").read_text())
    for view in setup["scenes"]:
        image = np.array(mi.render(scene(setup, view), spp=args.spp))[:, :, 1]
        out = HERE / f"{view['name']}.csv"
        np.savetxt(out, image, delimiter=",", fmt="%.6e")
        print(f"wrote {out} (mean {image.mean():.5f})")


if __name__ == "__main__":
    main()
