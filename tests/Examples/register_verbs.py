#!/usr/bin/env python3
"""`coloc register` end to end on a short twin room: scan -> scan-markers -> map -> register.
The registered map is in the scan's frame and carries its provenance; --only-markers and
--ignore-markers choose the scanned markers (an unknown id is an error naming the option), too
few markers is an error that names them, and a failed registration leaves an existing output
file untouched. Without markers the map registers from the map file alone: its keyframes store
their depth images (schema 4), so no --sequence is given.

Exit 0 on success, 1 on failure.
"""
import argparse
import json
import os
import shutil
import sqlite3
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


def text_hash(h, text):
    """Folds a text value into a content hash (docs/formats/mapdb.md, "Checksums")."""
    mask = (1 << 64) - 1

    def word(h, w):
        h = ((h ^ w) * 0x9e3779b97f4a7c15) & mask
        return h ^ (h >> 29)

    data = text.encode()
    h = word(word(h, 3), len(data))  # tag 3: text, then the length
    for i in range(0, len(data), 8):
        h = word(h, int.from_bytes(data[i:i + 8], "little"))
    return h


def make_schema3(path, out):
    """A copy of a map file as schema 3 wrote it: no keyframe_depth table, the metadata's
    checksum (of every entry but the checksums, in key order) recomputed."""
    shutil.copyfile(path, out)
    con = sqlite3.connect(out)
    con.execute("DROP TABLE keyframe_depth")
    con.execute("DELETE FROM metadata WHERE key IN ('count.keyframe_depth', "
                "'checksum.keyframe_depth')")
    h = 0x636f6c6f632d6d61
    rows = con.execute("SELECT key, value FROM metadata").fetchall()
    for key, value in sorted(rows, key=lambda r: r[0].encode()):
        if not key.startswith("checksum."):
            h = text_hash(text_hash(h, key), value)
    con.execute("UPDATE metadata SET value = ? WHERE key = 'checksum.metadata'", (f"{h:016x}",))
    con.execute("PRAGMA user_version = 3")
    con.commit()
    con.close()


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
        r = run(common + ["--out", os.path.join(tmp, "rough.db"), "--level", "rough"])
        ok &= check("level rough", r.returncode == 0)
        r = run(common + ["--out", os.path.join(tmp, "two.db"), "--only-markers",
                          ",".join(map(str, used[:2])), "--min-markers", "2", "--level", "rough"])
        ok &= check("two markers allowed", r.returncode == 0)

        # Without markers (level surface, the default): the map's dense cloud onto the scan, from
        # the markers' rigid transform moved by 5 cm (a user's --initial), then the BA against
        # the scan's surface. The keyframes' depth comes from the map file (no --sequence). The
        # written map is in the scan's frame and its keyframes land within 1 cm of where the
        # markers put them.
        map_info = json.loads(run([coloc, "mapdb", "info", os.path.join(tmp, "map.db"),
                                   "--json"]).stdout)
        ok &= check("every keyframe stores its depth",
                    map_info["schema_version"] == 4
                    and map_info["keyframe_depths"] == map_info["keyframes"] > 0)
        t = summary["scan_from_slam"]
        qx, qy, qz, qw = t["quaternion_xyzw"]
        rot = [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
               [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
               [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]
        shifted = [t["translation"][0] + 0.05, t["translation"][1] - 0.03, t["translation"][2]]
        initial = os.path.join(tmp, "initial.txt")
        with open(initial, "w") as f:
            for row in range(3):
                f.write(" ".join(str(v) for v in rot[row] + [shifted[row]]) + "\n")
            f.write("0 0 0 1\n")
        cloud_out = os.path.join(tmp, "cloud.db")
        scan = os.path.join(tmp, "twin", "scan", "scan.e57")
        sequence = os.path.join(tmp, "twin", "sequence")
        r = run([coloc, "register", "--map", os.path.join(tmp, "map.db"), "--scan", scan,
                 "--initial", initial, "--out", cloud_out, "--json"])
        if check("register without markers", r.returncode == 0):
            cloud = json.loads(r.stdout)
            print("level surface:", {k: cloud[k] for k in ("fitness", "inlier_rmse_m", "overlap")},
                  "rounds:", cloud["surface"]["rounds"])
            ok &= check("level surface", cloud["level"] == "surface" and cloud["fitness"] > 0.35)
            ok &= check("depth from the map", cloud["depth_source"] == "map")
            rounds = cloud["surface"]["rounds"]
            ok &= check("the surface BA brings the map's depth onto the scan",
                        rounds[-1]["median_distance_m"][1] < rounds[0]["median_distance_m"][0]
                        and rounds[-1]["depth_terms"] > 1000)
            ok &= check("cloud map in the scan frame", json.loads(
                run([coloc, "mapdb", "info", cloud_out, "--json"]).stdout)["frame_name"] == "scan")
            # Both maps' keyframes against the twin's truth, without alignment: the co-location
            # error of the map, by its shape and by the markers' rigid fit.
            truth = os.path.join(sequence, "groundtruth.txt")
            errors = {}
            for name, db in (("markers", os.path.join(tmp, "rough.db")), ("cloud", cloud_out)):
                kf = os.path.join(tmp, f"kf_{name}.txt")
                run([coloc, "mapdb", "export-trajectory", db, kf])
                ate = run([coloc, "eval", "ate", truth, kf, "--align", "none", "--json"])
                errors[name] = (json.loads(ate.stdout)["translation_m"]["rmse"]
                                if ate.returncode == 0 else 1e9)
            print("keyframe co-location RMSE (m), markers' rigid fit and no markers:", errors)
            ok &= check("no markers as good as the markers' rigid fit",
                        errors["cloud"] < max(errors["markers"] + 0.01, 0.02))
        else:
            print(r.stderr[-2000:])
        r = run([coloc, "register", "--map", os.path.join(tmp, "map.db"), "--out",
                 os.path.join(tmp, "nothing.db")])
        ok &= check("no markers needs the scan", r.returncode == 1 and "--scan" in r.stderr)
        # A map without stored depth (schema 3, or made so) still needs the recording: the
        # registered map is saved with depth too, so the test takes a schema-3 copy of it.
        old = os.path.join(tmp, "schema3.db")
        make_schema3(os.path.join(tmp, "map.db"), old)
        r = run([coloc, "register", "--map", old, "--scan", scan, "--out",
                 os.path.join(tmp, "nothing.db")])
        ok &= check("no depth needs the recording", r.returncode == 1 and "--sequence" in r.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
