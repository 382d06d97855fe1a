"""Where the repository's files are, for every test."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
"""The repository root."""

SAMPLE_LOGS = ROOT / "sample_logs"
"""The committed sample logs (``sample_logs/README.md`` says how each was made)."""

TANK_CSV = SAMPLE_LOGS / "three_tank_hstf.csv"
"""Paper 000's three-tank run, the log most tests analyse."""
