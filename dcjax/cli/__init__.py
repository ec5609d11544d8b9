"""`dcjax fit | simulate | validate | report | design | sample`: identification and its checks from a shell."""

import os
import signal
import sys
import threading
import warnings

from ..devices import compilation_cache, use_compiled_loops, use_host_devices
from ..errors import DcjaxError
from .commands import COMMANDS
from .flags import as_flags
from .parser import build_parser

__all__ = ["entry", "main"]


def main(argv: list[str] | None = None, cleanup: list | None = None) -> int:
    """The command line in this process (tests, notebooks): its exit status; errors as one line on
    stderr. `cleanup`: a list the output folders put their undo on while they are open (`entry`)."""
    try:
        args = build_parser().parse_args(argv)
    except DcjaxError as e:  # a malformed or unknown flag, a missing argument: one line
        print(f"dcjax: error: {e}", file=sys.stderr)
        return 2
    args.cleanup = cleanup

    use_host_devices()
    with warnings.catch_warnings():  # main() called in a process where JAX already runs: skip quietly
        warnings.simplefilter("ignore")
        use_compiled_loops()  # a population's time loop as one CPU function (XLA_FLAGS set by the user: kept)
    # A repeated fit, or a similar folder, loads its executables (DCJAX_NO_CACHE=1: off); every one,
    # the small ones too: a similar second folder of 20 files then spent 0.25 s in XLA (cache
    # reads) instead of 1.26 s (`python -m experiments.bench_each --lengths 400 1600 --again`).
    # For the command only: the calling process's own cache settings hold again after it.
    with compilation_cache(min_compile_seconds=0.0), warnings.catch_warnings():
        warnings.showwarning = _one_line_warning  # inside this block only (catch_warnings restores it)
        try:
            return COMMANDS[args.command].run(args)
        except BrokenPipeError:  # the reader went away (dcjax report RESULT.json | head): not an error
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error when Python flushes stdout
            return 0
        except (DcjaxError, OSError) as e:  # dcjax's one-line errors, and the system's (a file, a folder)
            print(f"dcjax: error: {as_flags(str(e))}", file=sys.stderr)
            return 2
        except Exception as e:  # never a traceback from the command line
            print(f"dcjax: error: {type(e).__name__}: {(str(e).splitlines() or [''])[0]}", file=sys.stderr)
            return 2


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    print(f"dcjax: warning: {as_flags(str(message))}", file=sys.stderr)


class _Signal(Exception):
    def __init__(self, signum: int):
        self.signum = signum


def entry(argv: list[str] | None = None) -> int:
    """The `dcjax` command: `main` in a worker thread while this one waits for it, so that Ctrl-C
    (SIGINT) or SIGTERM end the command at once with one line, also while a compiled search runs
    (XLA returns to Python only when its call ends): the files already written are whole (each
    was written to a temporary name and renamed), an output folder this run created and wrote
    nothing into is removed, and the exit status is 128 + the signal's number."""

    cleanup: list = []
    outcome: dict = {}

    def work():
        try:
            outcome["rc"] = main(argv, cleanup)
        except BaseException as e:  # argparse's SystemExit too: raised again in the main thread
            outcome["error"] = e

    def stop(signum, frame):
        raise _Signal(signum)

    previous = signal.signal(signal.SIGTERM, stop)
    worker = threading.Thread(target=work, name="dcjax", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.05)
    except (KeyboardInterrupt, _Signal) as e:
        signum = e.signum if isinstance(e, _Signal) else signal.SIGINT
        for undo in list(cleanup):
            undo()
        what = "interrupted" if signum == signal.SIGINT else f"stopped by signal {signal.Signals(signum).name}"
        print(f"\ndcjax: {what}: the files already written are whole; nothing half-written is left", file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(128 + int(signum))
    finally:
        signal.signal(signal.SIGTERM, previous)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["rc"]
