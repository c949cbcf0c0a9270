"""External FE results in the exchange format of ``docs/external.md``.

read_result(path, settings=None) -> ExternalResult
    path: a manifest ``steps.csv`` (or the folder holding it), a folder of step files, one step
    file, or a ``.pvd`` VTK series; settings: ``key -> text`` overriding the files' header items
    (conventions such as ``pressure_sign``, meta data such as ``code``).
ExternalResult.history(mu, E, nu) -> fem.FemHistory (FE-like, our convention)
ExternalResult.checked_history(mu, E, nu) -> (fem.FemHistory, notes): every step checked first
    (sum p w = P, sum q w = Q, sum x p w = M, p >= 0, widths, loads in order;
    exchange.check_consistency, exchange.check_stages)
write_result(hist, directory, code=..., case=..., force=False) -> path of the manifest (our own
    history exported; see compare.fileio.owned_output)
Conventions, Meta: the header items.  Errors: compare.errors.CaseError.
"""

from __future__ import annotations

from pathlib import Path

from compare.errors import CaseError
from compare.external.csvio import MANIFEST, read_csv_result, write_csv_result
from compare.external.exchange import Conventions, ExternalResult, Meta
from compare.external.vtkio import read_pvd_result


def read_result(path: str | Path, settings: dict | None = None) -> ExternalResult:
    """Read an external result (CSV manifest / step files / one step file / .pvd series)."""
    p = Path(path)
    if not p.exists():
        raise CaseError(f"{p}: no such file or folder; give a {MANIFEST} manifest, a folder of "
                        "step files or a .pvd series")
    if p.suffix == ".pvd":
        return read_pvd_result(p, settings)
    if p.is_file() and p.suffix != ".csv":
        raise CaseError(f"{p}: unknown result file type '{p.suffix}'; allowed: .csv, .pvd or a "
                        "folder")
    return read_csv_result(p, settings)


def write_result(hist, directory: str | Path, code: str = "multicontact fem", case: str = "",
                 force: bool = False) -> Path:
    """Export a ``fem.FemHistory`` in the exchange format (manifest + one CSV per step); a
    folder holding files multicontact did not write is refused unless ``force``
    (:func:`compare.fileio.owned_output`)."""
    seconds = sum(hist.timings.get(k, 0.0) for k in ("mesh", "assembly", "history"))
    meta = Meta(code=code, case=case, dofs=int(hist.n_dofs), order=int(hist.order),
                seconds=float(seconds))
    return write_csv_result(hist, directory, meta, force)


__all__ = ["Conventions", "ExternalResult", "Meta", "read_result", "write_result"]
