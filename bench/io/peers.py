"""Times numpy.loadtxt and pandas.read_csv on bench.csv with read_bench's rule (best and median of
REPEATS, file read included); prints `name best_seconds median_seconds megabytes samples`."""
import os
import statistics
import sys
import time

import numpy as np
import pandas as pd


def timed(repeats, f):
    secs, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = f()
        secs.append(time.perf_counter() - start)
    secs.sort()
    return secs[0], secs[len(secs) // 2], out


def main():
    path, repeats = os.path.join(sys.argv[1], "bench.csv"), int(sys.argv[2])
    mb = os.path.getsize(path) / 1e6
    best, median, a = timed(repeats, lambda: np.loadtxt(path, delimiter=",", skiprows=1))
    print(f"numpy-loadtxt {best:.6f} {median:.6f} {mb:.3f} {a.shape[0]}")
    best, median, df = timed(repeats, lambda: pd.read_csv(path))
    print(f"pandas-read_csv {best:.6f} {median:.6f} {mb:.3f} {len(df)}")


if __name__ == "__main__":
    main()
