"""Study: the paper's Fig. 5 (actual vs overlapped extent of the double wedge, Pe vs kappa).

The analytic curves come from ``analytic.fig5_data``; FE points are the right-zone widths of
one FE normal-load history per angle pair (every stage-1 increment is one load), judged against
the analytic extent solved at the same loads (:data:`FE_EXTENT_ELEMENTS`).  Loads are shown as
P A / c, the scale of the ``fig5_sweep`` sweep report.  Settings live
in ``compare/studies/fig5.toml``.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

import numpy as np

import analytic
import fem
from compare.errors import CaseError

STUDY_KEYS = {"description", "c", "E", "nu", "load_min", "load_max", "n_loads", "fem_level",
              "fem_increments", "pairs"}
PAIR_KEYS = {"label", "phi_inner", "phi_outer"}
#: The FE extent is judged in finest element lengths h: |FE - actual| <= this, i.e. each edge
#: within about half an element.  Its relative error is about h / extent, so it is largest at
#: the smallest load: pair (a) at P A / c = 0.0175 spans 6 elements at level 2, |FE - actual| =
#: 0.71 h (11 %); level 3 halves h: 0.39 h (3.2 %).  Measured max over the pairs at level 2: 0.71.
FE_EXTENT_ELEMENTS = 1.0


def study_file() -> Path:
    return Path(str(resources.files("compare") / "studies" / "fig5.toml"))


def load_study(path: Path | None = None) -> dict:
    """The Fig. 5 study settings (validated: unknown or missing keys raise CaseError)."""
    path = path or study_file()
    doc = tomllib.loads(path.read_text(encoding="utf-8"))
    unknown = sorted(set(doc) - STUDY_KEYS)
    missing = sorted(STUDY_KEYS - set(doc))
    if unknown or missing:
        raise CaseError(f"{path.name}: unknown keys {unknown} / missing keys {missing}; "
                        f"allowed: {', '.join(sorted(STUDY_KEYS))}")
    for i, p in enumerate(doc["pairs"]):
        if set(p) != PAIR_KEYS:
            raise CaseError(f"{path.name}: pairs[{i}] needs exactly the keys "
                            f"{', '.join(sorted(PAIR_KEYS))}")
    return doc


def fem_extents(doc: dict, phi1: float, phi2: float, A: float, P_max: float
                ) -> tuple[list[float], list[float], float]:
    """FE right-zone widths at the stage-1 increments of one normal-load history, and the
    finest element length h of its mesh."""
    prof = analytic.profiles.double_wedge(doc["c"], phi1, phi2)
    ns = analytic.solve_normal(prof, P_max, A)
    lo, hi = ns.zones[0][0], ns.zones[-1][1]
    pad = 0.05 * (hi - lo)
    hist = fem.solve_history(prof.h0, P_max, 0.0, 0.3, doc["E"], doc["nu"],
                             mesh=fem.MeshSpec(level=doc["fem_level"]),
                             increments=fem.LoadPath(n_normal=doc["fem_increments"]),
                             kinks=prof.kinks, window=(lo - pad, hi + pad))
    P, ext = [], []
    for s in hist.stage(1):
        right = [z for z in s.contact_zones if z[0] > 0]
        if right:
            P.append(float(s.P))
            ext.append(float(right[0][1] - right[0][0]))
    return P, ext, float(hist.h_min)


def fig5_rows(doc: dict | None = None) -> list[dict]:
    """Per angle pair: loads (``P`` and the scale-free ``PAc`` = P A / c of the sweep report),
    actual / overlapped extents, Pe, kappa, and the FE points: loads, extents, the analytic
    extent solved at those loads (``fem_actual``) and the finest element length ``fem_h``."""
    doc = doc or load_study()
    A = 4 * (1 - doc["nu"] ** 2) / doc["E"]
    rows = []
    for pr in doc["pairs"]:
        phi1, phi2 = pr["phi_inner"], pr["phi_outer"]
        scale = doc["c"] * np.tan(min(phi1, phi2)) / A
        loads = np.geomspace(doc["load_min"], doc["load_max"], doc["n_loads"]) * scale
        d = analytic.fig5_data(phi1, phi2, loads, c=doc["c"], A=A)
        fP, fe, h = fem_extents(doc, phi1, phi2, A, float(loads[-1]))
        at_fe = analytic.fig5_data(phi1, phi2, np.asarray(fP), c=doc["c"], A=A).actual if fP \
            else np.zeros(0)
        rows.append({"label": pr["label"], "phi1": phi1, "phi2": phi2, "P": d.P.tolist(),
                     "PAc": (d.P * A / doc["c"]).tolist(), "actual": d.actual.tolist(),
                     "overlapped": d.overlapped.tolist(), "Pe": d.Pe.tolist(),
                     "kappa": d.kappa.tolist(), "fem_P": fP,
                     "fem_PAc": [v * A / doc["c"] for v in fP], "fem_extent": fe,
                     "fem_actual": at_fe.tolist(), "fem_h": h})
    return rows


def fe_deviation(row: dict) -> dict | None:
    """The FE extents of one pair judged against FE_EXTENT_ELEMENTS: the largest
    ``|FE - actual|`` in finest element lengths, the largest relative deviation with its load
    (P A / c) and the zone width there in elements; None without FE points."""
    if not row["fem_extent"]:
        return None
    fe, act, h = np.asarray(row["fem_extent"]), np.asarray(row["fem_actual"]), row["fem_h"]
    dev = np.abs(fe - act)
    rel = dev / act
    i = int(np.argmax(rel))
    return {"elements": float(dev.max() / h), "passed": bool(dev.max() / h <= FE_EXTENT_ELEMENTS),
            "rel": float(rel[i]), "PAc": row["fem_PAc"][i], "across": float(act[i] / h)}
