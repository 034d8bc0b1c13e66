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


def test_a_fetched_frame_is_a_view_of_the_cameras_buffer_valid_in_its_block():
    def address(array):
        return array.__array_interface__["data"][0]

    with lfi.open_display(f"sim:{SCENE}") as display, \
            lfi.open_camera(f"sim:{SCENE}", pixel_format="Mono12") as camera:
        width, height = display.info["panel_px"]
        channels = display.info["channels"]
        display.show(np.full((height, width) if channels == 1 else (height, width, channels), 255, np.uint8))
        with camera.fetch() as frame:
            image = frame.image
            assert image.dtype == np.uint16 and image.shape == (56, 56) and frame.status == "Complete"
            assert not image.flags.owndata  # a view, not a copy
            first_address, first_id = address(image), frame.frame_id
            with pytest.raises(lfi.Error) as twice:
                camera.fetch()
            assert "a frame view is open" in str(twice.value)
            del image
        with pytest.raises(lfi.Error) as closed:
            frame.image
        assert "closed" in str(closed.value)
        with camera.fetch() as frame:
            # The next frame lands in the same memory: no allocation, no copy.
            assert address(frame.image) == first_address and frame.frame_id == first_id + 1
            held = frame.image
            kept = held.copy()
        with camera.fetch() as frame:
            # A view still held past its block keeps its frame: the camera takes other memory for the next.
            assert address(frame.image) != address(held) and np.array_equal(held, kept)
        copied = camera.grab()["image"]
        assert copied.flags.owndata and not np.shares_memory(copied, held)


def test_a_light_field_round_trips_through_its_file_with_its_parametrisation(tmp_path):
    rng = np.random.default_rng(7)
    lenslet = rng.uniform(0.0, 2.0, (3 * 4, 5 * 4)).astype(np.float32)
    field = lfi.LightField(lenslet, angular=4, pixel_pitch_mm=0.05, distance_mm=30.0)
    assert field.spatial == (5, 3) and field.angular == 4
    assert field.element_pitch_mm == pytest.approx(0.2)
    path = tmp_path / "field.exr"
    lfi.write_light_field(path, field)
    back = lfi.read_light_field(path)
    assert (back.spatial, back.angular, back.pixel_pitch_mm, back.distance_mm) == ((5, 3), 4, 0.05, 30.0)
    assert np.array_equal(back.lenslet, lenslet)  # float32 stored as float32: exact
    with pytest.raises(lfi.Error) as exists:
        lfi.write_light_field(path, field)
    assert exists.value.code == "Exists" and str(path) in str(exists.value)
    lfi.write_light_field(path, lfi.LightField(2 * lenslet, 4, 0.05), overwrite=True)
    assert np.array_equal(lfi.read_light_field(path).lenslet, 2 * lenslet)
    with pytest.raises(lfi.Error) as ragged:
        lfi.LightField(lenslet[:, :-1], angular=4, pixel_pitch_mm=0.05)
    assert "not whole 4 x 4 elements" in str(ragged.value)
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(lfi.Error) as corrupt:
        lfi.read_light_field(path)
    assert str(path) in str(corrupt.value)


def test_render_gives_a_camera_scenes_radiance_and_the_same_image_for_the_same_seed(tmp_path):
    # The tracer's reference scene (a lens on a Lambertian back light of radiance 1) at one sample a pixel:
    # float32 radiance of the camera's size, every pixel lit at most the light's radiance, deterministic.
    scene = SCENE.parent / "reference.toml"
    first = lfi.render(scene, spp=1, seed=5)
    again = lfi.render(scene, spp=1, seed=5, threads=1)
    assert first.dtype == np.float32 and first.shape == (512, 512)
    assert np.isfinite(first).all() and first.min() >= 0 and 0.5 < first.max() <= 1.0 + 1e-6
    assert np.array_equal(first, again)  # the tracer sums in sample order, whatever the threads
    other = lfi.render(scene, spp=1, seed=6)
    assert not np.array_equal(first, other)
    with pytest.raises(lfi.Error) as missing:
        lfi.render(tmp_path / "none.toml")
    assert "none.toml" in str(missing.value)
