"""Times numpy.loadtxt and pandas.read_csv on bench.csv with read_bench's rule (best and median of
REPEATS, file read included, and the least on-CPU seconds from /proc/self/schedstat as read_bench
reads it); prints `name best_seconds median_seconds cpu_seconds megabytes samples`. With a third
argument `pandas`, pandas only (bench/io/spread.sh)."""
import os
import statistics
import sys
import time

import numpy as np
import pandas as pd


def cpu_seconds():
    try:
        with open("/proc/self/schedstat") as f:
            return int(f.read().split()[0]) * 1e-9
    except OSError:
        return 0.0


def timed(repeats, f):
    secs, cpu, out = [], float("inf"), None
    for _ in range(repeats):
        start, cpu_start = time.perf_counter(), cpu_seconds()
        out = f()
        secs.append(time.perf_counter() - start)
        cpu = min(cpu, cpu_seconds() - cpu_start)
    secs.sort()
    return secs[0], secs[len(secs) // 2], cpu, out


def main():
    path, repeats = os.path.join(sys.argv[1], "bench.csv"), int(sys.argv[2])
    pandas_only = sys.argv[3:] == ["pandas"]
    mb = os.path.getsize(path) / 1e6
    if not pandas_only:
        best, median, cpu, a = timed(repeats, lambda: np.loadtxt(path, delimiter=",", skiprows=1))
        print(f"numpy-loadtxt {best:.6f} {median:.6f} {cpu:.6f} {mb:.3f} {a.shape[0]}")
    best, median, cpu, df = timed(repeats, lambda: pd.read_csv(path))
    print(f"pandas-read_csv {best:.6f} {median:.6f} {cpu:.6f} {mb:.3f} {len(df)}")


if __name__ == "__main__":
    main()
