"""The metrics of the paper's figures, by hand (hlcmp_drake.core.metrics)."""

import numpy as np
import pytest

from hlcmp_drake.core.metrics import (
    force_smoothness,
    max_abs_force,
    mean_abs_force,
    mean_abs_position_error,
    settle_time,
    value_at,
    wrist_readings,
)


def test_settle_time_is_the_start_of_the_last_stretch_inside():
    t = np.arange(0.0, 1.0, 0.1)
    x = np.array([0.0, 0.5, 0.9, 1.0, 1.2, 1.0, 1.0, 1.0, 1.0, 1.0])
    assert settle_time(t, x, 1.0, 0.05, 0.0, 2.0) == pytest.approx(0.5)  # 1.2 at 0.4 s breaks it
    assert settle_time(t, x, 1.0, 0.25, 0.0, 2.0) == pytest.approx(0.2)
    assert settle_time(t, x, 2.0, 0.05, 0.0, 2.0) is None  # never there
    assert settle_time(t, x, 1.0, 0.05, 0.0, 0.45) is None  # not inside at the window's end


def test_value_at_interpolates():
    assert value_at([0.0, 1.0], [0.0, 2.0], 0.25) == pytest.approx(0.5)


def test_per_axis_means_and_peaks():
    x = np.array([[1.0, 0.0], [3.0, -2.0]])
    np.testing.assert_allclose(mean_abs_position_error(x, np.array([2.0, 0.0])), [1.0, 1.0])
    np.testing.assert_allclose(mean_abs_force(x), [2.0, 1.0])
    np.testing.assert_allclose(max_abs_force(x), [3.0, 2.0])


def test_smoothness_is_the_sum_of_second_differences():
    f = np.array([[0.0], [1.0], [4.0], [9.0]])  # second differences 2, 2
    assert force_smoothness(f)[0] == pytest.approx(4.0)
    assert force_smoothness(np.linspace(0, 5, 20)[:, None])[0] == pytest.approx(0.0, abs=1e-12)


def test_probe_readings_by_hand():
    from hlcmp_drake.core.metrics import probe_readings

    distance = np.arange(61) * 0.001 - 0.01  # 1 mm steps; contact from sample 11 (1 mm)
    resisting = np.zeros(61)
    resisting[10:30] = 500 * distance[10:30]  # rises to 9.5 N at 19 mm ...
    resisting[30:] = 3.0  # ... then the foam gives way
    lateral = np.full(61, 0.1)
    lateral[40] = -0.4
    in_push = np.ones(61, bool)
    readings = probe_readings(distance, resisting, lateral, in_push)
    assert readings["peak_force_N"] == pytest.approx(9.5)
    assert readings["depth_at_peak_m"] == pytest.approx(0.018)  # from the first sample above 0.05 N
    assert readings["residual_force_N"] == pytest.approx(3.0)
    assert readings["max_lateral_force_N"] == pytest.approx(0.4)
    assert readings["min_resisting_force_N"] == 0.0


def test_wrist_readings_tilt_the_tool_axis_and_hold_it_with_k_q_plus_d_v():
    angles = np.array([[0.0, 0.0, 0.0], [0.0, 0.1, 0.0], [0.03, 0.04, 0.5]])
    rates = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -2.0]])
    down = np.diag([1.0, -1.0, -1.0])  # the tool's +z straight down: half a turn about x
    readings = wrist_readings(
        down, angles, rates, np.array([100.0, 200.0, 0.0]), 0.5, [0, 0, -3], np.ones(3, bool)
    )
    assert readings["start_tilt_rad"] == pytest.approx(0.0)
    # Rx(a) Ry(b) e_z makes an angle arccos(cos a cos b) with e_z; Rz turns about the axis.
    assert readings["final_tilt_rad"] == pytest.approx(np.arccos(np.cos(0.03) * np.cos(0.04)))
    assert readings["max_abs_wrist_torque_Nm"] == pytest.approx([3.0, 20.0, 1.0])


def test_a_probe_reading_of_no_force_is_zero_without_a_sign():
    from hlcmp_drake.core.metrics import probe_readings

    untouched = -np.zeros(5)  # the force against the push, negated: -0.0 everywhere
    readings = probe_readings(np.arange(5) * 1e-3, untouched, np.zeros(5), np.ones(5, bool))
    assert all(np.copysign(1.0, value) == 1.0 for value in readings.values()), readings
