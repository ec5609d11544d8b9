"""Regenerate data/SD1.csv … SD4.csv (+ JSON sidecars) from paper Tables 2–3.

    python data/generate_sd.py            # writes next to this script
    python data/generate_sd.py --check    # exit 1 if any file differs from a fresh generation
"""

import argparse
import sys
import tempfile
from pathlib import Path

from dcjax.datasets import SD_PARAMS, generate_sd
from dcjax.recording import save_csv


def write_all(folder: Path) -> None:
    for name in SD_PARAMS:
        save_csv(generate_sd(name), folder / f"{name}.csv")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()
    here = Path(__file__).resolve().parent
    if not args.check:
        write_all(here)
        print(f"wrote {', '.join(SD_PARAMS)} to {here}")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        write_all(Path(tmp))
        bad = [f.name for f in sorted(Path(tmp).iterdir()) if f.read_bytes() != (here / f.name).read_bytes()]
    print("identical" if not bad else f"differ: {bad}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
