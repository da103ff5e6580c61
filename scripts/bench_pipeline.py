#!/usr/bin/python3
"""Whole-pipeline speed and memory on real sequences (issue: global segment map).

`cuefusion run` in geometry mode (every stage of the loop; the network is excluded by
definition — it runs on its own thread in live use) on each dataset, tracking with ICP.
Reports per-stage medians (ms per 640x480 frame), the whole loop median and frames per
second, peak resident memory (/usr/bin/time), and the TSDF volume's size at 25/50/75/100 %
of the sequence, which shows whether memory keeps growing once the scene is covered.
Repeats each run --repeat times and takes the median of the per-run medians.
Prints Markdown for docs/benchmarks.md.
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
from bench_reconstruction import machine  # noqa: E402

STAGES = ["preprocess", "track", "integrate", "raycast", "geometric segmentation", "propagation", "segment merging",
          "label update", "segmentation", "whole loop"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+")
    parser.add_argument("--binary", default="build/apps/cuefusion")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rows = []
    for data in args.datasets:
        runs = []
        with tempfile.TemporaryDirectory(prefix="cuefusion-pipeline-") as tmp:
            for k in range(args.repeat):
                out = os.path.join(tmp, f"run{k}")
                proc = subprocess.run(["/usr/bin/time", "-f", "%M", args.binary, "run", data, "--out", out, "--mode", "geometry"],
                                      capture_output=True, text=True)
                if proc.returncode != 0:
                    sys.exit("cuefusion failed: " + proc.stderr.strip())
                timings = json.load(open(os.path.join(out, "timings.json")))
                tracking = json.load(open(os.path.join(out, "tracking.json")))
                volume = [f["volume_mib"] for f in timings["frames"]]
                runs.append({"stages": {s: timings["stages"][s]["median"] for s in STAGES if timings["stages"][s].get("median") is not None},
                             "peak": int(proc.stderr.strip().splitlines()[-1]) / 1024.0,
                             "volume": [volume[max(0, int(round(q * len(volume))) - 1)] for q in (0.25, 0.5, 0.75, 1.0)],
                             "frames": tracking["frames"], "tracked": tracking["tracked"],
                             "ate": tracking.get("ate", {}).get("rmse")})
                print(f"{data} run {k}: whole loop {runs[-1]['stages']['whole loop']:.1f} ms", file=sys.stderr)
        med = {s: statistics.median(r["stages"][s] for r in runs) for s in runs[0]["stages"]}
        rows.append((os.path.basename(os.path.normpath(data)), med, statistics.median(r["peak"] for r in runs), runs[0]))
    print("### Whole pipeline on real sequences\n")
    print(f"Command: `scripts/bench pipeline` ({datetime.date.today()}, {machine()}). `cuefusion run DATASET --mode geometry` "
          f"(tracking by ICP, every stage of the loop; the network is excluded), median over {args.repeat} runs of each "
          "run's per-frame median, ms per 640×480 frame.\n")
    print("| dataset | frames (tracked) | " + " | ".join(STAGES) + " | fps (whole loop) | peak memory | volume at 25/50/75/100 % |")
    print("|---|---|" + "---|" * len(STAGES) + "---|---|---|")
    for name, med, peak, first in rows:
        cells = " | ".join("%.1f" % med[s] if s in med else "n/a" for s in STAGES)
        fps = 1000.0 / med["whole loop"] if med.get("whole loop") else float("nan")
        print(f"| {name} | {first['frames']} ({first['tracked']}) | {cells} | {fps:.1f} | {peak:.0f} MiB | "
              + " / ".join("%.0f" % v for v in first["volume"]) + " MiB |")


if __name__ == "__main__":
    main()
