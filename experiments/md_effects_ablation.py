"""Why do the MD analogues miss some of the paper's findings? Fit MD1 and MD3 (RK, ND 1 and 10,
DE/rand/1/exp, 10 runs) on emulations with all effects off, with each effect alone, and with the
full set used for data/MD*.csv; print Ra, J, Tla errors and the best OF.

    .venv/bin/python experiments/md_effects_ablation.py
"""

import dataclasses

import numpy as np

import dcjax
from dcjax import PARAM_NAMES, identify
from dcjax.emulate import LAB_EFFECTS, Effects, emulate, md_settings

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)

CASES = {
    "none": Effects(),
    "noise+encoder": Effects(noise_u=0.3, noise_i=0.5, noise_w=0.1, encoder_ppr=1024, speed_window=0.01),
    "armature reaction": Effects(armature_reaction=0.03),
    "static friction": Effects(static_friction=True),
    "all (data files)": LAB_EFFECTS,
}


def main():
    for name in ("MD1", "MD3"):
        print(f"\n{name}")
        for label, eff in CASES.items():
            s = dataclasses.replace(md_settings(name), effects=eff)
            rec = emulate(s)
            for nd in (1, 10):
                r = identify(rec, integrator="rk4", nd=nd, bounds="table8", runs=10, seed=0)
                x = dict(zip(PARAM_NAMES, np.mean(r.run_params, axis=0)))
                t = s.params
                print(
                    f"  {label:18s} RK{nd:<3d} OF {r.stats['best']:.2e}  Ra {100 * (x['Ra'] / t['Ra'] - 1):+6.1f}%  "
                    f"J {100 * (x['J'] / t['J'] - 1):+6.1f}%  Tla {x['Tla']:.3f} (true {t['Tla']})  Tlc {x['Tlc']:.2e}"
                )


if __name__ == "__main__":
    main()
