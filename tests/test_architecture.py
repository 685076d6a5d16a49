"""The layers of bbdyn (README, Layout; docs/architecture.md), enforced by reading imports.

Every import counts, module level and inside functions alike.  ``python
tests/test_architecture.py`` prints the layer map: modules per layer and the imports
between layers.
"""

import ast
import inspect
import subprocess
import sys
from collections import Counter
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "bbdyn"

#: Layers from the bottom up, and the modules of each (by dotted-name prefix).
LAYERS = {
    "core": ("bbdyn.core",),
    "api": (
        "bbdyn",  # the package itself: Params and the version
        "bbdyn.params",
        "bbdyn.results",
        "bbdyn.sources",
        "bbdyn.runs",
        "bbdyn.billiard",
        "bbdyn.ensemble",
        "bbdyn.gpu",  # the CUDA engine of the ensembles
        "bbdyn.diffusion",
        "bbdyn.correlations",
        "bbdyn.classify",
        "bbdyn.poincare",
        "bbdyn.flat",  # the flat ball
        "bbdyn.lyapunov",
        "bbdyn.approx",
    ),
    "reference": ("bbdyn.reference",),
    "scans": ("bbdyn.scans",),
    "scenes": ("bbdyn.scenes",),
    "cli": ("bbdyn.commands", "bbdyn.__main__"),
}
#: Which layers each layer may import (its own included).
ALLOWED = {
    "core": {"core"},
    "api": {"core", "api"},
    "reference": {"core", "api", "reference"},
    "scans": {"core", "api", "scans"},
    # scenes reach the core only through the API; the B2 benchmarks time kernels directly
    "scenes": {"api", "reference", "scans", "scenes"},
    "cli": {"core", "api", "reference", "scans", "scenes", "cli"},
}
#: Scenes that may import the core: the benchmarks (they time and compare kernels).
BENCHMARK_SCENES = ("bbdyn.scenes.b2_flat", "bbdyn.scenes.b2_billiard")
#: Third-party packages the core may use.
# typing: NamedTuple buffers; numba_cuda: the CUDA target of the same functions (core.targets)
CORE_THIRD_PARTY = {"math", "numpy", "numba", "numba_cuda", "typing"}
#: The core's modules (docs/architecture.md, "The core's modules") and the core modules each
#: may import besides ``tolerances``, ``status`` and ``fmath``: the event step's ladder at
#: the bottom, the tangent maps and the ensemble's loop above it.
CORE_ROOMS = {
    "bbdyn.core": set(),
    "bbdyn.core.tolerances": set(),
    "bbdyn.core.status": set(),
    "bbdyn.core.fmath": set(),
    "bbdyn.core.targets": set(),
    "bbdyn.core.layout": set(),
    "bbdyn.core.plate": set(),
    "bbdyn.core.floor": set(),
    "bbdyn.core.taylor": set(),
    "bbdyn.core.search": {"plate", "taylor"},
    "bbdyn.core.flat": {"plate", "search"},
    "bbdyn.core.billiard": {"plate", "floor", "search", "taylor"},
    "bbdyn.core.flat_jacobian": {"plate", "flat"},
    "bbdyn.core.tangent": {"plate", "flat", "flat_jacobian"},
    "bbdyn.core.billiard_tangent": {"plate", "floor", "billiard", "tangent"},
    "bbdyn.core.highbounce": {"plate"},
    "bbdyn.core.features": {"plate"},
    "bbdyn.core.observables": {"plate", "floor", "layout", "features"},
    "bbdyn.core.fast_forward": {"billiard", "billiard_tangent", "layout", "observables"},
    "bbdyn.core.rng": set(),
    "bbdyn.core.noise": {"rng"},
    "bbdyn.core.ensemble": {
        "floor",
        "billiard",
        "layout",
        "observables",
        "features",
        "fast_forward",
        "noise",
    },
    "bbdyn.core.cuda_ensemble": {"ensemble", "layout"},
}
MAX_CORE_PARAMETERS = 10


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def layer_of(module: str) -> str:
    """The layer of a bbdyn module: the one with the longest matching prefix."""
    best, length = None, -1
    for layer, prefixes in LAYERS.items():
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > length:
                best, length = layer, len(prefix)
    if best is None:
        raise AssertionError(f"{module} belongs to no layer: add it to LAYERS")
    return best


def imports(module: str) -> set[str]:
    """Every module imported by ``module`` (absolute names; ``from a import b`` gives
    ``a.b`` when that is a bbdyn module, else ``a``)."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parent + ([base] if base else []))
            for alias in node.names:
                full = f"{base}.{alias.name}"
                names.add(full if full in MODULES else base)
    names.discard(module)
    return names


def internal_graph() -> dict[str, set[str]]:
    return {m: {n for n in imports(m) if n in MODULES} for m in MODULES}


def test_every_module_has_a_layer():
    for module in MODULES:
        layer_of(module)


def test_core_imports_only_numpy_math_typing_numba_and_core():
    for module in MODULES:
        if layer_of(module) != "core":
            continue
        for name in imports(module):
            top = name.split(".")[0]
            assert top in CORE_THIRD_PARTY | {"bbdyn"}, f"{module} imports {name}"
            if top == "bbdyn":
                assert layer_of(name) == "core", f"{module} imports {name}"


def test_each_core_module_imports_only_its_rooms():
    core = [m for m in MODULES if layer_of(m) == "core"]
    assert set(core) == set(CORE_ROOMS), "add the module to CORE_ROOMS and docs/architecture.md"
    always = {"tolerances", "status", "fmath"}
    for module in core:
        deps = {d.rpartition(".")[2] for d in internal_graph()[module]}
        extra = deps - CORE_ROOMS[module] - always
        assert not extra, f"{module} imports {sorted(extra)}"
    users = [m for m in MODULES if any(n.startswith("numba_cuda") for n in imports(m))]
    assert set(users) <= {"bbdyn.core.targets"}, users


def test_core_signatures_are_narrow():
    wide = set()
    for module, path in MODULES.items():
        if layer_of(module) != "core":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and len(node.args.args) > MAX_CORE_PARAMETERS:
                wide.add(node.name)
    assert not wide, f"more than {MAX_CORE_PARAMETERS} parameters: {sorted(wide)}"


def test_each_layer_imports_only_the_layers_below_it():
    wrong = []
    for module, deps in internal_graph().items():
        layer = layer_of(module)
        allowed = ALLOWED[layer] | ({"core"} if module in BENCHMARK_SCENES else set())
        wrong += [f"{module} ({layer}) imports {d} ({layer_of(d)})" for d in deps
                  if layer_of(d) not in allowed]  # fmt: skip
    assert not wrong, "\n".join(wrong)


def test_no_import_cycles():
    edges = internal_graph()
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = "open"
        for dep in sorted(edges[node]):
            if state.get(dep) == "open":
                cycles.append(" -> ".join(stack[stack.index(dep) :] + [dep]))
            elif dep not in state:
                visit(dep, stack + [dep])
        state[node] = "done"

    for module in sorted(edges):
        if module not in state:
            visit(module, [module])
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_import_bbdyn_loads_neither_sympy_nor_matplotlib_nor_dask():
    code = "import sys, bbdyn; print(*(m in sys.modules for m in ('sympy', 'matplotlib', 'dask')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "False"]


def lazy_imports(module: str) -> list[str]:
    """The imports of bbdyn inside the functions of ``module`` without a ``# lazy:`` comment
    (on the import's line or the line above) saying why, as ``module:line``."""
    lines = MODULES[module].read_text().splitlines()
    found = []
    for node in ast.walk(ast.parse("\n".join(lines))):
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for inner in ast.walk(node):
            if isinstance(inner, ast.Import):
                names = [alias.name for alias in inner.names]
            elif isinstance(inner, ast.ImportFrom) and not inner.level:
                names = [inner.module or ""]
            else:
                continue
            said = " ".join(lines[max(0, inner.lineno - 2) : inner.lineno])
            if any(n.split(".")[0] == "bbdyn" for n in names) and "# lazy:" not in said:
                found.append(f"{module}:{inner.lineno}")
    return found


def test_bbdyn_is_imported_at_module_level():
    """An import of bbdyn inside a function hides a dependency of its module: each one says
    why in a ``# lazy:`` comment (it keeps matplotlib, sympy and dask out of ``import bbdyn``,
    or breaks an import cycle)."""
    hidden = [hit for m in sorted(MODULES) for hit in lazy_imports(m)]
    assert not hidden, "imports of bbdyn inside functions: " + ", ".join(hidden)


def layer_map() -> str:
    """Modules per layer and the number of imports from each layer into each."""
    graph = internal_graph()
    lines = []
    for layer in LAYERS:
        members = sorted(m for m in MODULES if layer_of(m) == layer)
        lines.append(f"{layer} ({len(members)} modules): " + ", ".join(members))
    crossing = Counter((layer_of(m), layer_of(d)) for m, deps in graph.items() for d in deps)
    counts = ", ".join(f"{a} -> {b}: {n}" for (a, b), n in sorted(crossing.items()))
    lines.append(f"imports (from -> to: count): {counts}")
    return "\n".join(lines)


if __name__ == "__main__":
    print(layer_map())


def test_every_core_kernel_is_compiled_with_the_same_fast_math_flags():
    """numba may reuse a helper compiled for one caller in another, so kernels compiled with
    different flags make results depend on the order of compilation: every ``@njit`` of
    ``bbdyn/core`` passes ``fastmath=FMA`` (``core.tolerances``), nothing else."""
    for path in sorted((PACKAGE / "core").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.FunctionDef):
                continue
            for deco in node.decorator_list:
                name = getattr(getattr(deco, "func", deco), "id", None)
                if name != "njit":
                    continue
                flags = [k.value for k in getattr(deco, "keywords", []) if k.arg == "fastmath"]
                assert len(flags) == 1 and getattr(flags[0], "id", None) == "FMA", (
                    f"{path.name}: {node.name} is not compiled with fastmath=FMA"
                )


def test_forceinline_kernels_call_only_inlined_kernels():
    """numba compiles the callees of a ``forceinline`` kernel with the flag inherited, so a
    plain ``@njit`` helper called from one would be inlined or not depending on which caller
    compiled it first (core.tolerances, after FMA): a ``forceinline`` kernel of
    ``bbdyn/core`` calls, directly or through ``inline="always"`` kernels, only kernels that
    carry ``inline="always"`` or ``forceinline``."""
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    import bbdyn.core

    kernels = {}
    for info in pkgutil.iter_modules(bbdyn.core.__path__):
        module = importlib.import_module(f"bbdyn.core.{info.name}")
        for name, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module.__name__:
                kernels[name] = obj

    def kind(name):
        options = kernels[name].targetoptions
        if options.get("inline") == "always":
            return "inline"
        return "forceinline" if options.get("forceinline") else "plain"

    def reached(name, seen):
        """Kernels called by ``name``, following ``inline="always"`` ones into their bodies."""
        for node in ast.walk(ast.parse(inspect.getsource(kernels[name].py_func).lstrip())):
            callee = getattr(getattr(node, "func", None), "id", None)
            if isinstance(node, ast.Call) and callee in kernels and callee not in seen:
                seen.add(callee)
                if kind(callee) == "inline":
                    reached(callee, seen)
        return seen

    forced = [name for name in kernels if kind(name) == "forceinline"]
    assert {"flight_search", "collide", "event_search"} <= set(forced)
    for name in forced:
        plain = sorted(c for c in reached(name, set()) if kind(c) == "plain")
        assert not plain, f"forceinline kernel {name} calls plain kernels {plain}"
