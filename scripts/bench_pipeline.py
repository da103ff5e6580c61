#!/usr/bin/python3
"""Whole-pipeline speed and memory on real sequences (issues: global segment map, real time).

`cuefusion run` on each dataset, tracking with ICP, four ways: geometry only; fused with
the shipped network (xyz_instances), frames read, decoded and masked ahead of the loop on
another thread (the default); the same with --sequential (read, mask, process each frame
in turn); the network on every 3rd frame only (--masks-every 3, read ahead). Reports per-stage medians from timings.json (ms per 640x480 frame): reading and
decoding, the network, the loop's stages, the whole loop, the wall time per frame and the
frames per second of the run, its CPU time per frame, its peak resident memory, and the TSDF volume's size at
25/50/75/100 % of the sequence. Beside them the Open3D peer: Open3D 0.16's frame-to-model
loop (ray cast, point-to-plane ICP, integrate; bench_reconstruction.py), which has no
segmentation. Repeats each cuefusion run --repeat times and takes the median of the
per-run medians. Prints Markdown for docs/benchmarks.md.
"""
import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_reconstruction import machine, run_open3d  # noqa: E402

STAGES = ["read", "masks", "masks: input", "masks: forward", "masks: decode", "preprocess", "track", "integrate", "raycast", "geometric segmentation", "instance merge",
          "propagation", "segment merging", "label update", "segmentation", "whole loop", "wall per frame"]
MODES = [("geometry", ["--mode", "geometry"]),
         ("fused, network, read ahead", ["--model", "xyz_instances"]),
         ("fused, network, --sequential", ["--model", "xyz_instances", "--sequential"]),
         ("fused, network every 3rd frame, read ahead", ["--model", "xyz_instances", "--masks-every", "3"])]


def run_once(binary, data, out, extra):
    proc = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", binary, "run", data, "--out", out, *extra], capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit("cuefusion failed: " + proc.stderr.strip())
    timings = json.load(open(os.path.join(out, "timings.json")))
    tracking = json.load(open(os.path.join(out, "tracking.json")))
    volume = [f["volume_mib"] for f in timings["frames"]]
    user, system, peak = proc.stderr.strip().splitlines()[-1].split()
    return {"stages": {s: timings["stages"][s]["median"] for s in STAGES if timings["stages"].get(s, {}).get("median") is not None},
            "fps": timings["frames_per_second"], "peak": int(peak) / 1024.0,
            "cpu": (float(user) + float(system)) * 1000.0 / max(1, tracking["frames"]),
            "volume": [volume[max(0, int(round(q * len(volume))) - 1)] for q in (0.25, 0.5, 0.75, 1.0)],
            "frames": tracking["frames"], "tracked": tracking["tracked"], "ate": tracking.get("ate", {}).get("rmse")}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+")
    parser.add_argument("--binary", default="build/apps/cuefusion")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--no-peer", action="store_true", help="leave Open3D out")
    args = parser.parse_args()
    rows, peers = [], {}
    for data in args.datasets:
        name = os.path.basename(os.path.normpath(data))
        with tempfile.TemporaryDirectory(prefix="cuefusion-pipeline-") as tmp:
            for mode, extra in MODES:
                runs = []
                for k in range(args.repeat):
                    runs.append(run_once(args.binary, data, os.path.join(tmp, f"run{k}"), extra))
                    print(f"{name} {mode} run {k}: whole loop {runs[-1]['stages']['whole loop']:.1f} ms, "
                          f"{runs[-1]['fps']:.1f} fps", file=sys.stderr)
                med = {s: statistics.median(r["stages"][s] for r in runs) for s in runs[0]["stages"]}
                rows.append((name, mode, med, statistics.median(r["fps"] for r in runs), statistics.median(r["peak"] for r in runs), runs[0],
                             statistics.median(r["cpu"] for r in runs)))
        if not args.no_peer:
            peers[name] = run_open3d("frame_to_model", data, 0.01, 0.04, 5.0)
    print("### Whole pipeline on real sequences\n")
    print(f"Command: `scripts/bench pipeline` ({datetime.date.today()}, {machine()}). `cuefusion run DATASET` "
          f"(tracking by ICP) in each mode, median over {args.repeat} runs of each run's per-frame median, ms per 640×480 "
          "frame; read = reading and decoding the frame's files, masks = the network on it (on the reading thread when "
          "read ahead), whole loop = the pipeline's call per frame, wall clock (the network excluded; the frame's "
          "segmentation runs beside its tracking, so the stages add up to more), wall per frame = from one "
          "frame's end to the next's, fps = frames / the run's processing time, CPU = the process's user + system time "
          "over its frames (every thread, start-up and writing included; the work two cores share).\n")
    print("| dataset | mode | frames (tracked) | " + " | ".join(STAGES) + " | fps | CPU per frame | ATE | peak memory | volume at 25/50/75/100 % |")
    print("|---|---|---|" + "---|" * len(STAGES) + "---|---|---|---|---|")
    for name, mode, med, fps, peak, first, cpu in rows:
        cells = " | ".join("%.1f" % med[s] if s in med else "–" for s in STAGES)
        ate = "%.1f cm" % (100 * first["ate"]) if first["ate"] is not None else "–"
        print(f"| {name} | {mode} | {first['frames']} ({first['tracked']}) | {cells} | {fps:.1f} | {cpu:.0f} ms | {ate} | {peak:.0f} MiB | "
              + " / ".join("%.0f" % v for v in first["volume"]) + " MiB |")
    for name, peer in peers.items():
        if "error" in peer:
            print(f"\nOpen3D frame-to-model on {name}: failed ({peer['error']})")
        else:
            times = sorted(peer["times"])
            print(f"\nOpen3D 0.16 frame-to-model on {name} (ray cast, ICP, integrate; no segmentation, no reading): "
                  f"{statistics.median(times):.1f} ms a frame (median; {1000.0 / statistics.median(times):.1f} fps), "
                  f"ATE {100 * peer.get('ate', float('nan')):.1f} cm, peak {peer['peak_mib']:.0f} MiB.")


if __name__ == "__main__":
    main()
