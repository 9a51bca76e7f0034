#!/usr/bin/env python3
"""`make bench` against Mitsuba 3: paths per second and the equal-time race.

    python3 tools/bench_mitsuba.py [--spectrace BIN] [--time T] [--ref-spp N]
        [--runs R] [--only speed|race] [--scenes cornell,mesh] [--isa native|avx2]
    python3 tools/bench_mitsuba.py --machine [--spectrace BIN]

Two scenes: the Cornell box (scenes/cornell_box.gltf) and a mesh scene made here
in a temporary folder (mesh_scene: the same box and light without the two
spheres, around a bumpy torus of 1,000,000 triangles, white Lambertian), both
converted for Mitsuba by tools/scene_to_mitsuba.py (spectral, path integrator,
spectrace's colour definitions; the Cornell box's dispersive glass as a sum of
wavelength bands, each at its share of the samples).

paths/s (--only speed): the whole `spectrace render` process (load, BVH, program
from the cache, render, EXR written) against Mitsuba 3 llvm_ad_spectral's render
time alone (the scene loaded and the kernels compiled before), at 512x512, max
depth 8: the Cornell box at 64 spp and the mesh at 16 spp; R alternated runs
each, medians, and the ratio spectrace / Mitsuba (above 1: spectrace faster).
The Cornell box is also timed with --caustics off: its path tracing alone, the
work Mitsuba's path integrator does (spectrace's defaults add the caustic
passes there).

equal time (--only race): at 256x256, max depth 8, spectrace renders for T
seconds (`--time T`: its default sampler, and adaptive sampling, on by
default with --time); Mitsuba's rate is measured (its
independent sampler, compiled first) and each of its samplers (independent,
multijitter, ldsampler) renders the samples that rate fits in T seconds
(rounded down to what the sampler takes: ldsampler a power of two). Each image's
relMSE = mean((c - r)^2 / (r^2 + 0.01)) over pixels and linear sRGB channels is
taken against a reference of N samples per pixel rendered by Mitsuba
(multijitter sampler, in two independent halves; kept in
SPECTRACE_CACHE_DIR/bench_mitsuba by a hash of the scene and settings), and the
tool prints the ratio best-Mitsuba relMSE / spectrace relMSE (above 1:
spectrace cleaner in the same seconds). Each renderer ends a little before
or past T (spectrace's chunks are sized to end by T; Mitsuba's measured rate
is off by some percent): a second ratio scales each relMSE to T seconds
(relMSE ~ 1 / time). The reference's own noise adds to every relMSE alike and
so pulls the ratios toward 1: the halves' difference measures it, and a third
ratio, scaled too, takes it from both relMSE.

The first line names the CPU, its vector width, the load, spectrace's OpenCL
device (PoCL names the target it compiles for) and Mitsuba's LLVM target and
lanes (--machine prints that line alone). --isa avx2 makes both compile for
AVX2 on an AVX-512 host (PoCL's AVX2 kernel library, POCL_KERNELLIB_NAME=avx2;
Mitsuba's target Haswell, 8 lanes), to compare the two widths on one machine.

Defaults: --time 20 (SPECTRACE_BENCH_TIME), --ref-spp 4096
(SPECTRACE_BENCH_REF_SPP), --runs 3 (SPECTRACE_BENCH_RUNS). Without Mitsuba (pip
install mitsuba numpy) spectrace's figures are printed alone (its paths/s, the
samples it reaches in T) and the tool says so; exit 1 when a render fails.
"""
import argparse
import hashlib
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import scene_to_mitsuba as s2m  # noqa: E402

CORNELL = os.path.join(ROOT, "scenes", "cornell_box.gltf")
SAMPLERS = ("independent", "multijitter", "ldsampler")
PASS_PATHS = 1 << 24   # paths per Mitsuba launch at most (the LLVM wavefront's memory)


def mesh_scene(folder, n_major=1000, n_minor=500):
    """Writes folder/mesh_scene.gltf (+ .bin): the Cornell box's walls, block and
    light around a bumpy torus of 2 * n_major * n_minor triangles (1,000,000 by
    default) of the box's white material. Deterministic. Returns the path."""
    import json
    import numpy as np
    with open(CORNELL) as f:
        doc = json.load(f)
    keep = [i for i in doc["scenes"][0]["nodes"] if doc["nodes"][i].get("name") not in ("glass_sphere", "gold_sphere")]
    u = np.arange(n_major) * (2 * math.pi / n_major)
    v = np.arange(n_minor) * (2 * math.pi / n_minor)
    U, V = np.meshgrid(u, v, indexing="ij")
    r = 0.055 * (1.0 + 0.15 * np.sin(7 * U) * np.sin(5 * V) + 0.05 * np.sin(41 * U + 3 * V))
    R = 0.15 + r * np.cos(V)
    x, y, z = R * np.cos(U), r * np.sin(V), R * np.sin(U)
    # Tilted about x by 30 degrees, in the box's middle above the floor.
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    pos = np.stack([x + 0.3, c * y - s * z + 0.2, s * y + c * z + 0.3], axis=-1).reshape(-1, 3).astype(np.float32)
    i0 = (np.arange(n_major)[:, None] * n_minor + np.arange(n_minor)[None, :])
    i1 = ((np.arange(n_major)[:, None] + 1) % n_major) * n_minor + np.arange(n_minor)[None, :]
    j = (np.arange(n_minor) + 1) % n_minor
    i2 = ((np.arange(n_major)[:, None] + 1) % n_major) * n_minor + j[None, :]
    i3 = np.arange(n_major)[:, None] * n_minor + j[None, :]
    # Counter-clockwise seen from outside the tube.
    tris = np.concatenate([np.stack([i0, i3, i2], -1).reshape(-1, 3),
                           np.stack([i0, i2, i1], -1).reshape(-1, 3)]).astype(np.uint32)
    blob = pos.tobytes() + tris.tobytes()
    with open(os.path.join(folder, "mesh_scene.bin"), "wb") as f:
        f.write(blob)
    b = len(doc["buffers"])
    doc["buffers"].append({"uri": "mesh_scene.bin", "byteLength": len(blob)})
    nv = len(doc["bufferViews"])
    doc["bufferViews"] += [{"buffer": b, "byteOffset": 0, "byteLength": pos.nbytes, "target": 34962},
                           {"buffer": b, "byteOffset": pos.nbytes, "byteLength": tris.nbytes, "target": 34963}]
    na = len(doc["accessors"])
    doc["accessors"] += [{"bufferView": nv, "componentType": 5126, "count": len(pos), "type": "VEC3",
                          "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
                         {"bufferView": nv + 1, "componentType": 5125, "count": tris.size, "type": "SCALAR"}]
    doc["meshes"].append({"name": "torus", "primitives": [{"attributes": {"POSITION": na}, "indices": na + 1,
                                                            "material": 0}]})
    doc["nodes"].append({"name": "torus", "mesh": len(doc["meshes"]) - 1})
    doc["scenes"][0]["nodes"] = keep + [len(doc["nodes"]) - 1]
    path = os.path.join(folder, "mesh_scene.gltf")
    with open(path, "w") as f:
        json.dump(doc, f)
    return path


# ---- spectrace ------------------------------------------------------------------

def spectrace_render(a, scene, out, size, extra):
    """Runs `spectrace render`; returns (wall seconds of the process, spp done,
    render seconds it reported). Exits 1 when it fails."""
    cmd = [a.spectrace, "render", scene, "-o", out, "--width", str(size), "--height", str(size),
           "--max-depth", "8"] + extra
    t0 = time.time()
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.time() - t0
    m = re.findall(r"rendered \d+x\d+, (\d+) spp in ([0-9.]+) s", r.stderr)
    if r.returncode or not m:
        print("error: %s failed (exit %d): %s" % (" ".join(cmd), r.returncode, r.stderr.strip()[-400:]),
              file=sys.stderr)
        sys.exit(1)
    return wall, int(m[-1][0]), float(m[-1][1])


def machine_line(a, mi_target):
    """The CPU's name, its widest float vector (AVX-512: 16 lanes, AVX2: 8, else
    SSE's 4), cores and load, and the OpenCL device spectrace selects (PoCL
    names the target it compiles for): ratios differ between the two kinds
    of CPU (docs/performance.md, "Vector width")."""
    name, flags = "unknown CPU", set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, val = line.partition(":")
                if key.strip() == "model name" and name == "unknown CPU":
                    name = val.strip()
                elif key.strip() == "flags" and not flags:
                    flags = set(val.split())
    except OSError:
        pass
    width = ("AVX-512, 16 float lanes" if "avx512f" in flags else "AVX2, 8 float lanes" if "avx2" in flags
             else "SSE, 4 float lanes")
    device = "?"
    r = subprocess.run([a.spectrace, "devices"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    m = re.search(r"^ \*\[\d+\] (.*)$", r.stdout, re.M)
    if m:
        device = m.group(1).strip()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return "machine: %s (%s), %d cores, load %.2f; spectrace's device: %s%s" % (
        name, width, os.cpu_count() or 0, load, device, "; Mitsuba's LLVM target: " + mi_target if mi_target else "")


# ---- Mitsuba --------------------------------------------------------------------

def _drjit_llvm(mi, name, mangled):
    """The Dr.Jit core function `name` (C++ linkage in Dr.Jit 1.x: `mangled`),
    through ctypes, or None."""
    import ctypes
    import drjit
    lib = ctypes.CDLL(os.path.join(os.path.dirname(drjit.__file__), "libdrjit-core.so"))
    for n in (name, mangled):
        if hasattr(lib, n):
            return getattr(lib, n)
    return None


def mitsuba_target(mi, isa):
    """Mitsuba's LLVM target: its own choice for `native`; for `avx2` Haswell
    with every AVX-512 feature off and 8 lanes (jit_llvm_set_target), as on an
    AVX2 host. Returns "cpu, N lanes", or why it is not known."""
    import ctypes
    cpu = _drjit_llvm(mi, "jit_llvm_target_cpu", "_Z19jit_llvm_target_cpuv")
    feats = _drjit_llvm(mi, "jit_llvm_target_features", "_Z24jit_llvm_target_featuresv")
    width = _drjit_llvm(mi, "jit_llvm_vector_width", "_Z21jit_llvm_vector_widthv")
    setter = _drjit_llvm(mi, "jit_llvm_set_target", "_Z19jit_llvm_set_targetPKcS0_j")
    if not (cpu and feats and width and setter):
        return "target unknown (Dr.Jit's core library has no jit_llvm_target_cpu)"
    cpu.restype = feats.restype = ctypes.c_char_p
    width.restype = ctypes.c_uint32
    if isa == "avx2":
        off = ",".join(("-" + f[1:]) if f.startswith("+") and ("avx512" in f or f == "+evex512") else f
                       for f in feats().decode().split(","))
        setter.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
        setter(b"haswell", off.encode(), 8)
    return "%s, %d lanes" % (cpu().decode(), width())


class MitsubaScene:
    """A converted scene: its band scenes (one when nothing is dispersive) and,
    per sampler, their sensors."""

    def __init__(self, mi, path, size, tmp, bands=24):
        self.mi, self.size = mi, size
        sc = s2m.load_gltf(path)
        d = s2m.scene_dict(mi, sc, size, size, 1, 8, tmp)
        self.bands = [db for db, _ in s2m.band_scenes(d, bands)]
        self.scenes = [mi.load_dict(db) for db in self.bands]
        self.sensors = {}

    def sensors_for(self, sampler):
        if sampler not in self.sensors:
            out = []
            for db in self.bands:
                sd = dict(db["sensor"])
                sd["sampler"] = {"type": sampler, "sample_count": 1}
                out.append(self.mi.load_dict(sd))
            self.sensors[sampler] = out
        return self.sensors[sampler]

    def count(self, sampler, n):
        """The largest sample count <= n that the sampler takes as it is
        (ldsampler: a power of 4 from 4 on, as it rounds 1 up to 4;
        multijitter: most counts), 0 when none."""
        if n < 1:
            return 0
        if sampler == "ldsampler":
            return 4 ** int(math.log(n, 4) + 1e-9) if n >= 4 else 0
        for k in range(n, 0, -1):
            if self.mi.load_dict({"type": sampler, "sample_count": k}).sample_count() <= n:
                return k
        return 0

    def count_up(self, sampler, n):
        """The smallest sample count >= n that the sampler takes as it is."""
        k = max(1, n)
        while self.count(sampler, k) != k:
            k += 1
        return k

    def render(self, sampler, spp_band, seed):
        """Each band at up to spp_band samples per pixel, in launches of at most
        PASS_PATHS paths, each of a count the sampler takes as it is; returns
        (the image, linear sRGB HxWx3, the seconds, the paths traced, the
        samples per pixel per band)."""
        np, mi = s2m.np, self.mi
        per = max(1, PASS_PATHS // (self.size * self.size))
        img = np.zeros((self.size, self.size, 3))
        paths, done, t0 = 0, 0, time.time()
        for k, (msc, sensor) in enumerate(zip(self.scenes, self.sensors_for(sampler))):
            left, launch, acc, done = spp_band, 0, np.zeros_like(img), 0
            while left > 0:
                n = self.count(sampler, min(left, per))
                if n < 1:
                    break
                raw = np.array(mi.render(msc, sensor=sensor, seed=(seed * 100003 + k * 1009 + launch) & 0x7fffffff,
                                         spp=n), dtype=np.float64)
                acc += s2m.film_to_srgb(raw) * n
                left -= n
                done += n
                launch += 1
            img += acc / max(done, 1)
            paths += self.size * self.size * done
        return img, time.time() - t0, paths, done


def read_exr(mi, np, path):
    arr = np.array(mi.Bitmap(path), dtype=np.float64)
    return arr[..., :3]


def relmse(np, c, r):
    """relMSE, and its median over pixels (the mean is ruled by a few fireflies)."""
    e = ((c - r) ** 2 / (r ** 2 + 0.01)).mean(axis=2)
    return float(e.mean()), float(np.median(e))


def reference(a, ms, scene_path, size):
    """Mitsuba's reference at a.ref_spp samples per pixel or a few more (what
    its sampler takes), cached: its multijitter sampler (the least error per
    sample of its samplers on the mesh scene, and unbiased) in two independent
    halves, averaged. Every relMSE against it carries the
    reference's own noise alike, which pulls the ratios toward 1; the halves'
    difference estimates that noise: E[(A - B)^2] = 2 s^2 for halves of noise
    s^2 each, the average's is s^2 / 2, so a quarter of their relMSE.
    Returns (the image, that noise relMSE, the spp it holds, how it came)."""
    np = s2m.np
    half = ms.count_up("multijitter", -(-a.ref_spp // (2 * len(ms.bands))))
    h = hashlib.sha256()
    for p in (scene_path, os.path.splitext(scene_path)[0] + ".bin"):
        if os.path.exists(p):
            with open(p, "rb") as f:
                h.update(f.read())
    h.update(("%d %d %s %d multijitter halves of %d"
              % (size, a.ref_spp, ms.mi.__version__, len(ms.bands), half)).encode())
    h.update(open(os.path.join(ROOT, "tools", "scene_to_mitsuba.py"), "rb").read())
    folder = os.path.join(a.cache, "bench_mitsuba")
    path = os.path.join(folder, h.hexdigest()[:20] + ".npz")
    spp = 2 * half * len(ms.bands)
    if os.path.exists(path):
        z = np.load(path)
        return z["img"], float(z["noise"]), spp, "cached"
    A, s1, _, _ = ms.render("multijitter", half, seed=7777)
    B, s2, _, _ = ms.render("multijitter", half, seed=8888)
    img = (A + B) / 2
    noise = float(((A - B) ** 2 / (img ** 2 + 0.01)).mean()) / 4
    os.makedirs(folder, exist_ok=True)
    with open(path + ".tmp", "wb") as f:
        np.savez(f, img=img, noise=noise)
    os.replace(path + ".tmp", path)
    return img, noise, spp, "rendered in %.0f s" % (s1 + s2)


# ---- the blocks -------------------------------------------------------------------

def speed(a, mi, scenes, tmp):
    print("-- paths per second: 512x512, max depth 8, whole spectrace process against Mitsuba's render time, "
          "%d alternated runs, medians" % a.runs)
    for name, path, _ in scenes:
        spp = {"cornell": 64, "mesh": 16}[name]
        out = os.path.join(tmp, "speed.exr")
        spectrace_render(a, path, out, 16, ["--spp", "1"])   # program cache
        ms = None
        if mi is not None:
            ms = MitsubaScene(mi, path, 512, tmp)
            spp_band = max(1, int(math.ceil(spp / len(ms.bands))))
            ms.render("independent", 1, seed=1)   # compile
        # The Cornell box's glass and gold turn light, so spectrace's defaults
        # add its caustic passes (light tracing, photon merging), which
        # Mitsuba's path integrator does not run: its path tracing alone
        # (--caustics off) is timed too, in the same alternation, as the
        # like-for-like figure (docs/performance.md, "An Intel Xeon with
        # AVX-512").
        variants = [("", [])]
        if name == "cornell":
            variants.append((" --caustics off", ["--caustics", "off"]))
        ours = {what: [] for what, _ in variants}
        theirs = []
        for r in range(a.runs):
            for what, extra in variants:
                wall, done, _ = spectrace_render(a, path, out, 512, ["--spp", str(spp), "--seed", str(r)] + extra)
                ours[what].append(512 * 512 * done / wall)
            if ms is not None:
                _, secs, paths, _ = ms.render("independent", spp_band, seed=r + 10)
                theirs.append(paths / secs)
        t = statistics.median(theirs) if theirs else None
        for what, _ in variants:
            o = statistics.median(ours[what])
            line = "%-8s %3d spp%s: spectrace %.3f Mpaths/s (process)" % (name, spp, what, o * 1e-6)
            if t:
                line += ", Mitsuba %s %.3f Mpaths/s (render%s): ratio spectrace/Mitsuba %.2f" % (
                    mi.variant(), t * 1e-6, ", %d bands" % len(ms.bands) if len(ms.bands) > 1 else "", o / t)
            print(line, flush=True)


def race(a, mi, scenes, tmp):
    size = 256
    print("-- equal time: %dx%d, max depth 8, %g s each; relMSE against Mitsuba's multijitter sampler at %d spp"
          % (size, size, a.time, a.ref_spp))
    for name, path, _ in scenes:
        out = os.path.join(tmp, "race.exr")
        spectrace_render(a, path, out, 16, ["--spp", "1"])   # program cache
        wall, done, secs = spectrace_render(a, path, out, size, ["--time", "%g" % a.time, "--seed", "3"])
        if mi is None:
            print("%-8s spectrace: %d spp in %.2f s (no relMSE without Mitsuba)" % (name, done, secs), flush=True)
            continue
        np = s2m.np
        ms = MitsubaScene(mi, path, size, tmp)
        ref, noise, ref_spp, how = reference(a, ms, path, size)
        ours, ours_med = relmse(np, read_exr(mi, np, out), ref)
        print("%-8s reference: Mitsuba multijitter %d spp in two halves (%s); its own noise relMSE %.3g"
              % (name, ref_spp, how, noise))
        print("%-8s spectrace    %5d spp in %6.2f s: relMSE %.4g (median %.3g)" % (name, done, secs, ours, ours_med),
              flush=True)
        # Mitsuba's rate with its independent sampler, its kernels compiled
        # first (they depend on the sample count); a banded scene at 4 samples
        # per band, near what T fits, as a launch per band of 1 sample took
        # 1.6 times the time per sample.
        n_rate = 8 if len(ms.bands) == 1 else 4
        ms.render("independent", n_rate, seed=2)
        _, psecs, ppaths, _ = ms.render("independent", n_rate, seed=3)
        rate = ppaths / psecs
        budget = rate * a.time / (size * size)   # spp Mitsuba fits in T
        if len(ms.bands) > 1 and budget < 24 * 4:
            # A dispersive glass takes a sample per band at least: fewer, wider
            # bands (the ior constant over each) when T fits few samples.
            nb = max(1, min(24, int(budget // 4)))
            ms = MitsubaScene(mi, path, size, tmp, nb)
            print("%-8s Mitsuba's dispersive glass in %d bands (24 in the reference)" % (name, len(ms.bands)))
        # Each renderer may end a little before or past T: a second ratio
        # scales every relMSE to T seconds (relMSE ~ 1 / time, the
        # reference's noise excepted), and a third also takes that noise
        # from both.
        best = best_t = best_tn = None
        for k, smp in enumerate(SAMPLERS):
            spp_band = ms.count(smp, int(budget // len(ms.bands)))
            if spp_band < 1:
                print("%-8s Mitsuba %-11s fits under its smallest sample count%s in %g s"
                      % (name, smp, " per band" if len(ms.bands) > 1 else "", a.time))
                continue
            ms.render(smp, spp_band, seed=40 + k)   # compiled outside the timing, at the count timed
            img, msecs, _, done_band = ms.render(smp, spp_band, seed=20 + k)
            e, med = relmse(np, img, ref)
            f = msecs / a.time
            best = e if best is None else min(best, e)
            best_t = e * f if best_t is None else min(best_t, e * f)
            best_tn = (e - noise) * f if best_tn is None else min(best_tn, (e - noise) * f)
            print("%-8s Mitsuba %-11s %5d spp in %6.2f s: relMSE %.4g (median %.3g)"
                  % (name, smp, done_band * len(ms.bands), msecs, e, med), flush=True)
        if best is not None:
            f = secs / a.time
            print("%-8s ratio best-Mitsuba / spectrace relMSE: %.2f; %.2f with each relMSE scaled to %g s; "
                  "%.2f scaled and the reference's noise taken from both (Mitsuba's rate %.3f Mpaths/s, "
                  "%.0f spp in %g s)"
                  % (name, best / ours, best_t / (ours * f), a.time,
                     best_tn / ((ours - noise) * f) if ours > noise else float("nan"), rate * 1e-6, budget,
                     a.time), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spectrace", default=os.path.join(ROOT, "build", "spectrace"))
    ap.add_argument("--time", type=float, default=float(os.environ.get("SPECTRACE_BENCH_TIME", "20")))
    ap.add_argument("--ref-spp", type=int, default=int(os.environ.get("SPECTRACE_BENCH_REF_SPP", "4096")))
    ap.add_argument("--runs", type=int, default=int(os.environ.get("SPECTRACE_BENCH_RUNS", "3")))
    ap.add_argument("--only", choices=("speed", "race"))
    ap.add_argument("--scenes", default="cornell,mesh")
    ap.add_argument("--isa", choices=("native", "avx2"), default="native",
                    help="avx2: both renderers compile for AVX2 (8 lanes) on an AVX-512 host")
    ap.add_argument("--machine", action="store_true", help="print the machine line alone and exit")
    a = ap.parse_args()
    if a.time <= 0 or a.ref_spp < 1 or a.runs < 1:
        ap.error("--time must be > 0, --ref-spp and --runs >= 1")
    if a.machine:
        print(machine_line(a, None))
        return 0
    a.cache = os.environ.get("SPECTRACE_CACHE_DIR", os.path.join(ROOT, "build", "cache"))
    if a.isa == "avx2":
        # PoCL's CPU device then compiles with its AVX2 kernel library and
        # target (it names itself pthread-haswell); other implementations
        # ignore the variable.
        os.environ["POCL_KERNELLIB_NAME"] = "avx2"
    mi = None
    try:
        mi = s2m.import_mitsuba("llvm_ad_spectral")
    except Exception as e:  # noqa: BLE001 (no LLVM: say so, as for a missing package)
        print("Mitsuba 3's llvm_ad_spectral is not usable (%s): spectrace's figures alone" % e)
    if mi is None and s2m.np is not None:
        print("Mitsuba 3 cannot be imported (pip install mitsuba numpy): spectrace's figures alone")
    if s2m.np is None:
        print("skip: numpy is missing (pip install numpy): the mesh scene is made with it")
        return 0
    names = [n for n in a.scenes.split(",") if n]
    if any(n not in ("cornell", "mesh") for n in names):
        ap.error("--scenes takes cornell and mesh")
    mi_target = mitsuba_target(mi, a.isa) if mi is not None else None
    print(machine_line(a, mi_target), flush=True)
    with tempfile.TemporaryDirectory(prefix="spt_bench_") as tmp:
        scenes = [(n, CORNELL if n == "cornell" else mesh_scene(tmp), 0) for n in names]
        if a.only in (None, "speed"):
            speed(a, mi, scenes, tmp)
        if a.only in (None, "race"):
            race(a, mi, scenes, tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
