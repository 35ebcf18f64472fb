"""The presets: each loads by name, carries what its page says, and make presets rebuilds it."""

from pathlib import Path
import re
import sys

import pytest
import yaml

from gps_error_ros.model.profiles import builtin_dir, builtin_names, load_profile

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / 'docs' / 'presets.md'
#: The sections each preset has, as the page's table says.
SECTIONS = {'phone-suburban-drive': {'velocity', 'reported_accuracy', 'population'},
            'snapshot-receiver-on-foot': {'reported_accuracy', 'gross_failures', 'population'}}
OPTIONAL = ('availability', 'velocity', 'reported_accuracy', 'gross_failures', 'population')


@pytest.mark.parametrize('name', sorted(SECTIONS))
def test_a_preset_loads_by_name_with_its_sections(name):
    profile = load_profile(name.upper())         # names are case-insensitive
    assert profile.fitted
    raw = yaml.safe_load((builtin_dir() / f'{name}.yaml').read_text())
    assert {k for k in OPTIONAL if k in raw} == SECTIONS[name]
    row = next(line for line in PAGE.read_text().splitlines() if line.startswith(f'| `{name}`'))
    for section in SECTIONS[name]:
        assert f'`{section}`' in row, (name, section)
    assert profile.model().stationary_sd.min() > 0


def test_the_page_lists_every_fitted_builtin():
    text = PAGE.read_text()
    for name in builtin_names():
        if load_profile(name).fitted:
            assert f'`{name}`' in text, name
    # the held-out table is filled in, one row per check and order
    rows = re.findall(r'^\| Pixel 4.*\|$', text, re.M)
    assert len(rows) == 4, rows


def test_make_presets_rebuilds_the_shipped_phone_preset(tmp_path):
    sys.path.insert(0, str(ROOT / 'tools'))
    try:
        import presets
    finally:
        sys.path.pop(0)
    (tmp_path / 'config' / 'profiles').mkdir(parents=True)
    built = presets.build(ROOT / 'data', tmp_path)
    assert built.read_text() == (builtin_dir() / 'phone-suburban-drive.yaml').read_text()
