#!/usr/bin/env python3
"""Compares a spectrace render (EXR, linear sRGB) with Blender's Cycles on the same glTF file.

    python3 tools/blender_compare.py out/scene.exr scene.gltf --spp 256 --max-depth 8 \
        [--distribution both|ggx|multi_ggx] [--save-blender b.exr] [--json]

Blender (the `bpy` package from PyPI: `pip install bpy flip-evaluator`; bpy
pins its own numpy, so a virtual environment of its own is wise) imports the
glTF with its own importer, and the tool sets up what spectrace would see:

- the camera: spectrace's (the first camera in depth-first node order; without
  one, spectrace's default: the bounds' sphere in a 45 degree vertical field of
  view, looking down -Z), vertical field of view, the EXR's resolution;
- the sky: spectrace's default white sky (radiance 1, D65, which is linear sRGB
  (1, 1, 1)) as the world colour when the scene has no emissive material and
  no punctual light, else black; --background black|R,G,B as spectrace's;
- lights: point and spot lights of I candela as Blender lights of 4 pi I watts
  (radiant intensity I: film units, where spectrace's film Y is 1 per nit),
  directional lights of E lux as a sun of strength E, all without radius;
  emission (emissiveFactor x KHR_materials_emissive_strength) as the importer
  sets it, one-sided (back faces masked) as glTF and spectrace define it;
- Cycles on the CPU: --spp samples, no adaptive sampling, denoising, clamping
  or glossy blur; caustics on; every bounce limit max_depth - 2 (Cycles' 0
  bounces is direct light only, spectrace's --max-depth 2; -1 gives 1024); a
  one-pixel box filter, as spectrace's;
- Principled BSDF's microfacet distribution: "GGX" (single scattering, what the
  glTF BRDF of Appendix B is) and/or Blender's default "Multiscatter GGX",
  which adds energy compensation and is brighter on rough metals.
- textures filtered as glTF says (--texture-filter gltf, the default): Cycles
  interpolates an 8-bit sRGB image's encoded values and decodes afterwards, where
  glTF 2.0 asks for the sRGB transfer function to be decoded before linear
  interpolation (as spectrace does; Khronos' TextureLinearInterpolationTest
  model checks it); the tool hands Cycles such images as float images of their
  decoded values. Blender's importer gives a texture 'Closest' interpolation
  only when both of its sampler's filters are NEAREST (a magFilter NEAREST with a
  mipmapped minFilter becomes 'Linear'); the tool gives it 'Closest' whenever
  magFilter is NEAREST, as spectrace magnifies. --texture-filter blender keeps
  what Blender does by itself (textured regions differ at every texel boundary:
  +4-6% on the project's 4 x 4 cell textures, +23% on a black-white ramp).

Prints both images' channel means, their relative differences and the mean
FLIP error (HDR, flip-evaluator) of spectrace's image against Blender's, per
distribution; exits 1 when a channel mean differs by more than --tolerance
(relative, default 0.05; GGX only), 2 for a usage error or unreadable input,
0 with a "skip:" line when bpy is not installed.

Blender's importer knows glTF, not spectrace's extras: spectral reflectances,
emission spectra, measured conductors (extras.spectrace) and dispersion fall
back to baseColorFactor and the other glTF values, so such scenes differ by
design.
"""
import argparse
import json
import math
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scene_to_mitsuba as s2m  # noqa: E402  (glTF reading: nodes, cameras, bounds)
from mitsuba_compare import flip_error  # noqa: E402  (the FLIP error both comparisons print)

BPY_MISSING = "bpy is not installed: `pip install bpy flip-evaluator` (Blender as a Python module) to compare"


class BlenderQuiet:
    """Sends what Blender prints on the standard output (import and render logs)
    to the standard error while in the block, so --json output stays JSON."""
    def __enter__(self):
        sys.stdout.flush()
        self.saved = os.dup(1)
        os.dup2(2, 1)
        return self

    def __exit__(self, *exc):
        sys.stdout.flush()
        os.dup2(self.saved, 1)
        os.close(self.saved)
        return False


def gl_to_blender(v):
    """A glTF (Y up) point or direction in Blender's Z-up frame, as the importer maps it."""
    return (float(v[0]), -float(v[2]), float(v[1]))


def spectrace_camera(path, np):
    """spectrace's camera of the glTF at path: {'origin', 'forward', 'up', 'yfov',
    'ortho' (ymag or None)} in glTF coordinates."""
    with open(path) as f:
        doc = json.load(f)
    scenes = doc.get("scenes") or []
    if scenes:
        roots = scenes[doc.get("scene", 0)].get("nodes", [])
    else:
        children = {c for n in doc.get("nodes", []) for c in n.get("children", [])}
        roots = [i for i in range(len(doc.get("nodes", []))) if i not in children]
    # Depth-first, pre-order, children in file order (src/scene/gltf_load.cpp).
    stack = [(r, np.eye(4)) for r in reversed(roots)]
    while stack:
        n, parent = stack.pop()
        node = doc["nodes"][n]
        world = parent @ s2m._node_matrix(node)
        if "camera" in node:
            cam = doc["cameras"][node["camera"]]
            fwd = world[:3, :3] @ np.array([0.0, 0.0, -1.0])
            up = world[:3, :3] @ np.array([0.0, 1.0, 0.0])
            fwd /= np.linalg.norm(fwd)
            right = np.cross(fwd, up)
            right /= np.linalg.norm(right)
            up = np.cross(right, fwd)
            out = {"origin": world[:3, 3].copy(), "forward": fwd, "up": up, "yfov": math.radians(45), "ortho": None,
                   "znear": 1e-3}
            if cam.get("type") == "orthographic":
                out["ortho"] = float(cam["orthographic"]["ymag"])
                out["znear"] = float(cam["orthographic"].get("znear", 0.0))
            else:
                out["yfov"] = float(cam["perspective"]["yfov"])
                out["znear"] = float(cam["perspective"].get("znear", 1e-3))
            return out
        stack.extend((c, world) for c in reversed(node.get("children", [])))
    # spectrace's default camera (src/scene/scene.c scene_default_camera).
    scene = s2m.load_gltf(path)
    pts = [s[1][s[2].reshape(-1)] for s in scene["shapes"] if len(s[2])]
    yfov = math.radians(45.0)
    if pts:
        allp = np.concatenate(pts)
        lo, hi = allp.min(0), allp.max(0)
        centre, radius = (lo + hi) / 2, float(np.linalg.norm(hi - lo) / 2)
    else:
        centre, radius = np.zeros(3), 1.0
    radius = radius if radius > 0 else 1.0
    dist = radius / math.sin(yfov / 2)
    return {"origin": centre + np.array([0, 0, dist]), "forward": np.array([0, 0, -1.0]),
            "up": np.array([0, 1.0, 0]), "yfov": yfov, "ortho": None,
            "znear": max(1e-4 * dist, 0.5 * (dist - radius))}


def scene_has_light(path):
    """Whether spectrace lights the scene itself (emissive materials or punctual lights):
    then it gets no default sky."""
    scene = s2m.load_gltf(path)
    if scene["lights"]:
        return True
    used = {s[3] for s in scene["shapes"] if len(s[2])}
    for i, m in enumerate(scene["materials"]):
        if i not in used:
            continue
        spec = m.get("extras", {}).get("spectrace", {}) if isinstance(m.get("extras"), dict) else {}
        strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        if "emission" in spec or (max(m.get("emissiveFactor", [0, 0, 0])) * strength > 0
                                  or "emissiveTexture" in m):
            return True
    return False


def srgb_decode(np, c):
    """The sRGB transfer function's decoding (IEC 61966-2-1) of encoded values c in [0, 1]."""
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def importer_nearest_on_magnification():
    """Makes Blender's glTF importer give an Image Texture node 'Closest' interpolation
    whenever its sampler's magFilter is NEAREST (it does so only when minFilter is
    NEAREST too, or absent). Returns False where the importer's module is not where
    Blender 4 and 5 keep it."""
    try:
        from io_scene_gltf2.blender.imp import texture as imp_texture
        from io_scene_gltf2.io.com.constants import TextureFilter
    except ImportError:
        return False
    if not hasattr(imp_texture, "set_filtering"):
        return False

    def set_filtering(tex_img, pysampler):
        tex_img.interpolation = "Closest" if pysampler.mag_filter == TextureFilter.Nearest else "Linear"
    imp_texture.set_filtering = set_filtering
    return True


def linear_float_images(bpy, np):
    """Replaces every 8-bit sRGB image of an Image Texture node by a float image of
    its decoded values, so that Cycles interpolates linear values (glTF 2.0: the
    transfer function is decoded before linear interpolation). Returns how many."""
    done = {}
    for mat in bpy.data.materials:
        if mat.node_tree is None:
            continue
        for node in mat.node_tree.nodes:
            im = node.image if node.type == "TEX_IMAGE" else None
            if im is None or im.is_float or im.colorspace_settings.name != "sRGB":
                continue
            if im.name not in done:
                w, h = im.size
                px = np.empty(w * h * 4, dtype=np.float32)
                im.pixels.foreach_get(px)     # an 8-bit image's stored values / 255
                px = px.reshape(-1, 4)
                px[:, :3] = srgb_decode(np, px[:, :3].astype(np.float64))
                new = bpy.data.images.new(im.name + ".linear", w, h, alpha=True, float_buffer=True)
                new.colorspace_settings.name = "Linear Rec.709"
                new.alpha_mode = im.alpha_mode
                new.pixels.foreach_set(px.ravel())
                new.pack()
                done[im.name] = new
            node.image = done[im.name]
    return len(done)


def setup_blender(bpy, a, w, h, np):
    """Resets Blender, imports the glTF and sets camera, world, lights, textures and Cycles."""
    from mathutils import Matrix
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if a.texture_filter == "gltf" and not importer_nearest_on_magnification():
        print("warning: Blender's glTF importer has no set_filtering here: magFilter NEAREST follows the "
              "importer's own rule", file=sys.stderr)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(a.scene), export_import_convert_lighting_mode="RAW")
    if a.texture_filter == "gltf":
        linear_float_images(bpy, np)
    sc = bpy.context.scene
    # Camera: ours, not the importer's.
    for ob in [o for o in sc.objects if o.type == "CAMERA"]:
        bpy.data.objects.remove(ob, do_unlink=True)
    cam = spectrace_camera(a.scene, np)
    cd = bpy.data.cameras.new("spectrace_camera")
    cd.sensor_fit = "VERTICAL"
    if cam["ortho"] is not None:
        cd.type = "ORTHO"
        cd.ortho_scale = 2.0 * cam["ortho"]     # the vertical extent (sensor fit vertical)
    else:
        cd.angle_y = cam["yfov"]
    cd.clip_start = max(cam["znear"], 1e-5)
    cd.clip_end = 1e6
    co = bpy.data.objects.new("spectrace_camera", cd)
    sc.collection.objects.link(co)
    fwd, up = np.array(gl_to_blender(cam["forward"])), np.array(gl_to_blender(cam["up"]))
    right = np.cross(fwd, up)
    rot = np.stack([right, up, -fwd], axis=1)     # columns: the camera's local X, Y, Z
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = gl_to_blender(cam["origin"])
    co.matrix_world = Matrix(m.tolist())
    sc.camera = co
    # Lights: radiant intensity I for I candela (film units), suns of E lux as strength E.
    for ob in sc.objects:
        if ob.type != "LIGHT":
            continue
        ld = ob.data
        if ld.type in ("POINT", "SPOT"):
            ld.energy = ld.energy * 4.0 * math.pi
            ld.shadow_soft_size = 0.0
        elif ld.type == "SUN":
            ld.angle = 0.0
    # Emission one-sided, as glTF: Principled's emission strength times (1 - backfacing).
    for mat in bpy.data.materials:
        if not mat.use_nodes or not mat.use_backface_culling:   # the importer's doubleSided
            continue
        nt = mat.node_tree
        for node in list(nt.nodes):
            if node.type != "BSDF_PRINCIPLED":
                continue
            inp = node.inputs.get("Emission Strength")
            if inp is None:
                continue
            if not inp.is_linked and inp.default_value == 0.0:
                continue
            geo = nt.nodes.new("ShaderNodeNewGeometry")
            front = nt.nodes.new("ShaderNodeMath")
            front.operation = "SUBTRACT"
            front.inputs[0].default_value = 1.0
            nt.links.new(geo.outputs["Backfacing"], front.inputs[1])
            mul = nt.nodes.new("ShaderNodeMath")
            mul.operation = "MULTIPLY"
            if inp.is_linked:
                nt.links.new(inp.links[0].from_socket, mul.inputs[0])
            else:
                mul.inputs[0].default_value = inp.default_value
            nt.links.new(front.outputs[0], mul.inputs[1])
            nt.links.new(mul.outputs[0], inp)
    # The sky.
    world = bpy.data.worlds.new("spectrace_sky")
    sc.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    if a.background is None:
        sky = [0.0, 0.0, 0.0] if scene_has_light(a.scene) else [1.0, 1.0, 1.0]
    else:
        sky = s2m.parse_background(a.background) or [0.0, 0.0, 0.0]
    bg.inputs["Color"].default_value = (sky[0], sky[1], sky[2], 1.0)
    bg.inputs["Strength"].default_value = 1.0
    # Cycles.
    r = sc.render
    r.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = int(a.spp)
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = int(a.seed)
    bounces = 1024 if a.max_depth < 0 else max(a.max_depth - 2, 0)
    for attr in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces",
                 "transparent_max_bounces"):
        setattr(cy, attr, bounces)
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    r.resolution_x, r.resolution_y, r.resolution_percentage = w, h, 100
    r.film_transparent = False
    r.threads_mode = "FIXED"
    r.threads = max(1, int(a.threads))
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"
    return sky


def set_distribution(bpy, dist):
    """Every Principled BSDF's microfacet distribution: 'GGX' or 'MULTI_GGX'."""
    n = 0
    for mat in bpy.data.materials:
        if mat.use_nodes:
            for node in mat.node_tree.nodes:
                if node.type == "BSDF_PRINCIPLED":
                    node.distribution = dist
                    n += 1
    return n


def read_exr(bpy, np, path):
    """HxWx3 float64 linear RGB of an EXR, row 0 at the top, through Blender's image loader."""
    img = bpy.data.images.load(os.path.abspath(path), check_existing=False)
    try:
        img.colorspace_settings.name = "Non-Color"   # the values as stored
        w, h = img.size
        if w == 0 or h == 0:
            raise ValueError("not an image")
        buf = np.empty(w * h * 4, dtype=np.float32)
        img.pixels.foreach_get(buf)
        return buf.reshape(h, w, 4)[::-1, :, :3].astype(np.float64)
    finally:
        bpy.data.images.remove(img)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Compare a spectrace EXR with Blender Cycles' render of the same glTF.")
    ap.add_argument("exr", help="spectrace's image (linear EXR)")
    ap.add_argument("scene", help="the .gltf/.glb it was rendered from")
    ap.add_argument("--spp", type=int, default=256, help="Cycles samples per pixel (default 256)")
    ap.add_argument("--max-depth", type=int, default=-1,
                    help="as spectrace's --max-depth (default -1); Cycles gets max_depth - 2 bounces")
    ap.add_argument("--distribution", choices=("both", "ggx", "multi_ggx"), default="both",
                    help="Principled BSDF microfacet distribution: ggx (single scattering, the glTF BRDF), "
                         "multi_ggx (Blender's default) or both (default)")
    ap.add_argument("--background", metavar="black|R,G,B", help="as spectrace's --background")
    ap.add_argument("--texture-filter", choices=("gltf", "blender"), default="gltf",
                    help="gltf (default): Cycles filters sRGB textures after decoding them and magnifies "
                         "magFilter NEAREST with 'Closest', as glTF and spectrace; blender: as Blender "
                         "imports and filters them by itself")
    ap.add_argument("--tolerance", type=float, default=0.05,
                    help="largest relative difference of a channel mean (GGX) that passes (default 0.05)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1, help="Cycles threads (default: all)")
    ap.add_argument("--save-blender", metavar="EXR",
                    help="write Blender's image here (with --distribution both, NAME.ggx.exr and NAME.multi_ggx.exr)")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    a = ap.parse_args(argv)
    for f in (a.exr, a.scene):
        if not os.path.isfile(f):
            print("error: %s: no such file" % f, file=sys.stderr)
            return 2
    if a.spp < 1:
        ap.error("--spp: at least 1")
    import warnings
    warnings.filterwarnings("ignore", category=DeprecationWarning)   # bpy's notes on its next API
    try:
        import bpy
        import numpy as np
    except ImportError:
        print("skip: " + BPY_MISSING)
        return 0
    s2m.np = np
    if a.background is not None:
        try:
            s2m.parse_background(a.background)
        except ValueError as e:
            print("error: %s" % e, file=sys.stderr)
            return 2
    try:
        ours = read_exr(bpy, np, a.exr)
    except Exception as e:  # noqa: BLE001 (Blender raises RuntimeError for unreadable images)
        print("error: %s: cannot read: %s" % (a.exr, e), file=sys.stderr)
        return 2
    h, w = ours.shape[:2]
    try:
        with BlenderQuiet():
            sky = setup_blender(bpy, a, w, h, np)
    except Exception as e:  # noqa: BLE001 (the importer's errors)
        print("error: %s: Blender cannot import it: %s" % (a.scene, e), file=sys.stderr)
        return 2
    dists = {"both": ["GGX", "MULTI_GGX"], "ggx": ["GGX"], "multi_ggx": ["MULTI_GGX"]}[a.distribution]
    m_ours = ours.mean(axis=(0, 1))
    results = []
    with tempfile.TemporaryDirectory(prefix="spt_blender_") as tmp:
        for dist in dists:
            nbsdf = set_distribution(bpy, dist)
            out = os.path.join(tmp, "blender_%s.exr" % dist.lower())
            bpy.context.scene.render.filepath = out
            t0 = time.time()
            with BlenderQuiet():
                bpy.ops.render.render(write_still=True)
            secs = time.time() - t0
            ref = read_exr(bpy, np, out)
            if a.save_blender:
                dst = a.save_blender if len(dists) == 1 else "%s.%s.exr" % (os.path.splitext(a.save_blender)[0],
                                                                          dist.lower())
                with open(out, "rb") as src, open(dst + ".tmp", "wb") as f:
                    f.write(src.read())
                os.replace(dst + ".tmp", dst)
            m_ref = ref.mean(axis=(0, 1))
            rel = (m_ours - m_ref) / np.maximum(np.abs(m_ref), 1e-12)
            results.append({"distribution": dist, "principled_bsdfs": nbsdf, "render_s": round(secs, 2),
                            "mean_blender": m_ref.tolist(), "relative_difference": rel.tolist(),
                            "flip_mean": flip_error(np, ref, ours)})
    ggx = [r for r in results if r["distribution"] == "GGX"]
    worst = max(abs(v) for v in (ggx or results)[0]["relative_difference"])
    nonfinite = int((~np.isfinite(ours)).sum())
    ok = worst <= a.tolerance and nonfinite == 0
    summary = {"exr": a.exr, "scene": a.scene, "width": w, "height": h, "spp": a.spp, "max_depth": a.max_depth,
               "cycles_bounces": 1024 if a.max_depth < 0 else max(a.max_depth - 2, 0), "sky": sky,
               "blender": bpy.app.version_string, "texture_filter": a.texture_filter,
               "mean_spectrace": m_ours.tolist(), "results": results,
               "tolerance": a.tolerance, "nonfinite_pixels": nonfinite, "pass": ok}
    if a.json:
        print(json.dumps(summary, indent=1))
    else:
        print("%s vs Blender %s Cycles (%d spp, %d bounces, %dx%d, sky %s, textures filtered as %s)"
              % (a.exr, bpy.app.version_string, a.spp, summary["cycles_bounces"], w, h,
                 ",".join("%g" % c for c in sky), a.texture_filter))
        print("  mean spectrace:          %.6f %.6f %.6f" % tuple(m_ours))
        for r in results:
            print("  mean Blender %-10s  %.6f %.6f %.6f  relative %+.4f %+.4f %+.4f  FLIP %s  (%.1f s)"
                  % ((r["distribution"],) + tuple(r["mean_blender"]) + tuple(r["relative_difference"])
                     + ("%.4f" % r["flip_mean"] if r["flip_mean"] is not None else "n/a", r["render_s"])))
        if nonfinite:
            print("  %d non-finite values in %s" % (nonfinite, a.exr))
        print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
