"""Cross-checks of the FE model against the analytic solution (cases, metrics, reports)."""
