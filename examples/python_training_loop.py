#!/usr/bin/env python3
"""A training loop fed by facesynth's stream, in numpy alone: a linear landmark regressor learned from
grey 64x64 thumbnails, one SGD step per streamed batch, no files in between (docs/python.md shows the
same with PyTorch's DataLoader).
  PYTHONPATH=build/python python3 examples/python_training_loop.py [STEPS]"""

import sys

import numpy as np

import facesynth

steps = int(sys.argv[1]) if len(sys.argv) > 1 else 30
gen = facesynth.Generator(config={"pose.yaw.min": -30, "pose.yaw.max": 30}, seed=1, size=64, workers=2)
weights = np.zeros((64 * 64 + 1, 136))
losses = []
for step, batch in zip(range(steps), gen.batches(32)):
    x = np.c_[batch["image"].mean(axis=3).reshape(32, -1) / 255, np.ones(32)]  # pixels and a bias
    y = batch["landmarks"].reshape(32, -1) / 64                                # landmarks in image widths
    error = x @ weights - y
    weights -= 1e-3 * x.T @ error / 32
    losses.append(float((error ** 2).mean()))
print(f"python_training_loop: {steps} batches of 32, loss {losses[0]:.4f} -> {losses[-1]:.4f}")
sys.exit(0 if losses[-1] < 0.5 * losses[0] else 1)
