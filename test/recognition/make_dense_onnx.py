#!/usr/bin/python3
"""Writes a tiny ONNX model in cuefusion's xyz layout whose outputs are known exactly,
for the OnnxInstanceSegmenter tests.

usage: make_dense_onnx.py SPEC.json OUT.onnx

SPEC: {"input": S, "channels": 2, "foreground": [[y0, y1, x0, x1, logit], ...],
       "boundary": [[y0, y1, x0, x1, logit], ...],
       "input_channels": 3, "weights": [[output_channel, input_channel, weight], ...]}
Input [1, input_channels, S, S] (3: xyz; 6: xyz and colour), output [1, channels, S/2, S/2]
logits: -10 everywhere, and each rectangle (inclusive, output pixels) set to its logit in
its channel (foreground = 0, boundary = 1), plus a 1x1 convolution with stride 2 of the
input (a real network OpenCV's importer runs) whose weights are 0 except those listed:
without "weights" the output does not depend on the input. "channels" other than 2 writes
a model the decoder must refuse.
"""
import json
import sys

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper


def main():
    spec = json.load(open(sys.argv[1]))
    s = spec["input"]
    channels = spec.get("channels", 2)
    pattern = np.full((1, channels, s // 2, s // 2), -10.0, np.float32)
    for channel, key in ((0, "foreground"), (1, "boundary")):
        for y0, y1, x0, x1, logit in spec.get(key, []):
            pattern[0, channel, y0:y1 + 1, x0:x1 + 1] = logit
    inputs = spec.get("input_channels", 3)
    weights = np.zeros((channels, inputs, 1, 1), np.float32)
    for out, inp, w in spec.get("weights", []):
        weights[out, inp, 0, 0] = w
    inits = [numpy_helper.from_array(weights, "w"),
             numpy_helper.from_array(np.zeros(channels, np.float32), "b"),
             numpy_helper.from_array(pattern, "pattern")]
    nodes = [helper.make_node("Conv", ["xyz", "w", "b"], ["zero"], kernel_shape=[1, 1], strides=[2, 2]),
             helper.make_node("Add", ["zero", "pattern"], ["foreground_boundary"])]
    graph = helper.make_graph(nodes, "dense", [helper.make_tensor_value_info("xyz", TensorProto.FLOAT, [1, inputs, s, s])],
                              [helper.make_tensor_value_info("foreground_boundary", TensorProto.FLOAT,
                                                             [1, channels, s // 2, s // 2])], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 11)])
    onnx.checker.check_model(model)
    onnx.save(model, sys.argv[2])


if __name__ == "__main__":
    main()
