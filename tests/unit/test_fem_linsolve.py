"""The OpenBLAS kernel set named for CHOLMOD's BLAS follows the CPU's instruction sets and
never overrides the user's choice."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from fem.linsolve import (
    OPENBLAS_CORES,
    available_backends,
    blas_core_for,
    cpu_flags,
    import_cholmod,
    prefer_blas_kernels,
)

AVX512 = frozenset({"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"})


@pytest.mark.parametrize(("flags", "core"), [
    (AVX512 | {"avx2", "fma", "sse2"}, "SkylakeX"),
    (frozenset({"avx2", "fma", "sse2"}), "Haswell"),
    ((AVX512 - {"avx512bw"}) | {"avx2", "fma"}, "Haswell"),  # not every AVX-512 set it needs
    (frozenset({"avx2", "sse2"}), None),  # no FMA: OpenBLAS keeps its own choice
    (frozenset(), None),
])
def test_the_kernel_set_needs_all_its_instruction_sets(flags, core):
    assert blas_core_for(flags) == core
    if core is not None:
        assert dict(OPENBLAS_CORES)[core] <= flags


def test_it_sets_the_kernels_only_when_unset_and_known():
    env = {}
    assert prefer_blas_kernels(env, AVX512 | {"avx2", "fma"}) == "SkylakeX"
    assert env == {"OPENBLAS_CORETYPE": "SkylakeX"}
    env = {"OPENBLAS_CORETYPE": "Zen"}  # the user's choice stays
    assert prefer_blas_kernels(env, AVX512 | {"avx2", "fma"}) is None
    assert env == {"OPENBLAS_CORETYPE": "Zen"}
    env = {}
    assert prefer_blas_kernels(env, frozenset({"sse2"})) is None
    assert env == {}


def test_cpu_flags_are_read_from_the_first_flags_line(tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nmodel\t\t: 207\nflags\t\t: fpu sse2 avx2 fma\n\n"
                    "processor\t: 1\nflags\t\t: fpu\n")
    assert cpu_flags(info) == {"fpu", "sse2", "avx2", "fma"}
    assert cpu_flags(tmp_path / "absent") == frozenset()
    info.write_text("processor\t: 0\n")
    assert cpu_flags(info) == frozenset()


@pytest.mark.parametrize("user", [None, "Haswell"])
def test_the_variable_lasts_for_the_cholmod_import_only(monkeypatch, user):
    if user is None:
        monkeypatch.delenv("OPENBLAS_CORETYPE", raising=False)
    else:
        monkeypatch.setenv("OPENBLAS_CORETYPE", user)
    assert import_cholmod() == ("cholmod" in available_backends())
    assert os.environ.get("OPENBLAS_CORETYPE") == user


CORENAME = """
import ctypes, {module}
try:
    name = ctypes.CDLL("libopenblas.so.0").openblas_get_corename
except (OSError, AttributeError):
    print("")
else:
    name.restype = ctypes.c_char_p
    print(name().decode())
"""


@pytest.mark.parametrize("module", ["fem", "compare"])
def test_cholmods_openblas_runs_the_kernels_named_for_this_cpu(module):
    """A process that imports fem or compare first runs CHOLMOD's OpenBLAS on the kernel set
    named for its CPU (not an older OpenBLAS's fallback for a CPU model it does not know),
    where CHOLMOD's BLAS is a shared OpenBLAS and the CPU has an OPENBLAS_CORES set."""
    core = blas_core_for(cpu_flags())
    if "cholmod" not in available_backends() or core is None or "OPENBLAS_CORETYPE" in os.environ:
        pytest.skip("no CHOLMOD, no known kernel set for this CPU, or the user chose one")
    out = subprocess.run([sys.executable, "-c", CORENAME.format(module=module)], check=True,
                         capture_output=True, text=True).stdout.strip()
    if not out:
        pytest.skip("CHOLMOD's BLAS is not a shared OpenBLAS")
    assert out.lower() == core.lower()
