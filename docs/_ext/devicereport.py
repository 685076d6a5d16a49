"""Sphinx extension: the GPU page's numbers, drawn from the committed device report.

    ```{device-report} data/gpu_report.json
    ```

renders the report that ``benchmarks/gpu_check.py`` writes (``FILE`` relative to ``docs/``)
as tables: the device, the agreement with the committed full scan, the speed and scene B6.
Every number comes from the file.  Without the file (no GPU run has been committed) the
page shows a note saying how to make it (``MISSING``), so the site builds either way.
``report_markdown`` is what the tests call.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from datavalue import markdown_nodes
from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective

DOCS = Path(__file__).resolve().parents[1]
MISSING = (
    "No device report is committed yet; produce it with "
    "`python benchmarks/gpu_check.py --out docs/data/gpu_report.json` on a machine with a GPU."
)
QUANTITIES = ("D", "E", "E_x")


def _num(value, fmt: str = ".3g") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "--"
    return format(value, fmt)


def _row(cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _table(columns, rows) -> list[str]:
    return [_row(columns), _row(["---"] * len(columns)), *(_row(r) for r in rows), ""]


def _device_lines(report: dict) -> list[str]:
    gpu = report.get("gpu", {})
    cc = ".".join(str(v) for v in gpu.get("compute_capability", [])) or "--"
    memory = gpu.get("memory_total_bytes")
    return _table(
        ["device", "compute capability", "memory (GiB)", "driver", "runtime", "compilation (s)",
         "whole check (s)"],
        [[gpu.get("name", "--"), cc, _num(memory / 2**30 if memory else None, ".0f"),
          gpu.get("driver", "--"), gpu.get("runtime", "--"), _num(report.get("compile_s"), ".1f"),
          _num(report.get("total_s"), ".0f")]],
    )  # fmt: skip


def _cut_short(part: dict) -> str:
    return (f"cut short at {100 * part.get('fraction', 0):.0f} % after "
            f"{_num(part.get('wall_s'), '.0f')} s (extrapolated: "
            f"{_num(part.get('extrapolated_s'), '.0f')} s)")  # fmt: skip


def _agreement_rows(label: str, table: dict) -> list[list[str]]:
    rows = []
    for q in QUANTITIES:
        z = table[q]
        chi2 = f"{_num(z['chi2_per_dof'], '.2f')} ± {_num(z['chi2_per_dof_scatter'], '.2f')}"
        rows.append([label, q, table["n_points"], z["n_beyond"], _num(z["max_abs_z"], ".2f"),
                     chi2, z["n_exact"], "yes" if z["passed"] else "no"])  # fmt: skip
    return rows


def report_markdown(report: dict) -> list[str]:
    """Markdown lines of a ``gpu_check`` report: device, agreement, speed, B6."""
    command = report.get("command", "benchmarks/gpu_check.py")
    lines = [f"Report of `{command}`, {report.get('created_utc', '--')}, "
             f"bbdyn {report.get('bbdyn_version', '--')}.", ""]  # fmt: skip
    if report.get("smoke"):
        lines += ["This report is a smoke test of the script, not a measurement.", ""]
    lines += _device_lines(report)
    rows = []
    agreement, full = report.get("agreement", {}), report.get("full_scan", {})
    if agreement.get("done"):
        rows += _agreement_rows(f"{len(agreement['f'])} frequencies", agreement)
    if full.get("done"):
        rows += _agreement_rows("full scan", full["agreement"])
    if rows:
        lines += ["Agreement with the committed full scan (z of GPU minus CPU, in combined "
                  "standard errors; z = 0: equal within the rounding of the averages):",
                  ""]  # fmt: skip
        lines += _table(["run", "quantity", "points", "abs(z) > 3.5", "max abs(z)",
                         "chi^2/dof ± its scatter", "z = 0", "passed"], rows)  # fmt: skip
    for name, part in (("agreement", agreement), ("full scan", full)):
        if part and not part.get("done"):
            lines += [f"The {name} run was {_cut_short(part)}.", ""]
    if full.get("done"):
        cpu = full["cpu"]
        lines += _table(
            ["run", "points x particles", "t (s)", "GPU wall (s)", "events", "events/s",
             "CPU time, same work (s)", "CPU time / GPU wall"],
            [["full scan", f"{full['points']} x {full['n']}", _num(full["t"], "g"),
              _num(full["gpu_wall_s"], ".1f"), _num(full["events"], ".3g"),
              _num(full["events_per_s"], ".3g"), _num(cpu["cpu_s"], ".0f"),
              _num(full.get("cpu_over_gpu_wall"), ".0f")]],
        )  # fmt: skip
        gib = _num(full.get("device_bytes", full["state_bytes"]) / 2**30, ".2f")
        launches = f" in {full['launches']} launches" if "launches" in full else ""
        lines += [f"Device memory of the full scan's state: {gib} GiB; it ran{launches}.", ""]
    b6 = report.get("b6")
    if b6:
        done = [c for c in b6.get("centres", []) if c.get("done")]
        rows = [[_num(c["centre"], "g"), c["points"], c["n"], _num(c["gpu_wall_s"], ".1f"),
                 _num(c["events_per_s"], ".3g")] for c in done]  # fmt: skip
        if rows:
            lines += _table(["B6 centre (Hz)", "points", "n", "GPU wall (s)", "events/s"], rows)
        how = "measured" if b6.get("complete") else "extrapolated from the rate"
        lines += [f"B6 at its setting: {_num(b6.get('extrapolated_gpu_s'), '.0f')} s of GPU "
                  f"time for all its centres ({how}).", ""]  # fmt: skip
    if report.get("error"):
        lines += [f"The check stopped with an error: `{report['error']}`.", ""]
    return lines


class DeviceReport(SphinxDirective):
    """The ``device-report`` directive: the report at ``FILE`` as tables, or ``MISSING``."""

    required_arguments = 1

    def run(self):
        path = DOCS / self.arguments[0]
        if not path.is_file():
            note = nodes.note()
            self.state.nested_parse(StringList([MISSING], source=self.env.docname),
                                    self.content_offset, note)  # fmt: skip
            return [note]
        self.env.note_dependency(str(path))
        return markdown_nodes(self, report_markdown(json.loads(path.read_text())))


def setup(app):
    app.add_directive("device-report", DeviceReport)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
