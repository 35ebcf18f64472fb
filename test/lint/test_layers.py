"""
The house rules, checked on the source: imports run one way, sizes stay small.

Wings, bottom to top (``docs/architecture.md``): ``model`` imports nothing
of the package; ``traces`` the model; ``fit`` and ``sim`` the model and
traces; ``diagnose`` also fit; ``judge`` also diagnose; ``reports`` anything below; ``ros`` and
``cli`` sit on top (cli never imports ros); ``ns3`` (ns-3's path) sits on sim and
reports, beside them; ``api`` (the public names) takes from model, traces, fit,
sim, diagnose and judge. Only ``ros`` imports rclpy or message packages, only
``traces.bag_io`` imports rosbags (and not at module level), only ``ns3``
imports ns-3 (``ns``, ``cppyy``; not at module level), and only ``reports``
imports matplotlib.
"""

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[2] / 'gps_error_ros'
BELOW = {
    'model': set(),
    'traces': {'model'},
    'fit': {'model', 'traces'},
    'sim': {'model', 'traces'},
    'diagnose': {'model', 'traces', 'fit'},
    'judge': {'model', 'traces', 'fit', 'diagnose'},
    'reports': {'model', 'traces', 'fit', 'sim', 'diagnose', 'judge'},
    'ros': {'model', 'traces', 'fit', 'sim', 'reports'},
    'cli': {'model', 'traces', 'fit', 'sim', 'diagnose', 'judge', 'reports'},
    'ns3': {'model', 'traces', 'sim', 'reports'},
    'api': {'model', 'traces', 'fit', 'sim', 'diagnose', 'judge'},
}
ROS_PACKAGES = ('rclpy', 'rcl_interfaces', 'builtin_interfaces', 'rosgraph_msgs',
                'sensor_msgs', 'geometry_msgs', 'nav_msgs', 'std_srvs', 'std_msgs',
                'rosidl_runtime_py', 'diagnostic_msgs')
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 60
#: a function longer than the guide says why in its docstring, with this mark
LONG_MARK = 'Long because'


def modules():
    """Yield (wing, module path, parsed tree) of every package module."""
    for path in sorted(PKG.rglob('*.py')):
        rel = path.relative_to(PKG)
        wing = rel.parts[0] if len(rel.parts) > 1 else rel.stem
        yield wing, path, ast.parse(path.read_text(), str(path))


def imports(tree):
    """Yield (module name, lineno, at module level) of every import."""
    top = set(id(n) for n in tree.body)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno, id(node) in top
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                raise AssertionError(f'line {node.lineno}: relative import; the '
                                     f'package uses absolute imports')
            if node.module == 'gps_error_ros':
                for alias in node.names:
                    yield f'gps_error_ros.{alias.name}', node.lineno, id(node) in top
            else:
                yield node.module, node.lineno, id(node) in top


def test_every_module_belongs_to_a_wing():
    wings = {w for w, _, _ in modules()}
    assert wings <= set(BELOW) | {'__init__'}, wings - set(BELOW)


@pytest.mark.parametrize('wing', sorted(BELOW))
def test_imports_run_one_way(wing):
    bad = []
    for w, path, tree in modules():
        if w != wing:
            continue
        for name, line, top in imports(tree):
            parts = name.split('.')
            if parts[0] == 'gps_error_ros' and len(parts) > 1:
                other = parts[1]
                if other != wing and other not in BELOW[wing]:
                    bad.append(f'{path.relative_to(PKG)}:{line} imports {name}')
            if parts[0] in ROS_PACKAGES and wing != 'ros':
                bad.append(f'{path.relative_to(PKG)}:{line} imports ROS ({name})')
            if parts[0] == 'rosbags' and (path.name != 'bag_io.py' or top):
                bad.append(f'{path.relative_to(PKG)}:{line} imports rosbags '
                           f'(only bag_io may, inside a function)')
            if parts[0] in ('ns', 'cppyy') and (wing != 'ns3' or top):
                bad.append(f'{path.relative_to(PKG)}:{line} imports ns-3 ({name}; only '
                           f'ns3 may, inside a function)')
            if parts[0] == 'matplotlib' and wing != 'reports':
                bad.append(f'{path.relative_to(PKG)}:{line} imports matplotlib')
    assert not bad, '\n'.join(bad)


def test_the_checks_catch_a_wrong_import(tmp_path):
    tree = ast.parse('from gps_error_ros.ros import cdr\nimport rclpy\n')
    names = [n for n, _, _ in imports(tree)]
    assert names == ['gps_error_ros.ros', 'rclpy']
    assert 'ros' not in BELOW['model'] and 'ros' not in BELOW['cli']
    with pytest.raises(AssertionError, match='relative import'):
        list(imports(ast.parse('from .streams import agent_key\n')))


def docstring_lines(node):
    """Return the lines of ``node``'s own docstring (0 without one)."""
    body = getattr(node, 'body', [])
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        return body[0].end_lineno - body[0].lineno + 1
    return 0


def test_modules_and_functions_fit_the_size_guide():
    """Code lines, docstrings not counted: documenting a function never makes it too long."""
    bad = []
    for _, path, tree in modules():
        docs = sum(docstring_lines(n) for n in ast.walk(tree)
                   if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                     ast.AsyncFunctionDef)))
        lines = path.read_text().count('\n') - docs
        if lines > MAX_MODULE_LINES:
            bad.append(f'{path.relative_to(PKG)}: {lines} lines')
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1 - docstring_lines(node)
                doc = ast.get_docstring(node) or ''
                if n > MAX_FUNCTION_LINES and LONG_MARK not in doc:
                    bad.append(f'{path.relative_to(PKG)}:{node.lineno} '
                               f'{node.name}: {n} lines and no "{LONG_MARK}" '
                               f'in its docstring')
    assert not bad, '\n'.join(bad)


def module_graph():
    """Return {module: modules of the package it imports} (at any level, type-only included)."""
    paths = {}
    for path in sorted(PKG.rglob('*.py')):
        rel = path.relative_to(PKG.parent).with_suffix('').parts
        paths['.'.join(rel[:-1] if rel[-1] == '__init__' else rel)] = path
    graph = {m: set() for m in paths}
    for m, path in paths.items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                subs = [f'{node.module}.{a.name}' for a in node.names]
                names = [n for n in subs if n in paths]     # submodules taken by name
                if len(names) < len(subs):
                    names.append(node.module)               # names from the module itself
            graph[m].update(n for n in names if n in paths and n != m)
    return graph


def circles(graph):
    """Return the strongly connected groups of more than one module (Tarjan, iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    group = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        group.append(w)
                        if w == v:
                            break
                    if len(group) > 1:
                        out.append(sorted(group))
    return out


def test_no_modules_import_each_other():
    """No circle of imports between files, type-only and function-level imports included."""
    assert circles({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}) == [['a', 'b', 'c']]
    assert circles(module_graph()) == []
