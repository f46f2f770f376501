#!/usr/bin/python3
"""Trains the grasp network of vision/grasp/ggcnn_detector.hpp and exports it to ONNX.

Paper 003 (Sec. 4, "Robot Grab Detection Method") as a small GG-CNN-style network: a feature
extraction module (Conv2D + BN + ReLU, Sec. 4.1), a grasp detection module of residual blocks
(Sec. 4.2, eq. (11)) and an up-sampling path back to the input size that gives four maps
per pixel: grasp quality, cos 2 theta, sin 2 theta and width (eq. (12): G = (p, theta, w, q)),
trained on the squared error of eqs. (13)-(14). Differences from the paper, and why
(docs/grasp.md "Network"):
  - nearest-neighbour up-sampling + 3x3 convolution instead of transposed convolutions
    (CTAB): ~15x faster to train on these CPUs (/work/shared/PITFALLS.md), loads in cv::dnn;
  - strided convolutions instead of max pooling, 4 residual blocks of 32 channels with
    dilations 1, 2, 4, 1 instead of 5 of 128/256: a model of ~110 k parameters (< 1 MB) whose
    receptive field still spans the whole bin;
  - the quality target is a Gaussian (sigma 2 mm) across the line of true grasp centres, not
    GG-CNN's middle third of each rectangle: a thin arm then peaks as high as a wide block;
  - the squared error weighted: grasp pixels are a fraction of a percent of an image, so the
    quality term weighs them up to 10x, and the angle and width terms count on grasps only;
    --width-weight weighs the width term up (its target is opening / 50 px, so an error of
    7 mm costs 1/200 of the loss); 1 (the committed model), 10 tried (docs/grasp.md);
  - trained on 144 x 144 crops (60 % around a true grasp, 20 % around something standing on
    the floor that is no grasp: a clutter box, a part's hub; the rest anywhere), 4x cheaper
    than whole images. The 20 % "hard negatives" (--hard-negatives) came from the analysis of
    the previous model's misses: its best peak lay on a clutter box or off the part's grasps
    on 157 of 562 held-out images (docs/grasp.md "Failure analysis").

Data: our own depth scenes (`vgr sim render --3d --grasps`, the three parts of
sim/depth_parts.hpp among clutter in a bin), their grasp ground truth (sim/grasp_truth.hpp)
turned into input and target tensors by `vgr grasp tensors` (the C++ code the detector uses,
so training and inference see the same input). Held-out scenes (other seeds) are scored by
`vgr eval --grasp` at the end, against the analytic baseline.

Reproduce (CPU only, Debian's python3-torch; figures in docs/grasp.md):
    nice -n 19 /usr/bin/python3 models/grasp/train_ggcnn.py --vgr build/bin/vgr \
        --work /tmp/ggcnn-work --out models/grasp/ggcnn.onnx --threads 1
Writes the model, OUT with .json (the run's figures) and prints one JSON line at the end.
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

# Training scenes: (part, parts per scene, clutter, scenes, seed). Validation and the held-out
# evaluation sets use other seeds (renderDepthScene is deterministic in (seed, index)).
PARTS = ["bracket", "housing", "lever"]
TRAIN_SETS = [(p, n, c, k, 100 + 10 * i + j)
              for i, p in enumerate(PARTS)
              for j, (n, c, k) in enumerate([(1, 0, 100), (2, 4, 200), (3, 10, 200)])]
VAL_SETS = [(p, 2, 6, 30, 500 + i) for i, p in enumerate(PARTS)]
# The --min-quality sweep also runs on clean validation scenes (1 part, no clutter): among
# clutter every scene has a strong peak, alone a part's peak is weaker (evaluate()).
SWEEP_SETS = VAL_SETS + [(p, 1, 0, 30, 600 + i) for i, p in enumerate(PARTS)]
EVAL_SETS = {"clean": [(p, 1, 0, 100, 1000 + i) for i, p in enumerate(PARTS)],
             "cluttered": [(p, 3, 12, 100, 2000 + i) for i, p in enumerate(PARTS)]}


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    return r.stdout


def render(vgr, work, spec, tensors=True):
    part, n, clutter, count, seed = spec
    name = "%s-p%d-c%d-n%d-s%d" % (part, n, clutter, count, seed)
    ds = os.path.join(work, "sets", name)
    if not os.path.exists(os.path.join(ds, "grasps.csv")):
        run([vgr, "sim", "render", "--3d", "--grasps", "--views", "0", "--part", part, "--parts", str(n),
             "--clutter", str(clutter), "--count", str(count), "--seed", str(seed), "--empty-ratio", "0.03",
             "--out", ds])
    if not tensors:
        return ds, None
    tn = os.path.join(work, "tensors", name)
    if not os.path.exists(os.path.join(tn, "target.npy")):
        run([vgr, "grasp", "tensors", "--dataset", ds, "--out", tn])
    return ds, tn


def load(tensor_dirs):
    xs, ys = [], []
    for d in tensor_dirs:
        xs.append(np.load(os.path.join(d, "input.npy")))
        ys.append(np.load(os.path.join(d, "target.npy")))
    return np.concatenate(xs), np.concatenate(ys)


def cbr(cin, cout, k, stride=1, dil=1):
    return nn.Sequential(nn.Conv2d(cin, cout, k, stride, padding=dil * (k // 2), dilation=dil, bias=False),
                         nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class ResidualBlock(nn.Module):  # paper 003 Sec. 4.2, "RB"
    def __init__(self, c, dil):
        super().__init__()
        self.a = cbr(c, c, 3, 1, dil)
        self.b = nn.Sequential(nn.Conv2d(c, c, 3, 1, padding=dil, dilation=dil, bias=False), nn.BatchNorm2d(c))

    def forward(self, x):
        return F.relu(x + self.b(self.a(x)))


class GraspNet(nn.Module):
    """Input 1 x 1 x H x W (H, W multiples of 12), output 1 x 4 x H x W."""

    def __init__(self):
        super().__init__()
        # feature extraction module (Sec. 4.1): /3, /6, /12
        self.e1 = cbr(1, 16, 9, 3)
        self.e2 = cbr(16, 32, 5, 2)
        self.e3 = cbr(32, 32, 3, 2)
        # grasp detection module (Sec. 4.2): residual blocks, dilated for a bin-wide view
        self.res = nn.Sequential(ResidualBlock(32, 1), ResidualBlock(32, 2), ResidualBlock(32, 4), ResidualBlock(32, 1))
        # up-sampling back to the input size (nearest + 3x3 conv instead of CTAB), with skips
        self.d2 = cbr(64, 16, 3)
        self.d1 = cbr(32, 16, 3)
        self.h1 = nn.Sequential(nn.Conv2d(17, 8, 1), nn.ReLU(inplace=True))
        self.head = nn.Conv2d(8, 4, 3, padding=1)

    def forward(self, x):
        x1 = self.e1(x)
        x2 = self.e2(x1)
        x3 = self.res(self.e3(x2))
        y = self.d2(torch.cat([F.interpolate(x3, scale_factor=2.0, mode="nearest"), x2], 1))
        y = self.d1(torch.cat([F.interpolate(y, scale_factor=2.0, mode="nearest"), x1], 1))
        y = self.h1(torch.cat([F.interpolate(y, scale_factor=3.0, mode="nearest"), x], 1))
        return self.head(y)


def loss_fn(out, tgt, pos_weight, width_weight=1.0):
    """Paper 003's eqs. (13)-(14), 0.5 (G - G^)^2 averaged, weighted: the quality term by
    1 + (pos_weight - 1) q (grasp pixels are a fraction of a percent of the image), the angle
    and width terms by the target quality q (they mean something only on grasps)."""
    q = tgt[:, 0:1]
    lq = ((1.0 + (pos_weight - 1.0) * q) * (out[:, 0:1] - q) ** 2).mean()
    mass = q.sum().clamp(min=1.0)
    la = (q * (out[:, 1:3] - tgt[:, 1:3]) ** 2).sum() / mass
    lw = (q * (out[:, 3:4] - tgt[:, 3:4]) ** 2).sum() / mass
    return 0.5 * (lq + la + width_weight * lw)


def augment(x, y, k):
    """One of the 8 symmetries of the pixel grid for a whole batch; the angle maps follow.
    Angles are counter-clockwise as displayed (image y down): a left-right or up-down flip
    turns theta into -theta (mod 180: sin 2 theta changes sign); a quarter turn
    counter-clockwise adds 90 deg (cos 2 theta and sin 2 theta change sign)."""
    if k & 1:  # left-right
        x, y = x.flip(3), y.flip(3)
        y = torch.cat([y[:, 0:2], -y[:, 2:3], y[:, 3:4]], 1)
    if k & 2:  # up-down
        x, y = x.flip(2), y.flip(2)
        y = torch.cat([y[:, 0:2], -y[:, 2:3], y[:, 3:4]], 1)
    if k & 4:  # quarter turn counter-clockwise as displayed
        x, y = torch.rot90(x, 1, (2, 3)), torch.rot90(y, 1, (2, 3))
        y = torch.cat([y[:, 0:1], -y[:, 1:3], y[:, 3:4]], 1)
    return x, y


def check_augment():
    """A grasp drawn at angle a must read a + the symmetry's change after augment()."""
    h, w = 24, 36
    for k in range(8):
        a = np.deg2rad(25.0)
        t = torch.zeros(1, 4, h, w)
        t[0, 0, 5, 7] = 1
        t[0, 1, 5, 7] = np.cos(2 * a)
        t[0, 2, 5, 7] = np.sin(2 * a)
        # the direction of the grasp axis, drawn as two pixels along it (y down)
        img = torch.zeros(1, 1, 48, 48)
        img[0, 0, 24, 24] = 1
        img[0, 0, 24 - round(10 * np.sin(a)), 24 + round(10 * np.cos(a))] = 2
        img2, t2 = augment(img, t, k)
        ys, xs = np.nonzero(img2[0, 0].numpy() == 2)
        y0, x0 = np.nonzero(img2[0, 0].numpy() == 1)
        expect = np.arctan2(-(ys[0] - y0[0]), xs[0] - x0[0])
        qy, qx = np.nonzero(t2[0, 0].numpy())
        got = 0.5 * np.arctan2(t2[0, 2, qy[0], qx[0]].item(), t2[0, 1, qy[0], qx[0]].item())
        d = (got - expect) % np.pi
        assert min(d, np.pi - d) < np.deg2rad(6), (k, np.rad2deg(got), np.rad2deg(expect))


def export(net, path):
    """ONNX opset 11, BN folded into the convolutions; any H, W that are multiples of 12."""
    net.eval()
    torch.onnx.export(net, torch.zeros(1, 1, 240, 324), path, opset_version=11, input_names=["height"],
                      output_names=["grasp"], do_constant_folding=True)


def totals(results, detector):
    """Sums one detector's counts over several `vgr eval --grasp --json` results."""
    t = {"graspable": 0, "found": 0, "rect_successes": 0, "pos_successes": 0, "false_positives": 0}
    for r in results:
        for k in t:
            t[k] += r[detector][k]
    g = max(t["graspable"], 1)
    t["rect_success_rate"] = round(t["rect_successes"] / g, 4)
    t["pos_success_rate"] = round(t["pos_successes"] / g, 4)
    return t


def evaluate(a, summary):
    """The figures the model reached, through the C++ detectors (`vgr eval --grasp`):
    1. the validation sets (seeds 500-502 cluttered, 600-602 clean) at several --min-quality
       values: the detector's default (vision/grasp/grasp_detector.hpp) is chosen from this
       sweep (the highest value with the best success), never from the held-out sets;
    2. the held-out sets (seeds 1000+ clean, 2000+ cluttered) at the default, both detectors."""
    sweep = {}
    for q in (0.05, 0.1, 0.2, 0.3, 0.4, 0.5):
        res = []
        for s in SWEEP_SETS:
            ds, _ = render(a.vgr, a.work, s, tensors=False)
            out = run([a.vgr, "eval", "--grasp", "--detectors", "ggcnn", "--dataset", ds, "--model", a.out,
                       "--min-quality", str(q), "--json"])
            res.append(json.loads(out.strip().splitlines()[-1]))
        sweep[str(q)] = totals(res, "ggcnn")
        print(json.dumps({"validation_min_quality": q, "ggcnn": sweep[str(q)]}), flush=True)
    summary["validation_sweep"] = sweep
    for name, specs in EVAL_SETS.items():
        per_set = {}
        for s in specs:
            ds, _ = render(a.vgr, a.work, s, tensors=False)
            out = run([a.vgr, "eval", "--grasp", "--dataset", ds, "--model", a.out, "--json"])
            per_set[s[0]] = json.loads(out.strip().splitlines()[-1])
        summary["eval_" + name] = per_set
        summary["eval_" + name + "_total"] = {d: totals(per_set.values(), d) for d in ("ggcnn", "analytic")}
        print(json.dumps({"held_out": name, **summary["eval_" + name + "_total"]}), flush=True)
    print(json.dumps({k: v for k, v in summary.items() if k not in ("history",) and not (k.startswith("eval_") and not k.endswith("_total"))}))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vgr", default="build/bin/vgr")
    ap.add_argument("--work", default="/tmp/ggcnn-work", help="rendered sets and tensors (cached)")
    ap.add_argument("--out", default="models/grasp/ggcnn.onnx")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--epochs", type=int, default=20)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--crop", type=int, default=144, help="training crops, px of the network input (a multiple of 12)")
    ap.add_argument("--crops-per-image", type=int, default=2)
    ap.add_argument("--centred", type=float, default=0.6, help="share of crops around a true grasp (the rest anywhere)")
    ap.add_argument("--hard-negatives", type=float, default=0.2,
                    help="share of crops around something standing on the floor that is no grasp (clutter, a part's hubs; "
                         "the rest of the crops anywhere): docs/grasp.md")
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--pos-weight", type=float, default=10.0)
    ap.add_argument("--width-weight", type=float, default=1.0,
                    help="weight of the width term (an error of 0.1 in opening / 50 px is 5 network px, 7 mm, yet 0.005 of loss); "
                         "10 was tried: docs/grasp.md")
    ap.add_argument("--threads", type=int, default=1,
                    help="torch threads (1: on our shared 2-core machines under load, 2 threads ran 3x slower)")
    ap.add_argument("--no-eval", action="store_true", help="skip the held-out evaluation")
    ap.add_argument("--eval-only", action="store_true",
                    help="no training: evaluate the model at --out (the validation sweep and the held-out sets) and add the figures to its .json")
    a = ap.parse_args()
    if a.threads not in (1, 2):
        sys.exit("--threads: 1 or 2 (the machine is shared)")
    if a.eval_only:
        summary_path = os.path.splitext(a.out)[0] + ".json"
        summary = {}
        if os.path.exists(summary_path):
            with open(summary_path) as f:
                summary = json.load(f)
        evaluate(a, summary)
        with open(summary_path, "w") as f:
            json.dump(summary, f, indent=1)
        return

    t_wall0, t_cpu0 = time.time(), time.process_time()
    torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    rng = np.random.default_rng(a.seed)
    check_augment()

    print("rendering and converting %d training and %d validation sets" % (len(TRAIN_SETS), len(VAL_SETS)), flush=True)
    train_dirs = [render(a.vgr, a.work, s)[1] for s in TRAIN_SETS]
    val_dirs = [render(a.vgr, a.work, s)[1] for s in VAL_SETS]
    xtr, ytr = load(train_dirs)
    xva, yva = load(val_dirs)
    print("train %s, val %s, grasp pixels (quality > 0.5) %.3f %%" % (xtr.shape, xva.shape, 100 * float((ytr[:, 0] > 0.5).mean())),
          flush=True)
    t_data = time.time() - t_wall0

    net = GraspNet()
    params = sum(p.numel() for p in net.parameters())
    opt = torch.optim.Adam(net.parameters(), lr=a.lr)
    # Where the grasps are (network px), for crops around them.
    grasp_px = [np.argwhere(ytr[i, 0] > 0.5) for i in range(len(ytr))]
    # Where objects that are no grasp stand (>= 3 mm above the floor, target quality < 0.01),
    # up to 256 such pixels per image: hard negatives (--hard-negatives).
    object_px = []
    if a.hard_negatives > 0:
        for i in range(len(xtr)):
            o = np.argwhere((xtr[i, 0] >= 3.0 / 50.0) & (ytr[i, 0] < 0.01))
            object_px.append(o[rng.permutation(len(o))[:256]].astype(np.int16) if len(o) else o)
    samples = len(xtr) * a.crops_per_image
    steps_per_epoch = (samples + a.batch - 1) // a.batch
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=a.lr, total_steps=a.epochs * steps_per_epoch, pct_start=0.15)
    history = []
    rows, cols, c = xtr.shape[2], xtr.shape[3], a.crop
    for epoch in range(a.epochs):
        net.train()
        t0, c0 = time.time(), time.process_time()
        images = rng.permutation(np.repeat(np.arange(len(xtr)), a.crops_per_image))
        total = 0.0
        for b in range(steps_per_epoch):
            idx = images[b * a.batch:(b + 1) * a.batch]
            xb = np.empty((len(idx), 1, c, c), np.float32)
            yb = np.empty((len(idx), 4, c, c), np.float32)
            for k, i in enumerate(idx):
                g = grasp_px[i]
                if a.hard_negatives > 0:  # (the branch keeps the random sequence of --hard-negatives 0 as it was)
                    u = rng.random()
                    if not (len(g) and u < a.centred):
                        g = object_px[i] if a.centred <= u < a.centred + a.hard_negatives else g[:0]
                    pick = len(g) > 0
                else:
                    pick = len(g) and rng.random() < a.centred
                if pick:  # a true grasp (or, --hard-negatives, something that is none) somewhere in the crop
                    cy, cx = g[rng.integers(len(g))]
                    y0 = int(cy) - c // 2 + int(rng.integers(-(c // 2 - 24), c // 2 - 24 + 1))
                    x0 = int(cx) - c // 2 + int(rng.integers(-(c // 2 - 24), c // 2 - 24 + 1))
                else:
                    y0, x0 = int(rng.integers(rows - c + 1)), int(rng.integers(cols - c + 1))
                y0, x0 = min(max(y0, 0), rows - c), min(max(x0, 0), cols - c)
                xb[k] = xtr[i, :, y0:y0 + c, x0:x0 + c]
                yb[k] = ytr[i, :, y0:y0 + c, x0:x0 + c]
            x, y = augment(torch.from_numpy(xb), torch.from_numpy(yb), int(rng.integers(8)))
            opt.zero_grad()
            loss = loss_fn(net(x), y, a.pos_weight, a.width_weight)
            loss.backward()
            opt.step()
            sched.step()
            total += loss.item() * len(idx)
        net.eval()
        with torch.no_grad():
            vl = sum(loss_fn(net(torch.from_numpy(xva[i:i + 8].astype(np.float32))),
                             torch.from_numpy(yva[i:i + 8].astype(np.float32)), a.pos_weight, a.width_weight).item() * len(xva[i:i + 8])
                     for i in range(0, len(xva), 8)) / len(xva)
        history.append({"epoch": epoch + 1, "train_loss": total / samples, "val_loss": vl,
                        "wall_s": round(time.time() - t0, 1), "cpu_s": round(time.process_time() - c0, 1)})
        print(json.dumps(history[-1]), flush=True)
        export(net, os.path.join(a.work, "epoch-%02d.onnx" % (epoch + 1)))

    net.eval()
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    export(net, a.out)
    t_train_wall, t_train_cpu = time.time() - t_wall0, time.process_time() - t_cpu0
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    summary = {"model": a.out, "bytes": os.path.getsize(a.out), "parameters": params, "seed": a.seed,
               "epochs": a.epochs, "batch": a.batch, "crop": a.crop, "crops_per_image": a.crops_per_image,
               "centred": a.centred, "hard_negatives": a.hard_negatives, "lr": a.lr, "pos_weight": a.pos_weight, "width_weight": a.width_weight, "threads": a.threads,
               "torch": torch.__version__, "train_images": int(len(xtr)), "val_images": int(len(xva)),
               "final_train_loss": history[-1]["train_loss"], "final_val_loss": history[-1]["val_loss"],
               "wall_s": round(t_train_wall, 1), "cpu_s": round(t_train_cpu + children.ru_utime + children.ru_stime, 1),
               "data_wall_s": round(t_data, 1), "history": history}

    if not a.no_eval:
        evaluate(a, summary)
    with open(os.path.splitext(a.out)[0] + ".json", "w") as f:
        json.dump(summary, f, indent=1)
    if a.no_eval:
        print(json.dumps({k: v for k, v in summary.items() if k != "history"}))


if __name__ == "__main__":
    main()
