"""Reading the per-face NME files of `facesynth eval landmarks --nme-csv` (docs/report.md) for the
tools beside this one. Standard library only."""
import csv
import sys


def read_nme_rows(path):
    """The file's rows as dicts (key, yaw_deg, detected, view, regressor1, ...); exits naming the file
    when it cannot be read or holds no faces."""
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as error:
        sys.exit(f"{path}: {error.strerror}")
    if not rows:
        sys.exit(f"{path}: no faces")
    return rows


def sample_name(key):
    """The last path component of a row's key: the sample or photograph, whichever folder it was read from."""
    return key.replace("\\", "/").rsplit("/", 1)[-1]
