#!/usr/bin/env python3
"""The capture verbs end to end without a camera, on a replay device made from the real TUM
fr1/xyz recording: `coloc devices` lists the replayed D455 and its nodes; `coloc record` writes a
TUM sequence that `coloc map` reads; a camera unplugged mid-stream ends the recording with exit 1
and a complete sequence of what came before; `coloc map --camera` takes the live frames; `coloc
calibrate` calibrates the real chessboard photos and its file serves as `record --calibration`.

Exit 0 on success, 1 on failure, 77 (skipped) without the data.
"""
import argparse
import json
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, next(str(p / "testing") for p in pathlib.Path(__file__).resolve().parents
                        if p.name == "tests"))
from coloc_testing import REPO, shared_data_dir  # noqa: E402


def run(cmd, expect=0):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if r.returncode != expect:
        print("FAILED (exit %d, expected %d): %s\n%s\n%s" % (r.returncode, expect, " ".join(cmd),
                                                            r.stdout, r.stderr))
        sys.exit(1)
    return r


def lines(path):
    with open(path) as f:
        return [l for l in f if l.strip() and not l.startswith("#")]


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    coloc = p.parse_args().coloc
    data = shared_data_dir()
    tum = os.path.join(data, "tum_fr1_xyz_37f")
    chess = os.path.join(data, "handeye_visp_franka", "eye-in-hand")
    if not os.path.isdir(tum) or not os.path.isdir(chess):
        print("no data at", tum, "or", chess)
        return 77
    config = str(REPO / "Examples" / "RGB-D" / "TUM1.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        replay = os.path.join(tmp, "replay")
        run([coloc, "devices", "make-replay", "--sequence", tum, "--config", config, "--out", replay])
        # Served when read: no frame is lost however busy the machine, so counts are exact. The
        # paced replay (a camera's pace) drops what a slow reader cannot take: how many is the
        # machine's speed, which the tests only account for.
        unpaced = os.path.join(tmp, "replay_unpaced")
        run([coloc, "devices", "make-replay", "--sequence", tum, "--config", config, "--out",
             unpaced, "--unpaced"])
        d = json.loads(run([coloc, "devices", "--camera", "replay:" + replay, "--json"]).stdout)
        dev = d["devices"][0]
        assert dev["model"] == "D455" and dev["usb3"], dev
        kinds = [n["kind"] for n in dev["nodes"]]
        assert kinds == ["depth", "metadata", "infrared", "color", "metadata"], kinds

        rec = os.path.join(tmp, "rec")
        r = json.loads(run([coloc, "record", "--camera", "replay:" + unpaced, "--out", rec,
                            "--mode", "depth=640x480@30,color=640x480@30", "--json"]).stdout)
        assert r["pairs"] == 36 and r["driver_drops"] == 0 and r["queue_drops"] == 0, r
        assert not r["unplugged"] and r["metadata_missing"] == 0, r
        assert len(lines(os.path.join(rec, "rgb.txt"))) == 36
        m = json.loads(run([coloc, "map", "--sequence", rec, "--trajectory",
                            os.path.join(tmp, "rec.tum"), "--no-global-ba", "--json"]).stdout)
        assert m["tracked"] >= 30, m

        # SIGTERM (as Ctrl-C's SIGINT) ends the recording cleanly, everything written: sent
        # once the recording is under way (its first image written), on the paced replay. A
        # recording that ended first (a slow start) is as complete.
        rec_term = os.path.join(tmp, "rec_term")
        proc = subprocess.Popen([coloc, "record", "--camera", "replay:" + replay, "--out", rec_term,
                                 "--mode", "depth=640x480@30,color=640x480@30", "--json"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        rgb_dir = os.path.join(rec_term, "rgb")
        deadline = time.time() + 600  # only a stuck run reaches it
        while proc.poll() is None and time.time() < deadline and not (
                os.path.isdir(rgb_dir) and os.listdir(rgb_dir)):
            time.sleep(0.02)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, (proc.returncode, err)
        r = json.loads(out)
        assert len(lines(os.path.join(rec_term, "rgb.txt"))) == r["pairs"], r
        assert len(os.listdir(os.path.join(rec_term, "depth"))) == r["pairs"], r
        lost = r["driver_drops"] + r["queue_drops"] + r["unpaired"]
        assert r["pairs"] == 36 or r["interrupted"] or lost > 0, r

        cut = os.path.join(tmp, "replay_cut")
        run([coloc, "devices", "make-replay", "--sequence", tum, "--config", config, "--out", cut,
             "--unplug-after", "10", "--unpaced"])
        rec2 = os.path.join(tmp, "rec_cut")
        r = run([coloc, "record", "--camera", "replay:" + cut, "--out", rec2, "--mode",
                 "depth=640x480@30,color=640x480@30"], expect=1)
        assert "unplugged" in r.stderr and "recording so far" in r.stderr, r.stderr
        assert len(lines(os.path.join(rec2, "rgb.txt"))) == 10
        assert os.path.isfile(os.path.join(rec2, "camera.yaml"))

        live = json.loads(run([coloc, "map", "--camera", "replay:" + unpaced, "--mode",
                               "depth=640x480@30,color=640x480@30", "--trajectory",
                               os.path.join(tmp, "live.tum"), "--no-global-ba", "--json"]).stdout)
        lost = live["driver_drops"] + live["queue_drops"] + live["unpaired"]
        assert live["frames"] == 36 and lost == 0 and live["tracked"] >= 30, live

        images = [os.path.join(chess, "franka_image-%d.png" % i) for i in range(1, 9)]
        out = os.path.join(tmp, "franka.yaml")
        c = json.loads(run([coloc, "calibrate", *images, "--chessboard", "9x6", "--square",
                            "0.0236", "--out", out, "--json"]).stdout)
        assert abs(c["fx"] - 607.59) < 0.03 * 607.59, c
        # The written file is the fallback of a camera whose factory tables cannot be read.
        rec3 = os.path.join(tmp, "rec_calibrated")
        # --seconds counts the frames' own time: 0.5 s of a 30 Hz recording, whatever the load.
        r = json.loads(run([coloc, "record", "--camera", "replay:" + unpaced, "--out", rec3,
                            "--mode", "depth=640x480@30,color=640x480@30", "--calibration", out,
                            "--seconds", "0.5", "--json"]).stdout)
        assert 10 <= r["pairs"] <= 20 and r["queue_drops"] == 0, r
        with open(os.path.join(rec3, "camera.yaml")) as f:
            fx = float(next(l for l in f if l.startswith("Camera1.fx:")).split(":")[1])
        assert abs(fx - c["fx"]) < 1e-3 * c["fx"], (fx, c["fx"])
    print("capture verbs OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
