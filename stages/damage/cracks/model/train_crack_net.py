#!/usr/bin/python3
"""Trains the learned crack detector (a compact U-Net) and exports it to ONNX.

Data: the TRAIN splits of the crack patch sets only (crack500/train, deepcrack/train; layout
<set>/train/images/NAME.jpg + masks/NAME.jpg, mask >= 128 = crack). A hold-out of whole source
photographs (file-name prefix before the last '-') is kept out of training; it picks the epoch
and the probability threshold. The valid splits are never read.

Input: grey (ITU-R 601 weights, as OpenCV's BGR2GRAY), normalised per image to zero mean and unit
standard deviation (the C++ side does the same per tile), shape N x 1 x H x W with H, W multiples
of STRIDE. Output: crack probability (sigmoid), same size.

Prerequisites (a developer step, not needed to build or test): Debian's python3-torch (1.13),
python3-onnx, python3-numpy, python3-pil; CPU only. Run from the repository root:

  /usr/bin/python3 stages/damage/cracks/model/train_crack_net.py \
      --data /work/shared/data/crack_patches --out stages/damage/cracks/model

Writes crack_net.onnx and crack_net.json (training settings, hold-out figures, chosen threshold,
SHA-256 of the training data and of the model file) into --out.
"""

import argparse
import hashlib
import json
import os
import platform
import random
import sys
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from PIL import Image

STRIDE = 8  # three 2x2 poolings


def set_seeds(seed):
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    torch.use_deterministic_algorithms(True)


def list_pairs(data, sets):
    pairs = []
    for s in sets:
        d = os.path.join(data, s, "train")
        for name in sorted(os.listdir(os.path.join(d, "images"))):
            if os.path.isfile(os.path.join(d, "masks", name)):
                pairs.append((s, name, os.path.join(d, "images", name), os.path.join(d, "masks", name)))
    return pairs


def data_sha256(pairs, data):
    """SHA-256 over the sorted relative file names and their contents (image, then mask)."""
    h = hashlib.sha256()
    files = []
    for _, _, img, msk in pairs:
        files += [img, msk]
    for f in sorted(files, key=lambda p: os.path.relpath(p, data)):
        h.update(os.path.relpath(f, data).encode())
        h.update(b"\0")
        with open(f, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()


def grey_of(path):
    # OpenCV's BGR2GRAY weights (0.299 R + 0.587 G + 0.114 B), float.
    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.float32)
    return rgb[..., 0] * 0.299 + rgb[..., 1] * 0.587 + rgb[..., 2] * 0.114


def normalise(g):
    return (g - g.mean()) / max(float(g.std()), 1.0)


def load(pairs):
    out = []
    for s, name, img, msk in pairs:
        g = grey_of(img)
        m = np.asarray(Image.open(msk).convert("L"), dtype=np.uint8) >= 128
        if m.shape != g.shape:
            raise SystemExit(f"{msk}: mask size differs from the image's")
        out.append((s, name, g, m.astype(np.float32)))
    return out


def split_holdout(items, fraction, seed):
    """Whole source photographs (prefix before the last '-') go to the hold-out."""
    groups = sorted({(s, n.rsplit("-", 1)[0]) for s, n, _, _ in items})
    rng = random.Random(seed)
    rng.shuffle(groups)
    held = set(groups[: max(1, int(round(fraction * len(groups))))])
    train = [it for it in items if (it[0], it[1].rsplit("-", 1)[0]) not in held]
    hold = [it for it in items if (it[0], it[1].rsplit("-", 1)[0]) in held]
    return train, hold


class Block(nn.Sequential):
    def __init__(self, cin, cout):
        super().__init__(
            nn.Conv2d(cin, cout, 3, padding=1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True),
            nn.Conv2d(cout, cout, 3, padding=1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class CrackNet(nn.Module):
    """U-Net, three poolings: Conv, BatchNorm (folded on export), ReLU, MaxPool, ConvTranspose, Concat, Sigmoid."""

    def __init__(self, c=16):
        super().__init__()
        self.e1, self.e2, self.e3 = Block(1, c), Block(c, 2 * c), Block(2 * c, 4 * c)
        self.b = Block(4 * c, 8 * c)
        self.u3, self.d3 = nn.ConvTranspose2d(8 * c, 4 * c, 2, stride=2), Block(8 * c, 4 * c)
        self.u2, self.d2 = nn.ConvTranspose2d(4 * c, 2 * c, 2, stride=2), Block(4 * c, 2 * c)
        self.u1, self.d1 = nn.ConvTranspose2d(2 * c, c, 2, stride=2), Block(2 * c, c)
        self.head = nn.Conv2d(c, 1, 1)
        self.pool = nn.MaxPool2d(2)

    def logits(self, x):
        e1 = self.e1(x)
        e2 = self.e2(self.pool(e1))
        e3 = self.e3(self.pool(e2))
        b = self.b(self.pool(e3))
        d3 = self.d3(torch.cat([self.u3(b), e3], 1))
        d2 = self.d2(torch.cat([self.u2(d3), e2], 1))
        d1 = self.d1(torch.cat([self.u1(d2), e1], 1))
        return self.head(d1)

    def forward(self, x):
        return torch.sigmoid(self.logits(x))


def augment(g, m, rng, crop):
    """Random crop (padded by reflection when smaller), flips, 90-degree turns, brightness,
    contrast and gamma, then the per-image normalisation over the whole patch."""
    h, w = g.shape
    if h < crop or w < crop:
        ph, pw = max(0, crop - h), max(0, crop - w)
        g = np.pad(g, ((0, ph), (0, pw)), mode="reflect")
        m = np.pad(m, ((0, ph), (0, pw)), mode="reflect")
        h, w = g.shape
    # Photometric changes on the whole patch, normalised over the whole patch (as at inference).
    gain, offset, gamma = rng.uniform(0.6, 1.4), rng.uniform(-40, 40), rng.uniform(0.7, 1.4)
    g = np.clip(g * gain + offset, 0, 255)
    g = 255.0 * (g / 255.0) ** gamma
    if rng.random() < 0.3:
        g = g + rng.normal(0, rng.uniform(1, 6), g.shape)
    g = normalise(g.astype(np.float32))
    y, x = rng.integers(0, h - crop + 1), rng.integers(0, w - crop + 1)
    g, m = g[y:y + crop, x:x + crop], m[y:y + crop, x:x + crop]
    k = int(rng.integers(0, 4))
    g, m = np.rot90(g, k), np.rot90(m, k)
    if rng.random() < 0.5:
        g, m = g[:, ::-1], m[:, ::-1]
    return np.ascontiguousarray(g), np.ascontiguousarray(m)


def dice_loss(logits, target):
    p = torch.sigmoid(logits)
    inter = (p * target).sum((1, 2, 3))
    return (1 - (2 * inter + 1) / (p.sum((1, 2, 3)) + target.sum((1, 2, 3)) + 1)).mean()


def disk(radius):
    r = int(np.floor(radius))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    return torch.tensor((xx * xx + yy * yy <= radius * radius + 1e-4).astype(np.float32))[None, None]


def predict(net, g):
    """Probability map of one normalised grey patch, padded (reflect) to a multiple of STRIDE."""
    h, w = g.shape
    ph, pw = (-h) % STRIDE, (-w) % STRIDE
    x = torch.from_numpy(np.pad(g, ((0, ph), (0, pw)), mode="reflect"))[None, None]
    with torch.no_grad():
        return net(x)[0, 0, :h, :w]


def holdout_counts(net, hold, thresholds, tol_kernel):
    """Pooled tolerant counts per threshold: predicted, predicted near truth, truth, truth near predicted."""
    net.eval()
    c = np.zeros((len(thresholds), 4))
    for _, _, g, m in hold:
        p = predict(net, normalise(g))
        t = torch.from_numpy(m)[None, None]
        t_near = F.conv2d(t, tol_kernel, padding=tol_kernel.shape[-1] // 2)[0, 0] > 0
        for i, th in enumerate(thresholds):
            pr = (p >= th).float()[None, None]
            p_near = F.conv2d(pr, tol_kernel, padding=tol_kernel.shape[-1] // 2)[0, 0] > 0
            c[i] += [pr.sum().item(), (pr[0, 0].bool() & t_near).sum().item(), t.sum().item(),
                     (t[0, 0].bool() & p_near).sum().item()]
    prec = c[:, 1] / np.maximum(c[:, 0], 1)
    rec = c[:, 3] / np.maximum(c[:, 2], 1)
    f1 = 2 * prec * rec / np.maximum(prec + rec, 1e-9)
    return prec, rec, f1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="crack_patches root (holds <set>/train)")
    ap.add_argument("--out", required=True, help="folder for crack_net.onnx and crack_net.json")
    ap.add_argument("--sets", default="crack500,deepcrack")
    ap.add_argument("--channels", type=int, default=12, help="first level's channels (doubling per level)")
    ap.add_argument("--epochs", type=int, default=10)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--crop", type=int, default=96, help="training crop (multiple of 8)")
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--holdout", type=float, default=0.12, help="fraction of source photographs held out")
    ap.add_argument("--eval-every", type=int, default=2, help="hold-out check every n epochs (and the last)")
    ap.add_argument("--seed", type=int, default=20261129)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--every", type=int, default=1, help="every n-th pair only (a quick trial run)")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    set_seeds(a.seed)
    t0 = time.time()
    sets = a.sets.split(",")
    pairs = list_pairs(a.data, sets)[::a.every]
    sha = data_sha256(pairs, a.data)
    items = load(pairs)
    train, hold = split_holdout(items, a.holdout, a.seed)
    print(f"{len(items)} pairs ({len(train)} train, {len(hold)} hold-out), data sha256 {sha}", flush=True)

    net = CrackNet(a.channels)
    n_params = sum(p.numel() for p in net.parameters())
    print(f"{n_params} parameters", flush=True)
    opt = torch.optim.AdamW(net.parameters(), lr=a.lr, weight_decay=1e-4)
    steps_per_epoch = len(train) // a.batch
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=a.lr, total_steps=a.epochs * steps_per_epoch,
                                                pct_start=0.15)
    rng = np.random.default_rng(a.seed)
    tol = disk(2.0)
    thresholds = [round(0.05 * i, 2) for i in range(2, 19)]
    best = (-1.0, None, -1)
    history = []
    for epoch in range(a.epochs):
        net.train()
        order = rng.permutation(len(train))
        total = 0.0
        for s in range(steps_per_epoch):
            batch = [augment(train[j][2], train[j][3], rng, a.crop) for j in order[s * a.batch:(s + 1) * a.batch]]
            x = torch.from_numpy(np.stack([b[0] for b in batch]))[:, None]
            y = torch.from_numpy(np.stack([b[1] for b in batch]))[:, None]
            logits = net.logits(x)
            loss = F.binary_cross_entropy_with_logits(logits, y) + dice_loss(logits, y)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += loss.item()
        line = {"epoch": epoch + 1, "loss": round(total / steps_per_epoch, 4), "wall_s": round(time.time() - t0)}
        if (epoch + 1) % a.eval_every == 0 or epoch + 1 == a.epochs:
            prec, rec, f1 = holdout_counts(net, hold, thresholds, tol)
            i = int(np.argmax(f1))
            line.update(holdout_f1=round(float(f1[i]), 4), threshold=thresholds[i])
            if f1[i] > best[0]:
                best = (float(f1[i]), {k: v.clone() for k, v in net.state_dict().items()}, epoch + 1)
        history.append(line)
        print(json.dumps(line), flush=True)

    net.load_state_dict(best[1])
    prec, rec, f1 = holdout_counts(net, hold, thresholds, tol)
    i = int(np.argmax(f1))
    threshold = thresholds[i]
    per_set = {}
    for s in sets:
        sp, sr, sf = holdout_counts(net, [h for h in hold if h[0] == s], [threshold], tol)
        per_set[s] = {"precision": round(float(sp[0]), 4), "recall": round(float(sr[0]), 4), "f1": round(float(sf[0]), 4)}
    print(f"best epoch {best[2]}: threshold {threshold}, hold-out P {prec[i]:.3f} R {rec[i]:.3f} F1 {f1[i]:.3f}",
          flush=True)

    os.makedirs(a.out, exist_ok=True)
    onnx_path = os.path.join(a.out, "crack_net.onnx")
    net.eval()
    torch.onnx.export(net, torch.zeros(1, 1, 128, 128), onnx_path, opset_version=11, input_names=["grey"],
                      output_names=["probability"], do_constant_folding=True,
                      training=torch.onnx.TrainingMode.EVAL,
                      dynamic_axes={"grey": {2: "height", 3: "width"}, "probability": {2: "height", 3: "width"}})
    import onnx  # checked after export: the file loads and uses only the expected operators
    model = onnx.load(onnx_path)
    onnx.checker.check_model(model)
    ops = sorted({n.op_type for n in model.graph.node})
    with open(onnx_path, "rb") as fh:
        model_sha = hashlib.sha256(fh.read()).hexdigest()
    wall = time.time() - t0
    meta = {
        "model": "crack_net.onnx",
        "model_sha256": model_sha,
        "architecture": f"U-Net, 3 poolings, channels {a.channels}-{2 * a.channels}-{4 * a.channels}-{8 * a.channels}",
        "parameters": n_params,
        "onnx_opset": 11,
        "onnx_operators": ops,
        "input": "1x1xHxW grey (0.299 R + 0.587 G + 0.114 B), per-image (per-tile) mean 0, std 1 (std taken as at least min_std_grey grey levels)",
        "output": "1x1xHxW crack probability",
        "stride_px": STRIDE,
        # Inference never stretches a tile flatter than the flattest training photograph.
        "min_std_grey": int(np.floor(min(float(it[2].std()) for it in items))),
        "threshold": threshold,
        "holdout": {"precision": round(float(prec[i]), 4), "recall": round(float(rec[i]), 4),
                    "f1": round(float(f1[i]), 4), "tolerance_px": 2.0, "per_set": per_set,
                    "images": len(hold), "best_epoch": best[2],
                    "files": sorted(f"{h[0]}/train/images/{h[1]}" for h in hold)},
        "training_data": {"sets": [f"{s}/train" for s in sets], "pairs": len(items), "train_pairs": len(train),
                          "holdout_pairs": len(hold),
                          "sha256": sha,
                          "sha256_of": "sorted relative paths (images/ and masks/), each path, a NUL byte, the file's bytes"},
        "settings": {"epochs": a.epochs, "batch": a.batch, "crop_px": a.crop, "lr": a.lr, "optimizer": "AdamW, one-cycle",
                     "loss": "BCE + Dice", "holdout_fraction": a.holdout, "seed": a.seed, "threads": a.threads,
                     "augmentation": "random crop, flips, 90-degree turns, gain 0.6-1.4, offset +-40, gamma 0.7-1.4, noise"},
        "history": history,
        "torch": torch.__version__,
        "python": platform.python_version(),
        "train_wall_s": round(wall),
    }
    with open(os.path.join(a.out, "crack_net.json"), "w") as fh:
        json.dump(meta, fh, indent=2)
        fh.write("\n")
    print(f"wrote {onnx_path} ({model_sha}), {wall:.0f} s", flush=True)


if __name__ == "__main__":
    sys.exit(main())
