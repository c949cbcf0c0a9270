"""pytest plugin of multicontact (registered through the ``pytest11`` entry point)."""

from __future__ import annotations


def pytest_configure(config) -> None:
    config.addinivalue_line("markers", "slow: long convergence / refinement studies")
