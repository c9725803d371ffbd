"""Drivers: closed forms, derivatives against central differences, dict/CSV errors."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.kinematics.drivers import (
    DRIVERS,
    Constant,
    Driver,
    Harmonic,
    Ramp,
    SmoothStep,
    SumDriver,
    Table,
    driver_from_dict,
    load_table_csv,
)

TT = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0])
TV = np.array([0.1, 0.4, 0.35, 0.9, 1.2, 1.0])

# one representative of every registry type, built through the dict layer
SPECS = {
    "constant": {"type": "constant", "value": 0.7},
    "ramp": {"type": "ramp", "t0": 0.4, "rate": -0.25, "v0": 0.3},
    "smooth_step": {"type": "smooth_step", "t0": 0.2, "t1": 2.2, "v0": 0.3, "v1": 0.9},
    "smooth_step_cos": {"type": "smooth_step", "t0": 0.2, "t1": 2.2, "v0": 0.3, "v1": 0.9,
                        "shape": "cosine"},
    "harmonic": {"type": "harmonic", "amplitude": 0.2, "frequency": 1.3, "phase": 0.4,
                 "offset": 0.05},
    "spin_up": {"type": "spin_up", "t1": 2.0, "rate": 1.5, "v0": 0.2},
    "table_linear": {"type": "table", "times": TT.tolist(), "values": TV.tolist()},
    "table_pchip": {"type": "table", "times": TT.tolist(), "values": TV.tolist(),
                    "interpolation": "pchip"},
    "table_spline": {"type": "table", "times": TT.tolist(), "values": TV.tolist(),
                     "interpolation": "spline"},
    "sum": {"type": "sum", "terms": [
        {"type": "harmonic", "amplitude": 0.1, "frequency": 0.5},
        {"type": "smooth_step", "t0": 0.0, "t1": 1.0, "v0": 0.0, "v1": 1.0},
        {"type": "ramp", "t0": -1.0, "rate": 0.2}]},
}

# points where every driver above is smooth (away from t0/t1/knots by > h)
T_SMOOTH = np.array([-0.7, 0.13, 0.31, 0.77, 1.21, 1.74, 2.43, 2.61, 3.4])


def test_registry_covers_every_type():
    assert set(DRIVERS) == {"constant", "ramp", "smooth_step", "spin_up", "harmonic", "table",
                            "sum"}
    assert {s["type"] for s in SPECS.values()} == set(DRIVERS)


@pytest.mark.parametrize("name", sorted(SPECS))
def test_rate_and_accel_equal_central_differences(name):
    d = driver_from_dict(SPECS[name], f"drivers[{name}]")
    h = 1e-5
    fd_rate = (d.value(T_SMOOTH + h) - d.value(T_SMOOTH - h)) / (2 * h)
    fd_acc = (d.rate(T_SMOOTH + h) - d.rate(T_SMOOTH - h)) / (2 * h)
    # O(h^2) truncation ~1e-10 * q''' plus 1e-16/h round-off ~1e-11
    np.testing.assert_allclose(d.rate(T_SMOOTH), fd_rate, rtol=0, atol=2e-8)
    np.testing.assert_allclose(d.accel(T_SMOOTH), fd_acc, rtol=0, atol=2e-7)


@pytest.mark.parametrize("name", sorted(SPECS))
def test_scalar_in_float_out_array_in_array_out(name):
    d = driver_from_dict(SPECS[name], name)
    for f in (d.value, d.rate, d.accel):
        assert type(f(0.77)) is float
        grid = T_SMOOTH.reshape(3, 3)
        arr = f(grid)
        assert isinstance(arr, np.ndarray) and arr.shape == (3, 3)
        assert arr[1, 1] == f(float(grid[1, 1]))


@pytest.mark.parametrize("name", sorted(SPECS))
def test_state_is_value_rate_and_accel_in_one_call(name):
    d = driver_from_dict(SPECS[name], name)
    # also at the ends of the smooth steps and the table knots (tau clipped to [0, 1])
    for t in np.concatenate([T_SMOOTH, [0.2, 2.2, 0.0, 3.0, 10.0]]):
        v, r, a = d.state(float(t))
        assert all(type(x) is float for x in (v, r, a))
        assert (v, r, a) == pytest.approx((d.value(t), d.rate(t), d.accel(t)), abs=1e-15)


def test_constant_and_ramp_closed_forms():
    assert Constant(0.7).value(12.0) == 0.7 and Constant(0.7).rate(1.0) == 0.0
    r = Ramp(t0=0.4, slope=-0.25, v0=0.3)
    t = np.array([-1.0, 0.4, 2.4])
    np.testing.assert_allclose(r.value(t), [0.3, 0.3, 0.3 - 0.25 * 2.0], atol=1e-15)
    np.testing.assert_array_equal(r.rate(t), [0.0, -0.25, -0.25])


@pytest.mark.parametrize("shape", ["quintic", "cosine"])
def test_smooth_step_closed_form(shape):
    d = SmoothStep(0.2, 2.2, 0.3, 0.9, shape)
    tau = np.linspace(0.0, 1.0, 11)
    t = 0.2 + 2.0 * tau
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5 if shape == "quintic" else 0.5 - 0.5 * np.cos(
        np.pi * tau)
    np.testing.assert_allclose(d.value(t), 0.3 + 0.6 * s, atol=1e-15)
    assert d.value(-5.0) == 0.3 and d.value(9.0) == pytest.approx(0.9, abs=1e-15)
    assert d.rate(-5.0) == d.rate(9.0) == d.accel(9.0) == 0.0
    # peak rate: 15/8 (quintic) or pi/2 (cosine) times (v1 - v0)/T, at the middle
    peak = 15 / 8 if shape == "quintic" else np.pi / 2
    assert d.rate(1.2) == pytest.approx(peak * 0.6 / 2.0, rel=1e-14)
    if shape == "quintic":  # C2: acceleration vanishes at both ends
        assert abs(d.accel(0.2 + 1e-9)) < 1e-7 and abs(d.accel(2.2 - 1e-9)) < 1e-7
    else:  # C1 only: acceleration jumps to (v1 - v0) pi^2 / (2 T^2) at t0
        assert d.accel(0.2 + 1e-12) == pytest.approx(0.6 * np.pi**2 / 8, rel=1e-9)


def test_spin_up_rate_integrates_to_its_value():
    """The spin-up's value is the integral of its rate law (quadrature, independent of the
    closed form), continuous into the constant-rate phase."""
    from scipy.integrate import quad

    d = driver_from_dict({"type": "spin_up", "t1": 15.0, "rate": 4.0}, "drivers.x")

    def law(t):
        return 4.0 * (t / 15 - np.sin(2 * np.pi * t / 15) / (2 * np.pi)) if t < 15 else 4.0

    for t in (0.0, 3.0, 7.5, 14.99, 15.0, 22.0):
        assert d.value(t) == pytest.approx(quad(law, 0.0, t, points=[15.0])[0], abs=1e-9)
    assert d.rate(7.5) == pytest.approx(2.0) and d.rate(30.0) == 4.0
    assert d.accel(0.0) == d.accel(15.0) == 0.0 and d.accel(7.5) == pytest.approx(8 / 15)


def test_harmonic_closed_form():
    d = Harmonic(amplitude=0.2, frequency=1.3, phase=0.4, offset=0.05)
    t = np.linspace(0, 2, 7)
    w = 2 * np.pi * 1.3
    np.testing.assert_allclose(d.value(t), 0.05 + 0.2 * np.sin(w * t + 0.4), atol=1e-15)
    np.testing.assert_allclose(d.rate(t), 0.2 * w * np.cos(w * t + 0.4), atol=1e-14)
    np.testing.assert_allclose(d.accel(t), -w**2 * (d.value(t) - 0.05), atol=1e-13)


@pytest.mark.parametrize("interp", ["linear", "pchip", "spline"])
def test_table_passes_through_points_and_holds_ends(interp):
    d = Table(TT, TV, interp)
    np.testing.assert_allclose(d.value(TT), TV, atol=1e-14)
    outside = np.array([-3.0, -1e-9, 3.0 + 1e-9, 50.0])
    np.testing.assert_array_equal(d.value(outside), [TV[0], TV[0], TV[-1], TV[-1]])
    np.testing.assert_array_equal(d.rate(outside), 0.0)
    np.testing.assert_array_equal(d.accel(outside), 0.0)


def test_linear_table_slopes_and_midpoints():
    d = Table(TT, TV, "linear")
    mid = 0.5 * (TT[1:] + TT[:-1])
    np.testing.assert_allclose(d.value(mid), 0.5 * (TV[1:] + TV[:-1]), atol=1e-15)
    np.testing.assert_allclose(d.rate(mid), np.diff(TV) / np.diff(TT), atol=1e-14)
    assert d.rate(TT[1]) == pytest.approx((TV[2] - TV[1]) / (TT[2] - TT[1]))  # right slope


def test_pchip_is_monotone_and_spline_is_c2_with_clamped_ends():
    t = np.linspace(-0.5, 3.5, 4001)
    mono = Table(TT, np.array([0.0, 0.0, 0.1, 0.9, 1.0, 1.0]), "pchip")
    v = mono.value(t)
    assert np.all(np.diff(v) >= -1e-15) and v.min() >= 0.0 and v.max() <= 1.0
    spl = Table(TT, TV, "spline")
    eps = 1e-9
    for tk in TT[1:-1]:  # acceleration continuous across interior knots
        assert spl.accel(tk - eps) == pytest.approx(spl.accel(tk + eps), abs=1e-6)
    assert abs(spl.rate(TT[0] + eps)) < 1e-7 and abs(spl.rate(TT[-1] - eps)) < 1e-7


def test_sum_operator_and_builtin_sum():
    a, b = Harmonic(0.1, 0.5), SmoothStep(0.0, 1.0, 0.0, 1.0)
    s = a + b + 0.25
    assert isinstance(s, SumDriver) and len(s.terms) == 3
    t = np.linspace(-1, 2, 13)
    np.testing.assert_allclose(s.value(t), a.value(t) + b.value(t) + 0.25, atol=1e-15)
    np.testing.assert_allclose(s.accel(t), a.accel(t) + b.accel(t), atol=1e-15)
    np.testing.assert_allclose(sum([a, b]).value(t), a.value(t) + b.value(t), atol=1e-15)
    assert isinstance(s, Driver)


def test_from_dict_does_not_modify_input_and_builds_equal_driver():
    spec = {"type": "smooth_step", "t0": 0, "t1": 2, "v0": 0.3, "v1": 0.9}
    copy = dict(spec)
    assert driver_from_dict(spec) == SmoothStep(0.0, 2.0, 0.3, 0.9)
    assert spec == copy


@pytest.mark.parametrize("spec, msg", [
    ({"type": "smooth_step", "t0": 0, "t1": 0, "v0": 0, "v1": 1}, r"drivers\[2\]\.t1: expected t1 > t0"),
    ({"type": "smooth_step", "t0": 0, "t1": 1, "v0": 0}, r"drivers\[2\]\.v1: required"),
    ({"type": "smooth_step", "t0": 0, "t1": 1, "v0": 0, "v1": 1, "shape": "cubic"},
     r"drivers\[2\]\.shape"),
    ({"type": "ramp", "rate": "__import__('os')"}, r"drivers\[2\]\.rate: expected a number"),
    ({"type": "ramp", "rate": "1+1"}, r"drivers\[2\]\.rate: expected a number"),
    ({"type": "ramp", "rate": float("nan")}, r"drivers\[2\]\.rate: expected a finite"),
    ({"type": "ramp", "rate": True}, r"drivers\[2\]\.rate: expected a number"),
    ({"type": "harmonic", "amplitude": 1, "frequency": -2}, r"drivers\[2\]\.frequency"),
    ({"type": "constant", "value": 1, "vlaue": 2}, r"drivers\[2\]: unknown field.*vlaue"),
    ({"type": "spline"}, r"drivers\[2\]\.type: expected one of"),
    ({"value": 1.0}, r"drivers\[2\]\.type"),
    ({"type": "table", "times": [0, 1, 1], "values": [0, 1, 2]},
     r"drivers\[2\]\.times\[2\]: expected strictly increasing"),
    ({"type": "table", "times": [0, "x"], "values": [0, 1]}, r"drivers\[2\]\.times\[1\]"),
    ({"type": "table", "times": [0.0], "values": [1.0]}, r"at least 2 points"),
    ({"type": "table", "times": [0, 1], "values": [1]}, r"equal length"),
    ({"type": "table", "times": [0, 1], "values": [0, 1], "interpolation": "akima"},
     r"drivers\[2\]\.interpolation"),
    ({"type": "sum", "terms": []}, r"drivers\[2\]\.terms: expected a non-empty"),
    ({"type": "sum", "terms": [{"type": "ramp"}]}, r"drivers\[2\]\.terms\[0\]\.rate: required"),
])
def test_from_dict_errors_name_the_field(spec, msg):
    with pytest.raises(ConfigError, match=msg):
        driver_from_dict(spec, "drivers[2]")


def test_numeric_strings_are_parsed_not_evaluated():
    # PyYAML reads "1e3" (no dot) as a string: float() accepts it, nothing is evaluated
    assert driver_from_dict({"type": "constant", "value": "1e3"}).value(0.0) == 1000.0


# ----------------------------------------------------------------------------- CSV
def test_csv_table_with_header_comments_and_blank_lines(tmp_path):
    p = tmp_path / "stroke.csv"
    p.write_text("# lift cylinder stroke\ntime, value\n0.0, 0.80\n\n1.5, 1.10\n3.0,1.40\n")
    t, v = load_table_csv(p)
    np.testing.assert_array_equal(t, [0.0, 1.5, 3.0])
    np.testing.assert_array_equal(v, [0.80, 1.10, 1.40])
    d = driver_from_dict({"type": "table", "file": "stroke.csv", "interpolation": "pchip"},
                         "drivers[0]", base_dir=tmp_path)
    assert d.value(0.75) == pytest.approx(0.95, abs=1e-12)  # collinear data: pchip is linear
    assert d.value(10.0) == 1.40 and d.rate(10.0) == 0.0


@pytest.mark.parametrize("text, msg", [
    ("time,value\n0,1\n1,abc\n", r"stroke\.csv, line 3, column 'value': expected a finite number, got 'abc'"),
    ("0,1\nxx,2\n", r"line 2, column 'time'"),
    ("0,1\n1,2\n1,3\n", r"line 3: time 1\.0 is not greater than the previous time 1\.0 \(line 2\)"),
    ("0,1\n2,2\n1,3\n", r"line 3: time 1\.0 is not greater"),
    ("time,value\n0,1\n", r"stroke\.csv: expected at least 2 data rows.*got 1"),
    ("", r"expected at least 2 data rows"),
    ("0,1,2\n1,2,3\n", r"line 1: expected 2 columns"),
    ("0,1\n1,nan\n", r"line 2, column 'value': expected a finite number"),
])
def test_csv_errors_name_file_and_line(tmp_path, text, msg):
    p = tmp_path / "stroke.csv"
    p.write_text(text)
    with pytest.raises(ConfigError, match=msg):
        load_table_csv(p)


def test_csv_missing_file_and_mixed_sources(tmp_path):
    with pytest.raises(ConfigError, match=r"d.file: .*nope.csv: table file not found"):
        driver_from_dict({"type": "table", "file": str(tmp_path / "nope.csv")}, "d")
    with pytest.raises(ConfigError, match="d: give either 'file'"):
        driver_from_dict({"type": "table", "file": "x.csv", "times": [0, 1]}, "d")
