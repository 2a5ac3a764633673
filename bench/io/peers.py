"""Times numpy.loadtxt and pandas.read_csv on bench.csv; prints `name seconds megabytes samples`."""
import os
import sys
import time

import numpy as np
import pandas as pd


def best_of(repeats, f):
    best, out = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - start)
    return best, out


def main():
    path, repeats = os.path.join(sys.argv[1], "bench.csv"), int(sys.argv[2])
    mb = os.path.getsize(path) / 1e6
    secs, a = best_of(repeats, lambda: np.loadtxt(path, delimiter=",", skiprows=1))
    print(f"numpy-loadtxt {secs:.6f} {mb:.3f} {a.shape[0]}")
    secs, df = best_of(repeats, lambda: pd.read_csv(path))
    print(f"pandas-read_csv {secs:.6f} {mb:.3f} {len(df)}")


if __name__ == "__main__":
    main()
