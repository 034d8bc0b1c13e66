# SPDX-License-Identifier: Apache-2.0
"""The Python package against the command line tool on the shipped simulated bench: the same reference, the same
verdicts and defect positions, the same errors (docs/python.md)."""

import json
import os
import pathlib
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import lfi

SOURCE = pathlib.Path(os.environ["LFI_SOURCE_DIR"])
LFI = os.environ["LFI_EXECUTABLE"]

# The study's particles (tests/support/study_parts.h): Ø1 mm absorbers at the lens's centre and 10 mm out.
PARTICLES = """
[[object]]
name = "centre"
shape = "sphere"
radius_mm = 0.5
material = "absorber"
[[object]]
name = "rim"
shape = "sphere"
radius_mm = 0.5
position_mm = [10, 0, 0]
material = "absorber"
"""


@pytest.fixture
def bench(tmp_path):
    """The shipped simulated bench with its folders in the test's own."""
    text = (SOURCE / "data" / "benches" / "inspection_sim.toml").read_text()
    text = text.replace("sim:../scenes/", f"sim:{SOURCE}/data/scenes/")
    text = text.replace("../../out/bench/", f"{tmp_path}/")
    path = tmp_path / "bench.toml"
    path.write_text(text)
    return path


@pytest.fixture
def particles(tmp_path):
    path = tmp_path / "particles.toml"
    path.write_text((SOURCE / "data" / "scenes" / "inspection_bench.toml").read_text() + PARTICLES)
    return path


def cli_inspect(bench, part, out):
    r = subprocess.run([LFI, "-q", "inspect", str(bench), "--json", "--part", str(part), "--out", str(out)],
                       capture_output=True, text=True, check=False)
    return r.returncode, json.loads(r.stdout)


def test_a_part_inspected_from_python_is_the_one_the_cli_inspects(bench, particles, tmp_path):
    b = lfi.Bench(bench)
    assert b.capture() == str(tmp_path / "reference")
    intact = b.inspect(out=tmp_path / "py-intact")
    assert intact.verdict == "pass" and intact.passed and intact.defects == [] and intact.reasons == []
    record = b.inspect(part=particles, out=tmp_path / "py-particles")
    status, cli = cli_inspect(bench, particles, tmp_path / "cli-particles")
    assert status == 3 and cli["verdict"] == "fail"
    assert record.verdict == "fail" and not record.passed and record.reasons
    # The simulated camera draws the same noise for every opening of the scene: the same frames, so the same
    # numbers to the last digit, both ways.
    assert len(record.defects) == len(cli["defects"]) == 2
    for mine, theirs in zip(record.defects, cli["defects"]):
        assert mine.centroid_mm == tuple(theirs["centroid_mm"])
        assert mine.area_mm2 == theirs["area_mm2"]
    # ... and where the study put them, within a pixel (0.5 mm).
    found = sorted(record.defects, key=lambda d: d.centroid_mm[0])
    assert np.allclose([d.centroid_mm for d in found], [(0, 0), (10, 0)], atol=0.5)
    # The record written is the one Python holds.
    written = json.loads((tmp_path / "py-particles" / "record.json").read_text())
    assert written == json.loads(record.json)
    assert record.folder == str(tmp_path / "py-particles")


def test_the_image_is_a_float32_array_of_the_cameras_shape(bench, tmp_path):
    b = lfi.Bench(bench)
    b.capture()
    image = b.inspect(out=tmp_path / "inspect").image
    assert image.dtype == np.float32 and image.shape == (56, 56)
    # Mono12: the lens's image within the camera's range, the mean of 4 frames.
    assert 0 < image.max() <= 4095


def test_training_adds_images_to_the_golden_model(bench, particles):
    b = lfi.Bench(bench)
    b.capture()
    held = b.train(images=2)
    assert held == b.train(images=1) - 1


def test_errors_are_lfi_errors_naming_what_is_wrong(bench, tmp_path):
    with pytest.raises(lfi.Error) as missing:
        lfi.Bench(tmp_path / "no-such-bench.toml")
    assert "no-such-bench.toml" in str(missing.value)
    bad = tmp_path / "bad.toml"
    bad.write_text(bench.read_text().replace("exposure_us = 10000", "exposure_us = -5"))
    with pytest.raises(lfi.Error) as config:
        lfi.Bench(bad)
    assert config.value.code == "Config" and "exposure_us" in str(config.value)
    b = lfi.Bench(bench)
    b.capture()
    with pytest.raises(lfi.Error) as exists:
        b.capture()
    assert exists.value.code == "Exists"
    assert isinstance(exists.value, RuntimeError)
    b.capture(force=True)


def test_a_run_hands_its_records_as_they_come(bench, tmp_path):
    b = lfi.Bench(bench)
    b.capture()
    with b.run(parts=4, out=tmp_path / "run") as run:
        records = list(run)
    assert [r.part for r in records] == [1, 2, 3, 4]
    assert all(r.verdict == "pass" and r.image is None for r in records)
    lines = pathlib.Path(run.records_file).read_text().splitlines()
    assert [json.loads(line)["part"] for line in lines] == [1, 2, 3, 4]
    assert [json.loads(line) for line in lines] == [json.loads(r.json) for r in records]


def test_ctrl_c_ends_a_run_after_the_part_in_hand(bench, tmp_path):
    b = lfi.Bench(bench)
    b.capture()
    seen = []
    with pytest.raises(KeyboardInterrupt):
        with b.run(out=tmp_path / "run") as run:  # no limit: only the interrupt ends it
            seen += [next(run), next(run)]
            threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
            for record in run:
                seen.append(record)
    # Every record the run wrote, whole and in order, and none once the with block is left.
    lines = (tmp_path / "run" / "records.jsonl").read_text().splitlines()
    parts = [json.loads(line)["part"] for line in lines]
    assert parts == list(range(1, len(parts) + 1)) and len(parts) >= len(seen) > 2
    assert [r.part for r in seen] == parts[:len(seen)]
    time.sleep(0.3)
    assert len((tmp_path / "run" / "records.jsonl").read_text().splitlines()) == len(parts)
