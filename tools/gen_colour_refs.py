#!/usr/bin/env python3
"""Writes the colour reference data of tests/test_spectrum.c and tests/test_color_cmd.c
into tests/data/colour/, computed once with the colour-science package (independent
of spectrace's C code):

- colorchecker/NN.csv: the 24 ColorChecker reflectances ("ColorChecker N Ohta",
  colour.SDS_COLOURCHECKERS, 380-780 nm at 5 nm) as `wavelength_nm,value` CSV.
- colorchecker_expected.csv: per patch, XYZ under CIE D65 (colour.SDS_ILLUMINANTS
  ["D65"]) normalised so a perfect white reflector has Y = 1, and the 8-bit sRGB
  of that XYZ (colour.XYZ_to_sRGB, clipped to [0, 1], round(255 v)). The spectra
  are put on the CMF grid (CIE 1931 2 degree, 360-830 nm, 1 nm) by linear
  interpolation, zero outside their range, which is spectrace's documented
  convention, and integrated by colour.sd_to_XYZ(method="Integration").
- efficacy.csv: luminous efficacy (colour.luminous_efficacy, lm/W) of Planck
  blackbodies (colour.sd_blackbody) on 360-830 nm at 1 nm.

Run: python3 tools/gen_colour_refs.py  (from the repository root)
"""
import os
import warnings

warnings.filterwarnings("ignore")
import numpy as np  # noqa: E402
import colour  # noqa: E402
from colour import SpectralShape  # noqa: E402
from colour.algebra import LinearInterpolator  # noqa: E402

OUT = os.path.join("tests", "data", "colour")
SHAPE = SpectralShape(360, 830, 1)
ZERO = {"method": "Constant", "left": 0, "right": 0}


def on_grid(sd):
    """sd linearly interpolated onto the 1 nm CMF grid, zero outside its range."""
    return sd.copy().align(SHAPE, interpolator=LinearInterpolator, extrapolator_kwargs=ZERO)


def main():
    os.makedirs(os.path.join(OUT, "colorchecker"), exist_ok=True)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(SHAPE)
    d65 = on_grid(colour.SDS_ILLUMINANTS["D65"])
    patches = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    rows = ["# index,name,X,Y,Z,R8,G8,B8 (colour-science %s; see tools/gen_colour_refs.py)"
            % colour.__version__]
    for i, (name, sd) in enumerate(patches.items()):
        path = os.path.join(OUT, "colorchecker", "%02d.csv" % (i + 1))
        with open(path, "w") as f:
            f.write("# ColorChecker N Ohta patch %d '%s' (colour-science %s), reflectance\n"
                    % (i + 1, name, colour.__version__))
            f.write("wavelength_nm,value\n")
            for w, v in zip(sd.wavelengths, sd.values):
                f.write("%g,%.6g\n" % (w, v))
        # Re-read what was written, so the reference matches the committed file.
        data = np.loadtxt(path, delimiter=",", comments="#", skiprows=2)
        sd2 = colour.SpectralDistribution(dict(zip(data[:, 0], data[:, 1])))
        xyz = colour.sd_to_XYZ(on_grid(sd2), cmfs, d65, method="Integration") / 100.0
        rgb = colour.XYZ_to_sRGB(xyz)
        rgb8 = np.round(255.0 * np.clip(rgb, 0.0, 1.0)).astype(int)
        rows.append("%d,%s,%.7f,%.7f,%.7f,%d,%d,%d"
                    % (i + 1, name.replace(",", " "), xyz[0], xyz[1], xyz[2], *rgb8))
    with open(os.path.join(OUT, "colorchecker_expected.csv"), "w") as f:
        f.write("\n".join(rows) + "\n")

    with open(os.path.join(OUT, "efficacy.csv"), "w") as f:
        f.write("# kelvin,lm_per_W: colour.luminous_efficacy(colour.sd_blackbody(T, "
                "SpectralShape(360, 830, 1))), colour-science %s\n" % colour.__version__)
        for t in (2856.0, 6500.0):
            sd = colour.sd_blackbody(t, SHAPE)
            f.write("%g,%.6f\n" % (t, colour.luminous_efficacy(sd)))


if __name__ == "__main__":
    main()
