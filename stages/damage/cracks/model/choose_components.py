#!/usr/bin/python3
"""Chooses the learned crack model's component rules on its training hold-out.

The probability threshold alone does not make a crack: the damage stage keeps a thresholded
component only when its skeleton is long enough (min_length_px) and long for its width
(min_elongation). Those two rules go with the model, chosen like its threshold on the hold-out
the training script kept out (crack_net.json: holdout.files), never on a valid split.

Each pair of the grid is scored by the real detector (`roadsurvey eval cracks --detector learned`,
pooled 2-px tolerant F1 over the hold-out); the best F1 wins, and among equal F1 (to three
decimals) the stricter rules. The choice and the whole grid are written into crack_net.json under
"components".

  /usr/bin/python3 stages/damage/cracks/model/choose_components.py \\
      --roadsurvey build/roadsurvey --data ../shared/data/crack_patches --model stages/damage/cracks/model
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

LENGTHS_PX = [2, 10, 20, 30, 40]
ELONGATIONS = [1, 2, 3, 4, 6]


def holdout_folder(files, data, root):
    """images/ and masks/ of the hold-out pairs (symbolic links; names prefixed by their set)."""
    for kind in ("images", "masks"):
        os.makedirs(os.path.join(root, kind))
    for rel in files:  # <set>/train/images/NAME
        parts = rel.split("/")
        if len(parts) != 4 or parts[2] != "images":
            raise SystemExit(f"crack_net.json: holdout file {rel!r} is not <set>/train/images/NAME")
        for kind in ("images", "masks"):
            src = os.path.join(data, parts[0], parts[1], kind, parts[3])
            if not os.path.isfile(src):
                raise SystemExit(f"{src}: missing (named by crack_net.json's hold-out)")
            os.symlink(os.path.abspath(src), os.path.join(root, kind, f"{parts[0]}_{parts[3]}"))


def score(binary, folder, model, length_px, elongation):
    cmd = [binary, "eval", "cracks", folder, "--detector", "learned", "--model", model, "--json", "-",
           "--crack.min_length_px", str(length_px), "--crack.min_elongation", str(elongation)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    total = json.loads(out)["total"]
    return {k: round(float(total[k]), 4) for k in ("precision", "recall", "f1")}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--roadsurvey", required=True, help="the built roadsurvey program")
    ap.add_argument("--data", required=True, help="crack_patches root (holds <set>/train)")
    ap.add_argument("--model", required=True, help="folder with crack_net.onnx and crack_net.json")
    a = ap.parse_args()
    meta_path = os.path.join(a.model, "crack_net.json")
    with open(meta_path) as fh:
        meta = json.load(fh)
    files = meta.get("holdout", {}).get("files")
    if not files:
        raise SystemExit(f"{meta_path}: no holdout.files (written by train_crack_net.py)")
    # Scored without rules of its own, so that the flags decide.
    meta.pop("components", None)
    with open(meta_path, "w") as fh:
        json.dump(meta, fh, indent=2)
        fh.write("\n")
    grid = []
    with tempfile.TemporaryDirectory() as tmp:
        holdout_folder(files, a.data, tmp)
        for length_px in LENGTHS_PX:
            for elongation in ELONGATIONS:
                s = score(a.roadsurvey, tmp, os.path.join(a.model, "crack_net.onnx"), length_px, elongation)
                grid.append({"min_length_px": length_px, "min_elongation": elongation, **s})
                print(json.dumps(grid[-1]), flush=True)
    best = max(grid, key=lambda g: (round(g["f1"], 3), g["min_length_px"], g["min_elongation"]))
    meta["components"] = {
        "min_length_px": best["min_length_px"],
        "min_elongation": best["min_elongation"],
        "holdout": {k: best[k] for k in ("precision", "recall", "f1")},
        "chosen_by": "best pooled 2-px F1 on the hold-out (equal to 3 decimals: the stricter rules)",
        "grid": grid,
    }
    with open(meta_path, "w") as fh:
        json.dump(meta, fh, indent=2)
        fh.write("\n")
    print(f"components: min_length_px {best['min_length_px']}, min_elongation {best['min_elongation']}, "
          f"hold-out F1 {best['f1']:.3f}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
