#!/usr/bin/env python3
"""Writes the material test scenes tests/data/scenes/mat_*.gltf (see
tests/data/scenes/README.md, "Material scenes").

    python3 tools/make_material_scenes.py [OUTDIR]

Mitsuba comparison scenes: a closed box of Lambertian walls (pure diffuse:
KHR_materials_specular specularFactor 0) with a square area light under the
ceiling, a faceted sphere (no NORMAL attribute, so both renderers shade with
the flat geometric normals) in the middle, the camera inside the box:

  mat_conductor.gltf       smooth measured gold (extras.spectrace.conductor Au)
  mat_roughconductor.gltf  measured copper, roughnessFactor 0.5 (GGX alpha 0.25)
  mat_dielectric.gltf      smooth glass, KHR_materials_transmission 1, ior 1.5
  mat_roughdielectric.gltf the same glass with roughnessFactor 0.5

White furnace (no light: spectrace's default uniform D65 sky of radiance 1):

  mat_furnace_roughglass.gltf  a glass sphere (ior 1.5, roughnessFactor 0.5) of
                           radius 1 at the origin, camera at +Z 4 (yfov 0.6 rad):
                           the energy single-scattering microfacets lose, to
                           compare with Mitsuba's roughdielectric

Analytic scene:

  mat_point_light.gltf     a Lambertian plane (albedo 0.5, specularFactor 0)
                           under a KHR_lights_punctual point light of 1e5 cd
                           1 m above it; camera at 0.5 m looking straight down

Caustic scene (compared with Mitsuba's particle tracer, ptracer):

  caustic_sphere.gltf      a faceted glass sphere (ior 1.5, radius 0.5, centre
                           1 m above the floor) over a Lambertian floor (albedo
                           0.8, specularFactor 0) under a spot light of 1000 cd
                           3 m above the floor pointing down (cones 0.5 and
                           0.501 rad: a hard-edged beam, see
                           tests/data/mitsuba/README.md); the camera between the
                           sphere and the floor, 0.45 m up, looking straight
                           down (yfov 100 degrees): all it sees lies in the
                           sphere's shadow and is lit only through the glass
  caustic_sphere_area.gltf the same sphere, floor and camera under a square
                           area light instead (1 m x 1 m, 3 m above the
                           floor, facing down, emissive (1, 1, 1) x 50; the
                           floor's albedo 0.8): the view's middle is lit only
                           through the glass, its corners also directly (they
                           lie in the penumbra); compared with Mitsuba's path
                           tracer
  caustic_sphere_narrow.gltf  caustic_sphere.gltf with a narrow spot (cones
                           1.5 and 2 degrees, so a fifth of its flux lies
                           between the cones), all of whose beam goes through
                           the sphere's middle and lands focused in the view's
                           middle; compared with Mitsuba's particle tracer

Plain Python (the glTF writer of tools/make_cornell_box.py).
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_cornell_box import GltfBuilder, ROOT, orient_quad, uv_sphere  # noqa: E402

OUT = os.path.join(ROOT, "tests", "data", "scenes")
GEN = "spectrace tools/make_material_scenes.py"

# The box: x in [-1, 1], y in [0, 2], z in [-1, 1] (metres), walls facing in.
BOX_WHITE = (0.75, 0.75, 0.75)
BOX_RED = (0.63, 0.065, 0.05)     # left wall (x = -1)
BOX_GREEN = (0.14, 0.45, 0.091)   # right wall (x = +1)
LIGHT_HALF = 0.4                  # light: 0.8 m x 0.8 m square at y = 1.99, facing down
LIGHT_Y = 1.99
LIGHT_STRENGTH = 8.0              # emissive (1, 1, 1) x 8: D65 at film Y = 8
SPHERE_CENTER = (0.0, 0.55, -0.25)
SPHERE_RADIUS = 0.5
SPHERE_STACKS, SPHERE_SLICES = 32, 64
CAMERA_POS = (0.0, 0.6, 0.95)     # looking along -z
CAMERA_YFOV_DEG = 60.0

SPHERES = {
    "mat_conductor": dict(metallic=1.0, roughness=0.0, spectrace={"conductor": "Au"}),
    "mat_roughconductor": dict(metallic=1.0, roughness=0.5, spectrace={"conductor": "Cu"}),
    "mat_dielectric": dict(metallic=0.0, roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}}),
    "mat_roughdielectric": dict(metallic=0.0, roughness=0.5, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}}),
}

# Point light scene (the test derives its expectation from these numbers).
PL_ALBEDO = 0.5
PL_INTENSITY = 1.0e5   # candela (film Y about 0.2 under the light)
PL_HEIGHT = 1.0        # light above the plane (m)
PL_CAM_Y = 0.5
PL_YFOV_DEG = 60.0
PL_HALF = 5.0          # plane [-5, 5]^2


def box(g):
    """The closed box's six walls and its ceiling light."""
    white = g.material("white", BOX_WHITE, pure_diffuse=True)
    red = g.material("red", BOX_RED, pure_diffuse=True)
    green = g.material("green", BOX_GREEN, pure_diffuse=True)
    light = g.material("light", (0.0, 0.0, 0.0), emissive=(1.0, 1.0, 1.0), strength=LIGHT_STRENGTH,
                       pure_diffuse=True)
    x0, x1, y0, y1, z0, z1 = -1.0, 1.0, 0.0, 2.0, -1.0, 1.0
    walls = {
        "floor": ([(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)], (0, 1, 0), white),
        "ceiling": ([(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)], (0, -1, 0), white),
        "back": ([(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)], (0, 0, 1), white),
        "front": ([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)], (0, 0, -1), white),
        "left_red": ([(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)], (1, 0, 0), red),
        "right_green": ([(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)], (-1, 0, 0), green),
    }
    for name, (quad, inward, mat) in walls.items():
        g.quads_mesh(name, [orient_quad(quad, inward)], mat)
    h = LIGHT_HALF
    q = [(-h, LIGHT_Y, -h), (h, LIGHT_Y, -h), (h, LIGHT_Y, h), (-h, LIGHT_Y, h)]
    g.quads_mesh("light", [orient_quad(q, (0, -1, 0))], light)


def sphere_scene(path, name, spec):
    g = GltfBuilder(GEN)
    box(g)
    mat = g.pbr_material(name.replace("mat_", ""), (1.0, 1.0, 1.0), spec["metallic"], spec["roughness"],
                         extensions=spec.get("extensions"), spectrace=spec.get("spectrace"))
    pos, tris, _ = uv_sphere(SPHERE_STACKS, SPHERE_SLICES, SPHERE_RADIUS, SPHERE_CENTER)
    g.mesh_from("sphere", g.geometry(pos, tris), mat)
    g.camera("camera", math.radians(CAMERA_YFOV_DEG), CAMERA_POS)
    g.write(path, extras={"about": "material test scene (tests/data/scenes/README.md)", "units": "metres"})


def furnace_scene(path):
    g = GltfBuilder(GEN)
    mat = g.pbr_material("rough_glass", (1.0, 1.0, 1.0), 0.0, 0.5, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}})
    pos, tris, _ = uv_sphere(48, 96, 1.0)
    g.mesh_from("sphere", g.geometry(pos, tris), mat)
    g.camera("camera", 0.6, (0.0, 0.0, 4.0))
    g.write(path, extras={"about": "white furnace test scene (tests/data/scenes/README.md)", "units": "metres"})


def point_light_scene(path):
    g = GltfBuilder(GEN)
    plane = g.material("plane", (PL_ALBEDO,) * 3, pure_diffuse=True)
    s = PL_HALF
    g.quads_mesh("plane", [orient_quad([(-s, 0, -s), (s, 0, -s), (s, 0, s), (-s, 0, s)], (0, 1, 0))], plane)
    g.point_light("lamp", PL_INTENSITY, (0.0, PL_HEIGHT, 0.0))
    r = math.sqrt(0.5)   # -90 degrees about +X: the camera's -Z looks down (-y), image up is -z
    g.camera("camera", math.radians(PL_YFOV_DEG), (0.0, PL_CAM_Y, 0.0), rotation=(-r, 0.0, 0.0, r))
    g.write(path, extras={"about": "point light irradiance test scene (tests/data/scenes/README.md)",
                          "units": "metres"})


# Caustic scene: spot light, glass sphere, floor, camera under the sphere.
CS_LIGHT_Y = 3.0
CS_INTENSITY = 1000.0          # candela
CS_CONES = (0.5, 0.501)        # inner, outer half-angles (rad)
CS_NARROW_CONES = (math.radians(1.5), math.radians(2.0))
CS_SPHERE_CENTER = (0.0, 1.0, 0.0)
CS_SPHERE_RADIUS = 0.5
CS_FLOOR_ALBEDO = 0.8
CS_FLOOR_HALF = 3.0
CS_CAM_Y = 0.45
CS_YFOV_DEG = 100.0
CS_AREA_HALF = 0.5             # the area light's half-size (m), at CS_LIGHT_Y facing down
CS_AREA_STRENGTH = 50.0        # emissive (1, 1, 1) x 50


def caustic_sphere_scene(path, area=False, cones=CS_CONES):
    g = GltfBuilder(GEN)
    floor = g.material("floor", (CS_FLOOR_ALBEDO,) * 3, pure_diffuse=True)
    s = CS_FLOOR_HALF
    g.quads_mesh("floor", [orient_quad([(-s, 0, -s), (s, 0, -s), (s, 0, s), (-s, 0, s)], (0, 1, 0))], floor)
    glass = g.pbr_material("glass", (1.0, 1.0, 1.0), 0.0, 0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}})
    pos, tris, _ = uv_sphere(SPHERE_STACKS, SPHERE_SLICES, CS_SPHERE_RADIUS, CS_SPHERE_CENTER)
    g.mesh_from("sphere", g.geometry(pos, tris), glass)
    r = math.sqrt(0.5)   # -90 degrees about +X: the node's -Z points down (-y); image up is -z
    if area:
        light = g.material("light", (0.0, 0.0, 0.0), emissive=(1.0, 1.0, 1.0), strength=CS_AREA_STRENGTH,
                           pure_diffuse=True)
        h, y = CS_AREA_HALF, CS_LIGHT_Y
        g.quads_mesh("light", [orient_quad([(-h, y, -h), (h, y, -h), (h, y, h), (-h, y, h)], (0, -1, 0))], light)
    else:
        g.spot_light("spot", CS_INTENSITY, (0.0, CS_LIGHT_Y, 0.0), cones[0], cones[1],
                     rotation=(-r, 0.0, 0.0, r))
    g.camera("camera", math.radians(CS_YFOV_DEG), (0.0, CS_CAM_Y, 0.0), rotation=(-r, 0.0, 0.0, r))
    g.write(path, extras={"about": "caustic test scene (tests/data/scenes/README.md)", "units": "metres"})


def main(argv):
    out = argv[1] if len(argv) > 1 else OUT
    os.makedirs(out, exist_ok=True)
    for name, spec in SPHERES.items():
        p = os.path.join(out, name + ".gltf")
        sphere_scene(p, name, spec)
        print("wrote %s (%d bytes)" % (p, os.path.getsize(p)))
    p = os.path.join(out, "mat_furnace_roughglass.gltf")
    furnace_scene(p)
    print("wrote %s (%d bytes)" % (p, os.path.getsize(p)))
    p = os.path.join(out, "mat_point_light.gltf")
    point_light_scene(p)
    print("wrote %s (%d bytes)" % (p, os.path.getsize(p)))
    p = os.path.join(out, "caustic_sphere.gltf")
    caustic_sphere_scene(p)
    print("wrote %s (%d bytes)" % (p, os.path.getsize(p)))
    p = os.path.join(out, "caustic_sphere_area.gltf")
    caustic_sphere_scene(p, area=True)
    print("wrote %s (%d bytes)" % (p, os.path.getsize(p)))
    p = os.path.join(out, "caustic_sphere_narrow.gltf")
    caustic_sphere_scene(p, cones=CS_NARROW_CONES)
    print("wrote %s (%d bytes)" % (p, os.path.getsize(p)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
