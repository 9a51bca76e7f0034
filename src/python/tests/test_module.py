"""The Python module over build/libspectrace.so: arrays, settings, changes between
renders, errors, progress and colour, each checked against independent values
(the sRGB matrix of docs/architecture.md, exact scalings, the CIE white points)
or against the library's other paths."""
import subprocess
from pathlib import Path

import numpy as np
import pytest

import spectrace

BOX = "scenes/cornell_box.gltf"
SPOT = "tests/data/scenes/caustic_sphere.gltf"
SMALL = dict(width=32, spp=4, seed=3, caustics="off")
XYZ_TO_RGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415],
                       [0.0557, -0.2040, 1.0570]])


@pytest.fixture(scope="module")
def box():
    return spectrace.Scene(BOX)


def test_version():
    assert spectrace.version() == (1, 3)


def test_only_the_api_is_exported():
    lib = Path(spectrace._library_path())
    out = subprocess.run(["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True,
                         check=True).stdout
    names = {line.split()[-1].split("@")[0] for line in out.splitlines() if line.strip()}
    names.discard("SPECTRACE_1")
    extra = {n for n in names if not n.startswith("spectrace_")}
    assert extra == {"spt_fail", "input_check", "texture_io_free"}
    assert "spectrace_render" in names


def test_render_arrays(box):
    img = box.render(aov=["albedo", "Z", "spp"], spectral=8, **SMALL)
    rgb, xyz = img.rgb, img.xyz
    assert rgb.shape == (32, 32, 3) and rgb.dtype == np.float32
    # The linear sRGB is the XYZ through the sRGB matrix, pixel by pixel.
    np.testing.assert_allclose(rgb, xyz @ XYZ_TO_RGB.T, rtol=1e-4, atol=1e-6)
    assert np.all(img.counts == 4) and img.spp == 4
    np.testing.assert_array_equal(img.aov("spp"), img.counts)
    assert img.aov("albedo").shape == (32, 32, 3)
    z = img.aov("Z")
    # Depth along the view axis: positive where a ray hits (the box fills the view but
    # for the corners just past its edges), 0 where it misses.
    assert z.shape == (32, 32) and np.all(z >= 0) and np.mean(z > 0) > 0.95
    assert img.bands.shape == (32, 32, 8) and np.all(img.bands >= 0)
    np.testing.assert_allclose(img.band_centers, 360 + (np.arange(8) + 0.5) * 470 / 8)
    with pytest.raises(spectrace.SpectraceError) as e:
        img.aov("N")
    assert e.value.code == 2 and "no N layer" in e.value.message


def test_render_function_and_layers(box):
    rgb = spectrace.render(BOX, **SMALL)
    rgb2, extra = spectrace.render(box, layers=["xyz", "albedo", "counts"], **SMALL)
    # The same scene and settings: the same image, however it was asked for.
    np.testing.assert_array_equal(rgb, rgb2)
    assert set(extra) == {"xyz", "albedo", "counts"}
    assert np.all(extra["counts"] == 4)


def test_settings():
    s = spectrace.Settings(max_depth=8, light_paths=0.5, aov=["z", "albedo"], sampler="ZSOBOL")
    assert s["max-depth"] == "8" and s["max_depth"] == "8"
    assert s["light-paths"] == "0.5" and s["aov"] == "albedo,Z" and s["sampler"] == "zsobol"
    with pytest.raises(spectrace.SpectraceError) as e:
        s["spp"] = 0
    assert e.value.code == 2
    assert e.value.message == "render: --spp '0': expected a whole number from 1 to 16777216"
    assert s["spp"] == "16"
    with pytest.raises(spectrace.SpectraceError):
        s["output"] = "x.png"
    names = spectrace.settings_names()
    assert names["spp"][0] == "int" and "output" not in names and "width" in names


def test_roughness_and_back():
    box = spectrace.Scene(BOX)
    glass = box.materials["dispersive_glass"]
    assert glass.roughness == 0.0 and glass.name == "dispersive_glass"
    first = box.render(**SMALL).rgb
    first_bytes = box.stats["bytes_uploaded"]
    glass.roughness = 0.4
    rough = box.render(**SMALL).rgb
    glass.roughness = 0.0
    again = box.render(**SMALL).rgb
    assert not np.array_equal(first, rough)
    np.testing.assert_array_equal(first, again)
    # The first render uploaded the whole scene; the two changes only the
    # materials, a small part of it.
    ndev = len(spectrace._renderer(None).devices)
    st = box.stats
    assert st["renders"] == 3 and st["bvh_builds"] == 1 and st["program_builds"] == ndev
    assert st["geometry_uploads"] == ndev and st["material_uploads"] == 3 * ndev
    assert 0 < st["bytes_uploaded"] - first_bytes < 0.1 * first_bytes
    with pytest.raises(spectrace.SpectraceError) as e:
        glass.roughness = 1.5
    assert e.value.code == 2 and "outside [0, 1]" in e.value.message
    with pytest.raises(AttributeError):
        glass.shininess = 1


def test_light_intensity_and_emission_spectrum():
    scene = spectrace.Scene(SPOT)
    before = scene.render(**SMALL).rgb
    assert before.sum() > 0
    scene.lights[0].intensity = 2 * scene.lights[0].intensity
    # One light, every path the same: each contribution doubles.
    np.testing.assert_allclose(scene.render(**SMALL).rgb, 2 * before, rtol=1e-5, atol=1e-12)
    box = spectrace.Scene(BOX)
    base = box.render(**SMALL).rgb
    box.materials["light"].emission = np.array([[400, 0], [500, 16], [600, 31.2], [700, 36.8]])
    np.testing.assert_allclose(box.render(**SMALL).rgb, 2 * base, rtol=1e-5, atol=1e-12)


def test_scene_from_bytes(box):
    data = Path(BOX).read_bytes()
    mem = spectrace.Scene.from_bytes(data, base_dir="scenes")
    assert mem.materials.keys() == box.materials.keys()
    fresh = spectrace.Scene(BOX)
    np.testing.assert_array_equal(mem.render(**SMALL).rgb, fresh.render(**SMALL).rgb)


def test_denoise(box):
    # The noisy image is the render without denoising, bit for bit; the denoised one
    # is smoother (less difference between neighbouring pixels) with about the same
    # light (at 4 samples its fireflies take some 20% away; the command line's own
    # guard is half to twice: docs/outputs.md, "Denoising"). test_api.c compares it
    # with the command line's --denoise image bit for bit.
    plain = box.render(**SMALL).rgb
    try:
        img = box.render(denoise=True, **SMALL)
    except spectrace.SpectraceError as e:
        if "not installed" in e.message:
            pytest.skip("Open Image Denoise not installed (make denoise)")
        raise
    np.testing.assert_array_equal(img.noisy_rgb, plain)
    assert 0.7 < img.rgb.mean() / plain.mean() < 1.05
    rough = lambda a: np.abs(np.diff(a, axis=1)).mean()
    assert rough(img.rgb) < 0.8 * rough(plain)


def test_scene_from_bytes_posed():
    # The turntable at 0.5 s from its bytes is the file loaded at 0.5 s, and not its
    # rest pose.
    path = "tests/data/anim/turntable.gltf"
    data = Path(path).read_bytes()
    small = dict(width=16, spp=2, seed=7, caustics="off", max_depth=3)
    posed = spectrace.Scene.from_bytes(data, base_dir="tests/data/anim", at=0.5).render(**small).rgb
    np.testing.assert_array_equal(posed, spectrace.Scene(path, at=0.5).render(**small).rgb)
    rest = spectrace.Scene.from_bytes(data, base_dir="tests/data/anim").render(**small).rgb
    assert not np.array_equal(posed, rest)


def test_errors():
    with pytest.raises(spectrace.SpectraceError) as e:
        spectrace.Scene("no/such.gltf")
    assert e.value.code == 3 and e.value.message.startswith("no/such.gltf")
    with pytest.raises(spectrace.SpectraceError) as e:
        spectrace.render(BOX, width=0)
    assert e.value.code == 2


def test_progress_and_cancel(box):
    seen = []
    box.render(progress=lambda done, total: seen.append((done, total)), width=32, spp=32, caustics="off")
    assert seen and seen[-1] == (32, 32)
    assert all(b[0] > a[0] for a, b in zip(seen, seen[1:]))
    with pytest.raises(spectrace.Cancelled) as e:
        box.render(progress=lambda done, total: True, width=32, spp=32, caustics="off")
    assert e.value.code == 130


def test_color():
    d65 = spectrace.color("D65")
    # The D65 white point (CIE 15:2004), Y = 1, and white in sRGB.
    np.testing.assert_allclose(d65.xyz, [0.95047, 1.0, 1.08883], atol=2e-4)
    assert d65.srgb8 == (255, 255, 255)
    np.testing.assert_allclose(d65.xy, [0.3127, 0.3290], atol=2e-4)
    flat = spectrace.color([[360, 1.0], [830, 1.0]])  # illuminant E
    np.testing.assert_allclose(flat.xy, [1 / 3, 1 / 3], atol=2e-4)
    a = spectrace.color("A")
    np.testing.assert_allclose(a.xy, [0.44757, 0.40745], atol=2e-4)
    with pytest.raises(spectrace.SpectraceError) as e:
        spectrace.color("no-such-spd")
    assert e.value.code == 3


def test_write_image(tmp_path):
    ramp = np.zeros((4, 8, 3), dtype=np.float32)
    ramp[:, :, 0] = np.linspace(0, 1, 8)
    spectrace.write_image(tmp_path / "ramp.exr", ramp)
    spectrace.write_image(tmp_path / "ramp.png", ramp)
    assert (tmp_path / "ramp.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "ramp.exr").read_bytes()[:4] == b"\x76\x2f\x31\x01"
    with pytest.raises(spectrace.SpectraceError) as e:
        spectrace.write_image(tmp_path / "ramp.xyz", ramp)
    assert e.value.code == 2


def test_checkpoint_and_resume(box, tmp_path):
    """A render of 4 spp checkpointed and resumed to 12 equals the 12 spp render bit for
    bit (every sample is a function of its index: docs/architecture.md, "Scale"), and the
    checkpoint of a render stopped by its progress callback resumes the same way."""
    part = tmp_path / "part.exr"
    settings = dict(width=24, seed=5, caustics="off", aov="albedo,N", spectral=4)
    full = box.render(spp=12, **settings)
    first = box.render(spp=4, checkpoint=part, **settings)
    assert first.stats["checkpoint"] == str(part) and first.stats["checkpoint_spp"] == 4
    assert part.exists()
    resumed = box.render(spp=12, resume=part, **settings)
    assert resumed.stats["spp_resumed"] == 4 and resumed.spp == 12
    np.testing.assert_array_equal(resumed.xyz, full.xyz)
    np.testing.assert_array_equal(resumed.rgb, full.rgb)
    np.testing.assert_array_equal(resumed.counts, full.counts)
    np.testing.assert_array_equal(resumed.aov("albedo"), full.aov("albedo"))
    np.testing.assert_array_equal(resumed.bands, full.bands)
    # Not the same as a render of fewer samples: the comparison can fail.
    assert not np.array_equal(first.xyz, full.xyz)
    # Stopped by its progress callback, the render leaves its samples in the checkpoint.
    stopped = tmp_path / "stopped.exr"
    with pytest.raises(spectrace.Cancelled):
        box.render(spp=12, checkpoint=stopped, progress=lambda done, total: done >= 2, **settings)
    again = box.render(spp=12, resume=stopped, **settings)
    assert 2 <= again.stats["spp_resumed"] < 12
    np.testing.assert_array_equal(again.xyz, full.xyz)
    np.testing.assert_array_equal(again.rgb, full.rgb)
    # A resume with other settings that change the image is refused, naming the setting.
    with pytest.raises(spectrace.SpectraceError) as e:
        box.render(spp=12, resume=part, **dict(settings, seed=6))
    assert e.value.code == 3 and "seed" in e.value.message
    # A scene from bytes has no file for the checkpoint to identify it by.
    mem = spectrace.Scene.from_bytes(Path(BOX).read_bytes(), base_dir="scenes")
    with pytest.raises(spectrace.SpectraceError) as e:
        mem.render(spp=4, checkpoint=tmp_path / "mem.exr", **settings)
    assert e.value.code == 2


TURNTABLE = "tests/data/anim/turntable.gltf"


def _exr_hash(path):
    """The EXR's bytes with its render-time attribute zeroed (tools/image_hashes.sh)."""
    b = bytearray(Path(path).read_bytes())
    i = 8  # magic and version
    while b[i] != 0:
        n = b.index(0, i)
        t = b.index(0, n + 1)
        size = int.from_bytes(b[t + 1:t + 5], "little")
        v = t + 5
        if bytes(b[i:n]) == b"spectrace:renderSeconds":
            b[v:v + size] = bytes(size)
        i = v + size
    return bytes(b)


def test_time_frames(tmp_path, monkeypatch):
    # Frame 5 of a sequence at 24 frames per second through Scene.time: the command
    # line's frame 5 of --frames 0:5 (its EXR, byte for byte but the render's seconds),
    # with the BVH refitted, not built; frame 0 differs. With the BVH built anew (the
    # test hook SPECTRACE_TEST_BVH_REBUILD) a fresh load at 5/24 s, bit for bit (a
    # refitted tree keeps the first pose's triangle order, other noise:
    # tests/test_frames.c).
    small = dict(width=16, spp=2, seed=7, caustics="off", max_depth=3)
    scene = spectrace.Scene(TURNTABLE, at=0)
    assert scene.time == 0
    first = scene.render(**small)
    builds = scene.stats["program_builds"]
    scene.time = 5 / 24
    assert scene.time == 5 / 24
    fifth = scene.render(**small)
    assert scene.timing["bvh_refitted"] == 1 and scene.timing["bvh_refits"] == 1
    assert scene.stats["bvh_builds"] == 1 and scene.stats["program_builds"] == builds
    assert not np.array_equal(first.rgb, fifth.rgb)
    exe = Path(spectrace._library_path()).parent / "spectrace"
    subprocess.run([str(exe), "render", TURNTABLE, "--frames", "0:5", "--width", "16", "--spp",
                    "2", "--seed", "7", "--caustics", "off", "--max-depth", "3", "-q", "-o",
                    str(tmp_path / "f_#.exr")], check=True)
    fifth.write(tmp_path / "api.exr")
    assert _exr_hash(tmp_path / "f_5.exr") == _exr_hash(tmp_path / "api.exr")
    monkeypatch.setenv("SPECTRACE_TEST_BVH_REBUILD", "1")
    scene.time = 5 / 24
    built = scene.render(**small)
    assert scene.timing["bvh_refitted"] == 0
    fresh = spectrace.Scene(TURNTABLE, at=5 / 24).render(**small)
    np.testing.assert_array_equal(built.rgb, fresh.rgb)
    np.testing.assert_array_equal(built.xyz, fresh.xyz)
    assert spectrace.Scene(TURNTABLE).time is None  # the rest pose


def test_animations():
    # The file's animations with their first and last key times: the glTF's own (the
    # min and max of each channel's input accessor).
    import json
    gltf = json.loads(Path(TURNTABLE).read_text())
    want = []
    for a in gltf["animations"]:
        inputs = [gltf["accessors"][a["samplers"][c["sampler"]]["input"]] for c in a["channels"]]
        want.append((a.get("name", ""), min(x["min"][0] for x in inputs),
                     max(x["max"][0] for x in inputs), len(a["channels"])))
    got = [tuple(a) for a in spectrace.Scene(TURNTABLE).animations]
    assert got == want
    with pytest.raises(spectrace.SpectraceError):
        spectrace.Scene(TURNTABLE).time = float("nan")
