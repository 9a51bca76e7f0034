#!/usr/bin/env python3
"""Compares a spectrace render (EXR, linear sRGB) with Mitsuba 3 on the same scene.

    python3 tools/mitsuba_compare.py out/cornell_box.exr scenes/cornell_box.gltf \
        --spp 256 --max-depth 8 [--tolerance 0.02] [--flip] [--save-mitsuba m.exr]

Renders the glTF with Mitsuba 3 (tools/scene_to_mitsuba.py: spectral variant,
path integrator, same max depth) at the EXR's resolution, prints both images'
per-channel means and their relative differences, optionally the mean FLIP
error (`pip install flip-evaluator`), and exits 1 when a channel's mean differs
by more than the tolerance (relative, default 2%). Exit 0 with a "skip:" line
when mitsuba is not installed; 2 for a usage error or unreadable input.

--max-depth must be the one the EXR was rendered with (spectrace's --max-depth;
same convention: segments from the camera, -1 unlimited), and --background the
one it was rendered with (spectrace's default: a D65 sky of film Y = 1 when the
scene has no light). Materials without an exact Mitsuba counterpart are
refused (exit 2, the reason named) unless --approx (tools/scene_to_mitsuba.py
lists the mapping).
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scene_to_mitsuba as s2m  # noqa: E402


def read_exr_rgb(mi, np, path):
    """HxWx3 float64 linear RGB of an EXR (the R, G, B channels; other layers ignored)."""
    bmp = mi.Bitmap(path)
    arr = np.array(bmp, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[..., None]
    pf = bmp.pixel_format()
    if pf in (mi.Bitmap.PixelFormat.RGB, mi.Bitmap.PixelFormat.RGBA):
        return arr[..., :3]
    if pf in (mi.Bitmap.PixelFormat.Y, mi.Bitmap.PixelFormat.YA):
        return np.repeat(arr[..., :1], 3, axis=2)
    # Multichannel: pick R, G, B by name (layered EXR such as a checkpoint).
    names = [c for c in bmp.struct_()] if hasattr(bmp, "struct_") else []
    names = [getattr(f, "name", str(f)) for f in names]
    pick = []
    for want in ("R", "G", "B"):
        idx = [i for i, n in enumerate(names) if n == want or n.endswith("." + want)]
        if not idx:
            raise ValueError("%s: no %s channel (channels: %s)" % (path, want, ", ".join(names)))
        pick.append(idx[0])
    return arr[..., pick]


def flip_error(np, ref, test):
    try:
        import flip_evaluator as flip
    except ImportError:
        return None
    _, mean, _ = flip.evaluate(np.ascontiguousarray(ref, np.float32), np.ascontiguousarray(test, np.float32), "HDR")
    return float(mean)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Compare a spectrace EXR with a Mitsuba 3 render of the same scene.")
    ap.add_argument("exr", help="spectrace's image (linear EXR)")
    ap.add_argument("scene", help="the .gltf it was rendered from")
    ap.add_argument("--spp", type=int, default=256, help="Mitsuba samples per pixel (default 256)")
    ap.add_argument("--max-depth", type=int, default=-1, help="as spectrace's --max-depth (default -1)")
    ap.add_argument("--tolerance", type=float, default=0.02,
                    help="largest relative difference of a channel mean that passes (default 0.02)")
    ap.add_argument("--variant", default="auto", help="Mitsuba variant (default: llvm_ad_spectral if possible)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--approx", action="store_true",
                    help="convert materials without an exact Mitsuba counterpart to the nearest one (warned)")
    ap.add_argument("--background", metavar="black|R,G,B", help="as spectrace's --background")
    ap.add_argument("--flip", action="store_true", help="also print the mean FLIP error (flip-evaluator)")
    ap.add_argument("--save-mitsuba", metavar="EXR", help="write Mitsuba's image here")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    a = ap.parse_args(argv)
    if not os.path.isfile(a.exr) or not os.path.isfile(a.scene):
        print("error: %s: no such file" % (a.exr if not os.path.isfile(a.exr) else a.scene), file=sys.stderr)
        return 2
    mi = s2m.import_mitsuba(a.variant)
    if mi is None:
        print("skip: " + s2m.MITSUBA_MISSING)
        return 0
    import numpy as np
    try:
        ours = read_exr_rgb(mi, np, a.exr)
    except Exception as e:  # noqa: BLE001
        print("error: %s: cannot read: %s" % (a.exr, e), file=sys.stderr)
        return 2
    h, w = ours.shape[:2]
    try:
        ref, info = s2m.render(a.scene, w, h, a.spp, a.max_depth, a.variant, a.seed, verbose=False,
                               approx=a.approx, background=s2m.parse_background(a.background))
    except ValueError as e:   # a material Mitsuba cannot render exactly, a bad --background
        print("error: %s: %s" % (a.scene, e), file=sys.stderr)
        return 2
    if a.save_mitsuba:
        s2m.write_exr(mi, a.save_mitsuba, ref)
    m_ours, m_ref = ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1))
    rel = (m_ours - m_ref) / np.maximum(np.abs(m_ref), 1e-12)
    nonfinite = int((~np.isfinite(ours)).sum())
    worst = float(np.max(np.abs(rel)))
    ok = worst <= a.tolerance and nonfinite == 0
    result = {"exr": a.exr, "scene": a.scene, "width": w, "height": h, "max_depth": a.max_depth,
              "mitsuba": {"variant": info["variant"], "version": info["mitsuba_version"], "spp": a.spp,
                          "render_s": round(info["render_s"], 3)},
              "mean_spectrace": m_ours.tolist(), "mean_mitsuba": m_ref.tolist(),
              "relative_difference": rel.tolist(), "tolerance": a.tolerance,
              "nonfinite_pixels": nonfinite, "pass": ok}
    if info.get("warnings"):
        result["converter_warnings"] = info["warnings"]
    if "stderr_of_mean" in info:
        result["mitsuba_stderr_of_mean"] = info["stderr_of_mean"]
    if a.flip:
        f = flip_error(np, ref, ours)
        if f is None:
            print("note: flip-evaluator is not installed (pip install flip-evaluator); no FLIP error",
                  file=sys.stderr)
        else:
            result["flip_mean"] = f
    if a.json:
        print(json.dumps(result, indent=1))
    else:
        print("%s vs Mitsuba %s (%s, %d spp, max depth %d, %dx%d, %.1f s)"
              % (a.exr, info["mitsuba_version"], info["variant"], a.spp, a.max_depth, w, h, info["render_s"]))
        print("  mean spectrace: %.6f %.6f %.6f" % tuple(m_ours))
        print("  mean Mitsuba:   %.6f %.6f %.6f" % tuple(m_ref))
        print("  relative diff:  %+.4f %+.4f %+.4f (tolerance %.4f)" % (tuple(rel) + (a.tolerance,)))
        if nonfinite:
            print("  %d non-finite values in %s" % (nonfinite, a.exr))
        if "flip_mean" in result:
            print("  mean FLIP (HDR): %.4f" % result["flip_mean"])
        print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
