"""Write REPORT.md from a results store: one module per part of the paper, the thresholds in their
own module, one renderer (`render.write_report`).

    python -m experiments.report [--store ...] [--out ...] [--figures ...]
"""

from .render import load_profile, main, without_times, write_report

__all__ = ["load_profile", "main", "without_times", "write_report"]
