"""faiss-cpu k-means on the points vplgi's perf report wrote, for the side-by-side comparison.

Usage: faiss_kmeans.py POINTS.f32 K ITERATIONS RUNS
POINTS.f32 holds n x 3 little-endian float32 positions. Prints one JSON object: the median
training time over RUNS runs, the final mean squared distance of the points to their nearest
centroid, and faiss' version and thread count.
"""
import json
import statistics
import sys
import time

import faiss
import numpy as np


def main():
    path, k, iterations, runs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    x = np.fromfile(path, dtype="<f4").reshape(-1, 3)
    times, mse = [], None
    for run in range(runs):
        # max_points_per_centroid keeps faiss from subsampling: every point takes part in every
        # iteration, as in vplgi's gamma = 1 run.
        km = faiss.Kmeans(3, k, niter=iterations, seed=1234 + run, max_points_per_centroid=1 << 30, verbose=False)
        t0 = time.perf_counter()
        km.train(x)
        times.append(time.perf_counter() - t0)
        d, _ = km.index.search(x, 1)
        mse = float(d.mean())
    print(json.dumps({"seconds": statistics.median(times), "runs": times, "mse": mse, "points": int(x.shape[0]), "version": faiss.__version__, "threads": faiss.omp_get_max_threads()}))


if __name__ == "__main__":
    main()
