"""pytest plugin of multicontact (registered through the ``pytest11`` entry point).

Fixtures
--------
contact_case : factory ``contact_case(name_or_path, **fem_changes) -> CaseResult``: loads a
    library case (or a TOML path), optionally changes FE settings (``level=2``...), runs it
    and caches the result for the session (same arguments -> same result object).
Markers
-------
slow : long convergence / refinement studies (the project excludes them from ``make test``).
"""

from __future__ import annotations

import pytest


def pytest_configure(config) -> None:
    config.addinivalue_line("markers", "slow: long convergence / refinement studies")


@pytest.fixture(scope="session")
def contact_case():
    """Factory running a case once per session: ``contact_case("hertz", level=1)``."""
    from compare.cases import load_case
    from compare.run import run_case

    cache = {}

    def run(name_or_path, **fem_changes):
        key = (str(name_or_path), tuple(sorted(fem_changes.items())))
        if key not in cache:
            case = load_case(name_or_path)
            if fem_changes:
                case = case.with_fem(**fem_changes)
            cache[key] = run_case(case)
        return cache[key]

    return run
