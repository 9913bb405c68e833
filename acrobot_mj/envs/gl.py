"""Headless OpenGL for MuJoCo: choose EGL or OSMesa before MuJoCo is imported, never a window.

MuJoCo reads ``MUJOCO_GL`` once, when it is imported, so ``import acrobot_mj`` calls
:func:`configure_gl` first thing:

- if the user set ``MUJOCO_GL``, that choice stands;
- otherwise, on Linux, EGL and then OSMesa are probed through ``ctypes`` (load the library,
  open a display or create a context, release it) and the first that works is written to
  ``MUJOCO_GL``;
- if none works, nothing is set, and :func:`make_renderer` raises :class:`GLBackendError`
  saying which backends were tried, why each failed and what to install. MuJoCo's default (a
  GLFW window) is never used unless the user asks for it.

This module must not import ``mujoco`` at module level.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import platform
import sys
from collections.abc import Callable

BACKENDS = ("egl", "osmesa")
INSTALL_HINTS = {
    "egl": "Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri "
    "(Mesa's software EGL), or a GPU driver with EGL",
    "osmesa": "Debian/Ubuntu: apt-get install libosmesa6",
}

#: What configure_gl found: backend -> None (works) or the reason it failed.
ATTEMPTS: dict[str, str | None] = {}
#: How MUJOCO_GL came to be: "user", "probed", "unset" or "late" (mujoco was imported first).
CHOICE = "unset"


class GLBackendError(RuntimeError):
    """No usable headless OpenGL backend, with what was tried and what to install."""


def _load(names: tuple[str, ...], find: str) -> ctypes.CDLL:
    errors = []
    for name in (*names, ctypes.util.find_library(find)):
        if not name:
            continue
        try:
            return ctypes.CDLL(name)
        except OSError as error:
            errors.append(str(error))
    raise OSError("; ".join(errors) or f"lib{find} not found")


def probe_egl() -> str | None:
    """None if an EGL device display initialises (as MuJoCo's EGL backend opens it)."""
    try:
        egl = _load(("libEGL.so.1", "libEGL.so"), "EGL")
    except OSError as error:
        return f"libEGL cannot be loaded ({error})"
    get_proc = egl.eglGetProcAddress
    get_proc.restype, get_proc.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    query_address = get_proc(b"eglQueryDevicesEXT")
    display_address = get_proc(b"eglGetPlatformDisplayEXT")
    if not query_address or not display_address:
        return "EGL lacks the device extensions (EGL_EXT_device_enumeration)"
    query = ctypes.CFUNCTYPE(
        ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int)
    )(query_address)
    get_display = ctypes.CFUNCTYPE(
        ctypes.c_void_p, ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p
    )(display_address)
    devices, count = (ctypes.c_void_p * 16)(), ctypes.c_int(0)
    if not query(16, devices, ctypes.byref(count)) or count.value == 0:
        return "EGL finds no device (no GPU driver and no Mesa software device)"
    egl.eglInitialize.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    egl.eglTerminate.argtypes = [ctypes.c_void_p]
    platform_device = 0x313F  # EGL_PLATFORM_DEVICE_EXT
    for device in devices[: count.value]:
        display = get_display(platform_device, device, None)
        if display and egl.eglInitialize(display, None, None):
            egl.eglTerminate(display)
            return None
    return f"none of the {count.value} EGL devices initialises"


def probe_osmesa() -> str | None:
    """None if OSMesa creates a context."""
    try:
        osmesa = _load(("libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"), "OSMesa")
    except OSError as error:
        return f"libOSMesa cannot be loaded ({error})"
    create = osmesa.OSMesaCreateContextExt
    create.restype = ctypes.c_void_p
    create.argtypes = [ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_void_p]
    context = create(0x1908, 24, 8, 0, None)  # OSMESA_RGBA, depth, stencil, accum, no share
    if not context:
        return "OSMesaCreateContextExt failed"
    osmesa.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
    osmesa.OSMesaDestroyContext(context)
    return None


PROBES: dict[str, Callable[[], str | None]] = {"egl": probe_egl, "osmesa": probe_osmesa}


def select_backend(
    probes: dict[str, Callable[[], str | None]] | None = None,
) -> tuple[str | None, dict[str, str | None]]:
    """Probe the backends in order; return the first that works and every attempt's result."""
    attempts: dict[str, str | None] = {}
    for name, probe in (probes or PROBES).items():
        try:
            attempts[name] = probe()
        except Exception as error:  # a probe must never break the import
            attempts[name] = f"probe crashed: {error!r}"
        if attempts[name] is None:
            return name, attempts
    return None, attempts


def configure_gl() -> str | None:
    """Set ``MUJOCO_GL`` to a working headless backend unless the user set it (see module doc).
    Returns the backend in force, or None."""
    global CHOICE
    user = os.environ.get("MUJOCO_GL", "").strip()
    if user:
        CHOICE = "user"
        return user.lower()
    if "mujoco" in sys.modules:
        CHOICE = "late"
        return None
    if platform.system() != "Linux":
        return None  # macOS (CGL) and Windows (WGL) need no choice
    backend, attempts = select_backend()
    ATTEMPTS.update(attempts)
    if backend is not None:
        os.environ["MUJOCO_GL"] = backend
        CHOICE = "probed"
    return backend


def backend_error(attempts: dict[str, str | None], detail: str = "") -> GLBackendError:
    """The error that explains why no headless backend is available."""
    lines = [f"no headless OpenGL backend for MuJoCo{': ' + detail if detail else ''}."]
    for name in BACKENDS:
        if name in attempts:
            lines.append(
                f"  tried {name}: {attempts[name] or 'works'}; to install: {INSTALL_HINTS[name]}"
            )
    lines.append(
        "Set MUJOCO_GL=egl or MUJOCO_GL=osmesa once the libraries are installed "
        "(acrobot_mj never falls back to a window)."
    )
    return GLBackendError("\n".join(lines))


def make_renderer(model, width: int, height: int):
    """A ``mujoco.Renderer`` on the headless backend, or :class:`GLBackendError` that says why
    there is none."""
    backend = os.environ.get("MUJOCO_GL", "").strip().lower()
    if CHOICE == "late":
        raise backend_error(
            {},
            "mujoco was imported before acrobot_mj with MUJOCO_GL unset, "
            "so it chose a GLFW window; set MUJOCO_GL or import acrobot_mj "
            "first",
        )
    if not backend:
        raise backend_error(ATTEMPTS or select_backend()[1])
    import mujoco

    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as error:
        reason = f"{backend} failed to create a context: {error!r}"
        attempts = {backend: reason} if backend in BACKENDS else {}
        if backend in PROBES:
            attempts[backend] = f"{reason} (probe: {PROBES[backend]() or 'works'})"
        raise backend_error(attempts, f"MUJOCO_GL={backend} does not work") from error
