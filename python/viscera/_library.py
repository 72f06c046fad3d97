"""Loads the viscera MuJoCo plugin library, once per process."""

from __future__ import annotations

import ctypes
import os
import pathlib
import threading

import mujoco

_LIBRARY_NAME = "libviscera_plugin.so"
_lock = threading.Lock()
_loaded: pathlib.Path | None = None
_ctypes_library: ctypes.CDLL | None = None


def library_path() -> pathlib.Path:
    """Path of the plugin library: $VISCERA_PLUGIN_LIBRARY, else the packaged one."""
    override = os.environ.get("VISCERA_PLUGIN_LIBRARY")
    if override:
        return pathlib.Path(override).resolve()
    return (pathlib.Path(__file__).parent / "lib" / _LIBRARY_NAME).resolve()


def load() -> pathlib.Path:
    """Register the viscera plugins with MuJoCo (idempotent) and return the library path.

    MuJoCo refuses a plugin name registered twice, so the library is loaded
    once per process, whatever the number of calls.
    """
    global _loaded, _ctypes_library
    with _lock:
        if _loaded is None:
            path = library_path()
            if not path.is_file():
                raise FileNotFoundError(
                    f"viscera plugin library not found at {path}: install the package with "
                    "'pip install .' or set VISCERA_PLUGIN_LIBRARY")
            mujoco.mj_loadPluginLibrary(str(path))
            # the same file is already loaded: dlopen returns it, constructors do not rerun
            _ctypes_library = ctypes.CDLL(str(path))
            _ctypes_library.viscera_attribute_name.restype = ctypes.c_char_p
            _ctypes_library.viscera_attribute_name.argtypes = [ctypes.c_int]
            _ctypes_library.viscera_spline_basis.restype = ctypes.c_int
            _ctypes_library.viscera_spline_basis.argtypes = [
                ctypes.c_int, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
            _ctypes_library.viscera_spline_points.restype = ctypes.c_int
            _ctypes_library.viscera_spline_points.argtypes = [
                ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
            _ctypes_library.viscera_intestine_info.restype = ctypes.c_int
            _ctypes_library.viscera_intestine_info.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]
            _ctypes_library.viscera_skin.restype = ctypes.c_int
            _ctypes_library.viscera_skin.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int,
                                                     ctypes.c_int,
                                                     ctypes.c_void_p, ctypes.c_int, ctypes.c_int] + [
                ctypes.c_void_p] * 3 + [ctypes.POINTER(ctypes.c_int)] * 2
            _ctypes_library.viscera_intestine_stability.restype = ctypes.c_int
            _ctypes_library.viscera_intestine_stability.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]
            _ctypes_library.viscera_intestine_energy.restype = ctypes.c_int
            _ctypes_library.viscera_intestine_energy.argtypes = [ctypes.c_void_p, ctypes.c_int] + [ctypes.c_void_p] * 4
            _ctypes_library.viscera_attribute_field.restype = ctypes.c_int
            _ctypes_library.viscera_attribute_field.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p,
                                                                ctypes.c_int]
            _ctypes_library.viscera_allowed_value.restype = ctypes.c_char_p
            _ctypes_library.viscera_allowed_value.argtypes = [ctypes.c_char_p, ctypes.c_int]
            _ctypes_library.viscera_state_block_count.restype = ctypes.c_int
            _ctypes_library.viscera_state_block_count.argtypes = []
            _ctypes_library.viscera_state_block_name.restype = ctypes.c_char_p
            _ctypes_library.viscera_state_block_name.argtypes = [ctypes.c_int]
            _ctypes_library.viscera_default_stiffnesses.restype = ctypes.c_int
            _ctypes_library.viscera_default_stiffnesses.argtypes = [ctypes.c_double, ctypes.c_void_p]
            _ctypes_library.viscera_state_block_width.restype = ctypes.c_int
            _ctypes_library.viscera_state_block_width.argtypes = [ctypes.c_int]
            _ctypes_library.viscera_grasp_status_name.restype = ctypes.c_char_p
            _ctypes_library.viscera_grasp_status_name.argtypes = [ctypes.c_int]
            _ctypes_library.viscera_intestine_layout.restype = ctypes.c_int
            _ctypes_library.viscera_intestine_layout.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p,
                                                                 ctypes.c_void_p]
            _ctypes_library.viscera_intestine_reconfigure.restype = ctypes.c_int
            _ctypes_library.viscera_intestine_reconfigure.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int,
                                                                      ctypes.c_char_p, ctypes.c_int]
            _ctypes_library.viscera_grasp_pinches.restype = ctypes.c_int
            _ctypes_library.viscera_grasp_pinches.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int,
                                                              ctypes.c_void_p, ctypes.c_int]
            _ctypes_library.viscera_cache_locks_taken.restype = ctypes.c_long
            _ctypes_library.viscera_cache_locks_taken.argtypes = []
            _ctypes_library.viscera_damage_colours.restype = None
            _ctypes_library.viscera_damage_colours.argtypes = [ctypes.c_void_p]
            _ctypes_library.viscera_grid_under_axis.restype = ctypes.c_int
            _ctypes_library.viscera_grid_under_axis.argtypes = [
                ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p,
                ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_void_p]
            _loaded = path
        return _loaded


def native() -> ctypes.CDLL:
    """The plugin library's exported helper functions (loads the library if needed)."""
    load()
    assert _ctypes_library is not None
    return _ctypes_library
