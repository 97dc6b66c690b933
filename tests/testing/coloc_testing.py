"""Shared by the Python checks of the `coloc` CLI (the Python side of tests/testing/data.hpp)."""
import os
import pathlib
import socket

REPO = pathlib.Path(__file__).resolve().parents[2]


def shared_data_dir():
    """$COLOC_DATA if set, else <repo>/../shared/data."""
    return os.environ.get("COLOC_DATA") or str(REPO.parent / "shared" / "data")


def free_udp_port():
    """A UDP port free on loopback now (the process under test binds it right after)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port
