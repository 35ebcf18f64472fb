"""Public docstrings that document parameters document all of them, and what is returned."""

from pathlib import Path
import subprocess
import sys

import pytest

PKG = Path(__file__).resolve().parents[2] / 'gps_error_ros'
#: pydoclint, numpy style: every docstring with a Parameters section (a one-line
#: docstring of a small helper is left alone) lists exactly the signature's
#: arguments and has a Returns section where the function returns.
#: In the wings annotated whole (test_types.STRICT) the types are in the signature and
#: not repeated in the docstring; elsewhere, still in the docstring.
ARGS = ['--style=numpy', '--quiet', '--skip-checking-short-docstrings=True',
        '--check-return-types=False', '--check-yield-types=False',
        '--skip-checking-raises=True', '--check-class-attributes=False']
TYPED = ['--arg-type-hints-in-docstring=False', '--arg-type-hints-in-signature=True']
UNTYPED = ['--arg-type-hints-in-docstring=True', '--arg-type-hints-in-signature=False']
STRICT = ('model', 'fit', 'traces', 'sim', 'diagnose', 'judge', 'reports', 'cli', 'ros', 'ns3')


def _wings():
    return [(p, TYPED if p.name in STRICT else UNTYPED)
            for p in sorted(PKG.iterdir()) if p.is_dir() and (p / '__init__.py').exists()]


@pytest.mark.linter
@pytest.mark.parametrize('wing, hints', _wings(), ids=lambda v: getattr(v, 'name', ''))
def test_docstrings_match_their_signatures(wing, hints):
    run = subprocess.run([str(Path(sys.executable).with_name('pydoclint')), *ARGS, *hints,
                          str(wing)], capture_output=True, text=True)
    found = [line for line in (run.stdout + run.stderr).splitlines() if 'DOC' in line]
    assert not found, '\n'.join(found)
