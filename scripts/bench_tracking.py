#!/usr/bin/python3
"""Tracking against exact poses on generated sequences, with the events that break it.

`cuefusion synth` renders the tabletop orbit with Kinect depth noise (TUM layout), and the
script derives the cases from it by editing the frame lists (the renders are exact, so the
truth is too):
  - slow orbit: every frame of a 240-frame orbit;
  - fast orbit: the same orbit in 40 frames (6x the motion per frame);
  - gap: the 120-frame orbit with frames 50-69 missing (a jump of ~0.3 m and ~14 deg);
  - blackout: the 120-frame orbit with frames 50-59 without depth (a covered sensor);
  - return: frames 0-79, then frames 10-39 again (the camera back at an earlier view).
`cuefusion run` tracks each (geometry mode; the first frame at its true pose); the report
gives ATE (aligned RMSE over the frames reported tracked), the largest unaligned position
error of a frame reported tracked, frames lost, frames relocalised, and after the event
the share of frames tracked from the 5th frame on. Open3D 0.16's RGB-D odometry
(frame-to-frame, hybrid term: `bench_reconstruction.py`'s peer) runs on the same frame
lists, ATE over every frame. Prints Markdown for docs/benchmarks.md.
"""
import argparse
import datetime
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_reconstruction import ate_rmse, machine, read_tum, run_open3d  # noqa: E402

BINARY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "apps", "cuefusion")


def synth(out, frames, size):
    subprocess.run([BINARY, "synth", "--scene", "tabletop", "--frames", str(frames), "--noise", "--size", size, "--out", out],
                   check=True, stdout=subprocess.DEVNULL)


def listing(root, name):
    lines = open(os.path.join(root, name)).read().splitlines()
    return [l for l in lines if l.startswith("#")], [l for l in lines if l.strip() and not l.startswith("#")]


def derive(base, out, order, blank=()):
    """A copy of the TUM folder `base` whose frames are base's frames in `order` (repeats get
    new timestamps 100 s later per pass, with their true poses); frames in `blank` get depth
    images of zeros."""
    shutil.copytree(base, out)
    heads = {}
    rows = {}
    for name in ("depth.txt", "rgb.txt", "groundtruth.txt"):
        heads[name], rows[name] = listing(base, name)
    seen = {}
    new = {name: [] for name in rows}
    for i in order:
        shift = 100.0 * seen.get(i, 0)
        seen[i] = seen.get(i, 0) + 1
        for name in ("depth.txt", "rgb.txt", "groundtruth.txt"):
            v = rows[name][i].split()
            new[name].append(" ".join(["%.6f" % (float(v[0]) + shift)] + v[1:]))
    for name in new:
        open(os.path.join(out, name), "w").write("\n".join(heads[name] + new[name]) + "\n")
    if blank:
        import cv2
        for i in blank:
            path = os.path.join(out, rows["depth.txt"][i].split()[1])
            depth = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            cv2.imwrite(path, np.zeros_like(depth))


def evaluate(seq, out, event):
    proc = subprocess.run([BINARY, "run", seq, "--out", out, "--mode", "geometry"], capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit("cuefusion run failed: " + proc.stderr.strip())
    tracking = json.load(open(os.path.join(out, "tracking.json")))
    lost = {l["index"] for l in tracking["lost"]}
    est = dict(read_tum(os.path.join(out, "trajectory.txt")))
    ref = dict(read_tum(os.path.join(out, "reference_trajectory.txt")))
    keys = sorted(set(est) & set(ref))
    errors = [float(np.linalg.norm(est[k][:3, 3] - ref[k][:3, 3])) for k in keys]
    frames = tracking["frames"]
    after = None
    if event is not None:
        window = [i for i in range(event + 5, frames)]
        after = sum(1 for i in window if i not in lost) / float(len(window)) if window else float("nan")
    loop = json.load(open(os.path.join(out, "timings.json")))["stages"]
    return {"frames": frames, "tracked": tracking["tracked"], "lost": len(lost), "relocalised": len(tracking.get("relocalised", [])),
            "ate": ate_rmse([est[k] for k in keys], [ref[k] for k in keys]) if len(keys) >= 3 else float("nan"),
            "max_error": max(errors) if errors else float("nan"), "after": after,
            "reloc_ms": loop.get("relocalise (lost frames only)", {}).get("median")}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", default="320x240")
    args = ap.parse_args()
    work = tempfile.mkdtemp(prefix="cuefusion-bench-tracking-")
    try:
        synth(os.path.join(work, "orbit240"), 240, args.size)
        synth(os.path.join(work, "orbit120"), 120, args.size)
        synth(os.path.join(work, "orbit40"), 40, args.size)
        cases = [
            ("slow orbit (240 frames)", os.path.join(work, "orbit240"), None),
            ("fast orbit (40 frames)", os.path.join(work, "orbit40"), None),
        ]
        derive(os.path.join(work, "orbit120"), os.path.join(work, "gap"), list(range(50)) + list(range(70, 120)))
        cases.append(("gap (frames 50-69 missing)", os.path.join(work, "gap"), 50))
        derive(os.path.join(work, "orbit120"), os.path.join(work, "blackout"), list(range(120)), blank=range(50, 60))
        cases.append(("blackout (frames 50-59 without depth)", os.path.join(work, "blackout"), 60))
        derive(os.path.join(work, "orbit120"), os.path.join(work, "return"), list(range(80)) + list(range(10, 40)))
        cases.append(("return (0-79, then 10-39 again)", os.path.join(work, "return"), 80))

        print("Tracking on generated sequences: `scripts/bench tracking` (%s; %s)\n" % (machine(), datetime.date.today().isoformat()))
        print("The tabletop orbit rendered by `cuefusion synth` at %s with Kinect depth noise; exact poses. cuefusion: "
              "`run --mode geometry`, ICP frame to model, failure detection and relocalisation on. ATE: RMSE after rigid "
              "alignment over the frames reported tracked; max: largest unaligned error of a frame reported tracked; "
              "after: share of the frames from the 5th after the event on that are tracked. Open3D 0.16: RGB-D odometry "
              "frame to frame (hybrid term), ATE over every frame.\n" % args.size)
        print("| sequence | frames | tracked | lost | relocalised | ATE (mm) | max (mm) | after the event | relocalisation ms (median) | Open3D odometry ATE (mm) |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for name, seq, event in cases:
            r = evaluate(seq, os.path.join(work, "run-" + os.path.basename(seq)), event)
            o3d = run_open3d("odometry", seq, 0.01, 0.04, 5.0)
            o3d_ate = "%.1f" % (o3d["ate"] * 1000) if "ate" in o3d else o3d.get("error", "-")
            print("| %s | %d | %d | %d | %d | %.1f | %.1f | %s | %s | %s |"
                  % (name, r["frames"], r["tracked"], r["lost"], r["relocalised"], r["ate"] * 1000, r["max_error"] * 1000,
                     "-" if r["after"] is None else "%.0f %%" % (100 * r["after"]),
                     "-" if r["reloc_ms"] is None else "%.0f" % r["reloc_ms"], o3d_ate))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
