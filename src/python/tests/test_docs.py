"""docs/api.md's examples, run as they stand there, and what they make checked."""
import os
import re
import subprocess

import numpy as np
import pytest

import spectrace
from conftest import ROOT


def example(tag):
    text = (ROOT / "docs" / "api.md").read_text()
    m = re.search(r"```\w+ " + re.escape(tag) + r"\n(.*?)```", text, re.S)
    assert m, f"docs/api.md has no example {tag}"
    return m.group(1)


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A folder where an example's files go, its scenes/ that of the source tree."""
    (tmp_path / "scenes").symlink_to(ROOT / "scenes")
    (tmp_path / "tests").symlink_to(ROOT / "tests")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_sweep_example(workdir):
    ns = {}
    exec(compile(example("example-sweep"), "docs/api.md:example-sweep", "exec"), ns)
    images = ns["images"]
    assert len(images) == 20 and all(i.shape == (64, 64, 3) and np.isfinite(i).all() for i in images)
    # Roughness changes what the glass shows; the walls' light stays about the same.
    assert not np.array_equal(images[0], images[-1])
    assert abs(images[-1].mean() / images[0].mean() - 1) < 0.2
    assert (workdir / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # One scene load, one program and one geometry upload per device for the 20
    # renders; the materials uploaded at each change (docs/api.md, "Speed").
    ndev = len(spectrace._renderer(None).devices)
    assert ns["scene"].stats == dict(renders=20, bvh_builds=1, program_builds=ndev,
                                     geometry_uploads=ndev, material_uploads=20 * ndev,
                                     bytes_uploaded=ns["scene"].stats["bytes_uploaded"])


def test_spectrum_example(workdir):
    ns = {}
    exec(compile(example("example-spectrum"), "docs/api.md:example-spectrum", "exec"), ns)
    nm, wall = ns["nm"], ns["wall"]
    assert nm.shape == wall.shape == (47,)
    np.testing.assert_allclose(nm, 365 + 10 * np.arange(47))
    # The red wall reflects about 0.05 below 570 nm and 0.6 above 620 nm
    # (scenes/cornell_box.gltf), under a light rising towards the red.
    assert wall[nm > 620].mean() > 5 * wall[(nm > 450) & (nm < 560)].mean()
    assert ns["band_600"].shape == (64, 64)


def test_frames_example(workdir, capsys):
    ns = {}
    exec(compile(example("example-frames"), "docs/api.md:example-frames", "exec"), ns)
    # Four frames written, the first BVH built and the others refitted, with one
    # program build per device.
    assert capsys.readouterr().out.split() == "0 0 6 1 12 1 18 1".split()
    names = [workdir / f"turn_{f:02d}.exr" for f in (0, 6, 12, 18)]
    assert all(n.read_bytes()[:4] == b"\x76\x2f\x31\x01" for n in names)
    ndev = len(spectrace._renderer(None).devices)
    stats = ns["scene"].stats
    assert stats["renders"] == 4 and stats["bvh_builds"] == 1 and stats["program_builds"] == ndev
    assert ns["scene"].timing["bvh_refits"] == 3


def test_c_example(workdir):
    src = workdir / "render.c"
    src.write_text(example("example-c"))
    assert len(src.read_text().splitlines()) < 50
    lib = os.path.dirname(spectrace._library_path())
    subprocess.run(["cc", "-std=c11", "-Wall", "-Werror", f"-I{ROOT}/src/api", str(src), f"-L{lib}",
                    "-lspectrace", f"-Wl,-rpath,{lib}", "-o", "render"], check=True)
    run = subprocess.run(["./render", "scenes/cornell_box.gltf", "box.exr"], capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stderr
    assert "16/16 spp" in run.stderr
    m = re.search(r"128x128, mean ([0-9.]+)", run.stdout)
    assert m, run.stdout
    rgb = spectrace.render("scenes/cornell_box.gltf", width=128, spp=16)
    # The same render in both; the program prints 6 decimals.
    assert float(m.group(1)) == pytest.approx(float(rgb.astype(np.float64).mean()), abs=6e-7)
    assert (workdir / "box.exr").read_bytes()[:4] == b"\x76\x2f\x31\x01"
    bad = subprocess.run(["./render", "no/such.gltf", "x.exr"], capture_output=True, text=True)
    assert bad.returncode == 3 and bad.stderr.startswith("error: no/such.gltf")
