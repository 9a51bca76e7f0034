#!/usr/bin/env python3
"""`make bench` against Blender Cycles: the equal-time race on hard-light scenes.

    python3 tools/bench_cycles.py [--spectrace BIN] [--time T] [--ref-factor K]
        [--size S] [--scenes street,field,cornell,table,window] [--quick]

Five scenes (docs/performance.md, "Against Blender Cycles"): the street of
1,000 lamps and the field of 200 emissive quads (tools/make_light_scenes.py),
the Cornell box (scenes/cornell_box.gltf), a glass sphere on a table under a
small light and a room lit by a sun through a window
(tools/make_race_scenes.py), written to a temporary folder.

Each renders at S x S pixels, max depth 8 (Cycles: 6 bounces of every kind,
tools/blender_compare.py's mapping), for T seconds: spectrace with `--time T`
(its defaults: adaptive sampling on with --time, the light tree on where
`auto` puts it), Cycles on the CPU (every thread) with its time limit T and
its defaults (adaptive sampling at threshold 0.01, 4096 samples at most, its
light tree), denoising off; Blender imports the glTF and
tools/blender_compare.py's setup_blender sets what spectrace sees (camera,
light units, one-sided emission, black world) and two things that change
Cycles' image rather than its noise: a one-pixel box filter (spectrace's;
Cycles' default 1.5-pixel Blackman-Harris averages neighbours) and no
clamping. Each image's relMSE = mean((c - r)^2 / (r^2 + 0.01)) over pixels
and linear sRGB channels is taken against that renderer's own reference:
K * T seconds of the same renderer without adaptive sampling, in two halves
of different seeds (an unbiased image whatever the sample count; cached in
SPECTRACE_CACHE_DIR/bench_cycles by a hash of the scene, the settings and
the renderer's build). The reference's noise adds to every relMSE and pulls
the ratio toward 1: the halves' difference measures it (a quarter of their
relMSE) and it is taken from each relMSE before the ratio.

Prints per scene the samples per pixel each reached (Cycles': its rate
without adaptive sampling times its seconds), the seconds, each relMSE, and
the ratios Cycles / spectrace (above 1: spectrace cleaner in the same time):
as measured, scaled to T seconds (relMSE ~ 1 / time), and per sample (each
relMSE times its samples per pixel).

bpy (Blender as a Python module, `pip install bpy`) pins its own Python and
numpy: when this interpreter has no bpy the tool runs itself again with
SPECTRACE_BPY_PYTHON, or the first of ROOT/venv-bpy, ROOT/.venv-bpy,
ROOT/../venv-bpy that has it; else it prints a "skip:" line and exits 0.
Exit 1 when a render fails.

Defaults: --time 20 (SPECTRACE_BENCH_TIME), --ref-factor 16
(SPECTRACE_BENCH_REF_FACTOR), --size 256; --quick: --time 4, --ref-factor 8,
--size 128.
"""
import argparse
import hashlib
import os
import struct
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import bench_mitsuba as bm  # noqa: E402  (spectrace_render, machine_line, relmse)
import make_light_scenes  # noqa: E402
import make_race_scenes  # noqa: E402

SCENES = ("street", "field", "cornell", "table", "window")
MAX_DEPTH = 8   # bm.spectrace_render's
BPY_PYTHONS = ("venv-bpy/bin/python", ".venv-bpy/bin/python", "../venv-bpy/bin/python")


def find_bpy_python():
    """An interpreter with bpy: SPECTRACE_BPY_PYTHON, else the first of
    BPY_PYTHONS (relative to the repository) that imports it; None if none."""
    env = os.environ.get("SPECTRACE_BPY_PYTHON")
    cands = [env] if env else [os.path.normpath(os.path.join(ROOT, p)) for p in BPY_PYTHONS]
    for c in cands:
        if c and os.path.isfile(c):
            r = subprocess.run([c, "-c", "import bpy"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            if r.returncode == 0:
                return c
    return None


def read_exr_channels(path):
    """{channel name: HxW float array, row 0 at the top} of an uncompressed
    scanline EXR, single- or multi-part (what Blender writes for a multilayer
    image with codec NONE). OpenEXR's file layout: magic, version and flags
    (0x1000: multi-part), the headers (name, type, size, value; each ends
    with a null byte, a multi-part file's list with one more), the offset
    tables, then the chunks: (a multi-part file's part number,) y, byte count,
    each channel's row in name order."""
    import numpy as np
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError("%s: not an OpenEXR file" % path)
    multi = bool(struct.unpack_from("<I", data, 4)[0] & 0x1000)
    pos, headers = 8, []
    while True:
        attrs = {}
        while data[pos] != 0:
            end = data.index(b"\0", pos)
            end2 = data.index(b"\0", end + 1)
            size = struct.unpack_from("<i", data, end2 + 1)[0]
            attrs[data[pos:end].decode()] = data[end2 + 5:end2 + 5 + size]
            pos = end2 + 5 + size
        pos += 1
        headers.append(attrs)
        if not multi or data[pos] == 0:
            break
    pos += 1 if multi else 0
    parts = []
    for attrs in headers:
        if attrs["compression"][0] != 0:
            raise ValueError("%s: compressed (codec %d)" % (path, attrs["compression"][0]))
        chans, p, raw = [], 0, attrs["channels"]
        while raw[p] != 0:
            end = raw.index(b"\0", p)
            chans.append((raw[p:end].decode(), struct.unpack_from("<i", raw, end + 1)[0]))
            p = end + 17
        x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
        parts.append((chans, x1 - x0 + 1, y1 - y0 + 1, y0))
    out = {}
    for chans, w, h, y0 in parts:
        offsets = struct.unpack_from("<%dQ" % h, data, pos)
        pos += 8 * h
        for n, _ in chans:
            out[n] = np.empty((h, w), np.float32)
        for off in offsets:
            off += 4 if multi else 0
            y = struct.unpack_from("<i", data, off)[0] - y0
            q = off + 8
            for n, ptype in chans:
                dt = {0: np.uint32, 1: np.float16, 2: np.float32}[ptype]
                row = np.frombuffer(data, dtype=dt, count=w, offset=q)
                out[n][y] = row
                q += w * row.itemsize
    return out


class Silent:
    """Sends the standard output and error to /dev/null in the block: Cycles
    prints a line per image it saves (a failed render raises)."""
    def __enter__(self):
        sys.stdout.flush()
        sys.stderr.flush()
        self.saved = [os.dup(1), os.dup(2)]
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.dup2(null, 2)
        os.close(null)
        return self

    def __exit__(self, *exc):
        for fd, saved in zip((1, 2), self.saved):
            os.dup2(saved, fd)
            os.close(saved)
        return False


class Cycles:
    """Blender with one scene imported, set up as tools/blender_compare.py does."""

    def __init__(self, scene, size):
        import argparse as ap
        import numpy as np
        import bpy
        import blender_compare as bc
        self.bpy, self.np, self.bc = bpy, np, bc
        bc.s2m.np = np
        a = ap.Namespace(scene=scene, texture_filter="gltf", background=None, spp=1, seed=0,
                         max_depth=MAX_DEPTH, threads=os.cpu_count() or 1)
        with Silent():
            bc.setup_blender(bpy, a, size, size, np)
        sc = bpy.context.scene
        ims = sc.render.image_settings
        if hasattr(ims, "media_type"):            # Blender 5: multilayer is a media type
            ims.media_type = "MULTI_LAYER_IMAGE"
            ims.file_format = "OPEN_EXR_MULTILAYER"
        else:
            ims.file_format = "OPEN_EXR_MULTILAYER"
        sc.render.image_settings.exr_codec = "NONE"

    def render(self, out, seconds, seed, adaptive, samples=None):
        """Renders for `seconds` (Cycles' time limit, synchronisation left
        out; 0: none); adaptive: Cycles' default adaptive sampling and sample
        cap, else every pixel the same samples (`samples`, or as many as fit).
        Returns (the image HxWx3, the seconds the render call took)."""
        np, cy = self.np, self.bpy.context.scene.cycles
        cy.seed = seed
        cy.time_limit = seconds
        cy.use_adaptive_sampling = adaptive
        cy.adaptive_threshold = 0.01
        cy.adaptive_min_samples = 0
        cy.samples = samples or (4096 if adaptive else 1 << 24)
        self.bpy.context.scene.render.filepath = out
        t0 = time.time()
        with Silent():
            self.bpy.ops.render.render(write_still=True)
        secs = time.time() - t0
        ch = read_exr_channels(out)
        pre = [n[:-len(".R")] for n in ch if n.endswith("Combined.R")][0]   # ViewLayer.Combined
        return np.stack([ch[pre + "." + c] for c in "RGB"], -1).astype(np.float64), secs

    def rate(self, out, seconds):
        """Cycles' samples per pixel per second without adaptive sampling: the
        difference of two fixed-sample renders (the second near `seconds`
        long), so that synchronisation falls out. Cycles reports no sample
        count after a time-limited render (its sample-count pass is
        normalised), so the race's samples per pixel are this rate times its
        seconds."""
        _, t1 = self.render(out, 0, 1, False, samples=2)
        n2 = max(6, int(seconds * 2 / max(t1, 1e-3)))
        _, t2 = self.render(out, 0, 2, False, samples=n2)
        return (n2 - 2) / max(t2 - t1, 1e-3)


def file_hash(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def reference(a, name, key, render_half):
    """The reference of one renderer: two halves of a.ref_factor * a.time / 2
    seconds each, seeds 7777 and 8888, averaged and cached under key. Returns
    (the image, its noise relMSE, how it came)."""
    import numpy as np
    path = os.path.join(a.cache, "%s-%s.npz" % (name, key))
    if os.path.exists(path):
        z = np.load(path)
        return z["img"], float(z["noise"]), "cached"
    t0 = time.time()
    A = render_half(7777)
    B = render_half(8888)
    img = (A + B) / 2
    noise = float(((A - B) ** 2 / (img ** 2 + 0.01)).mean()) / 4
    os.makedirs(a.cache, exist_ok=True)
    with open(path + ".tmp", "wb") as f:
        np.savez(f, img=img, noise=noise)
    os.replace(path + ".tmp", path)
    return img, noise, "rendered in %.0f s" % (time.time() - t0)


def race_scene(a, name, scene, tmp):
    """One scene's row: {renderer: (spp, seconds, relMSE, reference noise)}."""
    import bpy
    import numpy as np
    import blender_compare as bc
    size, half = a.size, a.ref_factor * a.time / 2
    settings = "%d %d %g %g" % (size, MAX_DEPTH, a.time, a.ref_factor)
    scene_h = file_hash(scene)
    out = os.path.join(tmp, "spectrace.exr")
    bm.spectrace_render(a, scene, out, 16, ["--spp", "1"])   # program cache

    def sp_half(seed):
        bm.spectrace_render(a, scene, out, size, ["--time", "%g" % half, "--adaptive", "off", "--spp", "16777216",
                                                  "--seed", str(seed)])
        return bc.read_exr(bpy, np, out)

    key = hashlib.sha256(("spectrace %s %s %s" % (scene_h, settings, file_hash(a.spectrace))).encode()).hexdigest()
    sp_ref, sp_noise, sp_how = reference(a, name + "-spectrace", key[:20], sp_half)
    _, sp_spp, sp_secs = bm.spectrace_render(a, scene, out, size, ["--time", "%g" % a.time, "--seed", "3"])
    sp_err = bm.relmse(np, bc.read_exr(bpy, np, out), sp_ref)[0]

    cyc = Cycles(scene, size)
    cy_out = os.path.join(tmp, "cycles.exr")
    key = hashlib.sha256(("cycles %s %s %s" % (scene_h, settings, bpy.app.version_string)).encode()).hexdigest()
    cy_ref, cy_noise, cy_how = reference(a, name + "-cycles", key[:20],
                                         lambda seed: cyc.render(cy_out, half, seed, adaptive=False)[0])
    img, cy_secs = cyc.render(cy_out, a.time, 3, adaptive=True)
    cy_spp = cyc.rate(cy_out, min(a.time / 2, 5.0)) * cy_secs
    cy_err = bm.relmse(np, img, cy_ref)[0]
    # The two references' mean luminance: the same scene to both renderers
    # (within what Blender's importer and lights make of it).
    lum = np.array([0.2126, 0.7152, 0.0722])
    print("%-8s references (%g s each, two halves): spectrace %s, noise relMSE %.3g; Cycles %s, noise relMSE "
          "%.3g; mean luminance spectrace / Cycles %.3f"
          % (name, 2 * half, sp_how, sp_noise, cy_how, cy_noise, (sp_ref @ lum).mean() / max((cy_ref @ lum).mean(),
                                                                                            1e-30)), flush=True)
    return {"spectrace": (sp_spp, sp_secs, sp_err, sp_noise), "Cycles": (cy_spp, cy_secs, cy_err, cy_noise)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spectrace", default=os.path.join(ROOT, "build", "spectrace"))
    ap.add_argument("--time", type=float, default=None)
    ap.add_argument("--ref-factor", type=float, default=None)
    ap.add_argument("--size", type=int, default=None)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--quick", action="store_true", help="--time 4, --ref-factor 8, --size 128 unless given")
    a = ap.parse_args()
    q = a.quick
    a.time = a.time if a.time is not None else 4.0 if q else float(os.environ.get("SPECTRACE_BENCH_TIME", "20"))
    a.ref_factor = (a.ref_factor if a.ref_factor is not None else 8.0 if q
                    else float(os.environ.get("SPECTRACE_BENCH_REF_FACTOR", "16")))
    a.size = a.size if a.size is not None else 128 if q else 256
    names = [n for n in a.scenes.split(",") if n]
    if a.time <= 0 or a.ref_factor < 1 or a.size < 8 or any(n not in SCENES for n in names):
        ap.error("--time > 0, --ref-factor >= 1, --size >= 8, --scenes of %s" % ",".join(SCENES))
    try:
        import bpy  # noqa: F401
        import numpy  # noqa: F401
    except ImportError:
        other = None if os.environ.get("SPECTRACE_BENCH_CYCLES_CHILD") else find_bpy_python()
        if other is None:
            print("skip: the race against Blender Cycles needs bpy (Blender as a Python module: `pip install bpy`, "
                  "or SPECTRACE_BPY_PYTHON=/path/to/python of an environment that has it)")
            return 0
        env = dict(os.environ, SPECTRACE_BENCH_CYCLES_CHILD="1")
        return subprocess.call([other, os.path.abspath(__file__)] + sys.argv[1:], env=env)
    import warnings
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    import bpy
    a.cache = os.path.join(os.environ.get("SPECTRACE_CACHE_DIR", os.path.join(ROOT, "build", "cache")), "bench_cycles")
    print(bm.machine_line(a, None) + "; Blender %s Cycles on the CPU, %d threads" % (
        bpy.app.version_string, os.cpu_count() or 1), flush=True)
    print("-- equal time: %dx%d, max depth %d (Cycles: %d bounces), %g s each; each renderer's relMSE against "
          "its own reference of %g s" % (a.size, a.size, MAX_DEPTH, MAX_DEPTH - 2, a.time, a.ref_factor * a.time))
    rows = {}
    with tempfile.TemporaryDirectory(prefix="spt_cycles_") as tmp:
        make_light_scenes.street(os.path.join(tmp, "street.gltf"))
        make_light_scenes.field(os.path.join(tmp, "field.gltf"))
        make_race_scenes.table(os.path.join(tmp, "table.gltf"))
        make_race_scenes.window(os.path.join(tmp, "window.gltf"))
        for n in names:
            scene = bm.CORNELL if n == "cornell" else os.path.join(tmp, n + ".gltf")
            rows[n] = race_scene(a, n, scene, tmp)
    print("scene   | spectrace spp in s | Cycles spp in s | relMSE spectrace | relMSE Cycles | Cycles / spectrace "
          "| scaled to %g s | per sample" % a.time)
    for n, r in rows.items():
        sp, cy = r["spectrace"], r["Cycles"]
        # The reference's own noise taken from each relMSE (floored: a
        # relMSE at the reference's noise level says "no error measured").
        e_sp, e_cy = max(sp[2] - sp[3], 1e-12), max(cy[2] - cy[3], 1e-12)
        print("%-7s | %6d in %5.1f | %6.0f in %5.1f | %.4g | %.4g | %.2f | %.2f | %.2f"
              % (n, sp[0], sp[1], cy[0], cy[1], e_sp, e_cy, e_cy / e_sp,
                 (e_cy * cy[1]) / (e_sp * sp[1]), (e_cy * cy[0]) / (e_sp * sp[0])), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
