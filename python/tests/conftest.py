import os
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))

from cluster import use_fresh_auth_token  # noqa: E402

use_fresh_auth_token()  # before anything imports ray

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def scene_path(name: str) -> str:
    return os.path.join(REPO, "scenes", name)


@pytest.fixture(scope="session")
def torrey_bin() -> str:
    """The command line, built by .ci/python.sh (cargo build --profile ci)."""
    path = os.environ.get("TORREY_BIN", os.path.join(REPO, "target", "ci", "torrey"))
    if not os.path.exists(path):
        pytest.skip(f"{path} not built (cargo build --profile ci)")
    return path


def run_cli(torrey_bin: str, *args: str) -> None:
    out = subprocess.run([torrey_bin, *args, "--quiet"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr


def max_relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    a = a.astype(np.float64)
    b = b.astype(np.float64)
    scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-30)
    return float(np.max(np.abs(a - b) / scale))
