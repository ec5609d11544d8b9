"""Regenerate data/MD1.csv … MD4.csv (+ JSON sidecars): emulated analogues of the paper's
measured sets (Table 7), made by dcjax.emulate — NOT the paper's measurements.

    python data/generate_md.py            # writes next to this script
    python data/generate_md.py --check    # exit 1 if any file differs from a fresh generation
"""

import argparse
import sys
import tempfile
from pathlib import Path

from dcjax.emulate import emulate, md_settings
from dcjax.recording import save_csv

NAMES = ("MD1", "MD2", "MD3", "MD4")


def write_all(folder: Path) -> None:
    for name in NAMES:
        save_csv(emulate(md_settings(name)), folder / f"{name}.csv")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()
    here = Path(__file__).resolve().parent
    if not args.check:
        write_all(here)
        print(f"wrote {', '.join(NAMES)} to {here}")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        write_all(Path(tmp))
        bad = [f.name for f in sorted(Path(tmp).iterdir()) if f.read_bytes() != (here / f.name).read_bytes()]
    print("identical" if not bad else f"differ: {bad}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
