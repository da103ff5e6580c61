#!/usr/bin/python3
"""The Python binding's overhead on real sequences (issue 41).

Each frame of each dataset goes through cuefusion.Pipeline.process from Python as numpy
arrays (depth float32, colour RGB, K, and in fused mode the shipped network's masks as a
list of (mask, score, class) from cuefusion.InstanceSegmenter). Per frame: the wall time of
the process() call against the C++ loop's own wall time inside it (the report's loop_ms,
what timings.json calls the whole loop). Their difference bounds the binding's
cost from above: converting and checking the arrays, the GIL, building the report — and
whatever untimed C++ process() does. Prints Markdown for docs/benchmarks.md.
"""
import argparse
import datetime
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "python"))
from bench_reconstruction import machine  # noqa: E402
import cuefusion  # noqa: E402


def run(path, mode, frames):
    sequence = cuefusion.open_sequence(path)
    network = cuefusion.InstanceSegmenter("xyz_instances") if mode == "fused" else None
    pipeline = cuefusion.Pipeline(mode=mode)
    calls, loops = [], []
    for i in range(min(frames or len(sequence), len(sequence))):
        frame = sequence[i]
        depth, color, K = frame.depth, frame.color, frame.K
        masks = network(depth, color, K) if network else None
        t0 = time.perf_counter()
        report = pipeline.process(depth, color, K, masks=masks, timestamp=frame.timestamp)
        calls.append((time.perf_counter() - t0) * 1000.0)
        if report["segmented"]:
            loops.append((calls[-1], report["loop_ms"]))
    overhead = [c - l for c, l in loops]
    loop = statistics.median(l for _, l in loops)
    return {"frames": len(calls), "call": statistics.median(c for c, _ in loops), "loop": loop,
            "overhead": statistics.median(overhead), "worst": max(overhead), "share": statistics.median(overhead) / loop}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+")
    parser.add_argument("--frames", type=int, default=0, help="at most this many frames of each (0 = all)")
    args = parser.parse_args()
    print("### Python binding overhead\n")
    print(f"Command: `scripts/bench python` ({datetime.date.today()}, {machine()}). Per frame: the wall time of "
          "`Pipeline.process` called from Python with numpy arrays, against the C++ loop's own wall time inside it "
          "(the report's loop_ms); "
          "medians over the segmented frames, ms per 640×480 frame.\n")
    print("| dataset | mode | frames | process() from Python | C++ loop inside | overhead (median) | overhead (worst frame) | share of the loop |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for path in args.datasets:
        for mode in ("geometry", "fused"):
            r = run(path, mode, args.frames)
            print(f"| {os.path.basename(os.path.normpath(path))} | {mode} | {r['frames']} | {r['call']:.1f} | {r['loop']:.1f} | "
                  f"{r['overhead']:.2f} | {r['worst']:.2f} | {100 * r['share']:.1f} % |", flush=True)


if __name__ == "__main__":
    main()
