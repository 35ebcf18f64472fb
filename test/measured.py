"""The measured recordings the tests read: the repository's own ``data/`` (see its README)."""

from pathlib import Path

#: The folder of the measured trace CSVs, shipped in the repository.
DATA = Path(__file__).resolve().parents[1] / 'data'
#: The raw files they came from (NMEA, GnssLogger logs).
RAW = DATA / 'raw'
#: The SnapperGPS pedestrian walks, w00..w06.
WALKS = sorted(DATA.glob('snapper-walk-*.csv'))
