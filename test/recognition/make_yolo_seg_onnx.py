#!/usr/bin/python3
"""Writes a tiny ONNX model whose outputs are known exactly, in the YOLO segmentation
export layout, for the OnnxInstanceSegmenter tests.

usage: make_yolo_seg_onnx.py SPEC.json OUT.onnx

SPEC: {"layout": "v5" | "v8" | "flat", "input": S, "classes": C, "coefficients": K,
       "proto_size": P, "regions": [[channel, y0, y1, x0, x1], ...],
       "detections": [[cx, cy, w, h, objectness, class, class_score, coefficient_channel], ...]}
Prototypes are -10 everywhere except +10 inside each region (inclusive, proto pixels) of
its channel; a detection's coefficients are 1 for its channel and 0 elsewhere, so its mask
logit is +-10. The outputs do not depend on the image: every value is the bias of a 1x1
convolution with zero weights and stride S (so the graph is a real network OpenCV's
importer runs), reshaped to the output layout. "flat" writes detections as [1, N*D]
(a layout the decoder must refuse).
"""
import json
import sys

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper


def constant_output(name, values, shape, size, nodes, inits):
    flat = values.astype(np.float32).reshape(-1)
    w = np.zeros((flat.size, 3, 1, 1), np.float32)
    inits += [numpy_helper.from_array(w, name + "_w"), numpy_helper.from_array(flat, name + "_b"),
              numpy_helper.from_array(np.array(shape, np.int64), name + "_shape")]
    nodes.append(helper.make_node("Conv", ["images", name + "_w", name + "_b"], [name + "_conv"],
                                  kernel_shape=[1, 1], strides=[size, size]))
    nodes.append(helper.make_node("Reshape", [name + "_conv", name + "_shape"], [name]))


def main():
    spec = json.load(open(sys.argv[1]))
    s, c, k, p = spec["input"], spec["classes"], spec["coefficients"], spec["proto_size"]
    protos = np.full((k, p, p), -10.0, np.float32)
    for ch, y0, y1, x0, x1 in spec["regions"]:
        protos[ch, y0:y1 + 1, x0:x1 + 1] = 10.0
    rows = []
    for cx, cy, w, h, obj, cls, score, ch in spec["detections"]:
        classes = np.zeros(c, np.float32)
        classes[cls] = score
        coef = np.zeros(k, np.float32)
        coef[ch] = 1.0
        head = [cx, cy, w, h, obj] if spec["layout"] in ("v5", "flat") else [cx, cy, w, h]
        rows.append(np.concatenate([np.array(head, np.float32), classes, coef]))
    det = np.stack(rows)  # N x D
    nodes, inits = [], []
    if spec["layout"] == "v5":
        constant_output("output0", det, [1, det.shape[0], det.shape[1]], s, nodes, inits)
    elif spec["layout"] == "v8":
        constant_output("output0", det.T.copy(), [1, det.shape[1], det.shape[0]], s, nodes, inits)
    else:
        constant_output("output0", det, [1, det.size], s, nodes, inits)
    constant_output("output1", protos, [1, k, p, p], s, nodes, inits)
    det_shape = {"v5": [1, det.shape[0], det.shape[1]], "v8": [1, det.shape[1], det.shape[0]], "flat": [1, det.size]}
    graph = helper.make_graph(
        nodes, "yolo_seg_stub",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, s, s])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, det_shape[spec["layout"]]),
         helper.make_tensor_value_info("output1", TensorProto.FLOAT, [1, k, p, p])],
        inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 12)])
    model.ir_version = 7
    onnx.checker.check_model(model)
    onnx.save(model, sys.argv[2])


if __name__ == "__main__":
    main()
