"""Regenerate data/SD1.csv … SD4.csv (+ JSON sidecars) from paper Tables 2–3.

python data/generate_sd.py            # writes next to this script
python data/generate_sd.py --check    # exit 1 if any file differs from a fresh generation
"""

import argparse
import functools
import sys
from pathlib import Path

from dcjax.io.datasets import DATA_DIR, SD_PARAMS, generate_sd, write_or_check

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--check", action="store_true")
    makers = {name: functools.partial(generate_sd, name) for name in SD_PARAMS}
    sys.exit(write_or_check(makers, [Path(__file__).resolve().parent, DATA_DIR], ap.parse_args().check))
