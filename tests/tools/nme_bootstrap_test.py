#!/usr/bin/env python3
"""tools/nme_bootstrap.py on a made-up `eval landmarks --nme-csv` file: means, paired differences and
--average (ctest runs it)."""
import os
import subprocess
import sys
import tempfile

TOOL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "nme_bootstrap.py")


def run(*args, expect_failure=False):
    result = subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)
    if (result.returncode != 0) != expect_failure:
        sys.exit(f"nme_bootstrap.py {' '.join(args)}: exit {result.returncode}\n{result.stdout}{result.stderr}")
    return result.stdout + result.stderr


def main():
    with tempfile.TemporaryDirectory() as tmp:
        csv = os.path.join(tmp, "nme.csv")
        with open(csv, "w") as f:
            f.write("key,yaw_deg,detected,view,regressor1,regressor2,regressor3\n")
            # Two seeds of one recipe (columns 1 and 2) and a reference (3); the last face was not detected.
            f.write("a/f1,5,1,frontal,0.05,0.07,0.04\n")
            f.write("a/f2,10,1,frontal,0.04,0.06,0.03\n")
            f.write("a/f3,20,1,frontal,0.06,0.08,0.05\n")
            f.write("a/f4,25,1,frontal,0.05,0.07,0.04\n")
            f.write("a/f5,30,0,frontal,1,1,1\n")
        out = run(csv, "--names", "s1,s2,ref", "--reference", "3", "--average", "1,2")
        expected = ["5 faces, 4 detected", "s1: mean 0.0500", "s2: mean 0.0700", "mean(s1,s2): mean 0.0600 [",
                    "mean(s1,s2) - ref: +0.0200 [+0.0200, +0.0200], reference better on 4 of 4"]
        for text in expected:
            if text not in out:
                sys.exit(f"expected '{text}' in:\n{out}")
        ratio = run(csv, "--names", "s1,s2,ref", "--reference", "3", "--average", "1,2", "--ratio", "1.5")
        if "mean(s1,s2) - 1.5 x ref: -0.0000" not in ratio and "mean(s1,s2) - 1.5 x ref: +0.0000" not in ratio:
            sys.exit(f"expected the average at 1.5 x the reference:\n{ratio}")
        # Failure rates at 0.065: the first seed fails on no face, the second on three of four (not on
        # the average NME, which would fail on one).
        failures = run(csv, "--names", "s1,s2,ref", "--average", "1,2", "--fail-at", "0.065")
        if "mean(s1,s2): mean 0.3750" not in failures:
            sys.exit(f"expected the two runs' mean failure rate, 0.375:\n{failures}")
        unnamed = run(csv, "--average", "1,2")
        if "mean(regressor1,regressor2): mean 0.0600" not in unnamed:
            sys.exit(f"expected the average named after its columns:\n{unnamed}")
        for bad in ("1", "1,1", "1,4", "x,2"):
            message = run(csv, "--average", bad, expect_failure=True)
            if "--average" not in message:
                sys.exit(f"--average {bad}: expected an error naming the option, got:\n{message}")
    print("nme_bootstrap.py: means, paired differences and --average as made")


if __name__ == "__main__":
    main()
