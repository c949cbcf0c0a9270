"""The README's Python example runs as written (examples double as tests) and its numbers hold."""

from __future__ import annotations

import re
from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def _first_python_block() -> str:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks, "README.md has no python example"
    return blocks[0]


def test_readme_example_runs_and_balances(capsys) -> None:
    scope: dict = {}
    exec(compile(_first_python_block(), str(README), "exec"), scope)  # noqa: S102
    normal, stick, curve = scope["normal"], scope["stick"], scope["curve"]
    assert len(normal.zones) == 2  # the lifted cylinder is in contact at P = 100
    assert abs(sum(normal.zone_loads) - 100.0) < 1e-9
    for (a, b), (c, d) in zip(normal.zones, stick.stick_zones, strict=True):
        assert a < c < d < b  # stick zones inside the contact zones
    assert [len(s.zones) for s in curve] == [1, 2, 2]  # the second zone joins between 5 and 50
    assert "(" in capsys.readouterr().out


def test_readme_fe_example_runs_with_the_documented_fields(capsys) -> None:
    """The README's FE snippet (the python block that imports fem) runs as written; its
    FemStep fields exist and the FE contact half-width is Hertz's."""
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    (block,) = [b for b in blocks if "import fem" in b]
    scope: dict = {}
    exec(compile(block, str(README), "exec"), scope)  # noqa: S102
    step, a = scope["step"], scope["a"]
    ((lo, hi),) = step.contact_zones
    assert abs(hi - lo - 2 * a) < 0.02 * 2 * a  # level 0 resolves the width to ~1 %
    ((slo, shi),) = step.stick_zones
    assert lo < slo < shi < hi
    assert str(a) in capsys.readouterr().out
