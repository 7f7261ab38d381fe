"""Radiances of homogeneous cloud slabs from DISORT (Stamnes et al. 1988, "Numerically stable
algorithm for discrete-ordinate-method radiative transfer in multiple scattering and emitting
layered media"), the reference the crate's light model is tested against
(`cargo test --lib disort`).

    validation/.venv/bin/python validation/disort/make_slabs.py

writes `validation/disort/slabs.csv`. Each case is one plane-parallel, horizontally infinite
layer of optical depth `optical_depth` over a black ground, lit by a sun at `sun_zenith_deg`
(beam irradiance 1 on a surface facing the sun) and, when `sky_radiance` is not 0, by an
isotropic sky of that radiance on its top (per unit beam irradiance, 1/sr). The layer scatters
conservatively with the crate's dual-lobe Henyey-Greenstein phase at its defaults: 0.8 of a
lobe with g = 0.8 and 0.2 of one with g = -0.3. For each case the table holds the radiance, per
unit beam irradiance (1/sr), seen by an observer below the layer looking up (at the zenith and
45 degrees from it) and above it looking down (at the nadir and 45 degrees from it); the 45
degree views look 90 degrees in azimuth away from the sun. It also holds the layer's
transmitted and reflected fluxes per unit beam irradiance on a horizontal surface: the total
(direct and diffuse) downward flux at the base, the direct beam alone, and the upward flux at
the top.
"""

import csv
import math
import pathlib

import numpy as np
import torch
from pydisort import Disort, DisortOptions, scattering_moments

OPTICAL_DEPTHS = [0.5, 2.0, 8.0, 30.0, 100.0]
SUN_ZENITHS_DEG = [0.0, 40.0, 70.0, 85.0]
# Isotropic sky radiance on the top per unit beam irradiance, 1/sr: off, and about the crate's
# default ratio (a zenith sky of 5000 cd/m^2 under a sun of 100 000 lux).
SKY_RADIANCES = [0.0, 0.05]
# The crate's default dual-lobe phase (`MarchSettings`: phase_g_forward, phase_g_back,
# phase_blend).
G_FORWARD, G_BACK, BACK_WEIGHT = 0.8, -0.3, 0.2
# 64 streams and 64 phase moments: the dual lobe's moments fall below 1e-6 by the 64th, so the
# phase needs no truncation (nor DISORT's intensity correction), and 128 streams change no
# radiance by more than 1e-4.
STREAMS = 64
VIEW_AZIMUTH_DEG = 90.0
# (name, cosine of the travel direction in DISORT's convention: positive upward; the level).
VIEWS = [
    ("below_zenith", -1.0, "base"),
    ("below_45", -math.cos(math.radians(45.0)), "base"),
    ("above_nadir", 1.0, "top"),
    ("above_45", math.cos(math.radians(45.0)), "top"),
]
OUT = pathlib.Path(__file__).with_name("slabs.csv")


def solve(optical_depth: float, sun_zenith_deg: float, sky: float) -> dict:
    """One DISORT run: the radiances of every view and the fluxes at both levels."""
    options = DisortOptions().flags("usrtau,usrang,lamber,quiet")
    options.ds().nlyr = 1
    options.ds().nstr = STREAMS
    options.ds().nmom = STREAMS
    options.ds().nphase = STREAMS
    options.user_tau(np.array([0.0, optical_depth]))
    # DISORT wants the cosines sorted.
    mus = sorted({mu for _, mu, _ in VIEWS})
    options.user_mu(np.array(mus))
    options.user_phi(np.array([VIEW_AZIMUTH_DEG]))
    disort = Disort(options)
    mu0 = math.cos(math.radians(sun_zenith_deg))
    prop = torch.zeros((1, 2 + STREAMS), dtype=torch.float64)
    prop[0, 0] = optical_depth
    prop[0, 1] = 1.0
    # DISORT's double Henyey-Greenstein weights the first lobe by ff.
    prop[0, 2:] = scattering_moments(
        STREAMS, "double-henyey-greenstein", G_FORWARD, G_BACK, 1.0 - BACK_WEIGHT
    )
    boundary = {
        "umu0": torch.tensor([mu0], dtype=torch.float64),
        "phi0": torch.tensor([0.0], dtype=torch.float64),
        "fbeam": torch.tensor([[1.0]], dtype=torch.float64),
        "albedo": torch.tensor([[0.0]], dtype=torch.float64),
        "fluor": torch.tensor([[0.0]], dtype=torch.float64),
        "fisot": torch.tensor([[sky]], dtype=torch.float64),
    }
    disort.forward(prop, **boundary)
    # (nwave, ncol, nphi, ntau, numu) and (nwave, ncol, ntau, 8).
    radiance = disort.gather_rad()[0, 0, 0].numpy()
    flux = disort.gather_flx()[0, 0].numpy()
    out = {}
    for name, mu, level in VIEWS:
        tau_index = 0 if level == "top" else 1
        out[name] = float(radiance[tau_index, mus.index(mu)])
    # Flux columns: direct beam, diffuse down, diffuse up (kIRFLDIR, kIFLDN, kIFLUP).
    from pydisort import kIFLDN, kIFLUP, kIRFLDIR

    out["direct_down_base"] = float(flux[1, kIRFLDIR])
    out["total_down_base"] = float(flux[1, kIRFLDIR] + flux[1, kIFLDN])
    out["up_top"] = float(flux[0, kIFLUP])
    return out


def main() -> None:
    names = [name for name, _, _ in VIEWS]
    header = (
        ["optical_depth", "sun_zenith_deg", "sky_radiance"]
        + names
        + ["total_down_base", "direct_down_base", "up_top"]
    )
    rows = []
    for optical_depth in OPTICAL_DEPTHS:
        for sun_zenith in SUN_ZENITHS_DEG:
            for sky in SKY_RADIANCES:
                out = solve(optical_depth, sun_zenith, sky)
                rows.append(
                    [f"{optical_depth:g}", f"{sun_zenith:g}", f"{sky:g}"]
                    + [f"{out[key]:.6e}" for key in header[3:]]
                )
    with OUT.open("w", newline="") as file:
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
    print(f"wrote {len(rows)} cases to {OUT}")


if __name__ == "__main__":
    main()
