# SPDX-License-Identifier: BSD-3-Clause
"""Rewrites a trained xyz_instances ONNX model so that its decoder convolves the coarse
features before upsampling them instead of after: the same function, about a third less
arithmetic in the decoder (issue 44, item 3).

Each decoder step of model.py is nearest upsampling by 2, a concatenation with the skip
features and a 3x3 convolution (padding 1, BatchNorm folded in by the export):

    y = conv3x3([up2(a), s]) = conv3x3_a(up2(a)) + conv3x3_s(s) + bias

A 3x3 window over a nearest-upsampled image covers only 2x2 source pixels, which ones
depending on the output pixel's parity (di, dj): rows {i-1, i} for di = 0 and {i, i+1} for
di = 1, columns likewise. So conv3x3_a(up2(a)) is four 2x2 convolutions of `a` at the coarse
resolution (taps that fall on the same source pixel summed; padding on the side the
phase reaches out to), interleaved by DepthToSpace: 4 * 4 = 16 multiply-adds per coarse
pixel and channel pair instead of 4 * 9 = 36. The zero padding maps exactly: the
upsampled image's row -1 is the coarse row -1, its row 2H the coarse row H.

The result differs from the original only in the order floating-point sums are taken
(about 1e-6 relative); `--check` runs both on random inputs and on the inputs given and
reports the largest difference of the logits.

usage: subpixel_decoder.py IN.onnx OUT.onnx [--check]
"""
import argparse
import sys

import numpy as np
import onnx
from onnx import helper, numpy_helper


def constant_value(graph, name):
    for node in graph.node:
        if node.op_type == "Constant" and node.output[0] == name:
            return numpy_helper.to_array(node.attribute[0].t)
    for init in graph.initializer:
        if init.name == name:
            return numpy_helper.to_array(init)
    return None


# Output row 2i + di of the upsampled convolution takes coarse rows i - 1 and i (di = 0)
# or i and i + 1 (di = 1): (phase, tap of merge_taps) -> row of the stride-2 transposed 4x4
# kernel (padding 1) that holds it; columns likewise. Along an axis the four kernel rows
# are then (w2, w1 + w2, w0 + w1, w0) of the original 3x3 kernel's (w0, w1, w2).
TAP_ROWS = {(0, 0): 3, (0, 1): 1, (1, 0): 2, (1, 1): 0}


def merge_taps(kernel, phase, axis):
    """The 3 taps of `kernel` along `axis` as the 2 taps of one upsampling phase."""
    k0, k1, k2 = (np.take(kernel, t, axis) for t in range(3))
    return np.stack([k0, k1 + k2] if phase == 0 else [k0 + k1, k2], axis)


def unmerge_taps(kernel, axis):
    """The 3 taps (w0, w1, w2) along `axis` back from the transposed kernel's 4 (TAP_ROWS)."""
    def take(phase, tap):
        return np.take(kernel, TAP_ROWS[(phase, tap)], axis)
    w0, w2 = take(0, 0), take(1, 1)
    return np.stack([w0, take(0, 1) - w2, w2], axis)


def rewrite(model):
    graph = model.graph
    inits = {i.name: i for i in graph.initializer}
    consumers = {}
    for node in graph.node:
        for name in node.input:
            consumers.setdefault(name, []).append(node)
    producer = {o: n for n in graph.node for o in n.output}
    inferred = onnx.shape_inference.infer_shapes(model).graph
    channels = {v.name: v.type.tensor_type.shape.dim[1].dim_value for v in list(inferred.value_info) + list(inferred.input)
                if len(v.type.tensor_type.shape.dim) > 1}
    drop, new_nodes, rewritten = set(), {}, 0
    for conv in graph.node:
        if conv.op_type != "Conv":
            continue
        concat = producer.get(conv.input[0])
        if concat is None or concat.op_type != "Concat" or len(concat.input) != 2:
            continue
        resize = producer.get(concat.input[0])
        attrs = {a.name: helper.get_attribute_value(a) for a in conv.attribute}
        if resize is None or resize.op_type != "Resize" or attrs.get("kernel_shape") != [3, 3] or \
                attrs.get("pads") != [1, 1, 1, 1] or attrs.get("group", 1) != 1 or \
                any(v != 1 for v in attrs.get("strides", [1, 1]) + attrs.get("dilations", [1, 1])):
            continue
        r = {a.name: helper.get_attribute_value(a) for a in resize.attribute}
        scales = constant_value(graph, resize.input[2]) if len(resize.input) > 2 else None
        if r.get("mode") != b"nearest" or scales is None or list(scales) != [1, 1, 2, 2] or \
                r.get("coordinate_transformation_mode") != b"asymmetric" or r.get("nearest_mode") != b"floor":
            continue
        if len(consumers[concat.output[0]]) != 1 or len(consumers[resize.output[0]]) != 1:
            continue
        weight = numpy_helper.to_array(inits[conv.input[1]])
        bias = numpy_helper.to_array(inits[conv.input[2]]) if len(conv.input) > 2 else None
        coarse = resize.input[0]
        if not channels.get(concat.input[1]):
            raise SystemExit(f"subpixel_decoder: cannot tell the channels of {concat.input[1]}")
        up_channels = weight.shape[1] - channels[concat.input[1]]
        w_up, w_skip = weight[:, :up_channels], weight[:, up_channels:]
        base = conv.output[0] + "/subpixel"
        # One transposed convolution (stride 2, 4x4, padding 1) holds the four phases (TAP_ROWS).
        taps = np.zeros((weight.shape[0], up_channels, 4, 4), np.float64)
        for di in (0, 1):
            for dj in (0, 1):
                k = merge_taps(merge_taps(w_up.astype(np.float64), di, 2), dj, 3)
                for ty in (0, 1):
                    for tx in (0, 1):
                        taps[:, :, TAP_ROWS[(di, ty)], TAP_ROWS[(dj, tx)]] = k[:, :, ty, tx]
        wname = base + "/w_up"
        graph.initializer.append(numpy_helper.from_array(taps.transpose(1, 0, 2, 3).astype(np.float32), wname))
        nodes = [helper.make_node("ConvTranspose", [coarse, wname], [base + "/up"], kernel_shape=[4, 4],
                                  strides=[2, 2], pads=[1, 1, 1, 1])]
        skip_inputs = [concat.input[1], base + "/w_skip"]
        graph.initializer.append(numpy_helper.from_array(w_skip.astype(np.float32), base + "/w_skip"))
        if bias is not None:
            graph.initializer.append(numpy_helper.from_array(bias.astype(np.float32), base + "/bias"))
            skip_inputs.append(base + "/bias")
        nodes.append(helper.make_node("Conv", skip_inputs, [base + "/skip"], kernel_shape=[3, 3], pads=[1, 1, 1, 1]))
        nodes.append(helper.make_node("Add", [base + "/up", base + "/skip"], [conv.output[0]]))
        new_nodes[id(conv)] = nodes
        drop.update({id(resize), id(concat)})
        rewritten += 1
    out_nodes = []
    for node in graph.node:
        if id(node) in drop:
            continue
        out_nodes.extend(new_nodes.get(id(node), [node]))
    del graph.node[:]
    graph.node.extend(out_nodes)
    used = {i for n in graph.node for i in n.input}
    keep = [i for i in graph.initializer if i.name in used]
    del graph.initializer[:]
    graph.initializer.extend(keep)
    unused_constants = [n for n in graph.node if n.op_type == "Constant" and n.output[0] not in used]
    for n in unused_constants:
        graph.node.remove(n)
    return rewritten


def conv_weights(model):
    """The network's convolutions in graph order as (name, weight, bias or None), with each
    rewritten decoder step as the one 3x3 convolution over [upsampled, skip] it replaced
    (its weight recovered from the transposed convolution's taps, to float rounding): what
    train.py's --init-onnx loads, whichever form a model has."""
    inits = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    up = {n.output[0][: -len("/up")]: n for n in model.graph.node
          if n.op_type == "ConvTranspose" and n.output[0].endswith("/subpixel/up")}
    out = []
    for node in model.graph.node:
        if node.op_type != "Conv":
            continue
        weight = inits[node.input[1]]
        bias = inits[node.input[2]] if len(node.input) > 2 else None
        if node.output[0].endswith("/subpixel/skip"):
            taps = inits[up[node.output[0][: -len("/skip")]].input[1]].transpose(1, 0, 2, 3).astype(np.float64)
            w = unmerge_taps(unmerge_taps(taps, 2), 3)
            weight = np.concatenate([w.astype(np.float32), weight], 1)
        out.append((node.name or node.output[0], weight, bias))
    return out


def check(original, rewritten, inputs):
    import cv2
    a = cv2.dnn.readNetFromONNX(original)
    b = cv2.dnn.readNetFromONNX(rewritten)
    worst = 0.0
    for x in inputs:
        a.setInput(x)
        b.setInput(x)
        ya, yb = a.forward(), b.forward()
        worst = max(worst, float(np.abs(ya - yb).max() / max(1e-6, np.abs(ya).max())))
    return worst


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input")
    parser.add_argument("output")
    parser.add_argument("--check", action="store_true", help="compare the two models' logits on random inputs")
    args = parser.parse_args()
    model = onnx.load(args.input)
    count = rewrite(model)
    onnx.checker.check_model(model)
    onnx.save(model, args.output)
    print(f"subpixel_decoder: {count} decoder steps rewritten -> {args.output}")
    if args.check:
        shape = [d.dim_value for d in model.graph.input[0].type.tensor_type.shape.dim]
        rng = np.random.default_rng(1)
        inputs = [rng.uniform(-2, 4, shape).astype(np.float32) for _ in range(4)]
        print(f"largest logit difference, relative to the largest logit: {check(args.input, args.output, inputs):.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
