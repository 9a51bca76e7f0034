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

Block test (--chunks N): means hide regional bias, so this compares the two
images block by block. Give N spectrace EXRs rendered with N different seeds
(or --spectrace BIN to render them: SCENE only, --size, spp / N each, seeds
0..N-1); Mitsuba renders N chunks of spp / N with N other seeds. Each 8x8-pixel
block (--block) and channel gets a mean and a variance from the spread of its
chunk means on each side, and Welch's t-test (unequal variances) asks whether
the two means differ; the tool prints the fraction of block-channels rejected
at p < --alpha (default 0.01: an unbiased renderer rejects about 1%), per
channel, the worst blocks, and exits 1 when more than --max-rejected (default
0.02) are rejected.

    python3 tools/mitsuba_compare.py tests/data/scenes/cornell_box_rgb.gltf --chunks 16 \
        --spectrace build/spectrace --spp 4096 --size 256 --max-depth 8

--cache DIR keeps each side's chunks (NumPy files named by a hash of the scene
file, the settings, the seed and, for spectrace, the binary) and reuses them:
the Mitsuba reference is rendered once while spectrace changes, and a rebuilt
spectrace gets new chunks. Needs scipy for the t distribution.
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


def block_chunk_means(np, img, block):
    """(H/block, W/block, 3) means of block x block pixels (partial edge blocks dropped)."""
    h, w = img.shape[0] // block * block, img.shape[1] // block * block
    return img[:h, :w, :3].reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))


def welch_blocks(np, ours, ref, block=8, alpha=0.01):
    """Welch's t-test per block and channel between two lists of independent
    chunk images (same size; each chunk an unbiased estimate at its own seed).
    Each side's block mean is the mean of its chunks' block means and its
    variance their sample variance / n. Block-channels where both sides have
    zero variance (black, or the same constant) are not tested. Returns a dict
    with the rejected fraction overall and per channel, and the blocks."""
    from scipy import stats
    a = np.stack([block_chunk_means(np, c, block) for c in ours])   # (n, by, bx, 3)
    b = np.stack([block_chunk_means(np, c, block) for c in ref])
    na, nb = len(a), len(b)
    ma, mb = a.mean(0), b.mean(0)
    va, vb = a.var(0, ddof=1) / na, b.var(0, ddof=1) / nb
    se = np.sqrt(va + vb)
    tested = se > 0
    t = np.where(tested, (ma - mb) / np.where(tested, se, 1), 0.0)
    # Welch-Satterthwaite degrees of freedom.
    den = np.where(tested, va * va / (na - 1) + vb * vb / (nb - 1), 1)
    df = np.where(tested, (va + vb) ** 2 / np.where(den > 0, den, 1), 1)
    p = np.where(tested, 2 * stats.t.sf(np.abs(t), df), 1.0)
    rej = tested & (p < alpha)
    rel = (ma - mb) / np.where(mb != 0, np.abs(mb), np.inf)
    per_ch = [float(rej[..., c].sum() / max(tested[..., c].sum(), 1)) for c in range(3)]
    return {"block": block, "alpha": alpha, "chunks": [na, nb], "blocks": list(ma.shape[:2]),
            "tested": int(tested.sum()), "rejected": int(rej.sum()),
            "rejected_fraction": float(rej.sum() / max(tested.sum(), 1)),
            "rejected_fraction_per_channel": per_ch,
            "_t": t, "_p": p, "_rej": rej, "_rel": rel, "_ma": ma, "_mb": mb}


def worst_blocks(np, res, count=8):
    """The count block-channels of largest |t|: (row, col, channel, t, p, ours, ref, rel)."""
    t = res["_t"]
    order = np.argsort(-np.abs(t), axis=None)[:count]
    out = []
    for k in order:
        i, j, c = np.unravel_index(k, t.shape)
        out.append((int(i), int(j), "RGB"[c], float(t[i, j, c]), float(res["_p"][i, j, c]),
                    float(res["_ma"][i, j, c]), float(res["_mb"][i, j, c]), float(res["_rel"][i, j, c])))
    return out


def _file_hash(path):
    import hashlib
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for part in iter(lambda: f.read(1 << 20), b""):
            h.update(part)
    return h.hexdigest()[:16]


def _cached(np, cache, key, make):
    """make() or the array cached under key in folder cache (None: no cache)."""
    if cache is None:
        return make()
    path = os.path.join(cache, key + ".npy")
    if os.path.exists(path):
        return np.load(path)
    img = make()
    os.makedirs(cache, exist_ok=True)
    tmp = path + ".tmp.npy"
    np.save(tmp, img)
    os.replace(tmp, path)
    return img


def spectrace_chunks(mi, np, a, w, h, spp_chunk):
    """a.chunks spectrace renders of a.scene (seeds 0..n-1) as HxWx3 arrays."""
    import subprocess
    import tempfile
    tag = "spt_%s_%s_%dx%d_d%d_s%d_bg%s" % (_file_hash(a.spectrace), _file_hash(a.scene), w, h, a.max_depth,
                                           spp_chunk, (a.background or "default").replace(",", "_"))
    out = []
    with tempfile.TemporaryDirectory(prefix="spt_chunks_") as tmp:
        for k in range(a.chunks):
            def make(k=k):
                exr = os.path.join(tmp, "chunk%d.exr" % k)
                cmd = [a.spectrace, "render", a.scene, "-o", exr, "--spp", str(spp_chunk), "--seed", str(k),
                       "--width", str(w), "--height", str(h), "--max-depth", str(a.max_depth), "-q"]
                if a.background:
                    cmd += ["--background", a.background]
                r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
                if r.returncode != 0:
                    raise RuntimeError("%s failed (exit %d): %s" % (" ".join(cmd), r.returncode, r.stdout.strip()))
                return read_exr_rgb(mi, np, exr)
            out.append(_cached(np, a.cache, "%s_seed%d" % (tag, k), make))
            if not a.json:
                print("  spectrace chunk %d/%d" % (k + 1, a.chunks), file=sys.stderr)
    return out


def mitsuba_chunks(np, a, w, h, spp_chunk):
    """a.chunks Mitsuba renders (seeds a.seed * 1000 + k), with the render info of the first."""
    tag = "mts_%s_%dx%d_d%d_s%d_bg%s_%s%s_%s" % (_file_hash(a.scene), w, h, a.max_depth, spp_chunk,
                                               (a.background or "default").replace(",", "_"), a.variant,
                                               "_approx" if a.approx else "", a.colour)
    out, info = [], {}
    for k in range(a.chunks):
        seed = a.seed * 1000 + k

        def make(seed=seed):
            img, inf = s2m.render(a.scene, w, h, spp_chunk, a.max_depth, a.variant, seed, verbose=False,
                                  approx=a.approx, background=s2m.parse_background(a.background),
                                  colour=a.colour)
            info.update(inf)
            return img
        out.append(_cached(np, a.cache, "%s_seed%d" % (tag, seed), make))
        if not a.json:
            print("  Mitsuba chunk %d/%d" % (k + 1, a.chunks), file=sys.stderr)
    return out, info


def block_test(mi, np, a, exrs):
    """The --chunks mode: returns the exit code."""
    if a.spectrace:
        if exrs:
            print("error: give either spectrace EXRs or --spectrace, not both", file=sys.stderr)
            return 2
        w, h = a.width or a.size, a.height or a.size
        ours = spectrace_chunks(mi, np, a, w, h, a.spectrace_spp // a.chunks)
    else:
        if len(exrs) != a.chunks:
            print("error: --chunks %d wants %d spectrace EXRs (one per seed), got %d"
                  % (a.chunks, a.chunks, len(exrs)), file=sys.stderr)
            return 2
        try:
            ours = [read_exr_rgb(mi, np, e) for e in exrs]
        except Exception as e:  # noqa: BLE001
            print("error: cannot read: %s" % e, file=sys.stderr)
            return 2
        if len(set(o.shape for o in ours)) != 1:
            print("error: the EXRs differ in size", file=sys.stderr)
            return 2
    h, w = ours[0].shape[:2]
    try:
        ref, info = mitsuba_chunks(np, a, w, h, a.spp // a.chunks)
    except ValueError as e:
        print("error: %s: %s" % (a.scene, e), file=sys.stderr)
        return 2
    res = welch_blocks(np, ours, ref, a.block, a.alpha)
    m_ours = np.mean([o.mean(axis=(0, 1)) for o in ours], axis=0)
    m_ref = np.mean([r.mean(axis=(0, 1)) for r in ref], axis=0)
    rel = (m_ours - m_ref) / np.maximum(np.abs(m_ref), 1e-12)
    nonfinite = int(sum((~np.isfinite(o)).sum() for o in ours))
    ok = res["rejected_fraction"] <= a.max_rejected and nonfinite == 0
    if a.save_mitsuba:
        s2m.write_exr(mi, a.save_mitsuba, np.mean(ref, axis=0))
    worst = worst_blocks(np, res)
    result = {k: v for k, v in res.items() if not k.startswith("_")}
    result.update({"scene": a.scene, "width": w, "height": h, "max_depth": a.max_depth,
                   "spp_spectrace": a.spectrace_spp if a.spectrace else None, "spp_mitsuba": a.spp,
                   "mean_spectrace": m_ours.tolist(), "mean_mitsuba": m_ref.tolist(),
                   "relative_difference": rel.tolist(), "max_rejected": a.max_rejected,
                   "nonfinite_values": nonfinite, "pass": ok,
                   "worst": [dict(zip(("row", "col", "channel", "t", "p", "spectrace", "mitsuba", "rel"), x))
                             for x in worst]})
    if a.json:
        print(json.dumps(result, indent=1))
    else:
        print("%s: block test, %d x %d blocks of %dx%d pixels, %d + %d chunks, max depth %d"
              % (a.scene, res["blocks"][0], res["blocks"][1], a.block, a.block, len(ours), len(ref), a.max_depth))
        print("  mean spectrace: %.6f %.6f %.6f" % tuple(m_ours))
        print("  mean Mitsuba:   %.6f %.6f %.6f" % tuple(m_ref))
        print("  relative diff:  %+.4f %+.4f %+.4f" % tuple(rel))
        print("  Welch p < %g: %d of %d block-channels rejected (%.2f%%; R %.2f%% G %.2f%% B %.2f%%), "
              "allowed %.2f%%" % ((a.alpha, res["rejected"], res["tested"], 100 * res["rejected_fraction"])
                                  + tuple(100 * f for f in res["rejected_fraction_per_channel"])
                                  + (100 * a.max_rejected,)))
        print("  largest |t| (block row, col, channel: t, p, spectrace, Mitsuba, relative):")
        for i, j, c, t, p, x, y, r in worst:
            print("    %2d %2d %s: t %+6.2f p %.1e  %.6g %.6g %+.4f" % (i, j, c, t, p, x, y, r))
        if nonfinite:
            print("  %d non-finite values in spectrace's chunks" % nonfinite)
        print("PASS" if ok else "FAIL")
    return 0 if ok else 1


def main(argv=None):
    ap = argparse.ArgumentParser(description="Compare a spectrace EXR with a Mitsuba 3 render of the same scene.")
    ap.add_argument("inputs", nargs="+", metavar="EXR... SCENE",
                    help="spectrace's image (linear EXR; with --chunks one per chunk, or none with --spectrace) "
                         "and the .gltf it was rendered from")
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
    ap.add_argument("--colour", choices=("exact", "mitsuba"), default="exact",
                    help="Mitsuba's colour definitions (tools/scene_to_mitsuba.py): exact (default) spectrace's "
                         "observer and RGB upsampling, or mitsuba's own")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    bt = ap.add_argument_group("block test")
    bt.add_argument("--chunks", type=int, help="Welch test per block between N independent chunks of each side")
    bt.add_argument("--spectrace", metavar="BIN", help="render spectrace's chunks with this binary")
    bt.add_argument("--spectrace-spp", type=int, help="spectrace's samples per pixel in all chunks (default --spp)")
    bt.add_argument("--size", type=int, default=256, help="image size for --spectrace (default 256)")
    bt.add_argument("--width", type=int, help="width for --spectrace (overrides --size)")
    bt.add_argument("--height", type=int, help="height for --spectrace (overrides --size)")
    bt.add_argument("--block", type=int, default=8, help="block size in pixels (default 8)")
    bt.add_argument("--alpha", type=float, default=0.01, help="the test's significance level (default 0.01)")
    bt.add_argument("--max-rejected", type=float, default=0.02,
                    help="largest rejected fraction that passes (default 0.02)")
    bt.add_argument("--cache", metavar="DIR", help="keep and reuse each side's chunks in DIR")
    a = ap.parse_args(argv)
    a.scene, exrs = a.inputs[-1], a.inputs[:-1]
    if a.chunks is None and len(exrs) != 1:
        ap.error("want one EXR and the scene (or --chunks N for the block test)")
    if a.chunks is not None:
        if a.chunks < 2:
            ap.error("--chunks: at least 2")
        a.spectrace_spp = a.spectrace_spp or a.spp
        if a.spp < a.chunks or a.spectrace_spp < a.chunks:
            ap.error("--spp: at least one sample per pixel in each chunk")
        if a.spectrace and not os.access(a.spectrace, os.X_OK):
            print("error: %s: not an executable" % a.spectrace, file=sys.stderr)
            return 2
    for f in exrs + [a.scene]:
        if not os.path.isfile(f):
            print("error: %s: no such file" % f, file=sys.stderr)
            return 2
    mi = s2m.import_mitsuba(a.variant)
    if mi is None:
        print("skip: " + s2m.MITSUBA_MISSING)
        return 0
    import numpy as np
    if a.chunks is not None:
        try:
            import scipy  # noqa: F401
        except ImportError:
            print("skip: the block test needs scipy (pip install scipy)")
            return 0
        try:
            return block_test(mi, np, a, exrs)
        except RuntimeError as e:
            print("error: %s" % e, file=sys.stderr)
            return 2
    a.exr = exrs[0]
    try:
        ours = read_exr_rgb(mi, np, a.exr)
    except Exception as e:  # noqa: BLE001
        print("error: %s: cannot read: %s" % (a.exr, e), file=sys.stderr)
        return 2
    h, w = ours.shape[:2]
    try:
        ref, info = s2m.render(a.scene, w, h, a.spp, a.max_depth, a.variant, a.seed, verbose=False,
                               approx=a.approx, background=s2m.parse_background(a.background), colour=a.colour)
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
