"""`dcjax fit | simulate | validate | report | design | sample`: identification and its checks from a shell."""

import os
import sys
import warnings

from .args import _parser
from .design import design_cmd
from .fitting import bound_hints, fit
from .saved import report_cmd, sample_cmd, simulate_cmd, validate_cmd

__all__ = ["bound_hints", "main"]


COMMANDS = {
    "fit": fit,
    "simulate": simulate_cmd,
    "validate": validate_cmd,
    "report": report_cmd,
    "design": design_cmd,
    "sample": sample_cmd,
}


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    from ..devices import use_compilation_cache, use_compiled_loops, use_host_devices

    use_host_devices()
    with warnings.catch_warnings():  # main() called in a process where JAX already runs: skip quietly
        warnings.simplefilter("ignore")
        use_compiled_loops()  # a population's time loop as one CPU function (XLA_FLAGS set by the user: kept)
    # A repeated fit, or a similar folder, loads its executables (DCJAX_NO_CACHE=1: off); every one,
    # the small ones too: a similar second folder of 20 files then spent 0.25 s in XLA (cache
    # reads) instead of 1.26 s (`python -m experiments.bench_each --lengths 400 1600 --again`).
    use_compilation_cache(min_compile_seconds=0.0)
    with warnings.catch_warnings():
        warnings.showwarning = _one_line_warning  # inside this block only (catch_warnings restores it)
        try:
            return COMMANDS[args.command](args)
        except BrokenPipeError:  # the reader went away (dcjax report RESULT.json | head): not an error
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error when Python flushes stdout
            return 0
        except (ValueError, OSError) as e:
            print(f"dcjax: error: {e}", file=sys.stderr)
            return 2
        except Exception as e:  # never a traceback from the command line
            print(f"dcjax: error: {type(e).__name__}: {(str(e).splitlines() or [''])[0]}", file=sys.stderr)
            return 2


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    print(f"dcjax: warning: {message}", file=sys.stderr)
