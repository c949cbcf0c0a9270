"""pytest plugin of multicontact (registered through the ``pytest11`` entry point).

Fixtures
--------
contact_case : factory ``contact_case(name_or_path_or_case, **fem_changes) -> CaseResult``:
    loads a library case (or a TOML path, or takes a :class:`compare.cases.Case`), optionally
    changes FE settings (``level=2``...), runs it and caches the result for the session: the
    same case (the same case-file table, however it was named) -> the same result object, which
    the tests share and must not change.
Markers
-------
slow : long convergence / refinement studies (the project excludes them from ``make test``).
"""

from __future__ import annotations

import json

import pytest


def pytest_configure(config) -> None:
    config.addinivalue_line("markers", "slow: long convergence / refinement studies")


def case_key(case) -> str | None:
    """The case's case-file table as JSON text, or None where that table does not rebuild the
    case whole (a profile without a spec, a mesh file): such a case is not cached."""
    from compare.cases import case_from_dict

    try:
        doc = case.to_dict()
        if doc["profile"] is None or case.fem.mesh_file:
            return None
        if case_from_dict(doc, name=doc["name"]).to_dict() != doc:
            return None
        return json.dumps(doc, sort_keys=True)
    except Exception:  # noqa: BLE001 - any failure: do not share this case's run
        return None


@pytest.fixture(scope="session")
def contact_case():
    """Factory running a case once per session: ``contact_case("hertz", level=1)``."""
    from compare.cases import load_case
    from compare.run import run_case

    cache = {}

    def run(name_or_path, **fem_changes):
        case = load_case(name_or_path)
        if fem_changes:
            case = case.with_fem(**fem_changes)
        key = case_key(case)
        if key is None:
            return run_case(case)
        if key not in cache:
            cache[key] = run_case(case)
        return cache[key]

    return run
