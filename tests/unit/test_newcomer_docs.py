"""What a newcomer reads first: the CLI help, the README's command lines and its links."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from compare.cli import parser

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").glob("*.md"))


def _subcommands() -> list[str]:
    sub = next(a for a in parser()._actions if a.dest == "command")
    return list(sub.choices)


def test_help_lists_every_subcommand(capsys) -> None:
    with pytest.raises(SystemExit):
        parser().parse_args(["--help"])
    description = capsys.readouterr().out.split("\n\n")[1]
    assert "sweep" in _subcommands()
    for name in _subcommands():
        assert re.search(rf"\b{name}\b", description), f"--help does not list {name!r}"


def _readme_command_lines() -> list[str]:
    blocks = re.findall(r"```(?:bash|sh)\n(.*?)```", README.read_text(), re.S)
    lines = [ln.split("#")[0].strip() for b in blocks for ln in b.splitlines()]
    return [ln for ln in lines if re.match(r"(\.venv/bin/)?multicontact ", ln)]


def test_readme_cli_examples_parse() -> None:
    """Every README command line can be pasted into a shell as it stands (no [optional] or
    a | b synopsis) and parses (--version exits 0)."""
    lines = _readme_command_lines()
    assert len(lines) >= 8
    for line in lines:
        assert not re.search(r"[][|<>]", line), f"README command is a synopsis: {line!r}"
        args = shlex.split(line)[1:]
        try:
            parser().parse_args(args)
        except SystemExit as exc:
            if exc.code != 0:
                pytest.fail(f"README command does not parse: {line!r} (exit {exc.code})")


def test_readme_says_how_to_reach_the_command() -> None:
    text = README.read_text()
    assert ". .venv/bin/activate" in text and ".venv/bin/multicontact" in text


@pytest.mark.parametrize("doc", [README, *DOCS], ids=lambda p: p.name)
def test_docs_stand_alone(doc: Path) -> None:
    text = doc.read_text()
    assert "../shared" not in text and "DESIGN.md" not in text
    for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text):
        assert (doc.parent / target).exists(), f"{doc.name}: broken link {target}"


def test_readme_case_from_profile_example_builds_the_library_case(monkeypatch, capsys) -> None:
    """The README's ``Case.from_profile`` block builds the library case two_cylinders_unequal
    (run here without the FE run, which the validation tests do for that case)."""
    import compare
    from compare.cases import load_case

    class Ran:
        passed, metrics = True, {"edge_error_max": 0.0}

    monkeypatch.setattr(compare, "run_case", lambda case: Ran())
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    block = next(b for b in blocks if "Case.from_profile(" in b)
    scope: dict = {}
    exec(compile(block, str(README), "exec"), scope)  # noqa: S102
    made, lib = scope["case"].to_dict(), load_case("two_cylinders_unequal").to_dict()
    for doc in (made, lib):
        del doc["name"], doc["description"]
    assert made["load"].pop("Q0") == pytest.approx(lib["load"].pop("Q0"), rel=1e-15)
    assert made == lib
    assert "[[profile.members]]" in capsys.readouterr().out
