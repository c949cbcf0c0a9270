"""Randomised audit of the analytic solver (issue 13).

:mod:`compare.audit.cases` draws reproducible random cases from integer seeds;
:mod:`compare.audit.quadrature` integrates the returned ``pressure(x)`` independently of the
solver's equations; :mod:`compare.audit.checks` checks each case against those quadratures and
the discretised solver :mod:`compare.bem` at two resolutions; :mod:`compare.audit.run` runs
many cases and writes the result table (``benchmarks/audit.py`` is its command line).
"""
