"""
The public API: ``gps_error_ros.__all__``, typed, each name with an example that runs.

The examples in the docstrings are executed here as written (doctest, from
the repository's root: they read its ``data/``), and the API's fixes and
errors are checked against what ``simulate`` and the model give.
"""

import doctest
import inspect
from pathlib import Path

import numpy as np
import pytest

import gps_error_ros
import gps_error_ros as ge
from gps_error_ros import api

ROOT = Path(__file__).resolve().parents[1]


def test_all_is_the_api_and_every_name_has_an_example():
    import pkgutil
    # every subpackage imported first: a public name that is also a subpackage's
    # would then be the module, not the function
    for sub in pkgutil.iter_modules(gps_error_ros.__path__):
        assert sub.name not in api.__all__, sub.name
        if sub.ispkg:
            __import__(f'gps_error_ros.{sub.name}')
    assert gps_error_ros.__all__ == api.__all__
    for name in gps_error_ros.__all__:
        obj = getattr(gps_error_ros, name)
        assert obj is getattr(api, name)
        doc = inspect.getdoc(obj) or ''
        # numpydoc: an Examples section, which the site renders as code
        assert '\nExamples\n--------\n' in doc and '>>>' in doc, f'{name} has no example'
    assert (ROOT / 'gps_error_ros' / 'py.typed').exists()
    with pytest.raises(AttributeError, match='no attribute'):
        gps_error_ros.simulate_everything


def test_the_examples_run_as_written(monkeypatch):
    monkeypatch.chdir(ROOT)
    from gps_error_ros.model import profiles
    result = doctest.testmod(api, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 25
    assert result.failed == 0
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for test in finder.find(profiles.Profile, 'Profile', globs={}):
        runner.run(test)
    assert runner.summarize(verbose=False).attempted >= 3
    assert runner.summarize(verbose=False).failed == 0


def test_simulated_errors_are_the_models_streams():
    from gps_error_ros.model.streams import agent_keys
    profile = api.load_profile('DS2')
    e = api.simulate_errors(profile, ['a', 'b'], 100, seed=3, start_s=50)
    want = profile.model(about_truth=True).simulate(agent_keys(3, ['a', 'b']), 100, start=50)
    np.testing.assert_allclose(e.north_east, want.transpose(1, 0, 2), rtol=0, atol=1e-9)
    assert e.t[0] == 50.0 and e.velocity is None and not e.failed.any()
    np.testing.assert_allclose(e.covariance[0, 0], profile.model(
        about_truth=True).stationary_cov)


def test_added_errors_are_what_simulate_writes(tmp_path):
    import csv
    from gps_error_ros.sim.simulate import simulate_csv
    t = np.repeat(np.arange(10.0, 70.0), 2)
    agents = ['x', 'y'] * 60
    lat = 48.85 + 1e-5 * t
    lon = np.full(t.size, 2.35)
    src = tmp_path / 'truth.csv'
    src.write_text('t,agent,truth_lat,truth_lon\n' + ''.join(
        f'{float(a)!r},{b},{float(c)!r},{float(d)!r}\n'
        for a, b, c, d in zip(t, agents, lat, lon)))
    profile = api.load_profile('snapshot-receiver-on-foot')
    model = profile.model(about_truth=True)
    simulate_csv(src, tmp_path / 'o.csv', model, 1.0, 5, covariance_mode='conditional')
    with open(tmp_path / 'o.csv', newline='') as f:
        rows = list(csv.DictReader(f))
    fixes = api.add_errors(profile, t, 5, lat, lon, agents=agents,
                           covariance_mode='conditional')
    np.testing.assert_allclose(fixes.lat, [float(r['lat']) for r in rows], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fixes.accuracy, [float(r['accuracy']) for r in rows], rtol=1e-12)


def test_added_errors_flag_the_models_failures_and_report_velocity():
    # a gross failure of the profile lands on the same (agent, step) as in
    # simulate_errors; the failed fixes are the far ones
    t = np.arange(0.0, 3600.0)
    profile = api.load_profile('snapshot-receiver-on-foot')
    fixes = api.add_errors(profile, t, 1, east=1.3 * t, north=np.zeros(t.size),
                           datum=[51.75, -1.25])
    errors = api.simulate_errors(profile, [''], 3600, seed=1)
    np.testing.assert_array_equal(fixes.failed, errors.failed[0])
    off = np.hypot(fixes.east - 1.3 * t, fixes.north)
    assert fixes.failed.sum() > 10 and np.median(off[fixes.failed]) > 3 * np.median(off)
    assert fixes.speed is None               # this profile has no velocity section
    phone = api.add_errors(api.load_profile('phone-suburban-drive'), t[:60], 1,
                           east=1.3 * t[:60], north=np.zeros(60), datum=[37.42, -122.08])
    assert phone.speed is not None and np.nanmedian(np.abs(phone.speed - 1.3)) < 1.0
    assert np.nanmedian(np.abs(phone.bearing - 90.0)) < 45.0


@pytest.mark.parametrize('call, says', [
    (lambda p: api.simulate_errors(p, 2, 10, 1, covariance_mode='stated'),
     "covariance_mode 'stated'"),
    (lambda p: api.add_errors(p, [0.0], 1), 'give lat and lon'),
    (lambda p: api.add_errors(p, [0.0], 1, datum=[48.0, 2.0]), 'with datum, give east'),
    (lambda p: api.add_errors(p, [0.0], 1, lat=[48.0], lon=[2.0], east=[0.0], north=[0.0],
                              datum=[48.0, 2.0]), 'not both'),
    (lambda p: api.add_errors(p, [0.0], 1, east=[0.0], north=[0.0]), 'need datum'),
    (lambda p: api.add_errors(p, [0.0, 1.0], 1, lat=[48.0, 140.75], lon=[2.0, 2.0]),
     r'first row 1: lat 140.75, lon 2.0; expected finite degrees'),
    (lambda p: api.add_errors(p, [0.0], 1, lat=[float('nan')], lon=[2.0]),
     r'first row 0: lat nan'),
])
def test_a_wrong_call_says_what_was_expected(call, says):
    with pytest.raises(ValueError, match=says):
        call(api.load_profile('DS5'))


def test_the_package_lists_its_names():
    """Tab-completion and help() show the eight names, not the loader's internals."""
    import gps_error_ros
    assert set(gps_error_ros.__all__) <= set(dir(gps_error_ros))
    assert not {'Any', 'TYPE_CHECKING'} & set(dir(gps_error_ros))
    for name in gps_error_ros.__all__:
        assert name in gps_error_ros.__doc__
        assert getattr(gps_error_ros, name) is getattr(gps_error_ros.api, name)


def test_the_api_names_what_was_wrong():
    """Rows of different lengths, a mode that does not exist, a datum of one number."""
    profile = ge.load_profile('DS5')
    t = np.arange(10.0)
    with pytest.raises(ValueError, match=r't 10, lat 10, lon 9 values'):
        ge.add_errors(profile, t, 1, np.full(10, 40.75), np.full(9, -73.99))
    with pytest.raises(ValueError, match=r"covariance_mode 'bogus'"):
        ge.add_errors(profile, t, 1, np.full(10, 40.75), np.full(10, -73.99),
                      covariance_mode='bogus')
    with pytest.raises(ValueError, match=r'datum \[40.75\]: expected \[lat, lon\]'):
        ge.add_errors(profile, t, 1, east=t, north=t, datum=[40.75])


def test_calibrate_warns_when_it_cannot_fit_a_population(tmp_path):
    """Five minutes of one walk is one 300-s block; a population needs three."""
    import warnings
    rows = (ROOT / 'data' / 'snapper-walk-w00.csv').read_text().splitlines()
    short = tmp_path / 'short.csv'
    short.write_text('\n'.join(rows[:301]) + '\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        profile = ge.calibrate(short, population=True, within='ar', progress=False)
    assert profile.population is None
    said = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    assert said and 'no population section' in said[0] and '3' in said[0], said
    assert 'neither a population nor the extended model' in said[0], said
