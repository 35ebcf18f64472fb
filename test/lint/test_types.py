"""
The type checker is clean, and every function of the package is annotated.

mypy (pinned in requirements-dev.txt) with the configuration of setup.cfg:
the whole package checked, and the wings of ``STRICT`` held to the strict
rules there (every function annotated, no untyped calls, bodies checked).
"""

import ast
import itertools
from pathlib import Path
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / 'gps_error_ros'
#: The wings annotated whole, each with its strict section in setup.cfg
#: ([mypy-gps_error_ros.<wing>.*]): today every wing of the package.
STRICT = ('model', 'fit', 'traces', 'sim', 'diagnose', 'judge', 'reports', 'cli', 'ros',
          'ns3')


def _annotated(fn):
    args = fn.args.posonlyargs + fn.args.args + fn.args.kwonlyargs
    args += [a for a in (fn.args.vararg, fn.args.kwarg) if a is not None]
    return fn.returns is not None and all(
        a.annotation is not None for a in args if a.arg not in ('self', 'cls'))


def annotation_counts():
    """Return {wing: (functions annotated, functions)} over the package."""
    out = {}
    for path in sorted(PKG.rglob('*.py')):
        wing = path.relative_to(PKG).parts[0] if path.parent != PKG else '(top)'
        done, total = out.get(wing, (0, 0))
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                done, total = done + _annotated(node), total + 1
        out[wing] = (done, total)
    return out


@pytest.mark.linter
def test_mypy_is_clean():
    run = subprocess.run([sys.executable, '-m', 'mypy', '--config-file',
                          str(ROOT / 'setup.cfg'), str(PKG)],
                         capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stdout + run.stderr


#: The package's types with a model's state class as their parameter.
STATE_GENERIC = {'ErrorModel', 'ZoneProcess', 'Process', 'Wrapper', 'WrappedState',
                 'StepsPerFix', 'CrowdErrors', 'FixEngine', 'FcdRequest', 'FcdSteps', 'PartJob',
                 'AboutTruth', 'WithPopulation', 'WithFailures', 'WithAvailability'}


def state_erasures():
    """Return where the package forgets a model's state class: ``Any`` for it, or a cast."""
    found = []
    for path in sorted(PKG.rglob('*.py')):
        where = path.relative_to(PKG)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and \
                    node.value.id in STATE_GENERIC and any(
                        isinstance(n, ast.Name) and n.id == 'Any' for n in ast.walk(node.slice)):
                found.append(f'{where}:{node.lineno} {node.value.id}[Any]')
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and \
                    node.target.id in ('inner', 'state') and \
                    isinstance(node.annotation, ast.Name) and node.annotation.id == 'Any':
                found.append(f'{where}:{node.lineno} {node.target.id}: Any')
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
                    node.func.id == 'cast' and 'Model' in ast.unparse(node.args[0]):
                found.append(f'{where}:{node.lineno} cast to {ast.unparse(node.args[0])}')
    return found


@pytest.mark.linter
def test_a_models_state_is_typed_to_the_end():
    """
    No ``Any`` stands for a model's state; the one cast is :func:`~.protocol.opaque`.

    A profile's chain of wrappers is chosen at run time, and Python's types
    cannot name "some state class S with a model of S", so the package
    forgets S in one place (``opaque``), kept sound by its rule.
    """
    found = state_erasures()
    assert len(found) == 1 and found[0].startswith('model/protocol.py:') and \
        'cast to ' in found[0], found


@pytest.mark.linter
def test_the_strict_wings_are_annotated_whole():
    counts = annotation_counts()
    cfg = (ROOT / 'setup.cfg').read_text()
    for wing in STRICT:
        assert f'[mypy-gps_error_ros.{wing}.*]' in cfg, wing
        done, total = counts[wing]
        assert done == total, f'{wing}: {total - done} of {total} functions not annotated'
    done = sum(d for d, _ in counts.values())
    total = sum(t for _, t in counts.values())
    # a new wing joins STRICT (and setup.cfg); the package's own modules are annotated too
    assert set(counts) - {'(top)'} <= set(STRICT), set(counts) - {'(top)'} - set(STRICT)
    assert done == total, f'{total - done} of {total} functions of the package not annotated'
    print(f'annotated: {done} of {total} functions; ' + ', '.join(
        f'{w} {d}/{t}' for w, (d, t) in sorted(counts.items())))


USER_SCRIPT = '''
import numpy as np
import gps_error_ros as ge

profile: ge.Profile = ge.load_profile('DS5')
t = np.arange(0.0, 60.0)
fixes: ge.Fixes = ge.add_errors(profile, t, seed=7, east=1.4 * t, north=np.zeros(t.size),
                                datum=[40.75, -73.99], covariance_mode='conditional')
errors: ge.Errors = ge.simulate_errors(profile, agents=3, duration_s=60, seed=1)
print(fixes.covariance.shape, errors.north_east.shape)
east, north = ge.to_enu(fixes.lat, fixes.lon, datum=[40.75, -73.99])
error: float = float(np.hypot(*fixes.error.T).mean())
print(east - fixes.east if fixes.east is not None else north, error)
'''


def test_a_users_script_type_checks_against_the_installed_package(tmp_path):
    """
    A user's own script, outside the repository, sees the package's types (mypy --strict).

    The install ``make setup`` makes (editable, ``editable_mode=compat``) is
    one a type checker follows, and ``py.typed`` ships; a covariance mode that
    does not exist is caught before the script runs.
    """
    scripts = itertools.count()

    def check(text):
        # a cache of this test's own: the package is read once, each script after it
        name = f'mine{next(scripts)}.py'
        (tmp_path / name).write_text(text)
        return subprocess.run([sys.executable, '-m', 'mypy', '--strict', '--cache-dir',
                               str(tmp_path / 'cache'), name], cwd=tmp_path,
                              capture_output=True, text=True)
    ok = check(USER_SCRIPT)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    bad = check(USER_SCRIPT.replace("'conditional'", "'bogus'"))
    assert bad.returncode == 1 and 'covariance_mode' in bad.stdout, bad.stdout
    wrong = check(USER_SCRIPT.replace("error: float", "error: str"))
    assert wrong.returncode == 1 and 'error' in wrong.stdout, wrong.stdout
    text = check(USER_SCRIPT.replace("datum=[40.75, -73.99])", "datum=[40.75, -73.99])\n"
                                     "ge.add_errors(profile, t, 1, lat='abc', lon='abc')"))
    assert text.returncode == 1 and '"lat"' in text.stdout, text.stdout
