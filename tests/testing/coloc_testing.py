"""Shared by the Python checks of the `coloc` CLI (the Python side of tests/testing/data.hpp)."""
import os
import pathlib

REPO = pathlib.Path(__file__).resolve().parents[2]


def shared_data_dir():
    """$COLOC_DATA if set, else <repo>/../shared/data."""
    return os.environ.get("COLOC_DATA") or str(REPO.parent / "shared" / "data")
