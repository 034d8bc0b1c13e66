# SPDX-License-Identifier: Apache-2.0
"""lfi from Python: a bench's reference, training and inspection, with its records and images (docs/python.md).

The same code path as the ``lfi`` command line tool: a bench file read and checked, the same files written,
the same errors raised as :class:`Error` (its ``code`` the kind: ``"Config"``, ``"Device"``, ...).
Units: mm, µs, DN; image pixels with the top-left pixel's centre at (0, 0).
"""

from ._lfi import (Bench, Camera, Defect, Display, Error, FrameView, LightField, Record, Run, __version__,
                   open_camera, open_display, read_light_field, render, write_light_field)

__all__ = ["Bench", "Camera", "Defect", "Display", "Error", "FrameView", "LightField", "Record", "Run",
           "__version__", "open_camera", "open_display", "read_light_field", "render", "write_light_field"]
