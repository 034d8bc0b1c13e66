# SPDX-License-Identifier: Apache-2.0
"""A bench's devices alone from Python: frames as numpy arrays of the pixel format's type, panels shown from
numpy arrays, and the errors (docs/python.md)."""

import os
import pathlib

import numpy as np
import pytest

import lfi

SCENE = pathlib.Path(os.environ["LFI_SOURCE_DIR"]) / "data" / "scenes" / "inspection_bench.toml"


@pytest.mark.parametrize("pixel_format, dtype, full_scale", [("Mono8", np.uint8, 255), ("Mono12", np.uint16, 4095),
                                                             ("Mono16", np.uint16, 65535)])
def test_frames_are_arrays_of_the_pixel_formats_type(pixel_format, dtype, full_scale):
    # The scene's lens lit by its display's white panel.
    with lfi.open_display(f"sim:{SCENE}") as display, \
            lfi.open_camera(f"sim:{SCENE}", pixel_format=pixel_format) as camera:
        width, height = display.info["panel_px"]
        channels = display.info["channels"]
        display.show(np.full((height, width) if channels == 1 else (height, width, channels), 255, np.uint8))
        assert camera.info["sensor_px"] == (56, 56)
        first, second = camera.grab(), camera.grab()
    for frame in (first, second):
        image = frame["image"]
        assert image.dtype == dtype and image.shape == (56, 56) and frame["status"] == "Complete"
        assert 0 < image.max() <= full_scale
    assert second["frame_id"] == first["frame_id"] + 1


def test_a_panel_is_shown_from_an_array_of_the_panels_shape():
    with lfi.open_display(f"sim:{SCENE}") as display:
        width, height = display.info["panel_px"]
        channels = display.info["channels"]
        shape = (height, width) if channels == 1 else (height, width, channels)
        display.show(np.zeros(shape, np.uint8))
        with pytest.raises(lfi.Error) as wrong:
            display.show(np.zeros((height, width + 1), np.uint8))
        assert wrong.value.code == "InvalidArgument" and f"{height} x {width}" in str(wrong.value)


def test_a_device_that_is_not_there_is_named():
    with pytest.raises(lfi.Error) as missing:
        lfi.open_camera("sim:/no/such/scene.toml")
    assert "/no/such/scene.toml" in str(missing.value)
    with pytest.raises(lfi.Error) as unknown:
        lfi.open_display("nonsense:1")
    assert "nonsense" in str(unknown.value)
    with pytest.raises(lfi.Error) as bad_format:
        lfi.open_camera(f"sim:{SCENE}", pixel_format="Mono10")
    assert bad_format.value.code == "InvalidArgument" and "Mono10" in str(bad_format.value)
