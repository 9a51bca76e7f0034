"""spectrace from Python: renders glTF scenes into NumPy arrays.

A thin ctypes layer over build/libspectrace.so (src/api/spectrace.h, whose
comments are the reference; docs/api.md shows examples):

    import spectrace
    rgb = spectrace.render("scenes/cornell_box.gltf", spp=64, width=256)

    scene = spectrace.Scene("scenes/cornell_box.gltf")
    scene.materials["glass"].roughness = 0.2
    scene.lights[0].intensity = 50
    img = scene.render(spp=64, width=256, aov="albedo", spectral=47)
    img.rgb, img.xyz, img.aov("albedo"), img.bands

    # checkpoint and resume as the command line does (docs/api.md, "Checkpoints")
    scene.render(spp=32, checkpoint="part.exr")
    img = scene.render(spp=64, resume="part.exr")   # the 64 spp image, bit for bit

Settings are the options of `spectrace render` (README.md, "Rendering") as
keyword arguments, with "_" for "-" (max_depth=8, light_paths=0.5). The
library is found through the SPECTRACE_LIB variable, the path `make python`
recorded, or the build folder of the source tree this file lies in.
"""

import ctypes
import os
import sys
from collections import namedtuple
from pathlib import Path

import numpy as np

__all__ = ["render", "color", "write_image", "Scene", "Renderer", "Settings", "Image", "SpectraceError",
           "Cancelled", "settings_names", "version"]

API_MAJOR = 1


class SpectraceError(Exception):
    """A failure of the library: code (README.md, "Exit codes") and its one-line message."""

    def __init__(self, code, message):
        super().__init__(message)
        self.code = code
        self.message = message


class Cancelled(SpectraceError):
    """The render was stopped by its progress callback."""


class _Error(ctypes.Structure):
    _fields_ = [("code", ctypes.c_int), ("message", ctypes.c_char * 1024)]


class _ColorInfo(ctypes.Structure):
    _fields_ = [("xyz", ctypes.c_double * 3), ("linear_srgb", ctypes.c_double * 3),
                ("srgb8", ctypes.c_int * 3), ("x", ctypes.c_double), ("y", ctypes.c_double)]


class _SceneStats(ctypes.Structure):
    _fields_ = [("renders", ctypes.c_int), ("bvh_builds", ctypes.c_int),
                ("program_builds", ctypes.c_int), ("geometry_uploads", ctypes.c_int),
                ("material_uploads", ctypes.c_int), ("bytes_uploaded", ctypes.c_double)]


class _RenderStats(ctypes.Structure):
    _fields_ = [("spp_done", ctypes.c_uint32), ("spp_resumed", ctypes.c_uint32),
                ("stopped", ctypes.c_int), ("seconds", ctypes.c_double),
                ("build_seconds", ctypes.c_double), ("paths", ctypes.c_uint64),
                ("rays_extend", ctypes.c_uint64), ("rays_shadow", ctypes.c_uint64),
                ("nan_dropped", ctypes.c_uint64), ("stage_seconds", ctypes.c_double * 6),
                ("denoise_seconds", ctypes.c_double), ("denoiser", ctypes.c_char_p),
                ("devices", ctypes.c_char_p), ("checkpoint", ctypes.c_char_p),
                ("checkpoint_spp", ctypes.c_uint32)]


class _AnimationInfo(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("start", ctypes.c_double), ("end", ctypes.c_double),
                ("channels", ctypes.c_int)]


class _SceneTiming(ctypes.Structure):
    _fields_ = [("load_seconds", ctypes.c_double), ("bvh_seconds", ctypes.c_double),
                ("bvh_refitted", ctypes.c_int), ("bvh_refits", ctypes.c_int)]


_PROGRESS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_uint32, ctypes.c_uint32)


def _library_path():
    env = os.environ.get("SPECTRACE_LIB")
    if env:
        return env
    try:
        from ._library import LIBRARY  # written by `make python`
        if os.path.exists(LIBRARY):
            return LIBRARY
    except ImportError:
        pass
    tree = Path(__file__).resolve().parents[3] / "build" / "libspectrace.so"
    if tree.exists():
        return str(tree)
    raise ImportError("spectrace: libspectrace.so not found: build it with `make python` (or "
                      "`make build/libspectrace.so`) or set SPECTRACE_LIB to its path")


def _load():
    # RTLD_GLOBAL: libspectrace-oiio.so, loaded by the library when an image is
    # first read or written, calls back into it (src/io/oiio_lib.h).
    lib = ctypes.CDLL(_library_path(), mode=ctypes.RTLD_GLOBAL)
    P, I, D, F, C = ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_float, ctypes.c_char_p
    E = ctypes.POINTER(_Error)
    FP, DP = ctypes.POINTER(F), ctypes.POINTER(D)
    sig = {
        "version": (I, []),
        "renderer_open": (P, [C, E]), "renderer_close": (None, [P]),
        "renderer_device_count": (I, [P]), "renderer_device_name": (C, [P, I]),
        "settings_new": (P, []), "settings_copy": (P, [P]), "settings_free": (None, [P]),
        "settings_set": (I, [P, C, C, E]), "settings_set_int": (I, [P, C, ctypes.c_longlong, E]),
        "settings_set_double": (I, [P, C, D, E]), "settings_get": (I, [P, C, C, ctypes.c_size_t, E]),
        "settings_count": (I, []), "settings_name": (C, [I]), "settings_kind": (C, [I]),
        "settings_help": (C, [I]),
        "scene_load": (P, [C, P, E]), "scene_load_memory": (P, [C, ctypes.c_size_t, C, E]),
        "scene_load_memory_posed": (P, [C, ctypes.c_size_t, C, P, E]),
        "scene_free": (None, [P]), "scene_stats_get": (None, [P, ctypes.POINTER(_SceneStats)]),
        "scene_animation_count": (I, [P]),
        "scene_animation_info": (I, [P, I, ctypes.POINTER(_AnimationInfo), E]),
        "scene_time": (D, [P]), "scene_set_time": (I, [P, D, E]),
        "scene_timing_get": (None, [P, ctypes.POINTER(_SceneTiming)]),
        "scene_material_count": (I, [P]), "scene_material_name": (C, [P, I]),
        "scene_material_find": (I, [P, C]),
        "scene_material_get": (I, [P, I, C, FP, E]), "scene_material_set": (I, [P, I, C, FP, I, E]),
        "scene_material_set_spectrum": (I, [P, I, C, DP, DP, I, E]),
        "scene_light_count": (I, [P]), "scene_light_name": (C, [P, I]),
        "scene_light_get": (I, [P, I, C, FP, E]), "scene_light_set": (I, [P, I, C, FP, I, E]),
        "scene_light_set_spectrum": (I, [P, I, DP, DP, I, E]),
        "render": (I, [P, P, P, _PROGRESS, P, ctypes.POINTER(P), E]),
        "image_free": (None, [P]), "image_width": (I, [P]), "image_height": (I, [P]),
        "image_spp": (I, [P]), "image_seconds": (D, [P]),
        "image_stats": (None, [P, ctypes.POINTER(_RenderStats)]),
        "image_rgb": (I, [P, FP]), "image_noisy_rgb": (I, [P, FP]), "image_xyz": (I, [P, FP]), "image_counts": (I, [P, FP]),
        "image_aov": (I, [P, C, FP, E]), "image_band_count": (I, [P]), "image_bands": (I, [P, FP]),
        "image_write": (I, [P, C, E]), "write_rgb": (I, [C, FP, I, I, E]),
        "color": (I, [C, DP, DP, I, I, ctypes.POINTER(_ColorInfo), E]),
    }
    for name, (res, args) in sig.items():
        f = getattr(lib, "spectrace_" + name)
        f.restype, f.argtypes = res, args
    major = lib.spectrace_version() // 10000
    if major != API_MAJOR:
        raise ImportError(f"spectrace: the library's API is version {major}, this module's {API_MAJOR}")
    return lib


_lib = _load()


def version():
    """The library's API version as (major, minor)."""
    v = _lib.spectrace_version()
    return v // 10000, v // 100 % 100


def _check(rc, err):
    if rc:
        msg = err.message.decode(errors="replace")
        raise (Cancelled if rc == 130 else SpectraceError)(rc, msg)


def _enc(s):
    return None if s is None else str(s).encode()


def _floats(n):
    return np.empty(n, dtype=np.float32)


def _fp(a):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_float))


def _dp(a):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def settings_names():
    """Every setting: {name: (kind, help)}, from the command line's option list."""
    out = {}
    for i in range(_lib.spectrace_settings_count()):
        name = _lib.spectrace_settings_name(i).decode()
        if name in Settings.NOT_SETTINGS:
            continue
        out[name] = (_lib.spectrace_settings_kind(i).decode(), _lib.spectrace_settings_help(i).decode())
    return out


class Settings:
    """A render's settings: the options of `spectrace render` by name."""

    NOT_SETTINGS = {"output", "device", "quiet", "help"}

    def __init__(self, **kw):
        self._h = _lib.spectrace_settings_new()
        self.update(**kw)

    def __del__(self):
        if getattr(self, "_h", None):
            _lib.spectrace_settings_free(self._h)
            self._h = None

    def copy(self):
        s = Settings.__new__(Settings)
        s._h = _lib.spectrace_settings_copy(self._h)
        return s

    def __setitem__(self, name, value):
        name = name.replace("_", "-")
        err = _Error()
        if isinstance(value, bool):
            rc = _lib.spectrace_settings_set(self._h, _enc(name), b"1" if value else b"0", err)
        elif isinstance(value, (int, np.integer)):
            rc = _lib.spectrace_settings_set_int(self._h, _enc(name), int(value), err)
        elif isinstance(value, (float, np.floating)):
            rc = _lib.spectrace_settings_set_double(self._h, _enc(name), float(value), err)
        elif isinstance(value, (list, tuple)):
            rc = _lib.spectrace_settings_set(self._h, _enc(name), _enc(",".join(map(str, value))), err)
        else:
            rc = _lib.spectrace_settings_set(self._h, _enc(name), _enc(value), err)
        _check(rc, err)

    def __getitem__(self, name):
        err = _Error()
        buf = ctypes.create_string_buffer(4096)
        _check(_lib.spectrace_settings_get(self._h, _enc(name.replace("_", "-")), buf, 4096, err), err)
        return buf.value.decode()

    def update(self, **kw):
        for k, v in kw.items():
            if v is not None:
                self[k] = v
        return self


class Renderer:
    """The OpenCL devices of a selector, as --device takes it (None: the default)."""

    def __init__(self, device=None):
        err = _Error()
        self._h = _lib.spectrace_renderer_open(_enc(device), err)
        if not self._h:
            _check(err.code or 1, err)

    def __del__(self):
        if getattr(self, "_h", None):
            _lib.spectrace_renderer_close(self._h)
            self._h = None

    @property
    def devices(self):
        return [_lib.spectrace_renderer_device_name(self._h, i).decode()
                for i in range(_lib.spectrace_renderer_device_count(self._h))]


_renderers = {}


def _renderer(device):
    """One Renderer per device selector for the module's functions."""
    if isinstance(device, Renderer):
        return device
    if device not in _renderers:
        _renderers[device] = Renderer(device)
    return _renderers[device]


class _Params:
    """A material's or a light's parameters as attributes."""

    _kind = None
    _names = ()
    _spectra = ()

    def __init__(self, scene, index):
        object.__setattr__(self, "_scene", scene)
        object.__setattr__(self, "index", index)

    def _get(self, param):
        out = _floats(4)
        err = _Error()
        n = getattr(_lib, f"spectrace_scene_{self._kind}_get")(self._scene._h, self.index,
                                                               _enc(param), _fp(out), err)
        if n < 0:
            _check(-n, err)
        return float(out[0]) if n == 1 else out[:n].copy()

    def _set(self, param, value):
        v = np.ascontiguousarray(np.atleast_1d(np.asarray(value, dtype=np.float32)))
        err = _Error()
        _check(getattr(_lib, f"spectrace_scene_{self._kind}_set")(self._scene._h, self.index,
                                                                  _enc(param), _fp(v), v.size, err), err)

    def __getattr__(self, name):
        if name in self._names:
            return self._get(name)
        raise AttributeError(name)

    def __setattr__(self, name, value):
        if name in self._names:
            self._set(name, value)
        elif name in self._spectra:
            self._set_spectrum(name, value)
        else:
            raise AttributeError(f"{self._kind} has no parameter {name!r} (one of "
                                 f"{', '.join(self._names + tuple(self._spectra))})")

    @staticmethod
    def _samples(spd):
        if spd is None:
            return np.zeros(0), np.zeros(0)
        a = np.asarray(spd, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 2:
            raise ValueError("a spectrum is an array of (nm, value) rows")
        return np.ascontiguousarray(a[:, 0]), np.ascontiguousarray(a[:, 1])

    def __repr__(self):
        return f"<spectrace {self._kind} {self.index}: {self.name!r}>"


class Material(_Params):
    """scene.materials[name or index]: base_color, metallic, roughness, emissive, ... and
    the spectra reflectance and emission as (nm, value) arrays (None removes one)."""

    _kind = "material"
    _names = ("base_color", "metallic", "roughness", "emissive", "emissive_strength", "ior",
              "transmission", "dispersion", "attenuation_color", "attenuation_distance",
              "thickness", "specular", "specular_color", "clearcoat", "clearcoat_roughness",
              "sheen_color", "sheen_roughness")
    _spectra = ("reflectance", "emission")

    @property
    def name(self):
        return _lib.spectrace_scene_material_name(self._scene._h, self.index).decode()

    def _set_spectrum(self, which, spd):
        nm, v = self._samples(spd)
        err = _Error()
        _check(_lib.spectrace_scene_material_set_spectrum(self._scene._h, self.index, _enc(which),
                                                          _dp(nm), _dp(v), nm.size, err), err)


class Light(_Params):
    """scene.lights[index or name]: intensity, color, range, inner_cone_angle,
    outer_cone_angle, and the emission spectrum as (nm, value) arrays."""

    _kind = "light"
    _names = ("intensity", "color", "range", "inner_cone_angle", "outer_cone_angle")
    _spectra = ("emission",)

    @property
    def name(self):
        return _lib.spectrace_scene_light_name(self._scene._h, self.index).decode()

    def _set_spectrum(self, which, spd):
        nm, v = self._samples(spd)
        err = _Error()
        _check(_lib.spectrace_scene_light_set_spectrum(self._scene._h, self.index, _dp(nm), _dp(v),
                                                       nm.size, err), err)


class _Collection:
    def __init__(self, scene, cls, count, names):
        self._items = [cls(scene, i) for i in range(count)]
        self._names = names

    def __len__(self):
        return len(self._items)

    def __iter__(self):
        return iter(self._items)

    def __getitem__(self, key):
        if isinstance(key, str):
            for item, name in zip(self._items, self._names):
                if name == key:
                    return item
            raise KeyError(f"no {key!r} in the scene (it has {', '.join(self._names)})")
        return self._items[key]

    def keys(self):
        return list(self._names)


class Image:
    """A render's result; arrays are rows top to bottom, (height, width, channels)."""

    def __init__(self, handle):
        self._h = handle
        self.width = _lib.spectrace_image_width(handle)
        self.height = _lib.spectrace_image_height(handle)
        self.spp = _lib.spectrace_image_spp(handle)
        self.seconds = _lib.spectrace_image_seconds(handle)

    def __del__(self):
        if getattr(self, "_h", None):
            _lib.spectrace_image_free(self._h)
            self._h = None

    @property
    def stats(self):
        """The render's figures as a dict (spectrace_render_stats in spectrace.h): spp_done,
        spp_resumed (taken from a resumed checkpoint), seconds, paths, rays_extend,
        rays_shadow, nan_dropped, stage_seconds, checkpoint (the file written, or None) and
        checkpoint_spp, ..."""
        st = _RenderStats()
        _lib.spectrace_image_stats(self._h, ctypes.byref(st))
        out = {}
        for name, _ in _RenderStats._fields_:
            v = getattr(st, name)
            out[name] = v.decode() if isinstance(v, bytes) else list(v) if name == "stage_seconds" else v
        return out

    def _array(self, fn, channels):
        out = _floats(self.width * self.height * channels)
        fn(self._h, _fp(out))
        return out.reshape(self.height, self.width, channels) if channels > 1 else \
            out.reshape(self.height, self.width)

    @property
    def rgb(self):
        """Linear sRGB (with denoise=True the denoised image)."""
        return self._array(_lib.spectrace_image_rgb, 3)

    @property
    def noisy_rgb(self):
        """Linear sRGB before denoising (without denoise, rgb)."""
        return self._array(_lib.spectrace_image_noisy_rgb, 3)

    @property
    def xyz(self):
        """CIE XYZ, Y the luminance in cd/m^2."""
        return self._array(_lib.spectrace_image_xyz, 3)

    @property
    def counts(self):
        """Samples kept per pixel."""
        return self._array(_lib.spectrace_image_counts, 1)

    def aov(self, layer):
        """An AOV layer of the render's aov setting: albedo, N, P, variance (h, w, 3), Z, spp (h, w)."""
        out = _floats(self.width * self.height * 3)
        err = _Error()
        n = _lib.spectrace_image_aov(self._h, _enc(layer), _fp(out), err)
        if n < 0:
            _check(-n, err)
        out = out[: self.width * self.height * n]
        return out.reshape(self.height, self.width, n) if n > 1 else out.reshape(self.height, self.width)

    @property
    def bands(self):
        """The spectral bands (setting spectral=N): (h, w, N), W m^-2 sr^-1 nm^-1."""
        n = _lib.spectrace_image_band_count(self._h)
        if n == 0:
            raise SpectraceError(2, "image: the render has no spectral bands (set spectral=N)")
        return self._array(_lib.spectrace_image_bands, n).reshape(self.height, self.width, n)

    @property
    def band_centers(self):
        """The bands' centre wavelengths in nm."""
        n = _lib.spectrace_image_band_count(self._h)
        return 360.0 + (np.arange(n) + 0.5) * (470.0 / n) if n else np.zeros(0)

    def write(self, path):
        """Writes the image as the command line does (.exr with its layers, .png, ...)."""
        err = _Error()
        _check(_lib.spectrace_image_write(self._h, _enc(os.fspath(path)), err), err)


def _progress_callback(progress):
    """A ctypes callback for progress: True (a tqdm bar where tqdm is installed, else a
    line on stderr), False, None (tqdm where installed, else nothing), or a callable
    f(done, total) returning True to cancel."""
    state = {"cancel": False, "bar": None, "error": None}
    if progress is None or progress is True:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            tqdm = None
        if tqdm is not None:
            def fn(done, total):
                if state["bar"] is None:
                    state["bar"] = tqdm(total=total, unit="spp", desc="render", leave=False)
                state["bar"].update(done - state["bar"].n)
        elif progress is True:
            def fn(done, total):
                sys.stderr.write(f"\rrender: {done}/{total} spp")
                sys.stderr.flush()
        else:
            fn = None
    elif progress is False:
        fn = None
    else:
        fn = progress
    if fn is None:
        return _PROGRESS(), state

    def cb(user, done, total):
        try:
            return 1 if fn(int(done), int(total)) else 0
        except BaseException as e:  # an exception in the callback cancels the render
            state["error"] = e
            return 1

    return _PROGRESS(cb), state


class Scene:
    """A glTF scene loaded once and rendered many times. The pose settings at, animation
    and camera are given here (and must be those of each render)."""

    def __init__(self, path, at=None, animation=None, camera=None):
        self._pose = Settings(at=at, animation=animation, camera=camera)
        err = _Error()
        self._h = _lib.spectrace_scene_load(_enc(os.fspath(path)), self._pose._h, err)
        if not self._h:
            _check(err.code or 1, err)
        self._collections()

    @classmethod
    def from_bytes(cls, data, base_dir=None, at=None, animation=None, camera=None):
        """A scene from a .gltf or .glb file's bytes; external files from base_dir; posed
        as Scene(path, at=..., animation=..., camera=...) is."""
        s = cls.__new__(cls)
        s._pose = Settings(at=at, animation=animation, camera=camera)
        err = _Error()
        s._h = _lib.spectrace_scene_load_memory_posed(
            bytes(data), len(data), _enc(None if base_dir is None else os.fspath(base_dir)),
            s._pose._h, err)
        if not s._h:
            _check(err.code or 1, err)
        s._collections()
        return s

    def _collections(self):
        h = self._h
        self.materials = _Collection(self, Material, _lib.spectrace_scene_material_count(h),
                                     [_lib.spectrace_scene_material_name(h, i).decode()
                                      for i in range(_lib.spectrace_scene_material_count(h))])
        self.lights = _Collection(self, Light, _lib.spectrace_scene_light_count(h),
                                  [_lib.spectrace_scene_light_name(h, i).decode()
                                   for i in range(_lib.spectrace_scene_light_count(h))])

    def __del__(self):
        if getattr(self, "_h", None):
            _lib.spectrace_scene_free(self._h)
            self._h = None

    @property
    def animations(self):
        """The file's animations: a list of Animation(name, start, end, channels), their
        first and last key times in seconds."""
        out = []
        for i in range(_lib.spectrace_scene_animation_count(self._h)):
            a, err = _AnimationInfo(), _Error()
            _check(_lib.spectrace_scene_animation_info(self._h, i, ctypes.byref(a), err), err)
            out.append(Animation(a.name.decode(), a.start, a.end, a.channels))
        return out

    @property
    def time(self):
        """The time in seconds the scene is posed at (None: the rest pose). Setting it poses
        the scene at that time (spectrace_scene_set_time: the file read again, the last
        pose's BVH refitted by the next render, the programs kept); frame F of a sequence at
        R frames per second is at F / R."""
        t = _lib.spectrace_scene_time(self._h)
        return None if t != t else t

    @time.setter
    def time(self, seconds):
        err = _Error()
        _check(_lib.spectrace_scene_set_time(self._h, float(seconds), err), err)
        # The renders' settings give the scene's time as the library wrote it.
        self._pose["at"] = "%.17g" % float(seconds)

    @property
    def timing(self):
        """What the last pose cost, as a dict: load_seconds, bvh_seconds, bvh_refitted and
        bvh_refits (spectrace_scene_timing in spectrace.h)."""
        t = _SceneTiming()
        _lib.spectrace_scene_timing_get(self._h, ctypes.byref(t))
        return {name: getattr(t, name) for name, _ in _SceneTiming._fields_}

    @property
    def stats(self):
        """What the scene's renders have cost so far, as a dict: renders, bvh_builds,
        program_builds (per device), geometry_uploads and material_uploads (per device)
        and bytes_uploaded (spectrace_scene_stats in spectrace.h)."""
        st = _SceneStats()
        _lib.spectrace_scene_stats_get(self._h, ctypes.byref(st))
        return {name: getattr(st, name) for name, _ in _SceneStats._fields_}

    def render(self, settings=None, device=None, progress=None, **kw):
        """Renders with settings (a Settings, and/or keyword settings) on device's renderer
        (a selector or a Renderer); returns an Image."""
        s = settings.copy() if settings is not None else Settings()
        for k in ("at", "animation", "camera"):
            v = self._pose[k]
            if v and k not in kw:
                s[k] = v
        s.update(**kw)
        r = _renderer(device)
        cb, state = _progress_callback(progress)
        out = ctypes.c_void_p()
        err = _Error()
        try:
            rc = _lib.spectrace_render(r._h, self._h, s._h, cb, None, ctypes.byref(out), err)
        finally:
            if state["bar"] is not None:
                state["bar"].close()
            elif progress is True and cb:
                sys.stderr.write("\n")
        if state["error"] is not None:
            raise state["error"]
        _check(rc, err)
        return Image(out.value)


def write_image(path, rgb):
    """Writes a linear sRGB array (h, w, 3) with the command line's writers (the format
    from the extension: .png, .jpg, .exr, .tif, .hdr)."""
    a = np.ascontiguousarray(rgb, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError("write_image takes an (h, w, 3) array")
    err = _Error()
    _check(_lib.spectrace_write_rgb(_enc(os.fspath(path)), _fp(a), a.shape[1], a.shape[0], err), err)


_LAYERS = ("albedo", "N", "Z", "P", "variance", "spp")


def render(scene, layers=None, device=None, progress=None, **settings):
    """Renders scene (a path or a Scene) and returns its linear sRGB as a (h, w, 3) array;
    with layers (names of "xyz", "counts", "bands" and the AOV layers) also a dict of
    those arrays: rgb, extra = render(..., layers=["albedo", "bands"], spectral=47)."""
    if not isinstance(scene, Scene):
        scene = Scene(scene, at=settings.get("at"), animation=settings.get("animation"),
                      camera=settings.get("camera"))
    layers = list(layers or [])
    aovs = [l for l in layers if l in _LAYERS]
    if aovs and "aov" not in settings:
        settings["aov"] = aovs
    img = scene.render(device=device, progress=progress, **settings)
    if not layers:
        return img.rgb
    extra = {}
    for l in layers:
        if l == "xyz":
            extra[l] = img.xyz
        elif l == "counts":
            extra[l] = img.counts
        elif l == "bands":
            extra[l] = img.bands
        else:
            extra[l] = img.aov(l)
    return img.rgb, extra


Color = namedtuple("Color", "xyz linear_srgb srgb8 xy")
Animation = namedtuple("Animation", "name start end channels")


def color(spd, reflectance=False):
    """What `spectrace color` prints: spd a name (D65, A, blackbody:5000, ...), a CSV path,
    or (nm, value) rows; XYZ normalised to Y = 1 (reflectance: under D65)."""
    info = _ColorInfo()
    err = _Error()
    if isinstance(spd, (str, os.PathLike)):
        rc = _lib.spectrace_color(_enc(os.fspath(spd)), None, None, 0, int(reflectance), info, err)
    else:
        nm, v = _Params._samples(spd)
        rc = _lib.spectrace_color(None, _dp(nm), _dp(v), nm.size, int(reflectance), info, err)
    _check(rc, err)
    return Color(np.array(info.xyz[:]), np.array(info.linear_srgb[:]), tuple(info.srgb8[:]),
                 (info.x, info.y))
