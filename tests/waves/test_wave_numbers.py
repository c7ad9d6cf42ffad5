"""The k d0 -> n rounding of standing waves (``wave_numbers``): the nearest allowed k = 2 pi n / L,
ties, n >= 1, duplicates merged, and the refusal above k d0 = 2 pi."""

import numpy as np
import pytest

from solver.errors import InputError
from solver.io import coerce, schema

from solver.waves.excitation import wave_numbers

pytestmark = pytest.mark.serial_only  # pure arithmetic

BOX = 8 * np.pi  # 2 pi / L = 1/4 exactly in binary: n = k d0 L / 2 pi = 4 k d0 with no rounding


def spec(**waves):
    return coerce.build(schema.WavesSpec, waves)


def test_kd0_moves_to_the_nearest_allowed_wave_number():
    # 4 k d0 = 1.2, 2.49, 2.51, 7.9 -> n = 1, 2, 3, 8
    ns, ks = wave_numbers(spec(kd0=[0.3, 0.6225, 0.6275, 1.975]), BOX)
    assert ns.tolist() == [1, 2, 3, 8]
    assert np.array_equal(ks, 2 * np.pi * ns / BOX), ks
    # and against a brute-force search over every allowed n (no tie among these)
    rng = np.random.default_rng(0)
    kd0 = rng.uniform(0.3, 6.0, 40)
    allowed = 2 * np.pi * np.arange(1, int(BOX) + 1) / BOX
    nearest = 1 + np.argmin(np.abs(kd0[:, None] - allowed[None, :]), axis=1)
    for kd, n in zip(kd0, nearest):
        assert wave_numbers(spec(kd0=[float(kd)]), BOX)[0].tolist() == [n], kd


def test_ties_go_to_the_even_wave_number():
    """Half-way between two allowed k (4 k d0 = m + 1/2 exactly): Python's round, to the even n.

    The rule is written here so that a change of it is a decision, not an accident."""
    halves = np.array([0.375, 0.625, 0.875, 1.125])  # 4 k d0 = 1.5, 2.5, 3.5, 4.5
    assert np.array_equal(halves * BOX / (2 * np.pi), [1.5, 2.5, 3.5, 4.5]), "not exact ties"
    got = [int(wave_numbers(spec(kd0=[float(kd)]), BOX)[0][0]) for kd in halves]
    assert got == [2, 2, 4, 4], got


def test_small_kd0_gives_n_one_and_duplicates_merge():
    ns, ks = wave_numbers(spec(kd0=[0.01, 0.1, 0.26, 0.24]), BOX)  # 4 k d0 = 0.04, 0.4, 1.04, 0.96
    assert ns.tolist() == [1] and ks.tolist() == [2 * np.pi / BOX]
    ns, _ = wave_numbers(spec(n=[3, 1, 3, 2]), BOX)
    assert ns.tolist() == [1, 2, 3], "n given: sorted, each once"


def test_wave_number_above_two_pi_is_refused():
    box = 10.6  # k d0 = 2 pi rounds to n = 11: k d0 = 2 pi 11 / 10.6 > 2 pi; allowed n <= 10
    assert wave_numbers(spec(n=[10]), box)[0].tolist() == [10], "k d0 just below 2 pi is allowed"
    for waves in ({"kd0": [2 * np.pi]}, {"n": [11]}, {"n": [1, 40]}):
        with pytest.raises(InputError) as info:
            wave_numbers(spec(**waves), box)
        message = str(info.value)
        assert "exceeds 2 pi" in message and "allowed n <= 10" in message, message
        assert f"waves.n = {11 if waves != {'n': [1, 40]} else 40}" in message, message
