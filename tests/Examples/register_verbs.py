#!/usr/bin/env python3
"""`coloc register` end to end on a short twin room: scan -> scan-markers -> map -> register.
The registered map is in the scan's frame and carries its provenance; --only-markers and
--ignore-markers choose the scanned markers (an unknown id is an error naming the option), too
few markers is an error that names them, and a failed registration leaves an existing output
file untouched.

Exit 0 on success, 1 on failure.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def check(name, condition):
    """A named check: prints which one failed."""
    if not condition:
        print("check failed:", name)
    return bool(condition)


def run(cmd):
    return subprocess.run(cmd, capture_output=True, text=True, check=False)


def make_map(coloc, tmp):
    """Twin room (short walk, small scan faces), its scanned markers and a saved SLAM map."""
    twin = os.path.join(tmp, "twin")
    steps = [
        [coloc, "twin", "generate", "--preset", "room", "--seed", "2", "--seconds", "12",
         "--face-size", "1024", "--out", twin, "--json"],
        [coloc, "scan-markers", os.path.join(twin, "scan", "scan.e57"), "--dictionary",
         "DICT_4X4_50", "--size", "0.1675", "--out", os.path.join(tmp, "markers.yaml")],
        # Sequential: the same map every run (a concurrent mapper's keyframes, and with them the
        # markers a map holds, vary with the machine's load).
        [coloc, "map", "--sequence", os.path.join(twin, "sequence"), "--trajectory",
         os.path.join(tmp, "trajectory.txt"), "--save", os.path.join(tmp, "map.db"), "--sequential",
         "--json"],
    ]
    for cmd in steps:
        r = run(cmd)
        if r.returncode != 0:
            print(" ".join(cmd), "failed:", r.stderr[-3000:])
            return False
    return True


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    coloc = p.parse_args().coloc
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        if not make_map(coloc, tmp):
            return 1
        common = [coloc, "register", "--map", os.path.join(tmp, "map.db"), "--markers",
                  os.path.join(tmp, "markers.yaml"), "--json"]
        base = common + ["--level", "markers"]
        out = os.path.join(tmp, "registered.db")
        r = run(base + ["--out", out])
        if not check("register", r.returncode == 0):
            print(r.stderr[-3000:])
            return 1
        summary = json.loads(r.stdout)
        used = [m["id"] for m in summary["rough"]["markers"]]
        print("markers used:", used)
        ok &= check("three or more markers", len(used) >= 3)
        info = json.loads(run([coloc, "mapdb", "info", out, "--json"]).stdout)
        ok &= check("frame scan", info.get("frame_name") == "scan")

        # A map that saw exactly three markers keeps two once one is ignored: allowed here, since
        # what is checked is which markers are used, not how many a run happened to see.
        ignored = used[0]
        r = run(base + ["--out", os.path.join(tmp, "ignored.db"), "--ignore-markers",
                        str(ignored), "--min-markers", "2"])
        if not check("ignore one", r.returncode == 0):
            print(r.stderr[-2000:])
        if r.returncode == 0:
            left = [m["id"] for m in json.loads(r.stdout)["rough"]["markers"]]
            ok &= check("ignored marker left out", ignored not in left and len(left) >= 2)

        before = os.path.getmtime(out), os.path.getsize(out)
        r = run(base + ["--out", out, "--only-markers", "999"])
        ok &= check("unknown id", r.returncode != 0 and "--only-markers" in r.stderr
                    and "999" in r.stderr)
        r = run(base + ["--out", out, "--only-markers", ",".join(map(str, used[:2]))])
        ok &= check("two markers, three needed", r.returncode != 0)
        print("too few:", r.stderr.strip().splitlines()[-1:] if r.stderr else "")
        ok &= check("failed runs leave the output", before == (os.path.getmtime(out),
                                                                os.path.getsize(out)))
        r = run(common + ["--out", os.path.join(tmp, "two.db"), "--only-markers",
                          ",".join(map(str, used[:2])), "--min-markers", "2", "--level", "rough"])
        ok &= check("two markers allowed", r.returncode == 0)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
