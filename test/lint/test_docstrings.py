"""Public docstrings that document parameters document all of them, and what is returned."""

from pathlib import Path
import subprocess
import sys

import pytest

PKG = Path(__file__).resolve().parents[2] / 'gps_error_ros'
#: pydoclint, numpy style: every docstring with a Parameters section (a one-line
#: docstring of a small helper is left alone) lists exactly the signature's
#: arguments and has a Returns section where the function returns.
ARGS = ['--style=numpy', '--quiet', '--skip-checking-short-docstrings=True',
        '--arg-type-hints-in-docstring=True', '--arg-type-hints-in-signature=False',
        '--check-return-types=False', '--check-yield-types=False',
        '--skip-checking-raises=True', '--check-class-attributes=False']


@pytest.mark.linter
def test_docstrings_match_their_signatures():
    run = subprocess.run([str(Path(sys.executable).with_name('pydoclint')), *ARGS, str(PKG)],
                         capture_output=True, text=True)
    found = [line for line in (run.stdout + run.stderr).splitlines() if 'DOC' in line]
    assert not found, '\n'.join(found)
