"""The command line's names for the library's arguments, in one table: the library's messages
name Python arguments (`units={'omega': 'rpm'}`, `drop_nan=True`,
`params['J'].set(min=LO, max=HI)`), and the command line shows its flags (`--units omega=rpm`,
`--drop-nan`, `--bound J=LO:HI`) by `as_flags`, applied to every error, warning and note it
prints."""

import ast
import re
import shlex

# a mapping or a sequence of the library -> the flag's NAME=VALUE pairs or comma-separated names
PAIRS = {
    "units": "--units",
    "columns": "--columns",
    "scale": "--scale",
    "constants": "--const",
    "initial": "--initial",
    "hold": "--hold",
    "offsets": "--offset",
    "delays": "--delay",
    "measure": "--measure",
    "weights": "--weights",
    "process": "--process-noise",
    "measurement": "--measurement-noise",
    "fixed": "--fix",
    "start": "--x0",
    "log": "--log",
    "local": "--local",
}
VALUES = {
    "dt": "--dt",
    "rate": "--rate",
    "delimiter": "--delimiter",
    "decimal": "--decimal",
    "model": "--model",
    "params": "--bounds",
    "limit": "--limit",
    "window": "--window",
    "every": "--every",
    "focus": "--focus",
}
SWITCHES = {"drop_nan": "--drop-nan", "allow_changed_data": "--allow-changed-data", "trim": "--trim", "polish": "--polish"}
CALLS = [
    (r"params\[['\"]?([\w\[\]]+?)['\"]?\]\.set\(min=([^,()]+), max=([^,()]+)\)", r"--bound \1=\2:\3"),
    (r"\brecordings=\[?\.\.\.\]?", "--data FILE"),
    (r"params\[['\"]?([\w\[\]]+?)['\"]?\]\.set\(value=([^,()]+), vary=False\)", r"--fix \1=\2"),
    (r"\bresult\.uncertainty\(\)", "--uncertainty"),
    (r"\bintegrator=dcjax\.AutoSubsteps\(\)", "--nd auto"),
    (r"\bintegrator=dcjax\.RK4\(substeps=(\d+)\)", r"--nd \1"),
    (r"\bintegrator=dcjax\.Euler\(substeps=(\d+)\)", r"--integrator euler --nd \1"),
]


def _flag_value(text: str) -> str:
    """A Python literal as the command line spells it, quoted for a shell where it needs it:
    {'a': 1} -> a=1, ('a', 'b') -> a,b, 'x' -> x, {'t': 't [ms]'} -> 't=t [ms]', ';' -> ';'."""
    try:
        v = ast.literal_eval(text)
    except (ValueError, SyntaxError):  # a placeholder in it: {'k': V} -> k=V
        items = re.findall(r"['\"]?([\w.]+)['\"]?\s*:\s*['\"]?([^,'\"{}]+?)['\"]?\s*(?:,|\}|$)", text)
        return ",".join(f"{k}={x}" for k, x in items) if text.startswith("{") and items else text
    if isinstance(v, dict):
        return shlex.quote(",".join(f"{k}={x}" for k, x in v.items()))
    if isinstance(v, (list, tuple)):
        return shlex.quote(",".join(str(x) for x in v))
    return shlex.quote(str(v))


LITERAL = r"(\{[^{}]*\}|\([^()]*\)|\[[^\[\]]*\]|'[^']*'|\"[^\"]*\"|[^\s,;)]+)"


def as_flags(text: str) -> str:
    """`text` with every library argument of the table written as its command-line flag."""
    for pattern, repl in CALLS:
        text = re.sub(pattern, repl, text)
    for name, flag in SWITCHES.items():
        text = re.sub(rf"\b{name}=True\b", flag, text)
    for name, flag in {**PAIRS, **VALUES}.items():
        text = re.sub(rf"(?<![\w.]){name}=(?=[\s,;)/]|$)", flag, text)  # the argument alone: `dt=`
        text = re.sub(rf"(?<![\w.]){name}={LITERAL}", lambda m, f=flag: f"{f} {_flag_value(m.group(1))}", text)
    return text
