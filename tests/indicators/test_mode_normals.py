"""The mode library's normals as arrays, against the capture-by-capture computation; its drift test."""

from __future__ import annotations

import math
import pickle
import warnings

import numpy as np
import pytest
from scipy.stats import norm
from scipy.stats import t as student_t

from axiswatch.indicators._mode_library import ModeLibrary
from axiswatch.indicators._mode_normals import ModeBlock, NormalStats, nan_median, normal_shift
from axiswatch.indicators._modes import SPECTRUM_BANDS, CaptureDescription
from axiswatch.indicators._readings import Readings

N_FIT = 5


def _blocks(rng: np.random.Generator) -> list[ModeBlock]:
    """Three modes of 9, 6 and 12 captures; readings missing in every other capture, in a whole
    mode, and a reading with 2 values only."""
    blocks = []
    for m, scale in ((9, 1.0), (6, 3.0), (12, 0.5)):
        x = scale * rng.standard_normal((m, 4)) + rng.standard_normal(4)
        x[::2, 1] = np.nan
        if m == 6:
            x[:, 2] = np.nan
        x[2:, 3] = np.nan
        spectra = rng.standard_normal((m, 8)) * scale
        blocks.append(ModeBlock(x, spectra))
    return blocks


def _reference(
    blocks: list[ModeBlock], both: np.ndarray, k: int, rows: list[int]
) -> tuple[np.ndarray, tuple[np.ndarray, int]]:
    """Mode ``k``'s spreads from its captures ``rows`` (the other modes whole), one reading
    and one mode at a time, as the library computed them before they were arrays."""
    spreads = np.full(both.size, np.nan)
    for n in range(both.size):
        parts = []
        for j, block in enumerate(blocks):
            values = block.readings[rows if j == k else slice(None), n]
            values = values[np.isfinite(values)]
            if values.size >= 3:
                parts.append((values.size - 1, float(np.var(values, ddof=1))))
        if not parts:
            continue
        prior = sum(d * v for d, v in parts) / sum(d for d, _ in parts)
        own = blocks[k].readings[rows, n]
        own = own[np.isfinite(own)]
        variance = prior
        if own.size >= 3:
            dof, var = own.size - 1, float(np.var(own, ddof=1))
            variance = max(var, (dof * var + (N_FIT - 1) * prior) / (dof + N_FIT - 1))
        if variance > 0:
            spreads[n] = math.sqrt(variance)
    parts = []
    for j, block in enumerate(blocks):
        spectra = block.spectra[rows] if j == k else block.spectra
        parts.append((len(spectra) - 1, np.var(spectra, 0, ddof=1)))
    dof = sum(d for d, _ in parts)
    band = np.sqrt(sum(d * v for d, v in parts) / dof)
    return spreads, (band, dof)


def test_spreads_and_leave_one_out_distances_equal_the_capture_by_capture_computation() -> None:
    rng = np.random.default_rng(0)
    blocks = _blocks(rng)
    both = np.array([False, True, False, True])
    stats = NormalStats(blocks, both, N_FIT)
    readings, spectra = stats.leave_one_out()
    expected_readings, expected_spectra = [], []
    for k, block in enumerate(blocks):
        m = len(block.readings)
        whole, _ = _reference(blocks, both, k, list(range(m)))
        np.testing.assert_allclose(stats.spreads(k), whole, rtol=1e-12)
        for i in range(m):
            others = [r for r in range(m) if r != i]
            spreads, (band, dof) = _reference(blocks, both, k, others)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a reading never read
                centre = np.nanmedian(block.readings[others], 0)
            best = math.nan
            for n in range(both.size):
                x, c, s = block.readings[i, n], centre[n], spreads[n]
                if not (math.isfinite(x) and math.isfinite(c) and s > 0):
                    continue
                s *= math.sqrt(1 + math.pi / (2 * (m - 1)))  # the centre's own error
                z = abs(x - c) / s if both[n] else max((x - c) / s, 0.0)
                z = float(norm.isf(student_t.sf(z, m - 2))) if z > 0 else 0.0
                best = z if not z <= best else best
            if math.isfinite(best):
                expected_readings.append(best)
            band = band * math.sqrt(1 + math.pi / (2 * (m - 1)))
            rise = max(
                float(np.max((block.spectra[i] - np.median(block.spectra[others], 0)) / band)), 0
            )
            expected_spectra.append(float(norm.isf(student_t.sf(rise, dof))) if rise > 0 else 0.0)
    assert len(readings) == len(expected_readings) > 0
    np.testing.assert_allclose(readings, expected_readings, rtol=1e-12)
    np.testing.assert_allclose(spectra, expected_spectra, rtol=1e-12)


def test_normal_shift_is_the_normal_quantile_of_the_t_tail() -> None:
    z = np.array([-1.0, 0.0, 0.5, 3.0, np.nan])
    got = normal_shift(z, 4)
    assert got[:2].tolist() == [0.0, 0.0]
    assert got[2:4] == pytest.approx(norm.isf(student_t.sf(z[2:4], 4)), rel=1e-12)
    assert math.isnan(got[4])


# -- the drift test ----------------------------------------------------------------------------
def _capture(rng: np.random.Generator, k: int, **readings: float) -> CaptureDescription:
    values = {
        "coulomb_friction": 1.0 + 0.05 * rng.standard_normal(),
        "impulsiveness": 2.0 * math.exp(0.05 * rng.standard_normal()),
    }
    values.update(readings)
    spectrum = np.linspace(0.0, -3.0, SPECTRUM_BANDS) + 0.05 * rng.standard_normal(SPECTRUM_BANDS)
    signature = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5, 3.0])
    signature = signature * (1 + 0.005 * rng.standard_normal(signature.size))
    return CaptureDescription(f"c{k}.csv", signature, 10.0, Readings(values), spectrum)


def _states(captures: list[CaptureDescription]) -> list[str]:
    library = ModeLibrary(n_fit=N_FIT)
    return [library.update(c).state for c in captures]


def test_a_reading_of_every_other_capture_is_drift_tested_on_its_own_values() -> None:
    # gap_ringing read in one direction of motion only, low in its first two values (a warm-up).
    rng = np.random.default_rng(1)
    captures = []
    for k in range(40):
        ringing = (0.7 if k < 4 else 1.0) + 0.03 * rng.standard_normal() if k % 2 == 0 else math.nan
        captures.append(_capture(rng, k, gap_ringing=ringing))
    assert "drift" not in _states(captures)


def test_a_slowly_rising_load_or_a_falling_friction_is_not_a_drift() -> None:
    rng = np.random.default_rng(2)
    rising_load = [
        _capture(rng, k, load_forward=100.0 + 1.5 * k + rng.standard_normal()) for k in range(40)
    ]
    assert "drift" not in _states(rising_load)
    falling = [
        _capture(rng, k, coulomb_friction=1.0 - 0.01 * k + 0.05 * rng.standard_normal())
        for k in range(40)
    ]
    assert "drift" not in _states(falling)
    rising = [
        _capture(rng, k, coulomb_friction=1.0 + 0.01 * k + 0.05 * rng.standard_normal())
        for k in range(40)
    ]
    assert "drift" in _states(rising)


def test_a_library_keeps_the_first_and_latest_window_of_a_mode() -> None:
    rng = np.random.default_rng(3)
    library = ModeLibrary(n_fit=N_FIT, window=10)
    captures = [_capture(rng, k) for k in range(50)]
    verdicts = [library.update(c) for c in captures]
    mode = library.modes_["mode0"]
    assert mode.members == [*captures[:10], *captures[-10:]]
    assert verdicts[-1].n_seen == 49, "captures learned before the last, all counted"


def test_nan_median_is_numpys_bit_for_bit() -> None:
    rng = np.random.default_rng(4)
    for _ in range(500):
        shape = tuple(int(n) for n in rng.integers(1, 7, size=rng.integers(1, 4)))
        x = rng.standard_normal(shape).round(int(rng.integers(0, 3)))  # ties too
        kind = rng.random(shape)
        x[kind < 0.2] = np.nan
        x[(kind > 0.2) & (kind < 0.25)] = np.inf
        x[(kind > 0.25) & (kind < 0.28)] = -np.inf
        x[(kind > 0.28) & (kind < 0.3)] = -0.0
        axis = int(rng.integers(0, len(shape)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            expected = np.nanmedian(x, axis)
        got = nan_median(x, axis)
        np.testing.assert_array_equal(got, expected)
        np.testing.assert_array_equal(np.signbit(got), np.signbit(expected))


def test_a_stored_library_keeps_its_captures_as_columns() -> None:
    rng = np.random.default_rng(5)
    library = ModeLibrary(n_fit=N_FIT)
    for k in range(12):
        extra = {"gap_ringing": 0.5 + 0.01 * k} if k % 2 else {"load_forward": math.nan}
        library.update(_capture(rng, k, **extra))
    columns = library.modes_["mode0"].__getstate__()["members"]
    assert columns["readings"].shape == (12, 4)  # type: ignore[index]
    blob = pickle.dumps(library)
    again: ModeLibrary = pickle.loads(blob)
    for before, after in zip(
        library.modes_["mode0"].members, again.modes_["mode0"].members, strict=True
    ):
        assert (after.source, after.torque_scale, after.declared) == (
            before.source, before.torque_scale, before.declared,
        )  # fmt: skip
        np.testing.assert_array_equal(after.signature, before.signature)
        np.testing.assert_array_equal(after.spectrum, before.spectrum)
        names = sorted(before.readings.values)
        assert sorted(after.readings.values) == names
        np.testing.assert_array_equal(
            [after.readings.values[n] for n in names], [before.readings.values[n] for n in names]
        )
    probe = _capture(rng, 99, coulomb_friction=1.4)
    assert again.score(probe) == library.score(probe)


def test_a_library_stored_with_its_captures_as_objects_still_loads() -> None:
    rng = np.random.default_rng(6)
    library = ModeLibrary(n_fit=N_FIT)
    for k in range(8):
        library.update(_capture(rng, k))
    mode = library.modes_["mode0"]
    older = object.__new__(type(mode))
    older.__setstate__(dict(mode.__dict__))  # the state as pickled before: a list
    assert older.members == mode.members
