"""`dcjax simulate | validate | report`: what a saved result says about recordings."""

import argparse
import sys
import warnings
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from ..analysis.checks import pulse_width
from ..analysis.plotting import corner
from ..analysis.report import channel_fit
from ..errors import ConfigError
from ..fitting.restore import load_result
from ..io.files import file_sha256, strict_json, write_atomic, write_text
from ..io.loading import Reading
from ..io.units import ColumnError
from .args import _named_priors
from .fitting import _load, reading_of
from .flags import as_flags
from .output import announce, file_names, output_folder


def _result(args):
    """The saved result of `args.result`: its model named by the file where built in, else by
    --model; its recordings --data where given (read in the fit's layout), else the files it
    names where their bytes are the fitted ones (--allow-changed-data: read changed ones too)."""

    model = getattr(args, "model", None)
    allow = bool(getattr(args, "allow_changed_data", False))
    data = getattr(args, "data_files", None)
    if not data:
        return load_result(args.result, model=model, allow_changed_data=allow)
    res = load_result(args.result, [], model=model)
    as_fitted = argparse.Namespace(
        columns=None,
        units=None,
        scale=None,
        dt=None,
        rate=None,
        delimiter=None,
        decimal=".",
        const=None,
        drop_nan=False,
        window=None,
        every=None,
        trim=False,
        limit=None,
    )  # read in the fit's layout
    return load_result(args.result, [_load_like_fit(d, as_fitted, res) for d in data], model=model)


def _load_like_fit(data: str, args, res):
    """`data` read as the fit read its file: the reading options given (--columns, --units,
    --scale, --dt, --rate, --delimiter, --decimal, --const) replace the fit's as a whole; none
    given, a file in the fit's layout (its mapped columns are there) is read with the fit's
    (`result.json`'s `load`), and one without them whose header names the model's channels by its
    own header, with a note (the fit's unit conversions are not applied to it). A channel whose
    peak differs from the fitted recording's by more than 10x gets a one-line warning (a unit or
    scale slip)."""

    src = next((d for d in res.settings.get("data") or [] if isinstance(d, dict)), {})
    given = reading_of(args)
    fitted = Reading.from_record(src.get("load"))
    if given.given or not fitted.given or not Path(data).exists():
        rec = _load(data, args, res.model, given)
    else:
        try:
            rec = _load(data, args, res.model, fitted)
        except ColumnError as e:
            try:
                rec = _load(data, args, res.model, Reading(constants=fitted.constants))
            except ValueError:
                raise e from None
            print(
                f"note: {Path(data).name} is not in the fit's layout ({e.args[0].split('; ')[0].split(': ')[-1]}): read by its own "
                f"header ({', '.join(res.model.channels)}), without the fit's units and scales"
            )
    for c, peak_fit in (src.get("peaks") or {}).items():
        if c in rec.channels and peak_fit > 0:
            peak = float(np.max(np.abs(rec[c])))
            ratio = peak / peak_fit
            if not 0.1 <= ratio <= 10 and pulse_width(np.asarray(rec[c], float)) < 2:  # a short pulse, not a unit
                warnings.warn(
                    f"{rec.name}: the peak of {c} ({peak:.4g}, {ratio:.3g}x the fitted recording's) is a pulse shorter than two samples",
                    stacklevel=2,
                )
            elif not 0.1 <= ratio <= 10:
                warnings.warn(
                    f"{rec.name}: the peak of {c} is {ratio:.3g}x the fitted recording's ({peak:.4g} vs {peak_fit:.4g}): "
                    "a unit or scale slip? (--units, --scale)",
                    stacklevel=2,
                )
    return rec


def simulate_cmd(args) -> int:

    res = _result(args)
    rec = _load_like_fit(args.data, args, res)
    stem = f"simulated_{file_names([rec.name])[0]}"
    sim = res.simulate(rec)
    m = res.model
    cols = ["t", *m.inputs, *(f"{c}_meas" for c in m.outputs), *(f"{s}_sim" for s in m.states)]
    table = np.column_stack([rec.t, *(rec[c] for c in m.inputs), *(rec[c] for c in m.outputs), sim])
    with output_folder(args, lambda f: [f / f"{stem}.csv"], f"an earlier {stem}.csv") as folder:
        out = announce(folder)
        path = write_atomic(
            out / f"{stem}.csv", lambda tmp: np.savetxt(tmp, table, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
        )
        res.plot(out / f"{stem}.png", recordings=[rec], convergence=False)
    print(f"wrote {path} and {out / f'{stem}.png'}")
    return 0


def validate_cmd(args) -> int:

    res = _result(args)
    recs = [_load_like_fit(d, args, res) for d in args.data]
    x = jnp.asarray([res.best_values[n] for n in res.names], dtype=jnp.float64)
    width = max(12, *(len(r.name) for r in recs))
    with output_folder(args, lambda f: [f / "validation.json"], "an earlier validation.json") as folder:
        out = announce(folder)
        print(f"{'recording':>{width}} {'OF':>12}  " + "  ".join(f"{'fit % ' + c:>14}" for c in res.model.outputs))
        rows = []
        for rec, name in zip(recs, file_names([r.name for r in recs])):
            of = float(res.target([rec]).objective(x))  # a fitted recording with its own local values and initial states
            fits = channel_fit(res, rec)
            rows.append({"recording": rec.name, "of": of, "fit_percent": fits, "plot": f"validate_{name}.png"})
            print(f"{rec.name:>{width}} {of:12.4e}  " + "  ".join(f"{v:14.3f}" for v in fits.values()))
            for c, v in fits.items():
                if not v > 0:
                    print(f"warning: {rec.name}: fit % of {c} is {v:.1f} <= 0: the model does not follow {c} on this recording")
            res.plot(out / f"validate_{name}.png", recordings=[rec], convergence=False)
        write_text(out / "validation.json", strict_json(rows) + "\n")
    print(f"wrote {out / 'validation.json'} and {len(recs)} plot(s) in {out}")
    return 0


def sample_cmd(args) -> int:
    """Posterior draws of a saved result: the table (posterior beside the linearised 90 %
    intervals), posterior.npz and corner.png in --out."""

    res = _result(args)
    priors = _named_priors(args.prior)
    with output_folder(args, lambda f: [f / "posterior.npz"], "an earlier posterior.npz") as folder:
        out = folder.path
        post = res.sample(draws=args.draws, chains=args.chains, warmup=args.warmup, seed=args.seed, priors=priors)
        u = res.uncertainty().uncertainties
        assert u is not None
        print(post.table(u.intervals(post.names)))
        announce(folder)
        post.save(out / "posterior.npz", result_sha256=file_sha256(args.result))
        corner(post, out / "corner.png")
    bad = [n for n in post.names if not post.rhat[n] <= 1.01 or not post.ess_bulk[n] >= 400]
    if bad:
        print(
            f"warning: R-hat above 1.01 or bulk ESS below 400 for {', '.join(bad)}: more --draws/--warmup, or a posterior "
            "the sampler does not mix over (see corner.png)"
        )
    if post.divergences:
        print(f"warning: {post.divergences} divergent transitions: the draws may miss part of the posterior")
    print(f"wrote {out / 'posterior.npz'} and {out / 'corner.png'}")
    return 0


def report_cmd(args) -> int:
    from ..analysis.posterior import Posterior  # lazy: blackjax adds ~0.3 s to importing dcjax

    res = _result(args)
    if args.uncertainty:
        res = res.uncertainty()
    path = Path(args.posterior) if args.posterior else Path(args.result).parent / "posterior.npz"
    if args.posterior and not path.is_file():
        raise ConfigError(f"--posterior: no such file: {path}")
    post = Posterior.load(path) if path.is_file() else None
    if post is not None and post.result_sha256 != file_sha256(args.result):
        if not args.posterior:  # the file beside it belongs to another result (or a result changed since): not this one's
            print(
                f"note: {path} was not sampled from this result.json (another fit's, or the result changed): not reported; "
                "--posterior names a posterior to report anyway",
                file=sys.stderr,
            )
            post = None
        else:
            print(f"note: --posterior {path} was not sampled from this result.json", file=sys.stderr)
    if post is not None and not set(post.names) <= set(res.names):
        raise ConfigError(f"--posterior: {path} holds draws of {', '.join(post.names)}, not of this result's parameters")
    print(as_flags(res.report(posterior=post)))
    return 0
