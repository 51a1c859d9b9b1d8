#!/usr/bin/env python3
"""Which sampled parameters make renders hard to read: per-face NME from `facesynth eval landmarks
--nme-csv` on a synth dataset, joined with each sample's meta file (docs/train.md).

    facesynth eval landmarks --regressor dlib --data DATASET_OR_FOLDER --detector dlib --nme-csv F.csv
    tools/nme_factors.py F.csv DATASET [--column 1] [--bins 5] [--max-yaw 20]

For the faces the detector found (with --max-yaw, those within it), and for every number the meta files
hold for a sample (|yaw|, |pitch|, |roll|, fov, each degradation and lighting value, the number of
directional lights, the inter-ocular distance in pixels): its Pearson
correlation with the NME and the mean NME per quantile bin of it. For the texture (a categorical
parameter) the split-half correlation: the NMEs of two renders of the same texture, over textures with
at least two renders (near 0: the texture does not decide how hard a render is). With --bank (the
texture bank the dataset was rendered from), each texture's mean NME over its renders (as the first
texture, at least three renders) is related to the bank's numbers for it (fit_error, seen_share,
face_coverage, ...: docs/textures.md), and the --worst N textures are listed with their photographs.
The CSV's keys are matched to DATASET/meta by their last path component, so a folder of links to a
dataset's images and .pts works too. Standard library only.
"""
import argparse
import json
import math
import os
import sys

from nme_csv import read_nme_rows, sample_name


def pearson(a, b):
    n = len(a)
    if n < 3:
        return float("nan")
    ma, mb = sum(a) / n, sum(b) / n
    sa = math.sqrt(sum((x - ma) ** 2 for x in a))
    sb = math.sqrt(sum((y - mb) ** 2 for y in b))
    if sa == 0 or sb == 0:
        return float("nan")
    return sum((x - ma) * (y - mb) for x, y in zip(a, b)) / (sa * sb)


def factors_of(meta):
    """The numeric parameters of one sample's meta file, by name."""
    out = {}
    for name in ("yaw", "pitch", "roll"):
        if isinstance(meta.get(name), (int, float)):
            out["abs_" + name] = abs(meta[name])
    if isinstance(meta.get("fov"), (int, float)):
        out["fov"] = meta["fov"]
    for group in ("degradation", "lighting"):
        for key, value in (meta.get(group) or {}).items():
            if isinstance(value, bool):
                out[f"{group}.{key}"] = float(value)
            elif isinstance(value, (int, float)):
                out[f"{group}.{key}"] = value
            elif isinstance(value, list) and value and all(isinstance(v, (int, float)) for v in value):
                out[f"{group}.{key}_mean"] = sum(value) / len(value)
    lights = (meta.get("lighting") or {}).get("lights")
    if isinstance(lights, list):
        out["lighting.directional_lights"] = len(lights)
    landmarks = meta.get("landmarks")
    if isinstance(landmarks, list) and len(landmarks) == 68:
        out["interocular_px"] = math.dist(landmarks[36], landmarks[45])
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("csv", help="per-face NMEs from `facesynth eval landmarks --nme-csv`")
    parser.add_argument("dataset", help="the synth dataset whose meta/ folder describes the faces")
    parser.add_argument("--column", type=int, default=1, help="which regressor's NME (1 = the first)")
    parser.add_argument("--bins", type=int, default=5, help="quantile bins per parameter")
    parser.add_argument("--max-yaw", type=float, default=None, help="only the faces with |yaw| up to this (degrees; the CSV's yaw_deg)")
    parser.add_argument("--bank", help="the texture bank the dataset was rendered from: relate each texture's mean NME to its numbers")
    parser.add_argument("--worst", type=int, default=10, help="with --bank: list this many textures with the highest mean NME")
    args = parser.parse_args()
    if args.column < 1 or args.bins < 1 or args.worst < 0:
        parser.error("--column and --bins must be at least 1, --worst at least 0")
    if args.max_yaw is not None and not args.max_yaw >= 0:
        parser.error("--max-yaw must be a number of degrees, at least 0")

    rows = read_nme_rows(args.csv)
    column = f"regressor{args.column}"
    if column not in rows[0]:
        sys.exit(f"{args.csv}: no column {column} (is it an `eval landmarks --nme-csv` file?)")
    nmes, factors, textures = [], [], {}
    for row in rows:
        if row.get("detected") != "1":
            continue
        if args.max_yaw is not None and not (row.get("yaw_deg") and abs(float(row["yaw_deg"])) <= args.max_yaw):
            continue
        key = sample_name(row["key"])
        path = os.path.join(args.dataset, "meta", key + ".json")
        try:
            with open(path) as f:
                meta = json.load(f)
        except (OSError, ValueError) as e:
            sys.exit(f"{path}: cannot be read ({e})")
        nme = float(row[column])
        nmes.append(nme)
        factors.append(factors_of(meta))
        if meta.get("texture"):
            textures.setdefault(meta["texture"], []).append(nme)
    if len(nmes) < 3:
        sys.exit(f"{args.csv}: fewer than 3 detected faces")

    print(f"{len(nmes)} detected faces, mean NME {sum(nmes) / len(nmes):.4f} ({column})")
    names = sorted({name for f in factors for name in f})
    print(f"{'parameter':32s} {'r':>7s}  mean NME (faces) per quantile bin, low to high; equal values share a bin")
    for name in names:
        pairs = [(f[name], nme) for f, nme in zip(factors, nmes) if name in f]
        values = [p[0] for p in pairs]
        if len(pairs) < 3 or min(values) == max(values):
            continue
        pairs.sort(key=lambda p: p[0])
        bins, start = [], 0
        for b in range(1, args.bins + 1):
            end = b * len(pairs) // args.bins
            if end <= start:
                continue  # a run of equal values took this bin's share
            while end < len(pairs) and pairs[end][0] == pairs[end - 1][0]:
                end += 1  # equal values share a bin
            part = pairs[start:end]
            low, high = part[0][0], part[-1][0]
            span = f"{low:.3g}" if low == high else f"{low:.3g}..{high:.3g}"
            bins.append(f"{span}: {sum(p[1] for p in part) / len(part):.4f} ({len(part)})")
            start = end
        print(f"{name:32s} {pearson([p[0] for p in pairs], [p[1] for p in pairs]):+7.3f}  " + "  ".join(bins))
    repeated = [v for v in textures.values() if len(v) >= 2]
    if len(repeated) >= 3:
        print(f"texture: split-half r {pearson([v[0] for v in repeated], [v[1] for v in repeated]):+.3f} over {len(repeated)} textures "
              f"with two or more renders ({len(textures)} textures)")
    if args.bank:
        report_bank(args.bank, textures, args.worst)


def report_bank(bank, textures, worst):
    """Each texture's mean NME against the bank's per-texture numbers, and the worst textures."""
    path = os.path.join(bank, "bank.json")
    try:
        with open(path) as f:
            entries = {t["file"]: t for t in json.load(f)["textures"]}
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"{path}: cannot be read as a texture bank ({e})")
    means = {t: sum(v) / len(v) for t, v in textures.items() if len(v) >= 3 and t in entries}
    if len(means) < 3:
        sys.exit(f"{path}: fewer than 3 of the bank's textures have three or more renders here")
    print(f"bank: {len(means)} textures with three or more renders; r of their mean NME with")
    names = sorted({k for t in means for k, v in entries[t].items() if isinstance(v, (int, float)) and not isinstance(v, bool)})
    for name in names:
        pairs = [(entries[t][name], m) for t, m in means.items() if isinstance(entries[t].get(name), (int, float))]
        if len(pairs) >= 3:
            print(f"  {name:30s} {pearson([p[0] for p in pairs], [p[1] for p in pairs]):+7.3f}")
    for t, m in sorted(means.items(), key=lambda item: -item[1])[:worst]:
        print(f"worst: {t} {m:.4f} ({len(textures[t])} renders) from {entries[t].get('source', '?')}")


if __name__ == "__main__":
    main()
