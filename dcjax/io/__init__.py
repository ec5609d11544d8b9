"""Recordings and where they come from: the `Recording` (named channels, an optional clamp),
lab file formats and units, the embedded SD/MD data sets, the drive emulator, and the
independent NumPy reference integrator that made the SD data."""

from .loading import load_recording, preprocess
from .numpy_simulator import objective_numpy, simulate_numpy
from .recording import Recording, load_csv, save_csv, trim_switch_on

__all__ = ["Recording", "load_csv", "load_recording", "objective_numpy", "preprocess", "save_csv", "simulate_numpy", "trim_switch_on"]
