"""Cross-checks of the FE model against the analytic solution (cases, metrics, reports).

Public API
----------
Case, FemSettings, load_case(name_or_path), list_cases(), read_case(path), case_from_dict(doc)
Case.from_profile(profile, P, A=... or E=..., nu=..., mu=..., Q0=0, M=None, **fem) -> Case;
    case.to_dict() / case.to_toml() give it back as a case file
run_case(case, vtk_dir=None) -> CaseResult (metrics, checks, zones, samples, passed)
convergence(case, levels=(0, 1, 2), ...) -> ConvergenceStudy
verify(case, result_path) -> CaseResult: an external FE result (docs/external.md) vs analytic
verify_convergence(case, [path1, path2, ...]) -> SequenceVerification: one code's results at
    several resolutions (observed orders, converges / stalls, grid convergence index)
compare.testing.assert_agrees(result, edge_rtol=..., stick_rtol=..., pressure_rtol=...)
compare.report.write_report(cases, out_dir, convergence_cases=None, fig5=True) -> summary dict
CaseError: bad case input (CLI exit code 2).

``fem.linsolve`` is imported first: it loads CHOLMOD with the BLAS kernels named for the CPU,
which only works before anything else loads it (``scipy.optimize`` tries scikit-sparse's
CHOLMOD on import; the analytic side loads it only for tabulated profiles, through
``scipy.interpolate``).
"""

import fem.linsolve  # noqa: F401
from compare.cases import Case, FemSettings, case_from_dict, list_cases, load_case, read_case
from compare.convergence import ConvergenceStudy, convergence
from compare.errors import CaseError
from compare.run import CaseResult, Check, run_case
from compare.verify import verify
from compare.verify_sequence import SequenceVerification, verify_convergence

__all__ = ["Case", "CaseError", "CaseResult", "Check", "ConvergenceStudy", "FemSettings",
           "SequenceVerification", "case_from_dict", "convergence", "list_cases", "load_case",
           "read_case", "run_case", "verify", "verify_convergence"]
