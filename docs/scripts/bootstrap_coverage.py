"""How often the benchmark's 95 % bootstrap interval covers the true mean, by frame count
(the reason tables mark intervals from fewer than 10 frames; docs/benchmark.md).

Run from the project root::

    python docs/scripts/bootstrap_coverage.py [--trials 2000]

Per-frame errors are drawn from a skewed distribution (gamma, shape 2: like per-frame
hole RMSE, a few hard frames), the interval is computed exactly as the tables do
(:func:`inpaintenv.report.stats.bootstrap_mean_ci`, 2,000 resamples) and its coverage of the
distribution's mean is counted over ``--trials`` draws.
"""

from __future__ import annotations

import argparse

import numpy as np

from inpaintenv.report.stats import bootstrap_mean_ci


def coverage(n: int, trials: int, rng: np.random.Generator) -> float:
    shape, scale = 2.0, 3.0  # mean 6 m
    hits = 0
    for t in range(trials):
        _, low, high = bootstrap_mean_ci(rng.gamma(shape, scale, n), seed=t)
        hits += low <= shape * scale <= high
    return hits / trials


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=2000)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    print("frames  coverage of a nominal 95 % interval")
    for n in (2, 3, 5, 10, 20, 50):
        print(f"{n:>6}  {coverage(n, args.trials, rng):.1%}")


if __name__ == "__main__":
    main()
