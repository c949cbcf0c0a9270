"""The report's speed-ups keep its content: the identity memo computes once per object and
tag, and the cases shipped to worker processes rebuild to the same case."""

from __future__ import annotations

from compare._memo import memo
from compare.cases import case_from_dict, load_case
from compare.report import portable


def test_memo_computes_once_per_object_and_tag():
    calls = []
    a, b = object(), object()
    for owner in (a, a, b):
        memo(owner, ("t", 1), lambda: calls.append(1) or len(calls))
    assert memo(a, ("t", 1), lambda: -1) == 1 and memo(b, ("t", 1), lambda: -1) == 2
    assert memo(a, ("t", 2), lambda: -1) == -1 and len(calls) == 2


def test_library_cases_travel_to_workers_unchanged():
    cases = [load_case(n) for n in ("hertz", "punch_and_cylinder", "applied_moment")]
    docs = portable(cases)
    assert docs is not None
    for case, doc in zip(cases, docs, strict=True):
        back = case_from_dict(doc, name=doc["name"])
        assert back.to_dict() == case.to_dict()
        assert (back.profile.h0(0.3), back.M) == (case.profile.h0(0.3), case.M)
