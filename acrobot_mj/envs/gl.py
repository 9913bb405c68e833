"""OpenGL for MuJoCo: a headless backend (EGL or OSMesa) chosen before MuJoCo is imported for
frames and videos, and MuJoCo's viewer window (GLFW) where a display is asked for.

MuJoCo reads ``MUJOCO_GL`` once, on import, so ``import acrobot_mj`` calls :func:`configure_gl`
first; this module must not import ``mujoco`` at module level.
"""

from __future__ import annotations

import atexit
import ctypes
import ctypes.util
import os
import platform
import sys
import threading
import warnings
from collections.abc import Callable
from typing import Any

GL_BACKENDS = ("egl", "osmesa")
INSTALL_HINTS = {
    "egl": "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri, Mesa's software EGL, or a GPU "
    "driver with EGL",
    "osmesa": "apt-get install libosmesa6",
}
#: MUJOCO_GL values that turn MuJoCo's GL off, and those that render through a window.
NO_GL = ("disable", "disabled", "off", "false", "0")
WINDOWED = ("glfw", "glx", "enable", "enabled", "on", "true", "1", "wgl", "cgl")
#: Where a replaced MUJOCO_GL's problem is kept for child processes.
PROBLEM_VARIABLE = "ACROBOT_MJ_GL_PROBLEM"
#: What configure_gl found: backend -> None (works) or why it failed.
ATTEMPTS: dict[str, str | None] = {}
#: How MUJOCO_GL came to be: "user", "probed", "unset", "late" (mujoco imported first) or
#: "broken" (the user's value cannot work: PROBLEM).
CHOICE = "unset"
PROBLEM: str | None = None


class GLBackendError(RuntimeError):
    """No usable headless OpenGL backend, with what was tried and what to install."""


def _load(names: tuple[str, ...], find: str) -> ctypes.CDLL:
    errors = []
    for name in filter(None, (*names, ctypes.util.find_library(find))):
        try:
            return ctypes.CDLL(name)
        except OSError as error:
            errors.append(str(error))
    raise OSError("; ".join(errors) or f"lib{find} not found")


def probe_egl() -> str | None:
    """None if an EGL device display initialises (as MuJoCo opens it), else why not."""
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
    for device in devices[: count.value]:
        display = get_display(0x313F, device, None)  # EGL_PLATFORM_DEVICE_EXT
        if display and egl.eglInitialize(display, None, None):
            egl.eglTerminate(display)
            return None
    return f"none of the {count.value} EGL devices initialises"


def probe_osmesa() -> str | None:
    """None if OSMesa creates a context, else why not."""
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
    """The first backend that works (or None) and every attempt's result."""
    attempts: dict[str, str | None] = {}
    for name, probe in (probes or PROBES).items():
        attempts[name] = _run(probe)
        if attempts[name] is None:
            return name, attempts
    return None, attempts


def _run(probe: Callable[[], str | None]) -> str | None:
    try:
        return probe()
    except Exception as error:  # a probe must never break the import
        return f"probe crashed: {error!r}"


def user_problem(value: str) -> str | None:
    """Why ``MUJOCO_GL=value`` would make ``import mujoco`` fail here (None if it may work): an
    unknown name, or a headless backend whose library is missing."""
    name = value.strip().lower()
    if name in NO_GL or name in WINDOWED:
        return None
    if name not in GL_BACKENDS or platform.system() != "Linux":
        known = list(GL_BACKENDS)
        return f"MUJOCO_GL={value!r} is not a backend MuJoCo knows (headless: {known})"
    reason = PROBES[name]() if name in PROBES else None
    return None if reason is None else f"MUJOCO_GL={value} cannot work here: {reason}"


def configure_gl() -> str | None:
    """Set ``MUJOCO_GL`` to a working headless backend unless the user set it; returns the
    backend in force, or None. A user's value that cannot work becomes ``disable``, its problem
    kept (also in ``ACROBOT_MJ_GL_PROBLEM``, for child processes) for rendering to report."""
    global CHOICE, PROBLEM
    user = os.environ.get("MUJOCO_GL", "").strip()
    if user:
        inherited = os.environ.get(PROBLEM_VARIABLE) if user.lower() == "disable" else None
        PROBLEM = inherited or user_problem(user)
        if PROBLEM is None:
            CHOICE = "user"
            if user.lower() not in GL_BACKENDS and "mujoco" not in sys.modules:
                # For rendering's error; probed now: after MuJoCo opens EGL a probe would
                # close its display.
                ATTEMPTS.update(probe_all())
            return user.lower()
        CHOICE = "broken"
        ATTEMPTS.update(probe_all())
        os.environ["MUJOCO_GL"] = "disable"
        os.environ[PROBLEM_VARIABLE] = PROBLEM
        return None
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
    """Why there is no headless backend: what was asked, each backend tried and why it failed
    (with what to install), and what to set instead."""
    parts = [f"no headless OpenGL backend for MuJoCo{': ' + detail if detail else ''}"]
    tried = [name for name in GL_BACKENDS if name in attempts]
    for name in tried:
        hint = f" (to install: {INSTALL_HINTS[name]})" if attempts[name] else ""
        parts.append(f"tried {name}: {attempts[name] or 'works'}{hint}")
    working = [name for name in tried if attempts[name] is None]
    if working:
        parts.append(f"set MUJOCO_GL={working[0]} (it works here) or unset MUJOCO_GL")
    else:
        parts.append("install one, then unset MUJOCO_GL or set it to egl or osmesa")
    parts[-1] += " (acrobot_mj never falls back to a window)"
    return GLBackendError("; ".join(parts))


def probe_all() -> dict[str, str | None]:
    """Every probe's result (only before MuJoCo opens a GL context)."""
    return {name: _run(probe) for name, probe in PROBES.items()}


#: Viewer windows open, each with the thread that draws it: a process that ends while one is
#: open, or being torn down, crashes; they are closed, and their threads joined, at exit.
_VIEWERS: dict[int, tuple[Any, threading.Thread | None]] = {}


def close_viewer(viewer: Any) -> None:
    """Close a window of :func:`open_viewer` and wait until it is gone."""
    viewer.close()
    _, drawing = _VIEWERS.pop(id(viewer), (None, None))
    if drawing is not None:
        drawing.join(timeout=10)


def _close_viewers() -> None:
    for viewer, _ in list(_VIEWERS.values()):
        close_viewer(viewer)


def open_viewer(model: Any, data: Any, camera: str) -> Any:
    """MuJoCo's passive viewer window on ``model`` and ``data``, looking through ``camera``
    (close it with :func:`close_viewer`); :class:`GLBackendError` where no window can open (no
    display, or one that does not answer: GLFW would end the process)."""
    display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    if platform.system() == "Linux" and not display:
        raise GLBackendError(
            "render_mode='human' opens a window and no display is set (DISPLAY); use "
            "render_mode='rgb_array', or a virtual display (xvfb-run)"
        )
    import glfw
    import mujoco
    import mujoco.viewer

    with warnings.catch_warnings(record=True) as said:  # GLFW's errors come as warnings
        warnings.simplefilter("always")
        opened = glfw.init()
    if not opened:
        why = str(said[-1].message) if said else "GLFW could not start"
        raise GLBackendError(f"render_mode='human' cannot open a window: {why}")
    glfw.terminate()  # the viewer starts GLFW again on its own thread
    before = set(threading.enumerate())
    viewer = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
    drawing = next((t for t in threading.enumerate() if t not in before), None)
    # After the viewer's exit handlers (it registers glfw.terminate as it opens), so that this
    # one runs first (last in, first out): GLFW ended under an open window crashes.
    atexit.unregister(_close_viewers)
    atexit.register(_close_viewers)
    _VIEWERS[id(viewer)] = (viewer, drawing)
    with viewer.lock():
        viewer.cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
        viewer.cam.fixedcamid = model.camera(camera).id
    return viewer


def make_renderer(model, width: int, height: int):
    """A ``mujoco.Renderer`` on the headless backend; :class:`GLBackendError` says why not."""
    backend = os.environ.get("MUJOCO_GL", "").strip().lower()
    if CHOICE == "late":
        raise backend_error(
            {},
            "mujoco was imported before acrobot_mj with MUJOCO_GL unset, so it chose a GLFW "
            "window; set MUJOCO_GL or import acrobot_mj first",
        )
    if CHOICE == "broken":
        raise backend_error(ATTEMPTS, PROBLEM or "")
    if not backend:
        raise backend_error(ATTEMPTS)
    if backend in NO_GL:
        raise backend_error(ATTEMPTS, f"MUJOCO_GL={backend} turns MuJoCo's GL off")
    display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    if backend in WINDOWED and platform.system() == "Linux" and not display:
        raise backend_error(
            ATTEMPTS,
            f"MUJOCO_GL={backend} renders through a window, and no display is set (DISPLAY)",
        )
    import mujoco

    with warnings.catch_warnings(record=True) as said:  # GLFW's errors come as warnings
        warnings.simplefilter("always")
        try:
            renderer = mujoco.Renderer(model, height=height, width=width)
        except Exception as error:
            attempts = dict(ATTEMPTS)
            if backend in GL_BACKENDS:
                attempts[backend] = f"{backend} failed to create a context: {error!r}"
            first = f" ({said[0].message})" if said else ""
            raise backend_error(attempts, f"MUJOCO_GL={backend} does not work{first}") from error
    for warning in said:  # a renderer was made all the same: shown as they came
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    return renderer
