#!/usr/bin/env python3
"""Paper-style fitting sweep: error vs number of landmarks (7/13/49/68) and landmark noise (0/1/2/4 px).

Runs `facesynth eval fit` for every combination and writes a Markdown table and an SVG plot.
Usage: tools/fit_sweep.py FACESYNTH MODEL OUT_DIR [--count N] [--refine] [--data DATASET [--mode fixed|contour]]
With --data the cases are the samples of a rendered `facesynth synth` dataset (eval fit --data).
"""
import argparse
import json
import os
import subprocess

SETS = ["7", "13", "49", "68"]
NOISES = [0, 1, 2, 4]
COLOURS = {"7": "#d62728", "13": "#ff7f0e", "49": "#2ca02c", "68": "#1f77b4"}


def run(args, landmark_set, noise):
    out = os.path.join(args.out, f"eval_{landmark_set}_{noise}.json")
    cmd = [args.facesynth, "eval", "fit", "--model", args.model, "--landmarks", landmark_set, "--noise", str(noise),
           "--count", str(args.count), "--lambda", str(args.lam), "--sigma", str(max(1.0, noise)), "--quiet", "--json", out]
    if args.refine:
        cmd.append("--refine")
    if args.data:
        cmd += ["--data", args.data, "--mode", args.mode]
    subprocess.run(cmd, check=True)
    with open(out) as f:
        return json.load(f)


def panel(results, key, title, x0, y0, w, h):
    top = max(results[s][n][key] for s in SETS for n in NOISES) * 1.1
    parts = [f'<rect x="{x0}" y="{y0}" width="{w}" height="{h}" fill="none" stroke="#444"/>',
             f'<text x="{x0 + w / 2}" y="{y0 - 8}" text-anchor="middle" font-size="14">{title}</text>']
    sx = lambda n: x0 + w * n / NOISES[-1]
    sy = lambda v: y0 + h - h * v / top
    for n in NOISES:
        parts.append(f'<text x="{sx(n)}" y="{y0 + h + 16}" text-anchor="middle" font-size="11">{n} px</text>')
    for t in range(5):
        v = top * t / 4
        parts.append(f'<text x="{x0 - 6}" y="{sy(v) + 4}" text-anchor="end" font-size="11">{v:.2f}</text>')
    for s in SETS:
        pts = " ".join(f"{sx(n):.1f},{sy(results[s][n][key]):.1f}" for n in NOISES)
        parts.append(f'<polyline points="{pts}" fill="none" stroke="{COLOURS[s]}" stroke-width="2"/>')
    return parts


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("facesynth")
    p.add_argument("model")
    p.add_argument("out")
    p.add_argument("--count", type=int, default=300)
    p.add_argument("--lam", type=float, default=30)
    p.add_argument("--refine", action="store_true")
    p.add_argument("--data", default="", help="a facesynth synth dataset folder (default: cases generated in code)")
    p.add_argument("--mode", default="fixed", choices=["fixed", "contour"], help="jaw labels with --data")
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    results = {s: {n: run(args, s, n) for n in NOISES} for s in SETS}

    lines = ["| landmarks | noise px | yaw MAE ° | pitch MAE ° | roll MAE ° | vertex RMSE mm | mean-shape RMSE mm | α RMSE | ms/fit |",
             "|---|---|---|---|---|---|---|---|---|"]
    for s in SETS:
        for n in NOISES:
            r = results[s][n]
            lines.append(f"| {s} | {n} | {r['yaw_mae_deg']:.2f} | {r['pitch_mae_deg']:.2f} | {r['roll_mae_deg']:.2f} | "
                         f"{r['vertex_rmse_mm']:.2f} | {r['vertex_rmse_mm_meanshape']:.2f} | {r['alpha_rmse']:.3f} | {r['ms_per_fit']:.2f} |")
    with open(os.path.join(args.out, "sweep.md"), "w") as f:
        f.write("\n".join(lines) + "\n")

    svg = ['<svg xmlns="http://www.w3.org/2000/svg" width="900" height="340" font-family="sans-serif">',
           '<rect width="900" height="340" fill="white"/>']
    svg += panel(results, "vertex_rmse_mm", "identity vertex RMSE (mm)", 70, 40, 340, 240)
    svg += panel(results, "yaw_mae_deg", "yaw MAE (degrees)", 520, 40, 340, 240)
    for i, s in enumerate(SETS):
        svg.append(f'<text x="{300 + 90 * i}" y="325" font-size="12" fill="{COLOURS[s]}">{s} landmarks</text>')
    svg.append("</svg>")
    with open(os.path.join(args.out, "sweep.svg"), "w") as f:
        f.write("\n".join(svg) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
