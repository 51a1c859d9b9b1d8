#!/usr/bin/env python3
"""Streaming from Python against `facesynth synth` writing to tmpfs, measured in the same minutes.

Alternates, ROUNDS times: the CLI writing COUNT samples (PNG, the config's outputs) into /dev/shm,
and facesynth.Generator streaming the same COUNT samples (same config, seed and workers) as batches
of BATCH into numpy arrays. Both figures include loading the model and starting the renderers, as a
training job pays them. Prints one line per run and the median ratio (Python / CLI samples per s).

  PYTHONPATH=build/python python3 bench/python_stream.py [--cli build/facesynth] [--count 2000]
      [--workers 2] [--batch 64] [--rounds 3] [--size 256] [--set key=value ...] [--json F]
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", default="build/facesynth")
    parser.add_argument("--count", type=int, default=2000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--batch", type=int, default=64)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a config key for both (as synth --set)")
    parser.add_argument("--work", default="/dev/shm/facesynth-python-stream")
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()

    import facesynth

    settings = {}
    for item in args.set:
        key, _, text = item.partition("=")
        try:  # numbers and booleans as TOML would read them, anything else as a string
            settings[key] = json.loads(text)
        except ValueError:
            settings[key] = text
    runs = []
    for round_index in range(args.rounds):
        shutil.rmtree(args.work, ignore_errors=True)
        command = [args.cli, "synth", "--out", args.work, "--count", str(args.count), "--seed", str(args.seed), "--size", str(args.size),
                   "--threads", str(args.workers), "--quiet"] + [a for s in args.set for a in ("--set", s)]
        start = time.perf_counter()
        subprocess.run(command, check=True)
        cli = args.count / (time.perf_counter() - start)
        shutil.rmtree(args.work, ignore_errors=True)

        start = time.perf_counter()
        gen = facesynth.Generator(config=settings, seed=args.seed, size=args.size, workers=args.workers)
        made = sum(len(batch["image"]) for batch in gen.batches(args.batch, stop=args.count))
        python = made / (time.perf_counter() - start)
        del gen
        runs.append({"round": round_index + 1, "cli_samples_per_s": cli, "python_samples_per_s": python, "ratio": python / cli})
        print(f"round {round_index + 1}: cli {cli:.1f}/s  python {python:.1f}/s  python/cli {python / cli:.3f}", flush=True)
    ratio = statistics.median(r["ratio"] for r in runs)
    print(f"median python/cli {ratio:.3f} over {args.rounds} rounds ({args.count} samples, {args.workers} workers, {args.size}^2, batch {args.batch})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"count": args.count, "workers": args.workers, "size": args.size, "batch": args.batch, "median_ratio": ratio,
                       "runs": runs}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
