"""viscera: a real-time laparoscopic intestine simulator on MuJoCo.

Importing the package registers the viscera.intestine MuJoCo plugin (once per
process), so any MJCF that declares it compiles afterwards, and registers the
gymnasium ids (viscera/ClearArea-v0, ...) whenever gymnasium is imported, before
or after viscera, without importing gymnasium itself.
"""

import os

# Headless by default: without a display GLFW cannot render, EGL (Mesa) can.
# Must be decided before mujoco is first imported; the user's choice wins.
if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"

from viscera import _library, gymnasium_ids as _gymnasium_ids  # noqa: E402
from viscera.intestine import (  # noqa: E402
    PLUGIN_NAME, Intestine, add_to_mjcf, allowed_values, attribute_docs, attribute_names, config_strings,
    damage_colours, extension_xml, fixed_width_numbers, intestine, intestines, reconfigure, skin, spline_points)

__version__ = "0.3.0"

PLUGIN_LIBRARY = _library.load()
_gymnasium_ids.install()

__all__ = [
    "PLUGIN_LIBRARY", "PLUGIN_NAME", "Intestine", "add_to_mjcf", "allowed_values", "attribute_docs", "attribute_names",
    "config_strings", "damage_colours",
    "extension_xml", "fixed_width_numbers", "intestine", "intestines", "reconfigure", "skin", "spline_points",
]
