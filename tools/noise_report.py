#!/usr/bin/env python3
"""Measures how clean spectrace's images are: the per-pixel noise of the grey box
under the default sky, and the relMSE of a scene against a reference render.

    python3 tools/noise_report.py grey [--spectrace BIN] [--size 128] [--spp 256]
        [--seeds 4] [--sampler sobol|zsobol|independent]
    python3 tools/noise_report.py relmse REF.exr A.exr [B.exr ...]
        [--sphere X,Y,Z,R --scene FILE.gltf]

grey: renders tests/data/scenes/grey_box_sky.gltf (a Lambertian cube of albedo
0.5 under the uniform D65 sky of radiance 1: every face pixel's expected value
is 0.5 in every channel) with --seeds seeds and prints, over the face pixels
(below 0.75 with their 8 neighbours, off the border), the mean per channel, the
standard deviation across pixels of one image (mean over the seeds) and across
seeds per pixel, per linear sRGB channel and for the luminance.

relmse: mean((c - r)^2 / (r^2 + 0.01)) over pixels and channels of each image
c against the reference r (all at one resolution), with the median and the
99th percentile of the per-pixel terms (the mean of a scene with caustics is
ruled by a few fireflies).
It also counts speckles: the fraction of pixels where some channel's relative
error z = (c - r) / sqrt(r^2 + 0.01) lies more than 5 standard deviations from
the median of the 9 x 9 pixels around it, the standard deviation being their
robust one (1.4826 times their median absolute deviation), so the noise level
may vary over the image and fireflies do not inflate it (pixels within 4 of
the border are left out). Gaussian noise puts about 1e-6 of the pixels there;
a window across an edge between differently noisy regions flags some too, so
compare renders of one scene, not the figure with zero.

--sphere X,Y,Z,R --scene FILE: the figures over the pixels whose camera ray
(through the pixel's centre, from the scene's camera as spectrace picks it)
hits that sphere alone, e.g. the default Cornell box's glass sphere:
--sphere 0.186,0.1,0.169,0.1 --scene scenes/cornell_box.gltf.

Reads EXRs with Mitsuba 3's Bitmap: exits 0 with a "skip:" line when mitsuba
or numpy is missing; 2 for a usage error or a failed render.
"""
import argparse
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GREY = os.path.join(ROOT, "tests", "data", "scenes", "grey_box_sky.gltf")


def modules():
    try:
        import numpy as np
        import mitsuba as mi
    except ImportError as e:
        print("skip: %s (pip install mitsuba numpy)" % e)
        sys.exit(0)
    mi.set_variant("scalar_rgb")
    return np, mi


def read_rgb(np, mi, path):
    arr = np.array(mi.Bitmap(path), dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.shape[2] < 3:
        arr = np.repeat(arr[..., :1], 3, axis=2)
    return arr[..., :3]


def grey(a):
    np, mi = modules()
    imgs = []
    with tempfile.TemporaryDirectory() as tmp:
        for s in range(a.seeds):
            out = os.path.join(tmp, "grey%d.exr" % s)
            cmd = [a.spectrace, "render", GREY, "-o", out, "--spp", str(a.spp), "--width", str(a.size),
                   "--height", str(a.size), "--max-depth", "-1", "--seed", str(s), "--sampler", a.sampler, "-q"]
            r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if r.returncode:
                print("error: %s failed (exit %d): %s" % (" ".join(cmd), r.returncode, r.stderr.strip()),
                      file=sys.stderr)
                sys.exit(2)
            imgs.append(read_rgb(np, mi, out))
    imgs = np.array(imgs)
    g = imgs.mean(axis=0)[..., 1]
    face = g < 0.75
    inner = face.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inner &= np.roll(np.roll(face, dy, 0), dx, 1)
    inner[0, :] = inner[-1, :] = inner[:, 0] = inner[:, -1] = False
    px = imgs[:, inner, :]
    lum = px @ np.array([0.2126, 0.7152, 0.0722])
    print("grey box, %dx%d, %d spp, sampler %s, %d seeds, %d face pixels (expected 0.5)"
          % (a.size, a.size, a.spp, a.sampler, a.seeds, inner.sum()))
    print("  mean R G B:                        %s" % " ".join("%.5f" % v for v in px.mean(axis=(0, 1))))
    print("  std across pixels R G B (lum):     %s (%.5f)"
          % (" ".join("%.5f" % v for v in px.std(axis=1).mean(axis=0)), lum.std(axis=1).mean()))
    if a.seeds > 1:
        print("  std across seeds per pixel R G B:  %s"
              % " ".join("%.5f" % v for v in np.sqrt(px.var(axis=0, ddof=1).mean(axis=0))))


def sphere_mask(np, scene, sphere, h, w):
    """HxW booleans: the pixels whose ray through their centre from the
    scene's camera (tools/blender_compare.py's spectrace_camera; the image's
    aspect ratio, the camera's vertical field of view) hits the sphere."""
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    import blender_compare
    blender_compare.s2m.np = np
    cam = blender_compare.spectrace_camera(scene, np)
    fwd, up = cam["forward"], cam["up"]
    right = np.cross(fwd, up)
    t = np.tan(cam["yfov"] / 2)
    y = (1.0 - 2.0 * (np.arange(h) + 0.5) / h) * t
    x = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * t * w / h
    d = fwd[None, None, :] + x[None, :, None] * right[None, None, :] + y[:, None, None] * up[None, None, :]
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    oc = cam["origin"] - np.array(sphere[:3])
    b = d @ oc
    return b * b - (oc @ oc - sphere[3] ** 2) > 0.0


def relmse(a):
    np, mi = modules()
    r = read_rgb(np, mi, a.ref)
    mask = None
    if a.sphere:
        mask = sphere_mask(np, a.scene, a.sphere, r.shape[0], r.shape[1])
        print("%d pixels inside the sphere" % mask.sum())
    for p in a.images:
        c = read_rgb(np, mi, p)
        if c.shape != r.shape:
            print("error: %s is %dx%d, the reference %dx%d" % (p, c.shape[1], c.shape[0], r.shape[1], r.shape[0]),
                  file=sys.stderr)
            sys.exit(2)
        e = (c - r) ** 2 / (r ** 2 + 0.01)
        z = (c - r) / np.sqrt(r ** 2 + 0.01)
        win = np.lib.stride_tricks.sliding_window_view(z, (9, 9), axis=(0, 1))
        med = np.median(win, axis=(3, 4))
        sigma = 1.4826 * np.median(np.abs(win - med[..., None, None]), axis=(3, 4))
        far = np.abs(z[4:-4, 4:-4] - med) > 5.0 * np.maximum(sigma, 1e-12)
        if mask is not None:
            e, far = e[mask], far[mask[4:-4, 4:-4]]
        speckle = far.any(axis=-1).mean()
        print("%s: relMSE %.5g (median %.3g, 99th percentile %.3g); pixels beyond 5 sigma %.4f%%"
              % (p, e.mean(), np.median(e), np.percentile(e, 99), 100.0 * speckle))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("grey", help="per-pixel noise of the grey box under the sky")
    g.add_argument("--spectrace", default=os.path.join(ROOT, "build", "spectrace"))
    g.add_argument("--size", type=int, default=128)
    g.add_argument("--spp", type=int, default=256)
    g.add_argument("--seeds", type=int, default=4)
    g.add_argument("--sampler", default="sobol", choices=("sobol", "zsobol", "independent"))
    r = sub.add_parser("relmse", help="relMSE of images against a reference")
    r.add_argument("ref")
    r.add_argument("images", nargs="+")
    r.add_argument("--sphere", type=lambda v: [float(x) for x in v.split(",")], metavar="X,Y,Z,R",
                   help="only the pixels whose camera ray hits this sphere (needs --scene)")
    r.add_argument("--scene", help="the glTF whose camera --sphere uses")
    a = ap.parse_args()
    if a.cmd == "relmse" and a.sphere and (len(a.sphere) != 4 or not a.scene):
        ap.error("--sphere takes X,Y,Z,R and needs --scene")
    if a.cmd == "grey":
        if a.size < 8 or a.spp < 1 or a.seeds < 1:
            ap.error("--size must be >= 8, --spp and --seeds >= 1")
        grey(a)
    else:
        relmse(a)


if __name__ == "__main__":
    main()
