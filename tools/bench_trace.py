#!/usr/bin/env python3
"""Traversal against Embree: spectrace's ray queries and Mitsuba 3's (which
traces with Embree) on the same triangles and the same rays.

    python3 tools/bench_trace.py [--bench-trace BIN] [--scenes cornell,mesh]
                                 [--rays N] [--runs R]

For each scene (the Cornell box, and tools/bench_mitsuba.py's box around a
1M-triangle torus) the triangles come from tools/scene_to_mitsuba.py's glTF
reader, world space, and the rays are N incoherent ones (default 2^21): origins
uniform in the middle 98% of the scene's bounds, directions uniform on the
sphere (numpy, seed 1), like the bounce rays of a path tracer inside a closed
room, and as many segments between two such points (shadow rays: the any-hit
query up to 0.9999 of the length). build/tools/bench_trace times spectrace's
kernels on them (docs/performance.md, "Where a ray's time goes"); Mitsuba's
llvm_ad_spectral variant times Scene.ray_intersect_preliminary (the closest
hit, no shading data) and Scene.ray_test (any hit; the rays unbounded, then
the segments) over the same input in one launch each, a warm-up then R timed
runs, medians. Both use the machine's threads. Without
Mitsuba (pip install mitsuba numpy) spectrace's figures are printed alone;
without numpy, nothing runs (exit 0 with a skip line).
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import scene_to_mitsuba as s2m  # noqa: E402

CORNELL = os.path.join(ROOT, "scenes", "cornell_box.gltf")


def triangles(np, path):
    """The scene's world-space triangles, float32 (T, 9)."""
    sc = s2m.load_gltf(path)
    tris = [pos[faces].reshape(-1, 9) for _, pos, faces, *_ in sc["shapes"]]
    return np.concatenate(tris).astype(np.float32)


def rays(np, tris, n):
    """n rays and n segments (origin, direction; a segment's direction reaches
    its end) as float32 (n, 6) each: see the module's text."""
    pts = tris.reshape(-1, 3)
    lo, hi = pts.min(axis=0).astype(np.float64), pts.max(axis=0).astype(np.float64)
    rng = np.random.default_rng(1)

    def inside():
        return lo + (hi - lo) * (0.01 + 0.98 * rng.random((n, 3)))
    org = inside()
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    s0 = inside()
    seg = np.concatenate([s0, inside() - s0], axis=1)
    return np.concatenate([org, d], axis=1).astype(np.float32), seg.astype(np.float32)


QUERIES = ("closest hit, two rays per work-item", "closest hit", "any hit, unbounded", "any hit, segments")


def spectrace_times(a, tris_path, rays_path, segs_path):
    """Runs bench_trace; returns {query: ns per ray} and prints its lines."""
    out = subprocess.run([a.bench_trace, tris_path, rays_path, segs_path, str(a.runs)], check=True,
                         stdout=subprocess.PIPE, universal_newlines=True).stdout
    ns = {}
    for line in out.splitlines():
        print("  spectrace:" + line[1:] if line.startswith("  ") else line)
        for q in QUERIES:
            if line.strip().startswith(q + " ") and q not in ns:
                ns[q] = float(line.split(q, 1)[1].split()[0])
                break
    return ns


def mitsuba_times(a, mi, np, path, ray_arr, seg_arr, tmp):
    """Mitsuba's ns per ray for the closest hit and the two any-hit queries,
    medians of a.runs."""
    import drjit as dr
    sc = s2m.load_gltf(path)
    d = s2m.scene_dict(mi, sc, 16, 16, 1, 8, tmp)
    scene = mi.load_dict(s2m.band_scenes(d, 1)[0][0])
    faces = sum(s.face_count() for s in scene.shapes() if s.is_mesh())

    def mi_rays(arr, segments):
        col = [mi.Float(np.ascontiguousarray(arr[:, k])) for k in range(6)]
        r = mi.Ray3f(mi.Point3f(col[0], col[1], col[2]), dr.normalize(mi.Vector3f(col[3], col[4], col[5])))
        if segments:
            # bench_trace's SEGMENT_TMAX, in Mitsuba's units of length
            r.maxt = dr.norm(mi.Vector3f(col[3], col[4], col[5])) * 0.9999
        dr.eval(r)
        return r
    ray, seg = mi_rays(ray_arr, False), mi_rays(seg_arr, True)
    dr.sync_thread()
    n = len(ray_arr)
    out = {}
    for q in ("closest hit", "any hit, unbounded", "any hit, segments"):
        secs = []
        for r in range(a.runs + 1):
            t0 = time.time()
            if q == "closest hit":
                res = scene.ray_intersect_preliminary(ray)
                dr.eval(res.t)
            else:
                res = scene.ray_test(seg if q == "any hit, segments" else ray)
                dr.eval(res)
            dr.sync_thread()
            if r:
                secs.append(time.time() - t0)
        hit = res.is_valid() if q == "closest hit" else res
        frac = dr.count(hit)[0] / n if hasattr(dr, "count") else float(np.mean(np.array(hit)))
        out[q] = statistics.median(secs) / n * 1e9
        print("  Mitsuba %s (%d triangles, %d threads): %-18s %7.1f ns/ray  %7.2f Mrays/s  (median of %d; "
              "hit %.4f of the rays)" % (mi.variant(), faces, dr.thread_count(), q, out[q], 1e3 / out[q], a.runs,
                                         frac))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bench-trace", default=os.path.join(ROOT, "build", "tools", "bench_trace"))
    ap.add_argument("--scenes", default="cornell,mesh")
    ap.add_argument("--rays", type=int, default=1 << 21)
    ap.add_argument("--runs", type=int, default=int(os.environ.get("SPECTRACE_BENCH_RUNS", "5")))
    a = ap.parse_args()
    if a.rays < 2 or a.runs < 1:
        ap.error("--rays must be >= 2 and --runs >= 1")
    names = [n for n in a.scenes.split(",") if n]
    if any(n not in ("cornell", "mesh") for n in names):
        ap.error("--scenes takes cornell and mesh")
    np = s2m.np
    if np is None:
        print("skip: numpy is missing (pip install numpy)")
        return 0
    mi = None
    try:
        mi = s2m.import_mitsuba("llvm_ad_spectral")
    except Exception as e:  # noqa: BLE001 (no LLVM: say so, as for a missing package)
        print("Mitsuba 3's llvm_ad_spectral is not usable (%s): spectrace's figures alone" % e)
    if mi is None:
        print("Mitsuba 3 cannot be imported (pip install mitsuba numpy): spectrace's figures alone")
    with tempfile.TemporaryDirectory(prefix="spt_trace_") as tmp:
        for name in names:
            if name == "cornell":
                path = CORNELL
            else:
                import bench_mitsuba
                path = bench_mitsuba.mesh_scene(tmp)
            tris = triangles(np, path)
            ray_arr, seg_arr = rays(np, tris, a.rays)
            tp, rp, sp = (os.path.join(tmp, f) for f in ("tris.f32", "rays.f32", "segments.f32"))
            tris.tofile(tp)
            ray_arr.tofile(rp)
            seg_arr.tofile(sp)
            print("%s: %d triangles, %d rays and as many segments" % (name, len(tris), len(ray_arr)), flush=True)
            ours = spectrace_times(a, tp, rp, sp)
            if mi is not None:
                theirs = mitsuba_times(a, mi, np, path, ray_arr, seg_arr, tmp)
                for q in ("closest hit", "any hit, unbounded", "any hit, segments"):
                    if q in ours:
                        print("  %s: Mitsuba/Embree's time per ray / spectrace's %.2f" % (q, theirs[q] / ours[q]))
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
