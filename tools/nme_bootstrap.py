#!/usr/bin/env python3
"""Paired bootstrap of per-face NMEs from `facesynth eval landmarks --nme-csv` (docs/train.md).

For the faces the detector found (all regressors share the boxes), prints each regressor's mean NME
with a 95 % percentile interval, and for the reference column against every other one the mean paired
difference (other - reference), its 95 % interval and on how many faces the reference is better.
With yaw in the CSV the paired differences are also given per |yaw| bin (0-15, 15-30, 30-45, 45-60)
and per detector view. Standard library only.

With --cluster-size N the rows come in clusters of N consecutive rows that are not independent (the
frames of one clip from `facesynth eval track --nme-csv`), and whole clusters are resampled.

--average K,L adds a column: the per-face mean NME of regressor columns K and L (and more), compared as
any other. For models trained alike with different seeds it is what one training run makes on these
faces, on average over those runs (the interval is over the faces, not over the seeds).

Targets stated as ratios ("within 1.2 x the reference") are read with --ratio R: every paired
difference is then other - R x reference per face, so an interval below 0 means the target is met on
these faces. --yaw-split D adds the faces with |yaw| <= D and > D as two more groups. With --fail-at T
every NME is first replaced by 1 if it exceeds T, else 0, so that the means are failure rates over the
detected faces and the paired differences differences in failure rate.

Several CSV files are joined by the last path component of their keys, so that the same sample index of
two datasets rendered with one setting changed (or the same photographs in two runs) pair up: their
regressor columns follow one another, a face counts as detected where every file found it, and the yaw
and view are the first file's; faces missing from any file are left out.

    tools/nme_bootstrap.py F.csv [G.csv ...] [--reference 1] [--names ours,dlib,...] [--resamples 5000] [--seed 1] [--cluster-size N]
                           [--ratio R] [--yaw-split D] [--fail-at T] [--average K,L]
"""
import argparse
import math
import random
import sys

from nme_csv import read_nme_rows, sample_name


def percentile(sorted_values, q):
    position = q * (len(sorted_values) - 1)
    low = math.floor(position)
    high = min(low + 1, len(sorted_values) - 1)
    return sorted_values[low] + (sorted_values[high] - sorted_values[low]) * (position - low)


def bootstrap_mean(values, resamples, rng, clusters=None):
    """95 % percentile interval of the mean; with `clusters` (one id per value) whole clusters are drawn."""
    if clusters is None:
        n = len(values)
        means = sorted(sum(values[rng.randrange(n)] for _ in range(n)) / n for _ in range(resamples))
        return percentile(means, 0.025), percentile(means, 0.975)
    groups = {}
    for cluster, value in zip(clusters, values):
        groups.setdefault(cluster, []).append(value)
    sums = [(sum(g), len(g)) for g in groups.values()]
    means = []
    for _ in range(resamples):
        total, count = 0.0, 0
        for _ in range(len(sums)):
            s, c = sums[rng.randrange(len(sums))]
            total, count = total + s, count + c
        means.append(total / count)
    means.sort()
    return percentile(means, 0.025), percentile(means, 0.975)


def joined_rows(paths):
    """One file's rows as they are; several files' rows joined by the last path component of the key."""
    if len(paths) == 1:
        return read_nme_rows(paths[0])
    tables = []
    for path in paths:
        table = {}
        for row in read_nme_rows(path):
            name = sample_name(row["key"])
            if name in table:
                sys.exit(f"{path}: key '{name}' appears twice, so the files cannot be joined by it")
            table[name] = row
        tables.append(table)
    joined = []
    for name, first in tables[0].items():
        if not all(name in table for table in tables[1:]):
            continue
        row = {"key": name, "yaw_deg": first["yaw_deg"], "view": first["view"],
               "detected": "1" if all(table[name]["detected"] == "1" for table in tables) else "0"}
        values = [v for table in tables for c, v in table[name].items() if c.startswith("regressor")]
        row.update((f"regressor{k}", value) for k, value in enumerate(values, 1))
        joined.append(row)
    if not joined:
        sys.exit(f"{', '.join(paths)}: no face is in every file")
    return joined


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("csv", nargs="+")
    parser.add_argument("--reference", type=int, default=1, help="regressor column (1-based) the others are compared with")
    parser.add_argument("--names", default="", help="comma-separated names of the regressor columns")
    parser.add_argument("--resamples", type=int, default=5000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--cluster-size", type=int, default=0, help="resample clusters of this many consecutive rows (clips)")
    parser.add_argument("--ratio", type=float, default=1.0, help="compare each regressor with this multiple of the reference")
    parser.add_argument("--yaw-split", type=float, default=None, help="also compare the faces with |yaw| up to and beyond this")
    parser.add_argument("--fail-at", type=float, default=None, help="compare failure rates: NME above this counts 1, else 0")
    parser.add_argument("--average", default="", help="comma-separated regressor columns (1-based) whose per-face mean is added as one more column")
    args = parser.parse_args()
    if args.cluster_size < 0:
        sys.exit("--cluster-size must not be negative")
    if not math.isfinite(args.ratio) or args.ratio <= 0:
        sys.exit("--ratio must be a positive number")
    if args.fail_at is not None and not (math.isfinite(args.fail_at) and args.fail_at > 0 and args.ratio == 1):
        sys.exit("--fail-at must be a positive NME, and is not combined with --ratio")
    if args.yaw_split is not None and not (0 <= args.yaw_split <= 90):
        sys.exit("--yaw-split must be between 0 and 90 degrees")

    rows = joined_rows(args.csv)
    source = " + ".join(args.csv)
    measured = [c for c in rows[0].keys() if c.startswith("regressor")]
    columns = list(measured)  # and, with --average, the mean column after them
    names = args.names.split(",") if args.names else list(columns)
    if len(names) != len(columns):
        sys.exit(f"{source}: {len(columns)} regressor columns, {len(names)} names")
    if args.average:
        try:
            averaged = [int(k) for k in args.average.split(",")]
        except ValueError:
            sys.exit(f"--average: '{args.average}' is not a list of regressor columns")
        if len(averaged) < 2 or len(set(averaged)) != len(averaged) or not all(1 <= k <= len(columns) for k in averaged):
            sys.exit(f"--average: two or more different regressor columns of 1-{len(columns)}")
        averaged_columns = [columns[k - 1] for k in averaged]
        columns.append("_average")
        names.append("mean(" + ",".join(names[k - 1] for k in averaged) + ")")
    if not 1 <= args.reference <= len(columns):
        sys.exit(f"{source}: --reference {args.reference}, but the file has {len(columns)} regressor columns")
    if args.yaw_split is not None and not rows[0]["yaw_deg"]:
        sys.exit(f"{source}: --yaw-split needs the yaw_deg column, which is empty")
    for position, row in enumerate(rows):
        row["_cluster"] = position // args.cluster_size if args.cluster_size else position
    found = [r for r in rows if r["detected"] == "1"]
    if args.fail_at is not None:
        for r in found:
            r.update((c, "1" if float(r[c]) > args.fail_at else "0") for c in measured)
    if args.average:  # after --fail-at: the mean of the runs' failures, not the failure of their mean NME
        for r in found:
            r["_average"] = str(sum(float(r[c]) for c in averaged_columns) / len(averaged_columns))

    def clusters_of(subset):
        return [r["_cluster"] for r in subset] if args.cluster_size else None
    ref = columns[args.reference - 1]
    rng = random.Random(args.seed)
    unit = f"; clusters of {args.cluster_size} rows resampled" if args.cluster_size else ""
    measure = f"; failure rates at {args.fail_at:g}" if args.fail_at is not None else ""
    print(f"{source}: {len(rows)} faces, {len(found)} detected; {args.resamples} resamples{unit}{measure}")
    for column, name in zip(columns, names):
        values = [float(r[column]) for r in found]
        low, high = bootstrap_mean(values, args.resamples, rng, clusters_of(found))
        print(f"  {name:>14}: mean {sum(values) / len(values):.4f} [{low:.4f}, {high:.4f}]")

    reference = names[args.reference - 1] if args.ratio == 1 else f"{args.ratio:g} x {names[args.reference - 1]}"
    count_label = "reference better" if args.ratio == 1 else "above it"

    def paired(subset, label):
        if not subset:
            return
        for column, name in zip(columns, names):
            if column == ref:
                continue
            diffs = [float(r[column]) - args.ratio * float(r[ref]) for r in subset]
            low, high = bootstrap_mean(diffs, args.resamples, rng, clusters_of(subset))
            above = sum(d > 0 for d in diffs)
            print(f"  {label:>12} {name:>14} - {reference}: {sum(diffs) / len(diffs):+.4f} "
                  f"[{low:+.4f}, {high:+.4f}], {count_label} on {above} of {len(diffs)}; "
                  f"means {sum(float(r[column]) for r in subset) / len(subset):.4f} vs "
                  f"{sum(float(r[ref]) for r in subset) / len(subset):.4f}")

    paired(found, "all")
    if found and found[0]["yaw_deg"]:
        for low, high in ((0, 15), (15, 30), (30, 45), (45, 60)):
            paired([r for r in found if low <= abs(float(r["yaw_deg"])) < high or (high == 60 and abs(float(r["yaw_deg"])) == 60)],
                   f"yaw {low}-{high}")
        if args.yaw_split is not None:
            paired([r for r in found if abs(float(r["yaw_deg"])) <= args.yaw_split], f"yaw<={args.yaw_split:g}")
            paired([r for r in found if abs(float(r["yaw_deg"])) > args.yaw_split], f"yaw>{args.yaw_split:g}")
    for view in ("frontal", "nose_left", "nose_right"):
        paired([r for r in found if r["view"] == view], view)


if __name__ == "__main__":
    main()
