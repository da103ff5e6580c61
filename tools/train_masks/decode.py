"""Python twin of the C++ decoder (OnnxInstanceSegmenter::decodeDense), for validation
during training: seeds = foreground > 0.5 and boundary < 0.5; 4-connected components of
the seeds (smaller than min_pixels dropped); the labels then grow into the rest of the
foreground by up to grow_steps 3x3 maximum filters. stability() is the score's second
factor: a mask's IoU with the mask it overlaps most when decoded at the boundary threshold
minus and plus a delta (the lower of the two)."""
import cv2
import numpy as np


def decode(fg, bd, shape=None, threshold=0.5, boundary_threshold=0.5, min_pixels=6, grow_steps=3):
    fgm = fg > threshold
    seeds = (fgm & (bd < boundary_threshold)).astype(np.uint8)
    n, labels = cv2.connectedComponents(seeds, connectivity=4)
    sizes = np.bincount(labels.ravel(), minlength=n)
    keep = np.zeros(n, np.int32)
    keep[1:][sizes[1:] >= min_pixels] = np.arange(1, int((sizes[1:] >= min_pixels).sum()) + 1)
    labels = keep[labels].astype(np.uint16)
    kernel = np.ones((3, 3), np.uint8)
    for _ in range(grow_steps):
        grown = cv2.dilate(labels, kernel)
        fill = fgm & (labels == 0) & (grown > 0)
        if not fill.any():
            break
        labels[fill] = grown[fill]
    if shape is not None:
        labels = cv2.resize(labels, (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST)
    return labels


def stability(labels, others):
    """Per label k of `labels` (index k of the result; index 0 unused): the lowest, over the
    label images in `others`, of the IoU with the label there that overlaps it most."""
    n = int(labels.max()) + 1
    out = np.ones(n)
    for other in others:
        m = int(other.max()) + 1
        overlap = np.bincount(labels.ravel().astype(np.int64) * m + other.ravel(), minlength=n * m).reshape(n, m)
        size, other_size = overlap.sum(1), overlap.sum(0)
        for k in range(1, n):
            row = overlap[k, 1:]
            if row.size == 0 or row.max() == 0:
                out[k] = 0.0
                continue
            j = 1 + int(row.argmax())
            out[k] = min(out[k], row[j - 1] / float(size[k] + other_size[j] - row[j - 1]))
    return out


def match_iou(pred, truth, min_pixels=50):
    """Mean over truth instances (>= min_pixels) of the best IoU of a predicted label."""
    ious = []
    for t in np.unique(truth):
        if t == 0:
            continue
        tm = truth == t
        if tm.sum() < min_pixels:
            continue
        cand = pred[tm]
        cand = cand[cand > 0]
        best = 0.0
        for p in np.unique(cand):
            pm = pred == p
            best = max(best, (tm & pm).sum() / float((tm | pm).sum()))
        ious.append(best)
    return (float(np.mean(ious)) if ious else 1.0), len(np.unique(pred)) - 1
