#!/usr/bin/python3
"""Trains cuefusion's class-agnostic instance segmenter on views rendered by
`cuefusion synth-views` and exports it to ONNX (opset 11, loads in OpenCV 4.6 DNN).

    tools/train_masks/train.py --train VIEWS_DIR --val VAL_DIR --out data/models/xyz_instances.onnx

Everything runs on the CPU (Debian's python3-torch, python3-opencv); --device cuda uses a
GPU where one exists. Seeded: the same views, seed and iteration count give the same
weights on the same machine (thread scheduling can change the last bits).
See README.md beside this file.
"""
import argparse
import json
import os
import sys
import time

import cv2
import numpy as np
import onnx
import onnx.numpy_helper
import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from model import XyzInstanceNet  # noqa: E402
from decode import decode, match_iou  # noqa: E402
import subpixel_decoder  # noqa: E402


def load_views(folder, limit=0, color=False):
    """Depth in metres, instance ids and intrinsics of the views in `folder`; with color,
    also their colour images (RGB, uint8). Several folders may be joined by commas."""
    if "," in folder:
        parts = [load_views(f, limit, color) for f in folder.split(",")]
        return tuple(np.concatenate(x) for x in zip(*parts))
    meta = json.load(open(os.path.join(folder, "views.json")))
    units = float(meta["depth_units_per_metre"])
    views = meta["views"][: limit or None]
    depth = np.stack([cv2.imread(os.path.join(folder, "depth", v["file"]), cv2.IMREAD_UNCHANGED) for v in views])
    inst = np.stack([cv2.imread(os.path.join(folder, "instance", v["file"]), cv2.IMREAD_UNCHANGED) for v in views])
    cams = np.array([[v["camera"][k] for k in ("fx", "fy", "cx", "cy")] for v in views], np.float32)
    if not color:
        return depth.astype(np.float32) / units, inst, cams
    rgb = np.stack([cv2.imread(os.path.join(folder, "color", v["file"]), cv2.IMREAD_COLOR)[:, :, ::-1] for v in views])
    return depth.astype(np.float32) / units, inst, cams, rgb


def model_channels(path):
    """Input channels of an exported model: 3 (xyz) or 6 (xyz and colour)."""
    return onnx.load(path).graph.input[0].type.tensor_type.shape.dim[1].dim_value


def network_input(z, cam, rgb=None):
    """The network's input for one view, as OnnxInstanceSegmenter::denseInput builds it:
    xyz [3, H, W], then with a colour image RGB / 255 - 0.5 [3, H, W]."""
    xyz = back_project(z, cam)
    if rgb is None:
        return xyz
    return np.concatenate([xyz, rgb.transpose(2, 0, 1).astype(np.float32) / 255.0 - 0.5])


def back_project(z, cam):
    """xyz [3, H, W] in the camera frame; 0 where z is 0 (the C++ side does the same)."""
    h, w = z.shape
    fx, fy, cx, cy = cam
    u = np.arange(w, dtype=np.float32)[None, :]
    v = np.arange(h, dtype=np.float32)[:, None]
    return np.stack([(u - cx) / fx * z, (v - cy) / fy * z, z])


def targets(inst):
    """Foreground (2x2 block mean) and instance boundary at half resolution."""
    h, w = inst.shape
    fg = (inst > 0).astype(np.float32).reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3))
    ids = inst[::2, ::2].astype(np.int32)
    boundary = np.zeros_like(fg)
    padded = np.pad(ids, 1)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            n = padded[1 + dy: 1 + dy + ids.shape[0], 1 + dx: 1 + dx + ids.shape[1]]
            boundary[(ids > 0) & (n > 0) & (n != ids)] = 1.0
    return fg, boundary


def augment(z, inst, rng):
    """Real-sensor imperfections the renderer leaves out: IR shadows beside depth jumps,
    missing blobs and speckle, disparity quantisation; and mirror images."""
    z = z.copy()
    if rng.random() < 0.5:  # Kinect disparity steps: d(1/z) = 2.85e-3 / m
        q = 2.85e-3 * rng.uniform(0.5, 1.5)
        valid = z > 0
        z[valid] = 1.0 / (np.round((1.0 / z[valid]) / q) * q)
    width = int(rng.integers(0, 5))  # shadow band on the far side of a jump, one image side
    if width:
        side = 1 if rng.random() < 0.5 else -1
        shadow = np.zeros(z.shape, bool)
        for k in range(1, width + 1):
            near = np.roll(z, side * k, axis=1)
            shadow |= (near > 0) & (z - near > 0.03)
        z[shadow] = 0
    for _ in range(int(rng.integers(0, 4))):  # missing blobs (dark or shiny surfaces)
        cy, cx = rng.integers(0, z.shape[0]), rng.integers(0, z.shape[1])
        axes = (int(rng.integers(2, 20)), int(rng.integers(2, 20)))
        mask = np.zeros(z.shape, np.uint8)
        cv2.ellipse(mask, (int(cx), int(cy)), axes, float(rng.uniform(0, 180)), 0, 360, 1, -1)
        z[mask > 0] = 0
    z[rng.random(z.shape) < rng.uniform(0, 0.03)] = 0  # speckle
    flip = rng.random() < 0.5
    return z, inst, flip


def random_color(rng):
    return rng.uniform(0.05, 0.95, 3).astype(np.float32)


def paint_shapes(img, region, shading, rng, count):
    """Paints `count` random rectangles, ellipses and stripes (random colours, shaded like
    the surface under them) over img where `region` is set: printed boxes, labels."""
    ys, xs = np.nonzero(region)
    if len(ys) < 20:
        return
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    for _ in range(count):
        shape = np.zeros(region.shape, np.uint8)
        cx, cy = int(rng.integers(x0, x1)), int(rng.integers(y0, y1))
        ax = int(max(2, rng.uniform(0.1, 0.6) * (x1 - x0)))
        ay = int(max(2, rng.uniform(0.1, 0.6) * (y1 - y0)))
        kind = rng.integers(0, 3)
        if kind == 0:
            box = ((cx, cy), (2 * ax, 2 * ay), float(rng.uniform(0, 180)))
            cv2.fillPoly(shape, [cv2.boxPoints(box).astype(np.int32)], 1)
        elif kind == 1:
            cv2.ellipse(shape, (cx, cy), (ax, ay), float(rng.uniform(0, 180)), 0, 360, 1, -1)
        else:  # a band across the whole region
            if rng.random() < 0.5:
                shape[max(0, cy - ay // 3): cy + ay // 3 + 1, x0:x1] = 1
            else:
                shape[y0:y1, max(0, cx - ax // 3): cx + ax // 3 + 1] = 1
        m = (shape > 0) & region
        img[m] = random_color(rng)[None, :] * shading[m][:, None]


def augment_color(rgb, inst, rng):
    """Colour as real scenes have it, which flat-shaded renders lack: printed textures on
    objects and on the support, objects of one colour side by side (so that colour alone
    never decides), lighting and white balance, sensor noise, blur, colour-depth
    misregistration of a pixel, and sometimes no colour at all (grey)."""
    img = rgb.astype(np.float32) / 255.0
    lum = img.mean(axis=2)
    ids = [i for i in np.unique(inst) if i > 0]
    shading = np.ones_like(lum)
    for i in ids + [0]:
        m = inst == i
        if m.any():
            shading[m] = lum[m] / max(1e-3, float(np.median(lum[m])))
    shading = np.clip(shading, 0.2, 1.5)
    if len(ids) > 1 and rng.random() < 0.2:  # distinct objects in one colour
        a, b = rng.choice(ids, 2, replace=False)
        ma, mb = inst == a, inst == b
        ca, cb = img[ma].mean(axis=0), img[mb].mean(axis=0)
        img[ma] = np.clip(img[ma] * (cb / np.maximum(ca, 1e-3))[None, :], 0, 1)
    for i in ids:
        if rng.random() < 0.2:
            paint_shapes(img, inst == i, shading, rng, int(rng.integers(1, 4)))
    if rng.random() < 0.3:
        paint_shapes(img, inst == 0, shading, rng, int(rng.integers(1, 8)))
    img = img * rng.uniform(0.75, 1.25, 3)[None, None, :].astype(np.float32) + np.float32(rng.uniform(-0.08, 0.08))
    img = np.clip(img, 0, 1) ** np.float32(rng.uniform(0.7, 1.4))
    if rng.random() < 0.3:
        img = cv2.GaussianBlur(img, (3, 3), 0)
    img = img + rng.normal(0, rng.uniform(0, 0.04), img.shape).astype(np.float32)
    if rng.random() < 0.5:
        img = np.roll(img, (int(rng.integers(-1, 2)), int(rng.integers(-1, 2))), axis=(0, 1))
    if rng.random() < 0.05:
        img[:] = img.mean(axis=2, keepdims=True)
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def batch(depth, inst, cams, index, rng, train, rgb=None):
    xs, fgs, bds = [], [], []
    for i in index:
        z, ids, flip = augment(depth[i], inst[i], rng) if train else (depth[i], inst[i], False)
        color = None
        if rgb is not None:
            color = augment_color(rgb[i], inst[i], rng) if train else rgb[i]
        x = network_input(z, cams[i], color)
        if flip:  # a mirrored world: columns reversed, x negated
            x = x[:, :, ::-1].copy()
            x[0] = -x[0]
            ids = ids[:, ::-1]
        fg, bd = targets(ids)
        xs.append(x)
        fgs.append(fg)
        bds.append(bd)
    return (torch.from_numpy(np.stack(xs)), torch.from_numpy(np.stack(fgs)), torch.from_numpy(np.stack(bds)))


def loss_fn(logits, fg, bd, boundary_weight=4.0):
    l_fg = F.binary_cross_entropy_with_logits(logits[:, 0], fg)
    l_bd = F.binary_cross_entropy_with_logits(logits[:, 1], bd, pos_weight=torch.tensor(boundary_weight))
    return l_fg + l_bd, l_fg.item(), l_bd.item()


def validate(net, depth, inst, cams, device, rgb=None):
    training = net.training
    net.eval()
    ious, counts = [], []
    with torch.no_grad():
        for i in range(len(depth)):
            x, _, _ = batch(depth, inst, cams, [i], None, False, rgb)
            prob = torch.sigmoid(net(x.to(device)))[0].cpu().numpy()
            labels = decode(prob[0], prob[1], depth[i].shape)
            mean_iou, n = match_iou(labels, inst[i])
            ious.append(mean_iou)
            counts.append(n)
    net.train(training)
    return float(np.mean(ious)), float(np.mean(counts))


def inline_identities(model):
    """torch's exporter shares equal weight tensors through Identity nodes, which
    OpenCV 4.6 DNN cannot import: give each user its own copy of the initializer."""
    inits = {t.name: t for t in model.graph.initializer}
    for node in [n for n in model.graph.node if n.op_type == "Identity" and n.input[0] in inits]:
        copy = onnx.TensorProto()
        copy.CopyFrom(inits[node.input[0]])
        copy.name = node.output[0]
        model.graph.initializer.append(copy)
        model.graph.node.remove(node)
    return model


def load_onnx_weights(net, path):
    """Starts from a model exported by export(): its Conv nodes, in graph order, are the
    network's convolutions in definition order, with each BatchNorm folded into the conv
    before it (the exporter does so in eval mode). The conv takes the folded weight, its
    BatchNorm becomes the identity plus the folded bias (mean 0, variance 1 - eps, scale 1),
    so the network computes exactly the exported function as long as BatchNorm stays in
    eval mode (train with the network in eval mode: main() does)."""
    convs = subpixel_decoder.conv_weights(onnx.load(path))  # decoder steps as one 3x3 conv each
    modules = [m for m in net.modules() if isinstance(m, torch.nn.Conv2d)]
    norms = {}
    for seq in [m for m in net.modules() if isinstance(m, torch.nn.Sequential)]:
        children = list(seq.children())
        for a, b in zip(children, children[1:]):
            if isinstance(a, torch.nn.Conv2d) and isinstance(b, torch.nn.BatchNorm2d):
                norms[a] = b
    if len(convs) != len(modules):
        raise SystemExit("%s: %d Conv nodes, the network has %d convolutions" % (path, len(convs), len(modules)))
    with torch.no_grad():
        for (name, weight, bias), conv in zip(convs, modules):
            weight = torch.from_numpy(weight.copy())
            bias = torch.from_numpy(bias.copy()) if bias is not None else torch.zeros(weight.shape[0])
            if conv is modules[0] and weight.shape[1] == 3 and conv.weight.shape[1] == 6:
                # An xyz model starts an xyz-and-colour one: colour enters with zero weights,
                # so training starts from exactly the xyz model's function.
                weight = torch.cat([weight, torch.zeros_like(weight)], 1)
            if weight.shape != conv.weight.shape:
                raise SystemExit("%s: Conv %s has weights %s, the network %s"
                                 % (path, name, tuple(weight.shape), tuple(conv.weight.shape)))
            conv.weight.copy_(weight)
            if conv in norms:
                bn = norms[conv]
                bn.weight.fill_(1.0)
                bn.bias.copy_(bias)
                bn.running_mean.zero_()
                bn.running_var.fill_(1.0 - bn.eps)
            else:
                conv.bias.copy_(bias)


def export(net, path, h, w):
    # Leaves the network in eval mode. main() trains on after a validation and export, so
    # from the first validation on BatchNorm uses its running statistics (frozen) and only
    # its scale and shift learn; the shipped model's runs trained so and reproduce so.
    net.eval()
    tmp = path + ".tmp"
    name = "xyz" if net.in_channels == 3 else "xyz_rgb"
    torch.onnx.export(net.cpu(), torch.zeros(1, net.in_channels, h, w), tmp, opset_version=11, input_names=[name],
                      output_names=["foreground_boundary"], do_constant_folding=True)
    model = inline_identities(onnx.load(tmp))
    subpixel_decoder.rewrite(model)  # the same function, a third less arithmetic in the decoder
    onnx.checker.check_model(model)
    onnx.save(model, tmp)
    os.replace(tmp, path)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--train", required=True, help="folder written by cuefusion synth-views")
    p.add_argument("--val", required=True, help="held-out folder written by cuefusion synth-views (another --seed)")
    p.add_argument("--out", required=True, help="ONNX file to write")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--iterations", type=int, default=6000)
    p.add_argument("--minutes", type=float, default=0, help="stop early after this long (0 = no limit)")
    p.add_argument("--batch", type=int, default=8)
    p.add_argument("--lr", type=float, default=3e-3)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--device", default="cpu")
    p.add_argument("--init", default="", help="start from these weights (a .pt written by an earlier run)")
    p.add_argument("--init-onnx", default="",
                   help="start from an exported model's weights (BatchNorm folded: trains with BatchNorm frozen)")
    p.add_argument("--boundary-weight", type=float, default=4.0, help="positive weight of the boundary loss")
    p.add_argument("--color", action="store_true",
                   help="the network also sees the colour image (input xyz and RGB, 6 channels)")
    p.add_argument("--log", default="", help="JSON log of the run (default OUT.log.json)")
    a = p.parse_args()

    torch.manual_seed(a.seed)
    torch.set_num_threads(a.threads)
    rng = np.random.default_rng(a.seed)
    t0 = time.time()
    rgb = vrgb = None
    if a.color:
        depth, inst, cams, rgb = load_views(a.train, color=True)
        vdepth, vinst, vcams, vrgb = load_views(a.val, color=True)
    else:
        depth, inst, cams = load_views(a.train)
        vdepth, vinst, vcams = load_views(a.val)
    print("loaded %d training and %d validation views in %.0f s" % (len(depth), len(vdepth), time.time() - t0), flush=True)

    net = XyzInstanceNet(in_channels=6 if a.color else 3)
    if a.init:
        net.load_state_dict(torch.load(a.init, map_location="cpu"))
    if a.init_onnx:
        load_onnx_weights(net, a.init_onnx)
        net.eval()  # BatchNorm frozen as the identity the fold left (see load_onnx_weights)
    net.to(a.device)
    opt = torch.optim.AdamW(net.parameters(), lr=a.lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=a.lr, total_steps=a.iterations, pct_start=0.05)
    log = {"args": vars(a), "parameters": sum(p.numel() for p in net.parameters()), "history": []}
    t0 = time.time()
    run_fg = run_bd = 0.0
    it = 0
    for it in range(1, a.iterations + 1):
        index = rng.integers(0, len(depth), a.batch)
        x, fg, bd = batch(depth, inst, cams, index, rng, True, rgb)
        logits = net(x.to(a.device))
        loss, l_fg, l_bd = loss_fn(logits, fg.to(a.device), bd.to(a.device), a.boundary_weight)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        run_fg = 0.98 * run_fg + 0.02 * l_fg if it > 1 else l_fg
        run_bd = 0.98 * run_bd + 0.02 * l_bd if it > 1 else l_bd
        minutes = (time.time() - t0) / 60
        if it % 250 == 0 or it == a.iterations or (a.minutes and minutes > a.minutes):
            entry = {"iteration": it, "minutes": round(minutes, 2), "loss_fg": round(run_fg, 4), "loss_boundary": round(run_bd, 4)}
            if it % 1000 == 0 or it == a.iterations or (a.minutes and minutes > a.minutes):
                entry["val_mean_iou"], entry["val_instances"] = validate(net, vdepth, vinst, vcams, a.device, vrgb)
                export(net, a.out, depth.shape[1], depth.shape[2])
                torch.save(net.state_dict(), a.out + ".pt")
                net.to(a.device)
            log["history"].append(entry)
            print(json.dumps(entry), flush=True)
        if a.minutes and minutes > a.minutes:
            break
    log["iterations_done"] = it
    log["minutes"] = round((time.time() - t0) / 60, 2)
    log["threads"] = a.threads
    with open(a.log or a.out + ".log.json", "w") as f:
        json.dump(log, f, indent=1)
    print("wrote %s after %d iterations, %.1f min" % (a.out, it, log["minutes"]))


if __name__ == "__main__":
    main()
