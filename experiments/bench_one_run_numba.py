"""One SD1 run (the paper's DE/rand/1/exp, NP 70, F 0.6, CR 0.8, 140,000 FEs, RK4 ND 1, Table 4's
ranges) by dcjax against a hand-written numba DE of the same algorithm on one and on two threads
(issue: speed at scale, Done-when (d)).

The peer: the whole DE in one `numba.njit` function; each generation evaluates the 70 trials with
one population objective, eq. 8-9 by RK4 with eq. 29's interpolated voltage (1/La, 1/J hoisted),
eq. 24 summed in the time loop, time outside and the members inside (the inner loop runs over
contiguous member arrays, which LLVM vectorises); in parallel, a `prange` over one contiguous
chunk of members per thread, each chunk's time loop outside its members (one parallel region per
generation: a region per time step, 2,000 x 500 of them, costs more than it saves). dcjax: `dcjax.fit(SD1, params="table4", search=dcjax.Search(runs=1))` with compiled loops, its
`timing["run_s"]` (the compiled run, no compilation). Each figure is the median of `--repeat`
runs (seeds 0..), after one warm-up run; all in one process.

Needs numba (not a dcjax dependency): `pip install numba` into the environment that runs it.

    python -m experiments.bench_one_run_numba [--repeat 7]
"""

import argparse
import os
import platform
import statistics
import time

import numpy as np

import dcjax
from dcjax import datasets

dcjax.use_compiled_loops()


def peer(parallel: bool):
    """The numba DE: `run(lo, hi, t, u, i_meas, w_meas, generations, seed)` -> (best OF, best x)."""
    import numba
    from numba import njit, prange

    @njit(fastmath=False, cache=False)
    def time_outer(x, t, u, im, wm, lo, hi, out):
        """Eq. 24 of rows lo..hi of x (P, 7) into `out`: time outside, the members inside (the inner
        loop runs over contiguous member arrays, which LLVM vectorises)."""
        p, n = hi - lo, t.shape[0]
        si, sw = 1.0 / np.max(np.abs(im)) ** 2, 1.0 / np.max(np.abs(wm)) ** 2
        ra, rla, cm, rj = x[lo:hi, 0].copy(), 1.0 / x[lo:hi, 1], x[lo:hi, 2].copy(), 1.0 / x[lo:hi, 3]
        tla, tlb, tlc = x[lo:hi, 4].copy(), x[lo:hi, 5].copy(), x[lo:hi, 6].copy()
        i, w, acc = np.full(p, im[0]), np.full(p, wm[0]), np.zeros(p)
        for k in range(1, n):
            h, ua, ub = t[k] - t[k - 1], u[k - 1], u[k]
            um = 0.5 * (ua + ub)
            for m in range(p):
                a, b = i[m], w[m]
                k1, l1 = (ua - a * ra[m] - cm[m] * b) * rla[m], (cm[m] * a - tla[m] - tlb[m] * b - tlc[m] * b * b) * rj[m]
                i2, w2 = a + 0.5 * h * k1, b + 0.5 * h * l1
                k2, l2 = (um - i2 * ra[m] - cm[m] * w2) * rla[m], (cm[m] * i2 - tla[m] - tlb[m] * w2 - tlc[m] * w2 * w2) * rj[m]
                i3, w3 = a + 0.5 * h * k2, b + 0.5 * h * l2
                k3, l3 = (um - i3 * ra[m] - cm[m] * w3) * rla[m], (cm[m] * i3 - tla[m] - tlb[m] * w3 - tlc[m] * w3 * w3) * rj[m]
                i4, w4 = a + h * k3, b + h * l3
                k4, l4 = (ub - i4 * ra[m] - cm[m] * w4) * rla[m], (cm[m] * i4 - tla[m] - tlb[m] * w4 - tlc[m] * w4 * w4) * rj[m]
                i[m] = a + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
                w[m] = b + h * (l1 + 2.0 * l2 + 2.0 * l3 + l4) / 6.0
                acc[m] += si * (i[m] - im[k]) ** 2 + sw * (w[m] - wm[k]) ** 2
        for m in range(p):
            out[lo + m] = acc[m] / n if np.isfinite(acc[m]) else np.inf

    @njit(fastmath=False, parallel=parallel, cache=False)
    def objective(x, t, u, im, wm):
        """Eq. 24 of every row of x (P, 7): serial, or (parallel) the members in one contiguous
        chunk per thread, each chunk's time loop outside its members (one parallel region a call)."""
        p = x.shape[0]
        out = np.empty(p)
        if parallel:
            chunks = numba.get_num_threads()
            for c in prange(chunks):
                time_outer(x, t, u, im, wm, c * p // chunks, (c + 1) * p // chunks, out)
        else:
            time_outer(x, t, u, im, wm, 0, p, out)
        return out

    @njit(cache=False)
    def run(lo, hi, t, u, im, wm, generations, seed):
        """DE/rand/1/exp in the unit cube: r1, r2, r3, i distinct, exponential crossover, an
        out-of-range gene redrawn uniformly, one-to-one greedy selection."""
        np.random.seed(seed)
        p, d = 70, lo.shape[0]
        f, cr = 0.6, 0.8
        pop = np.random.random((p, d))
        fit = objective(lo + pop * (hi - lo), t, u, im, wm)
        trial = np.empty((p, d))
        for _ in range(generations):
            for m in range(p):
                r1 = m
                while r1 == m:
                    r1 = np.random.randint(p)
                r2 = m
                while r2 == m or r2 == r1:
                    r2 = np.random.randint(p)
                r3 = m
                while r3 == m or r3 == r1 or r3 == r2:
                    r3 = np.random.randint(p)
                trial[m] = pop[m]
                j, length = np.random.randint(d), 0
                while True:
                    v = pop[r1, j] + f * (pop[r2, j] - pop[r3, j])
                    trial[m, j] = v if 0.0 <= v <= 1.0 else np.random.random()
                    j, length = (j + 1) % d, length + 1
                    if length >= d or np.random.random() >= cr:
                        break
            tf = objective(lo + trial * (hi - lo), t, u, im, wm)
            for m in range(p):
                if tf[m] <= fit[m]:
                    fit[m] = tf[m]
                    pop[m] = trial[m]
        b = np.argmin(fit)
        return fit[b], lo + pop[b] * (hi - lo)

    return numba, run


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    sd1 = datasets.load("SD1")
    t, u, im, wm = (np.ascontiguousarray(np.asarray(a, float)) for a in (sd1.t, sd1["u_a"], sd1["i_a"], sd1["omega"]))
    params = dcjax.DC().parameters("table4")
    lo, hi = np.asarray(params.lower, float), np.asarray(params.upper, float)
    generations = (140_000 - 70) // 70 + ((140_000 - 70) % 70 > 0)  # 1999: as dcjax's DE counts its budget
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; one SD1 run, 140,000 FEs; median of {args.repeat}")
    fit = lambda s: dcjax.fit(sd1, params=params, search=dcjax.Search(runs=1, seed=s))
    fit(99)  # compiles
    times = [fit(s).timing["run_s"] for s in range(args.repeat)]
    ref = statistics.median(times)
    print(f"{'dcjax (one core)':<34} {ref:8.4f} s   best OFs {fit(0).of:.2e}")
    for label, parallel, threads in (("numba, 1 thread", False, 1), ("numba prange over chunks, 1 thread", True, 1),
                                     ("numba prange over chunks, 2 threads", True, 2)):  # fmt: skip
        numba, run = peer(parallel)
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        run(lo, hi, t, u, im, wm, 2, 0)  # compiles
        ts, ofs = [], []
        for s in range(args.repeat):
            t0 = time.perf_counter()
            of, _ = run(lo, hi, t, u, im, wm, generations, s)
            ts.append(time.perf_counter() - t0)
            ofs.append(of)
        med = statistics.median(ts)
        print(f"{label:<34} {med:8.4f} s   dcjax {med / ref:5.2f}x as fast   best OFs median {np.median(ofs):.2e}", flush=True)


if __name__ == "__main__":
    main()
