#!/usr/bin/env python3
"""`make bench`: the light tree against power-based light selection at equal
time, on the many-light scenes of tools/make_light_scenes.py (the street of
1,000 lamps and the field of 200 emissive quads).

    python3 tools/bench_lights.py [--spectrace BIN] [--time T] [--ref-spp N]
        [--runs R] [--width W] [--scenes street,field]

Each scene renders R times with `--light-tree off` and R times with `on`,
alternated, for T seconds each (`--time T`, seeds 1..R), at W pixels wide,
and each image's relMSE = mean((c - r)^2 / (r^2 + 0.01)) over pixels and
linear sRGB channels is taken against a reference of N samples per pixel
(`--light-tree on`, seed 1000; both settings converge to the same image),
kept in SPECTRACE_CACHE_DIR/bench_lights by a hash of the scene, the width,
N and the program. Prints the medians and their ratio off / on (above 1:
the tree is cleaner in the same seconds), and the samples per pixel each
reached. The reference's own noise adds to both relMSE alike and pulls the
ratio toward 1.

Defaults: --time 10 (SPECTRACE_BENCH_TIME), --ref-spp 1024
(SPECTRACE_BENCH_REF_SPP), --runs 3 (SPECTRACE_BENCH_RUNS), --width 160.
Reads EXRs with the OpenEXR and numpy modules: without them it prints a
"skip:" line and exits 0; exit 1 when a render fails.
"""
import argparse
import hashlib
import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import make_light_scenes  # noqa: E402


def read_rgb(path):
    import numpy as np
    import OpenEXR
    import Imath
    f = OpenEXR.InputFile(path)
    dw = f.header()["dataWindow"]
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    ft = Imath.PixelType(Imath.PixelType.FLOAT)
    ch = [np.frombuffer(f.channel(c, ft), dtype=np.float32).reshape(h, w) for c in "RGB"]
    return np.stack(ch, -1).astype(np.float64)


def relmse(c, r):
    import numpy as np
    return float(np.mean((c - r) ** 2 / (r ** 2 + 0.01)))


def render(exe, scene, out, args):
    cmd = [exe, "render", scene, "-o", out] + args
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if p.returncode != 0:
        sys.stderr.write(p.stdout)
        raise RuntimeError("render failed: " + " ".join(cmd))
    m = re.search(r"(\d+) spp in ([0-9.]+) s", p.stdout)
    return (int(m.group(1)), float(m.group(2))) if m else (0, 0.0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spectrace", default=os.path.join(ROOT, "build", "spectrace"))
    ap.add_argument("--time", type=float, default=float(os.environ.get("SPECTRACE_BENCH_TIME", "10")))
    ap.add_argument("--ref-spp", type=int, default=int(os.environ.get("SPECTRACE_BENCH_REF_SPP", "1024")))
    ap.add_argument("--runs", type=int, default=int(os.environ.get("SPECTRACE_BENCH_RUNS", "3")))
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--scenes", default="street,field")
    a = ap.parse_args()
    try:
        import numpy  # noqa: F401
        import OpenEXR  # noqa: F401
    except ImportError:
        print("skip: the light tree bench reads EXRs with the OpenEXR and numpy modules")
        return 0
    cache = os.path.join(os.environ.get("SPECTRACE_CACHE_DIR", os.path.join(ROOT, "build", "cache")),
                         "bench_lights")
    os.makedirs(cache, exist_ok=True)
    with open(a.spectrace, "rb") as f:
        exe_hash = hashlib.sha256(f.read()).hexdigest()[:16]
    status = 0
    with tempfile.TemporaryDirectory() as tmp:
        make_light_scenes.street(os.path.join(tmp, "street.gltf"))
        make_light_scenes.field(os.path.join(tmp, "field.gltf"))
        print("scene | spp off / on | relMSE off | relMSE on | off / on")
        for name in a.scenes.split(","):
            scene = os.path.join(tmp, name + ".gltf")
            with open(scene, "rb") as f:
                key = hashlib.sha256(f.read() + ("%d %d %s" % (a.width, a.ref_spp, exe_hash)).encode()).hexdigest()[:16]
            ref = os.path.join(cache, "%s-%s.exr" % (name, key))
            try:
                if not os.path.exists(ref):
                    render(a.spectrace, scene, ref + ".tmp.exr", ["--width", str(a.width), "--spp", str(a.ref_spp),
                                                                  "--seed", "1000", "--light-tree", "on"])
                    os.replace(ref + ".tmp.exr", ref)
                r = read_rgb(ref)
                err = {"off": [], "on": []}
                spp = {"off": [], "on": []}
                for run in range(a.runs):
                    for mode in ("off", "on"):
                        out = os.path.join(tmp, "%s-%s-%d.exr" % (name, mode, run))
                        n, _ = render(a.spectrace, scene, out, ["--width", str(a.width), "--time", str(a.time),
                                                                "--spp", "1000000", "--seed", str(run + 1),
                                                                "--light-tree", mode])
                        spp[mode].append(n)
                        err[mode].append(relmse(read_rgb(out), r))
            except RuntimeError as e:
                print("%s: %s" % (name, e))
                status = 1
                continue
            off, on = statistics.median(err["off"]), statistics.median(err["on"])
            print("%s | %d / %d | %.4g | %.4g | %.2fx" % (name, statistics.median(spp["off"]),
                                                          statistics.median(spp["on"]), off, on, off / on))
    return status


if __name__ == "__main__":
    sys.exit(main())
