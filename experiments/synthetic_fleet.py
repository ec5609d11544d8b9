"""A synthetic lab folder: clean DC-motor recordings and one recording of each broken kind the
data checks must name (`dcjax.analysis.checks`), written as CSV files (t, u_a, i_a, omega in SI).

Clean motors: Ra, La, cm, J, Tla drawn within +-15 % of a nominal small motor (4 Ohm, 20 mH,
0.05 Vs, 2e-5 kg m^2, 5 mNm; La/Ra = 5 ms), no viscous or quadratic load (Tlb = Tlc = 0, so a fit
puts them at their zero bound), a stepped voltage (0 V for 5 % of the time, then four levels),
simulated with `dcjax.simulate` (RK4, 4 sub-steps) and 0.5 % Gaussian noise (of each channel's
peak), `n` samples at 1 ms. Broken ones (each from its own clean motor):

| file            | what is wrong                                        | expected finding          |
|-----------------|------------------------------------------------------|---------------------------|
| `dead`          | the current channel all zero                         | error `dead`              |
| `near-dead`     | the current sensor at 1.5 % of its gain              | warning `near-dead:i_a`   |
| `reversed`      | current and speed wired in reverse (negated)         | warning `reversed:omega`  |
| `alternating`   | the speed's sign flips every other sample            | error `alternating`       |
| `saturated`     | the current clipped at 40 % of its peak              | warning `saturated:i_a`   |
| `nan`           | a NaN in the speed                                   | error `nan`               |
| `bad-times`     | a duplicated time stamp                              | error `time`              |
| `slow-rate`     | sampled every 20 ms (> La/Ra)                        | warning `slow-rate`       |

    python -m experiments.synthetic_fleet DIR [--clean 20] [--samples 665]
"""

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import dcjax

NOMINAL = {"Ra": 4.0, "La": 0.02, "cm": 0.05, "J": 2e-5, "Tla": 0.005, "Tlb": 0.0, "Tlc": 0.0}
EXPECTED = {
    "dead": ("error", "dead"),
    "near-dead": ("warning", "near-dead:i_a"),
    "reversed": ("warning", "reversed:omega"),
    "alternating": ("error", "alternating"),
    "saturated": ("warning", "saturated:i_a"),
    "nan": ("error", "nan"),
    "bad-times": ("error", "time"),
    "slow-rate": ("warning", "slow-rate"),
}


def motor(rng: np.random.Generator) -> dict[str, float]:
    p = dict(NOMINAL)
    for k in ("Ra", "La", "cm", "J", "Tla"):
        p[k] *= rng.uniform(0.85, 1.15)
    return p


def stepped_input(t: np.ndarray, rng: np.random.Generator, u_max: float = 12.0) -> np.ndarray:
    """0 V for the first 5 %, then four levels between 40 % and 100 % of `u_max`."""
    edges = np.linspace(0.05, 1.0, 5) * t[-1]
    levels = rng.uniform(0.4, 1.0, 4) * u_max
    u = np.zeros_like(t)
    for k in range(4):
        u[t >= edges[k]] = levels[k]  # each level from its edge on (a later one overwrites)
    return u


def simulate_motor(p: dict[str, float], t: np.ndarray, u: np.ndarray, rng: np.random.Generator, noise: float = 0.005) -> np.ndarray:
    """(N, 2) current and speed with Gaussian noise of `noise` x each channel's peak."""
    rec = dcjax.Recording(t=t, u_a=u, i_a=np.ones_like(t), omega=np.ones_like(t))
    y = np.asarray(dcjax.simulate(p, dcjax.make_problem(rec, dcjax.RK4(substeps=4), initial={"i_a": 0.0, "omega": 0.0})))
    return y + noise * np.max(np.abs(y), axis=0) * rng.standard_normal(y.shape)


def _write(path: Path, t, u, y) -> None:
    table = np.column_stack([t, u, y[:, 0], y[:, 1]])
    np.savetxt(path, table, delimiter=",", header="t,u_a,i_a,omega", comments="", fmt="%.12g")


def write_fleet(folder: str | Path, clean: int = 20, samples: int = 665, broken: bool = True, seed: int = 0,
                lengths: Sequence[int] | None = None) -> dict[str, str]:  # fmt: skip
    """Write the fleet's CSV files into `folder`; returns file stem -> kind ("clean" or a broken kind).
    `lengths`: the clean files' sample counts, one each (default all `samples`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    kinds: dict[str, str] = {}
    t = np.arange(samples) * 1e-3
    if lengths is not None and len(lengths) != clean:
        raise ValueError(f"lengths: one per clean file ({clean}), got {len(lengths)}")
    for k in range(clean):
        t = np.arange(samples if lengths is None else int(lengths[k])) * 1e-3
        u = stepped_input(t, rng)
        _write(folder / f"motor{k:03d}.csv", t, u, simulate_motor(motor(rng), t, u, rng))
        kinds[f"motor{k:03d}"] = "clean"
    if not broken:
        return kinds
    t = np.arange(samples) * 1e-3
    for kind in EXPECTED:
        p = motor(rng)
        tt = t if kind != "slow-rate" else np.arange(max(40, samples // 20)) * 0.02
        u = stepped_input(tt, rng)
        y = simulate_motor(p, tt, u, rng)
        if kind == "dead":
            y[:, 0] = 0.0
        elif kind == "near-dead":
            y[:, 0] *= 0.015
        elif kind == "reversed":
            y = -y
        elif kind == "alternating":
            y[1::2, 1] *= -1
        elif kind == "saturated":
            y[:, 0] = np.clip(y[:, 0], -0.4 * np.max(np.abs(y[:, 0])), 0.4 * np.max(np.abs(y[:, 0])))
        elif kind == "nan":
            y[samples // 7, 1] = np.nan
        elif kind == "bad-times":
            tt = tt.copy()
            tt[samples // 3] = tt[samples // 3 - 1]
        _write(folder / f"{kind}.csv", tt, u, y)
        kinds[kind] = kind
    return kinds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("folder")
    ap.add_argument("--clean", type=int, default=20)
    ap.add_argument("--samples", type=int, default=665)
    ap.add_argument("--no-broken", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    kinds = write_fleet(args.folder, args.clean, args.samples, not args.no_broken, args.seed)
    print(f"wrote {len(kinds)} files to {args.folder}")


if __name__ == "__main__":
    main()
