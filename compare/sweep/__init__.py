"""Parameter sweeps: many cases from one base case, run on a process pool or dask.distributed.

A sweep file (TOML, schema in ``docs/sweeps.md``) names a base case (a library case, a case
file, or an inline ``[base]`` table in the case-file schema) and one or more *parts*; a part
has a task (what to compute per case) and parameter axes.  The cases of a part are the
Cartesian product of its axes, where a ``[zip.NAME]`` group of equally long axes counts as one
axis.  Parameters are dotted case-file keys: ``load.P``, ``profile.phi_inner``, ``fem.level``,
``profile.members.1.lift`` (union members), ...

Every case becomes a plain-data task dict executed by ``execute`` (on a local process pool
or on dask workers), which returns one flat JSON record.  The coordinating process appends the
records to ``DIR/results.jsonl`` (one complete line per case, written + flushed + fsynced), so
an interrupted sweep resumes by skipping the keys already there.  A case's key is a hash of its
task and its resolved case table (not of its position), so extending an axis reuses the
finished cases.

Modules: ``spec`` (sweep files -> validated cases), ``tasks`` (what runs for one case, and its
record), ``store`` (results.jsonl, sweep.json, lock), ``backends`` (local process pool, dask),
``runner`` (``run_sweep``: resume, progress, interrupt), ``report`` (figures and tables of a
sweep directory) and ``cli`` (``multicontact sweep``, ``multicontact report --sweep``; the only
module that uses both the runner and the report).  This package exports the Python interface of
``docs/sweeps.md``.
"""

from compare.errors import SweepError
from compare.sweep.cli import main
from compare.sweep.runner import SweepOutcome, run_sweep
from compare.sweep.spec import Sweep, list_studies, load_sweep, sweep_from_dict
from compare.sweep.store import read_records

__all__ = ["Sweep", "SweepError", "SweepOutcome", "list_studies", "load_sweep", "main",
           "read_records", "run_sweep", "sweep_from_dict"]
