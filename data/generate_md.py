"""Regenerate data/MD1.csv … MD4.csv (+ JSON sidecars): emulated analogues of the paper's
measured sets (Table 7), made by dcjax.io.emulate — NOT the paper's measurements.

    python data/generate_md.py            # writes next to this script
    python data/generate_md.py --check    # exit 1 if any file differs from a fresh generation
"""

import argparse
import sys
from pathlib import Path

from dcjax.io.datasets import DATA_DIR, write_or_check
from dcjax.io.emulate import emulate, md_settings

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--check", action="store_true")
    makers = {name: (lambda n=name: emulate(md_settings(n))) for name in ("MD1", "MD2", "MD3", "MD4")}
    sys.exit(write_or_check(makers, [Path(__file__).resolve().parent, DATA_DIR], ap.parse_args().check))
