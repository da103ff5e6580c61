# SPDX-License-Identifier: BSD-3-Clause
"""Fixtures of the Python package's tests: the build's cuefusion command, and generated
sequences with exact truth (`cuefusion synth`), made once per session."""
import os
import subprocess

import pytest

BUILD_DIR = os.environ.get("CUEFUSION_BUILD_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "build"))
BINARY = os.path.join(BUILD_DIR, "apps", "cuefusion")


def cuefusion_command(*args, cwd=None):
    """Runs the cuefusion command; its output on failure."""
    proc = subprocess.run([BINARY, *args], capture_output=True, text=True, cwd=cwd)
    assert proc.returncode == 0, proc.stderr
    return proc


@pytest.fixture(scope="session")
def sequence(tmp_path_factory):
    """30 frames of the generated clutter scene at 160x120 (Redwood layout: depth, colour,
    poses, instance ids, the simulated detector's masks)."""
    path = str(tmp_path_factory.mktemp("seq") / "clutter")
    cuefusion_command("synth", "--scene", "clutter", "--frames", "30", "--size", "160x120", "--layout", "redwood",
                      "--out", path)
    return path
