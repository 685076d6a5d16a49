"""``load_result`` reads back every kind of result bbdyn saves in a fresh process, without
importing the module that defines it first (``bbdyn.results.KINDS``)."""

import importlib
import json
import pkgutil
import subprocess
import sys

import numpy as np

import bbdyn
from bbdyn.commands import cli
from bbdyn.results import _REGISTRY, KINDS, Result


def all_result_classes() -> dict[str, type[Result]]:
    """Every Result subclass of the package (not those of the tests): import every module,
    then read the registry."""
    for module in pkgutil.walk_packages(bbdyn.__path__, "bbdyn."):
        if not module.name.endswith("__main__"):
            importlib.import_module(module.name)
    return {k: c for k, c in _REGISTRY.items() if c.__module__.startswith("bbdyn.")}


def test_the_kind_table_names_every_result_class_and_its_module():
    classes = all_result_classes()
    assert set(classes) == set(KINDS)
    for kind, cls in classes.items():
        assert cls.__module__ == KINDS[kind], kind


def load_in_fresh_process(paths) -> list[dict]:
    """``load_result`` of each path in a new interpreter that imports nothing else first:
    the kind, class and module it got, and the names of the arrays."""
    code = (
        "import json, sys\n"
        "from bbdyn.results import load_result\n"
        "out = []\n"
        "for path in sys.argv[1:]:\n"
        "    r = load_result(path)\n"
        "    out.append({'kind': r.kind, 'class': type(r).__name__,\n"
        "                'module': type(r).__module__, 'arrays': sorted(r.arrays)})\n"
        "print(json.dumps(out))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, *map(str, paths)], capture_output=True,
                          text=True, timeout=120, check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_every_kind_loads_in_a_fresh_process(tmp_path):
    """A file of each kind (its header and an array, as ``Result.save`` writes them)."""
    paths = []
    for kind in KINDS:
        cls = _REGISTRY.get(kind) or all_result_classes()[kind]
        obj = cls.__new__(cls)
        Result.__init__(obj, {"x": np.arange(3.0)}, {"note": kind})
        obj.save(tmp_path / kind)
        paths.append(tmp_path / kind)
    loaded = load_in_fresh_process(paths)
    assert [r["kind"] for r in loaded] == list(KINDS)
    assert [r["module"] for r in loaded] == list(KINDS.values())


def test_results_the_cli_saves_load_in_a_fresh_process(tmp_path, capsys):
    """``simulate --save``, ``gk --save`` and a scan's points, read back in a new process."""
    tiny = ["--f", "85.2", "--n", "4", "--t", "1", "--threads", "1"]
    assert cli.main(["simulate", *tiny, "--save", str(tmp_path / "run1")]) == 0
    assert cli.main(["gk", *tiny, "--nmax", "2", "--save", str(tmp_path / "gk1")]) == 0
    assert cli.main(["scan", "--f-start", "85", "--f-stop", "85", "--f-step", "1", "--n", "4",
                     "--t", "1", "--workers", "1", "--out", str(tmp_path / "s")]) == 0  # fmt: skip
    capsys.readouterr()
    (point,) = (tmp_path / "s" / "points").glob("*.json")
    loaded = load_in_fresh_process([tmp_path / "run1", tmp_path / "gk1", point])
    assert [(r["kind"], r["class"]) for r in loaded] == [
        ("ensemble", "EnsembleResult"), ("green_kubo", "GreenKuboResult"),
        ("scan_point", "_ScanPoint"),
    ]  # fmt: skip
    assert "displacement" in loaded[0]["arrays"] and "D_n" in loaded[1]["arrays"]
