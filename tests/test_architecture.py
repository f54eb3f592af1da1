"""The package's shape (issue 8, docs/architecture.md): every import goes down the layer list below, no import
circles between modules (lazy in-function imports included), ``scenarios/`` holds configuration and wiring only,
and no function is longer than 80 lines except numba kernels. Read from the source with ``ast``; nothing runs."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "sarnav"

#: lowest first; a package may import only from layers strictly below its own (and from itself)
LAYERS = [
    ("errors",),
    ("units", "tomlio", "record", "version"),
    ("rotations", "frames", "cf"),
    ("signal",),
    ("trajectory", "sensors"),
    ("ins",),
    ("filters",),
    ("radar",),
    ("imaging",),
    ("io",),
    ("measurements",),
    ("navigation",),
    ("recording",),
    ("simulation",),
    ("analysis",),
    ("montecarlo",),
    ("report",),
    ("scenarios",),
    ("cli", "api"),
    ("__main__",),
]
RANK = {pkg: i for i, layer in enumerate(LAYERS) for pkg in layer}
MAX_FUNCTION_LINES = 80


def _modules():
    for f in sorted(SRC.rglob("*.py")):
        if f == SRC / "_version.py":  # written by setuptools-scm when built or installed, not in git
            continue
        rel = f.relative_to(SRC).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        yield f, ".".join(("sarnav",) + parts), f.relative_to(SRC).parts[0].removesuffix(".py")


def _from_module(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The absolute module of ``from ... import`` in ``module`` (relative imports resolved)."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(tree: ast.AST, module: str, is_package: bool):
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            mod = _from_module(node, module, is_package)
            yield mod
            for a in node.names:  # "from sarnav.filters import update" imports the module sarnav.filters.update
                yield f"{mod}.{a.name}"


MODULES = {mod: (f, pkg) for f, mod, pkg in _modules()}


def _graph():
    graph = {}
    for mod, (f, pkg) in MODULES.items():
        tree = ast.parse(f.read_text())
        targets = set()
        for name in _imports(tree, mod, f.name == "__init__.py"):
            while name and name not in MODULES:
                name = name.rpartition(".")[0]
            if name and name != mod and name != "sarnav":
                targets.add(name)
        graph[mod] = targets
    return graph


GRAPH = _graph()


def test_every_package_is_in_the_layer_list():
    pkgs = {pkg for _, pkg in MODULES.values()} - {"__init__"}
    assert pkgs <= set(RANK), f"add {sorted(pkgs - set(RANK))} to LAYERS"


def test_no_package_imports_one_at_or_above_its_layer():
    bad = []
    for mod, targets in GRAPH.items():
        pkg = MODULES[mod][1]
        if pkg == "__init__":  # sarnav/__init__.py: the facade, re-exporting lazily (sarnav.run, sarnav.__version__)
            continue
        for t in targets:
            tp = MODULES[t][1]
            if tp != pkg and tp != "__init__" and RANK[tp] >= RANK[pkg]:
                bad.append(f"{mod} -> {t}")
    assert not bad, "imports upward or sideways:\n" + "\n".join(sorted(bad))


def _cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circles_between_modules():
    # a package's __init__ re-exporting its modules is not a circle of the design: drop package -> own child edges
    graph = {m: {t for t in ts if not (MODULES[m][0].name == "__init__.py" and t.startswith(m + "."))}
             for m, ts in GRAPH.items()}
    assert not _cycles(graph)


@pytest.mark.parametrize("needle", ["numba", "njit", "fft", "np.linalg", "einsum", "scipy.linalg"])
def test_scenarios_hold_configuration_and_wiring_only(needle):
    hits = [f"{f.name}:{i}" for f in (SRC / "scenarios").glob("*.py")
            for i, line in enumerate(f.read_text().splitlines(), 1) if needle in line]
    assert not hits, f"{needle} in scenarios/: {hits}"


def _function_lengths():
    rows = []
    for mod, (f, _) in MODULES.items():
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if any("jit" in ast.unparse(d) or "vectorize" in ast.unparse(d) for d in node.decorator_list):
                    continue  # numba kernels are written out for speed
                body = node.body
                start = body[1].lineno if (len(body) > 1 and isinstance(body[0], ast.Expr)
                                           and isinstance(body[0].value, ast.Constant)) else body[0].lineno
                rows.append((node.end_lineno - start + 1, f"{mod}.{node.name}"))
    return sorted(rows, reverse=True)


def test_no_function_is_longer_than_80_lines():
    rows = _function_lengths()
    assert rows[0][0] <= MAX_FUNCTION_LINES, f"longest: {rows[:5]}"


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _module_of(name: str) -> str | None:
    """The sarnav module a dotted name denotes, if any."""
    return name if name in MODULES else None


def _private_imports(f, mod):
    """``from sarnav.x import _name`` (the imported name private; ``import public as _alias`` is fine) and
    ``x._name`` on a name bound to another sarnav module, in module ``mod``: (line, text)."""
    tree = ast.parse(f.read_text())
    is_package = f.name == "__init__.py"
    bound = {}                                     # local name -> sarnav module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            src = _from_module(node, mod, is_package)
            if not (src == "sarnav" or src.startswith("sarnav.")) or src == mod:
                continue
            for a in node.names:
                if _private(a.name):
                    yield node.lineno, f"from {src} import {a.name}"
                elif _module_of(f"{src}.{a.name}"):
                    bound[a.asname or a.name] = f"{src}.{a.name}"
        elif isinstance(node, ast.Import):
            for a in node.names:
                if _module_of(a.name) and a.asname:
                    bound[a.asname] = a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            target = bound.get(ast.unparse(node.value)) or _module_of(ast.unparse(node.value))
            if target and target != mod:
                yield node.lineno, f"{ast.unparse(node.value)}.{node.attr} ({target})"


def test_no_module_uses_a_private_name_of_another_module():
    """A name with a leading underscore is its module's own (issue 25): a helper that another module needs is made
    public in its home module or moved to a shared one (``imaging.kernels``)."""
    bad = [f"{mod}:{line}: {text}" for mod, (f, _) in MODULES.items() for line, text in _private_imports(f, mod)]
    assert not bad, "private names used across modules:\n" + "\n".join(sorted(bad))


# --- docs/architecture.md is true to the code -------------------------------------------------------------------
DOC = SRC.parents[1] / "docs" / "architecture.md"


def _doc_rows():
    """(layer, package, lines) of the layer table of docs/architecture.md."""
    rows = []
    for line in DOC.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 4 and cells[0].isdigit():
            rows.append((int(cells[0]), cells[1].strip("`").removesuffix(".py").rstrip("/"), int(cells[3])))
    return rows


def _package_deps():
    deps = {pkg: set() for layer in LAYERS for pkg in layer}
    for mod, targets in GRAPH.items():
        pkg = MODULES[mod][1]
        if pkg == "__init__":  # the facade (test_no_package_imports_one_at_or_above_its_layer)
            continue
        for t in targets:
            tp = MODULES[t][1]
            if tp not in (pkg, "__init__"):
                deps[pkg].add(tp)
    return deps


def test_documented_layers_are_the_tested_layers():
    """The layer table of docs/architecture.md lists every package at the layer ``LAYERS`` gives it."""
    assert [(layer, pkg) for layer, pkg, _ in _doc_rows()] == [(i, p) for i, layer in enumerate(LAYERS) for p in layer]


def test_documented_line_counts():
    """Each package's documented line count is within 10 % of ``wc -l`` (update the table when a package grows)."""
    bad = []
    for _, pkg, documented in _doc_rows():
        path = SRC / pkg
        files = [path.with_suffix(".py")] if path.with_suffix(".py").exists() else sorted(path.rglob("*.py"))
        lines = sum(len(f.read_text().splitlines()) for f in files)
        if abs(lines - documented) > 0.10 * lines:
            bad.append(f"{pkg}: documented {documented}, measured {lines}")
    assert not bad, "\n".join(bad)


def test_documented_dependencies():
    """The dependency list of docs/architecture.md is the package import graph measured from the code."""
    text = DOC.read_text()
    section = text[text.index("### Dependencies"):text.index("### What was not moved")]
    documented = {}
    for line in section.splitlines():
        if not line.startswith("- "):
            continue
        for clause in line[2:].split("; "):
            src, _, dst = clause.partition(" → ")
            names = [n.strip().strip("`") for n in dst.split(",")]
            documented[src.strip().strip("`")] = set() if names == ["nothing"] else set(names)
    assert documented == _package_deps()


def test_one_kalman_update():
    """Every filter updates through ``filters.update.fuse`` (issue 25: one update loop): no module outside
    ``filters/`` imports or calls the Joseph / correlated forms themselves."""
    forms = {"joseph_update", "correlated_update", "joseph", "correlated"}
    bad = []
    for mod, (f, pkg) in MODULES.items():
        if pkg == "filters":
            continue
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sarnav.filters"):
                bad += [f"{mod}: imports {a.name}" for a in node.names if a.name in forms]
            elif isinstance(node, ast.Attribute) and node.attr in forms and ast.unparse(node.value).endswith("update"):
                bad.append(f"{mod}: calls {ast.unparse(node)}")
    assert not bad, "\n".join(bad)


#: the one module that writes a Kalman gain (the Joseph and correlated forms that ``filters.update.fuse`` applies)
GAIN_HOME = "filters/ekf.py"


def _gain_assignments(source: str) -> list[str]:
    """Assignments of a Kalman gain in ``source``: a target named ``K`` or ``*gain*`` whose value calls
    ``inv`` or ``solve`` (``K = P @ H.T @ np.linalg.inv(S)``)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Assign):
            continue
        names = [t.id for t in node.targets if isinstance(t, ast.Name)]
        calls = {c.func.attr if isinstance(c.func, ast.Attribute) else getattr(c.func, "id", "")
                 for c in ast.walk(node.value) if isinstance(c, ast.Call)}
        if any(n == "K" or "gain" in n.lower() for n in names) and calls & {"inv", "solve", "pinv", "lstsq"}:
            out.append(ast.unparse(node))
    return out


def test_the_kalman_gain_is_written_once():
    """The gain is computed in ``filters/ekf.py`` only (issue 25): the particle filters' Gaussian update, the
    pulse-grid Kalman filter, the MEKF and the navigator all reach it through ``filters.update.fuse``."""
    bad = [f"{f.relative_to(SRC)}: {a}" for f in sorted(SRC.rglob("*.py")) if str(f.relative_to(SRC)) != GAIN_HOME
           for a in _gain_assignments(f.read_text())]
    assert not bad, "\n".join(bad)
    assert _gain_assignments((SRC / GAIN_HOME).read_text()), "the rule no longer sees the gain where it lives"


def test_the_gain_rule_sees_a_hand_written_gain():
    """The rule flags the form ``filters/grid_particle.update_gaussian`` had before it used ``fuse``."""
    assert _gain_assignments("K = P @ np.swapaxes(H, -1, -2) @ np.linalg.inv(S)\n")
    assert not _gain_assignments("K = B / T\nS = np.linalg.solve(A, b)\n")
