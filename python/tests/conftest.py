"""Shared fixtures of the Python tests: the dev data (../shared/data beside the checkout, or
KESTREL_DATA_DIR) and the `kestrel` CLI of the same build (KESTREL_BINARY, set by CTest)."""

import os
import pathlib

import pytest


def data_dir() -> pathlib.Path:
    for var in ("KESTREL_DATA_DIR", "KESTREL_DEFAULT_DATA_DIR"):
        if os.environ.get(var):
            return pathlib.Path(os.environ[var])
    return pathlib.Path(__file__).resolve().parents[2] / ".." / "shared" / "data"


def require_data(relative: str) -> pathlib.Path:
    path = data_dir() / relative
    if not path.exists():
        pytest.skip(f"dev data {path} not found (set KESTREL_DATA_DIR)")
    return path


@pytest.fixture(scope="session")
def rpy_folder() -> pathlib.Path:
    """TUM fr1/rpy, first 250 frames: hand-held, fast rotations, a distorted camera."""
    return require_data("tum/rgbd_dataset_freiburg1_rpy_part1")


@pytest.fixture(scope="session")
def reference_trajectories() -> pathlib.Path:
    return require_data("tum/reference_trajectories")


@pytest.fixture(scope="session")
def kestrel_binary() -> pathlib.Path:
    binary = os.environ.get("KESTREL_BINARY")
    if not binary or not pathlib.Path(binary).exists():
        pytest.skip("KESTREL_BINARY (the kestrel CLI of this build) not set; CTest sets it")
    return pathlib.Path(binary)
