"""The registry: names, parameters, presets and the Estimate contract."""

import dataclasses
import math

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods import Method, Preset, param, register

EXPECTED = {"butterworth", "finite_difference", "savitzky_golay", "sindy_smoothing"}


def _registered():
    """Every registered method (generated from the registry, never a hand-written list)."""
    return [name for name in methods.available() if not name.startswith("_test")]


def test_available_lists_the_builtin_methods():
    assert EXPECTED <= set(methods.available())
    assert methods.available() == sorted(methods.available())


def test_unknown_method_lists_the_valid_names():
    with pytest.raises(ValueError, match=r"unknown method 'savgol'.*savitzky_golay"):
        methods.get("savgol")


def test_unknown_or_misspelt_parameter_is_an_error():
    with pytest.raises(ValueError, match=r"window_sec.*valid: window_s, degree"):
        methods.get("savitzky_golay", window_sec=0.1)


def test_duplicate_registration_is_an_error():
    with pytest.raises(ValueError, match="already registered"):

        @register("finite_difference")
        class Again(Method):
            accuracy_order: int = param(2, choices=(2,), integer=True)


def test_undeclared_parameter_is_an_error():
    with pytest.raises(TypeError, match=r"must be declared with methods.param"):

        @register("_test_undeclared")
        class Undeclared(Method):
            width: float = 1.0


def test_time_stamps_declaration_is_checked_at_registration():
    with pytest.raises(ValueError, match=r"time_stamps is 'yes'; it must be one of"):

        @register("_test_bad_stamps")
        class BadStamps(Method):
            time_stamps = "yes"

    with pytest.raises(ValueError, match=r"'native' needs an _estimate_at of its own"):

        @register("_test_native_without")
        class NativeWithout(Method):
            time_stamps = "native"


def test_preset_with_out_of_range_value_is_rejected_at_registration():
    with pytest.raises(ValueError, match=r"`width` must be a finite number in \(0, inf\)"):

        @register("_test_bad_preset")
        class BadPreset(Method):
            width: float = param(1.0, low=0.0, low_open=True)
            presets = {"x": Preset({"width": -1.0}, "test")}


@pytest.mark.parametrize("name", _registered())
def test_every_parameter_is_declared_with_range_and_presets_are_valid(name):
    cls = methods.method_class(name)
    specs = methods.params_of(cls)
    assert specs, "a method without parameters cannot be tuned"
    for spec in specs:
        assert spec.doc
        spec.check(spec.default)  # the default lies in its own range
        if spec.tune_low is not None:
            spec.check(spec.tune_low)
            spec.check(spec.tune_high)
            assert spec.tune_low < spec.tune_high
        else:
            why = f"{spec.name}: no tuning range, no choices and no reason (`untuned`)"
            assert spec.choices is not None or spec.untuned, why
    for key, chosen in cls.presets.items():
        instance = cls(**chosen.values)
        assert instance.params() == {**cls().params(), **chosen.values}, key


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        ("savitzky_golay", {"degree": -1}, r"`degree` must be an integer in \[0, 20\], got -1"),
        ("savitzky_golay", {"degree": 2.5}, r"`degree` must be an integer in \[0, 20\], got 2.5"),
        ("savitzky_golay", {"window_s": -0.1}, r"`window_s` must be a finite number in \(0, inf\)"),
        ("savitzky_golay", {"window_s": math.nan}, r"`window_s` must be a finite number.*nan"),
        ("savitzky_golay", {"window_s": math.inf}, r"`window_s` must be a finite number.*inf"),
        ("butterworth", {"order": -2}, r"`order` must be an integer in \[1, 20\], got -2"),
        ("butterworth", {"order": 0}, r"`order` must be an integer in \[1, 20\], got 0"),
        ("butterworth", {"cutoff_hz": 0.0}, r"`cutoff_hz` must be a finite number in \(0, inf\)"),
        (
            "finite_difference",
            {"accuracy_order": 3},
            r"`accuracy_order` must be one of \{2, 4, 6\}",
        ),
        ("sindy_smoothing", {"accuracy_order": 6}, r"`accuracy_order` must be one of \{2, 4\}"),
        ("savitzky_golay", {"degree": True}, r"`degree` must be an integer in \[0, 20\], got True"),
    ],
)
def test_out_of_range_parameters_name_the_argument_and_range(name, params, message):
    with pytest.raises(ValueError, match=message):
        methods.get(name, **params)


@pytest.mark.parametrize("name", _registered())
def test_windows_and_frequencies_say_their_kind(name):
    """``kind`` is declared, never guessed, and says what the name suffixes bench/core/tuning.py
    guessed from (``*window_s``, ``*_hz``; other times ``*_s`` are durations): reading
    ``spec.kind`` instead changes nothing."""
    for spec in methods.params_of(methods.method_class(name)):
        guessed = (
            "window"
            if spec.name.endswith("window_s")
            else "frequency"
            if spec.name.endswith("_hz")
            else "duration"
            if spec.name.endswith("_s")
            else None
        )
        assert spec.kind == guessed, spec.name
        assert spec.kind in methods.PARAM_KINDS


def test_kind_defaults_to_none_and_changes_nothing_else():
    plain = methods.Param(
        name="width",
        default=1.0,
        low=0.0,
        low_open=True,
        tune_low=0.1,
        tune_high=2.0,
        log=True,
        doc="a width",
    )
    assert plain.kind is None
    windowed = dataclasses.replace(plain, kind="window")
    assert windowed.describe_range() == plain.describe_range() == "(0, inf)"
    for value in (0.5, np.float32(2.0), 7):
        assert windowed.check(value) == plain.check(value)
    for value in (0.0, -1.0, math.nan, "wide", True):
        with pytest.raises(ValueError) as with_kind:
            windowed.check(value)
        with pytest.raises(ValueError) as without_kind:
            plain.check(value)
        assert str(with_kind.value) == str(without_kind.value)


def test_unknown_kind_is_rejected_at_registration():
    with pytest.raises(
        ValueError,
        match=r"_test_bad_kind: parameter `width` has kind 'windows'; "
        r"it must be one of None, 'window', 'frequency'",
    ):

        @register("_test_bad_kind")
        class BadKind(Method):
            width: float = param(1.0, low=0.0, low_open=True, kind="windows")

    assert "_test_bad_kind" not in methods.available()


def test_integer_parameters_accept_numpy_integers_and_store_plain_ints():
    method = methods.get("savitzky_golay", degree=np.int64(4), window_s=np.float32(0.5))
    assert type(method.degree) is int and method.degree == 4
    assert type(method.window_s) is float


def test_methods_are_frozen():
    method = methods.get("finite_difference")
    with pytest.raises(AttributeError):
        method.accuracy_order = 4


def test_preset_returns_an_instance_and_its_spec_says_where_it_comes_from():
    method = methods.preset("butterworth", "robot")
    assert isinstance(method, methods.method_class("butterworth"))
    assert (method.order, method.cutoff_hz) == (4, 5.0)
    spec = methods.preset_spec("butterworth", "robot")
    assert "sec. IV" in spec.source and spec.label == "preset (paper)"
    assert methods.preset_spec("kalman", "paper-signal").label == "preset (diffbench)"


def test_default_preset_is_the_class_defaults():
    assert methods.preset("savitzky_golay", "default") == methods.get("savitzky_golay")
    assert methods.preset_spec("savitzky_golay", "default").label == "class defaults"


def test_misspelt_preset_is_an_error_naming_the_close_key_or_listing_the_keys():
    close = r"no preset 'paper-sginal'; did you mean 'paper-signal'\?$"
    with pytest.raises(ValueError, match=close):
        methods.preset("jacobi", "paper-sginal")
    every = r"no preset 'lab'; available: paper-signal, robot, default$"
    with pytest.raises(ValueError, match=every):
        methods.preset("jacobi", "lab")


def test_estimate_rejects_nan_on_valid_samples():
    values = {1: np.array([np.nan, 1.0, 2.0, np.nan])}
    with pytest.raises(ValueError, match="not finite on a valid sample"):
        methods.Estimate(values=values, valid={1: np.array([True, True, False, False])})
    # estimated but not trusted: the third sample keeps its value, marked not valid
    estimate = methods.Estimate(values=values, valid={1: np.array([False, True, False, False])})
    assert estimate.coverage(1) == 0.25
    np.testing.assert_array_equal(estimate.estimated(1), [False, True, True, False])
    np.testing.assert_array_equal(estimate.trusted(1), [np.nan, 1.0, np.nan, np.nan])
    with pytest.raises(ValueError, match="`order` 2 was not estimated"):
        estimate[2]
