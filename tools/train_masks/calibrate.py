#!/usr/bin/python3
"""Chooses the decoder's boundary threshold on held-out *synthetic* views (never on the
real evaluation data): runs an exported model through OpenCV DNN, as cuefusion does, and
prints the mean best IoU per truth object for each threshold.

    tools/train_masks/calibrate.py MODEL.onnx VAL_DIR [--thresholds 0.2,0.3,0.4,0.5]
"""
import argparse
import json
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from decode import decode, match_iou  # noqa: E402
from train import load_views, model_channels, network_input  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model")
    p.add_argument("val")
    p.add_argument("--thresholds", default="0.2,0.3,0.4,0.5,0.6")
    a = p.parse_args()
    thresholds = [float(t) for t in a.thresholds.split(",")]
    net = cv2.dnn.readNetFromONNX(a.model)
    rgb = None
    if model_channels(a.model) == 6:
        depth, inst, cams, rgb = load_views(a.val, color=True)
    else:
        depth, inst, cams = load_views(a.val)
    scores = {t: [] for t in thresholds}
    counts = {t: [] for t in thresholds}
    for i in range(len(depth)):
        net.setInput(network_input(depth[i], cams[i], rgb[i] if rgb is not None else None)[None].astype(np.float32))
        out = net.forward()[0]
        fg, bd = 1 / (1 + np.exp(-out[0])), 1 / (1 + np.exp(-out[1]))
        for t in thresholds:
            labels = decode(fg, bd, depth[i].shape, boundary_threshold=t)
            iou, n = match_iou(labels, inst[i])
            scores[t].append(iou)
            counts[t].append(n)
    truth = np.mean([len(np.unique(x)) - 1 for x in inst])
    result = {str(t): {"mean_iou": float(np.mean(scores[t])), "instances": float(np.mean(counts[t]))} for t in thresholds}
    print(json.dumps({"views": len(depth), "truth_instances": float(truth), "by_boundary_threshold": result}, indent=1))


if __name__ == "__main__":
    main()
