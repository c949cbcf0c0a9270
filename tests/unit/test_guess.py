"""Overlap guess (analytic._guess): accuracy of the load root, the None cases, and its cost in
profile evaluations (the search is batched: a handful of ``dh0`` calls, not one per trial)."""

from __future__ import annotations

import numpy as np
import pytest

from analytic import profiles
from analytic._guess import CHEB, overlap_guess


class _CountingProfile:
    """A profile that counts its ``dh0`` calls (everything else is delegated)."""

    def __init__(self, profile: profiles.Profile) -> None:
        self._profile = profile
        self.dh0_calls = 0

    def __getattr__(self, name: str):
        return getattr(self._profile, name)

    def dh0(self, x: np.ndarray) -> np.ndarray:
        self.dh0_calls += 1
        return self._profile.dh0(x)


def _zone_load(profile: profiles.Profile, theta: float, A: float, edges: np.ndarray) -> float:
    """The Hertz-type load estimate of the given zones, summed zone by zone."""
    u = np.cos(np.pi * (np.arange(CHEB) + 0.5) / CHEB)
    total = 0.0
    for a, b in edges.reshape(-1, 2):
        c, r = 0.5 * (a + b), 0.5 * (b - a)
        s = c + r * u
        total += float(np.sum((s - c) * (profile.dh0(s) - theta))) * np.pi / CHEB / A
    return total


def _union3() -> profiles.Profile:
    return profiles.union(profiles.cylinder(1.0, center=-1.5),
                          profiles.cylinder(0.5, center=0.2, lift=0.01),
                          profiles.cylinder(2.0, center=1.8, lift=0.03))


CASES = [
    (profiles.biquadratic(1.0, 1.0), 0.0, 0.5 * np.pi / 4),
    (profiles.biquadratic(1.0, 1.0), 0.05, 0.3),
    (_union3(), 0.0, 0.5),
    (_union3(), 0.05, 0.5),
    (_union3(), -0.02, 0.1),
    (profiles.cylinder(1.0), 0.0, 0.5),
    (profiles.flat_punch(-1, 1, corner_radius=0.2), 0.0, 0.5),
    (profiles.flat_punch(-1, 1, corner_radius=0.2), 0.05, 0.1),
    (profiles.double_wedge(1.0, 0.11, 0.07), 0.0, 0.1),
    (profiles.double_wedge(1.0, 0.11, 0.07), 0.0, 3.0),
    (profiles.wedge(0.1, 0.2), 0.05, 1.0),
]


@pytest.mark.parametrize(("profile", "theta", "P"), CASES)
def test_guess_zones_carry_the_load(profile, theta, P):
    guess = overlap_guess(profile, theta, P, 1.0)
    assert guess is not None
    assert np.all(np.diff(guess.edges) > 0) and not guess.pinned.any()
    # log(delta) to ~1e-4 and d log P / d log delta of order one
    assert _zone_load(profile, theta, 1.0, guess.edges) == pytest.approx(P, rel=5e-4)


def test_cylinder_guess_is_the_hertz_half_width():
    R, P, A = 2.0, 0.3, 1.5
    guess = overlap_guess(profiles.cylinder(R, center=0.4), 0.0, P, A)
    half = np.sqrt(2 * R * P * A / np.pi)  # overlap delta = P A / pi, half-width sqrt(2 R delta)
    np.testing.assert_allclose(guess.edges, [0.4 - half, 0.4 + half], rtol=1e-3)


@pytest.mark.parametrize(("profile", "theta", "P"), [
    (profiles.cylinder(1.0), 0.0, 1e-20),  # reached at the smallest delta already
    (profiles.cylinder(1.0), 0.0, 1e60),  # beyond the ladder
    (profiles.flat_punch(-1, 1), 0.0, 0.5),  # a flat face carries nothing
    (profiles.flat_punch(-1, 1), 0.05, 0.5),  # the minimum sits on a corner
])
def test_guess_none_cases(profile, theta, P):
    assert overlap_guess(profile, theta, P, 1.0) is None


@pytest.mark.parametrize(("profile", "theta", "P"), CASES[:4])
def test_guess_takes_few_profile_passes(profile, theta, P):
    counting = _CountingProfile(profile)
    assert overlap_guess(counting, theta, P, 1.0) is not None
    assert counting.dh0_calls <= 3
