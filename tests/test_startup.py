"""Start-up (issue 14 item 8): the command line and the method listing import no heavy
library; the shipped method catalogue is the one the registry generates."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.cli.catalogue import FIELDS, catalogue, generated_text

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "scipy.stats", "scipy.signal", "matplotlib", "jinja2", "polars", "numpy")

PROBE = """
import sys
from pipeline.cli import app
try:
    app({args!r}, prog_name="pipeline")
except SystemExit:
    pass
print("HEAVY", sorted(m for m in {heavy!r} if m in sys.modules), file=sys.stderr)
"""


def imported_heavy(args: list[str]) -> tuple[list[str], str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "-c", PROBE.format(args=args, heavy=HEAVY)],
                       capture_output=True, text=True, env=env, timeout=120)
    line = [ln for ln in r.stderr.splitlines() if ln.startswith("HEAVY")][-1]
    return json.loads(line.removeprefix("HEAVY ").replace("'", '"')), r.stdout


@pytest.mark.parametrize("args", [["--help"], ["methods"], ["run", "--help"]])
def test_cli_starts_without_heavy_imports(args):
    heavy, stdout = imported_heavy(args)
    assert heavy == []
    assert "Usage" in stdout or "Methods" in stdout


def test_methods_listing_shows_every_registered_method():
    from pipeline.methods import REGISTRY

    _, stdout = imported_heavy(["methods"])
    listed = [m["id"] for m in catalogue()]
    assert listed == list(REGISTRY)
    assert all(m in stdout for m in listed)


def test_shipped_catalogue_is_the_generated_one():
    shipped = (ROOT / "pipeline" / "data" / "methods.json").read_text(encoding="utf-8")
    assert shipped == generated_text(), "regenerate: python -m pipeline.cli.catalogue " \
        "> pipeline/data/methods.json"
    assert all(tuple(m) == FIELDS for m in catalogue())


def test_identify_without_a_report_loads_no_report_library(tmp_path):
    """``identify --json`` makes no report: matplotlib and Jinja2 are never imported (they
    were 30 MB of the process's peak on DaISy when run.py imported the report's names)."""
    import math

    rows = [f"{x:.1f},{float(x >= 5)},{2 * -math.expm1(-max(x - 5, 0) / 2)}"
            for x in (0.1 * k for k in range(200))]
    (tmp_path / "log.csv").write_text("time,u,y\n" + "\n".join(rows) + "\n")
    heavy, stdout = imported_heavy(["identify", str(tmp_path / "log.csv"), "--input", "u",
                                    "--output", "y", "--time", "time", "--method",
                                    "first_order", "--json"])
    assert '"recommended"' in stdout  # it ran
    assert "matplotlib" not in heavy and "jinja2" not in heavy
