#!/usr/bin/python3
"""Chooses how the xyz decoder scores its masks, on held-out *synthetic* views (never on
the real evaluation data nor on the benchmark sequences): runs an exported model through
OpenCV DNN as cuefusion does, decodes every view at the boundary threshold, and asks how
well each candidate score ranks the masks: AP50 of the masks pooled over the views (a mask
is a true positive when its IoU with a not yet matched truth object exceeds 0.5, taken in
score order). Candidates: the mean foreground probability alone, no ranking at all (every
mask tied), and the mean foreground times the mask's stability for each delta (decoded at
threshold - delta and + delta, decode.stability). The oracle line is the AP50 of a perfect
ranking (every true positive first): how much ranking can win at all.

    tools/train_masks/score_calibration.py MODEL.onnx VAL_DIR [--threshold 0.3] [--deltas 0.05,0.1,0.15,0.2]
"""
import argparse
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from decode import decode, stability  # noqa: E402
from train import load_views, model_channels, network_input  # noqa: E402

MIN_PIXELS = 25  # output pixels: the 100 frame pixels of the C++ decoder at 640x480 / 320 columns / 2


def pooled_ap50(masks, truths, scores):
    """Interpolated AP50 of masks (view, best IoU, best truth id) ranked by scores."""
    taken, tp = set(), []
    for j in np.argsort(-np.asarray(scores), kind="stable"):
        view, iou, truth = masks[j]
        hit = iou > 0.5 and (view, truth) not in taken
        if hit:
            taken.add((view, truth))
        tp.append(hit)
    tp = np.asarray(tp, float)
    hits = np.cumsum(tp)
    precision = hits / np.arange(1, len(tp) + 1)
    recall = hits / truths
    ap, previous = 0.0, 0.0
    for k in np.nonzero(tp)[0]:
        ap += (recall[k] - previous) * precision[k:].max()
        previous = recall[k]
    return ap


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model")
    p.add_argument("val")
    p.add_argument("--threshold", type=float, default=0.3)
    p.add_argument("--deltas", default="0.05,0.1,0.15,0.2")
    a = p.parse_args()
    deltas = [float(d) for d in a.deltas.split(",")]
    net = cv2.dnn.readNetFromONNX(a.model)
    rgb = None
    if model_channels(a.model) == 6:
        depth, inst, cams, rgb = load_views(a.val, color=True)
    else:
        depth, inst, cams = load_views(a.val)
    masks, base, stab = [], [], {d: [] for d in deltas}
    truths = 0
    for i in range(len(depth)):
        net.setInput(network_input(depth[i], cams[i], rgb[i] if rgb is not None else None)[None].astype(np.float32))
        out = net.forward()[0]
        fg, bd = 1 / (1 + np.exp(-out[0])), 1 / (1 + np.exp(-out[1]))
        labels = decode(fg, bd, boundary_threshold=a.threshold, min_pixels=MIN_PIXELS)
        s = {d: stability(labels, [decode(fg, bd, boundary_threshold=a.threshold - d, min_pixels=MIN_PIXELS),
                                   decode(fg, bd, boundary_threshold=a.threshold + d, min_pixels=MIN_PIXELS)]) for d in deltas}
        truth = cv2.resize(inst[i], (labels.shape[1], labels.shape[0]), interpolation=cv2.INTER_NEAREST)
        ids = [t for t in np.unique(truth) if t and (truth == t).sum() >= MIN_PIXELS]
        truths += len(ids)
        for k in range(1, int(labels.max()) + 1):
            m = labels == k
            if not m.any():
                continue
            best, best_id = 0.0, 0
            for t in ids:
                tm = truth == t
                iou = (m & tm).sum() / float((m | tm).sum())
                if iou > best:
                    best, best_id = iou, t
            masks.append((i, best, best_id))
            base.append(fg[m].mean())
            for d in deltas:
                stab[d].append(s[d][k])
    good = sum(1 for _, iou, _ in masks if iou > 0.5)
    print("%d views, %d truth objects, %d masks (%d with IoU > 0.5)" % (len(depth), truths, len(masks), good))
    print("mask AP50 pooled over the views, by score:")
    print("  oracle ranking              %.4f" % pooled_ap50(masks, truths, [float(m[1] > 0.5) for m in masks]))
    print("  mean foreground             %.4f" % pooled_ap50(masks, truths, base))
    print("  tied (no ranking)           %.4f" % pooled_ap50(masks, truths, np.ones(len(masks))))
    for d in deltas:
        print("  foreground x stability %.2f %.4f" % (d, pooled_ap50(masks, truths, np.asarray(base) * np.asarray(stab[d]))))


if __name__ == "__main__":
    main()
