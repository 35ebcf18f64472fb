"""ament_flake8 over the package and tests (the ROS 2 template's linter test)."""

from pathlib import Path

import pytest
from ament_flake8.main import main_with_errors

CONFIG = Path(__file__).with_name('flake8.ini')


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    rc, errors = main_with_errors(argv=['--config', str(CONFIG)])
    assert rc == 0, \
        'Found %d code style errors / warnings:\n' % len(errors) + \
        '\n'.join(errors)
