"""One rule for what a number is (``discgym.values``), and the families that read their
numbers through it: a scene's field (SceneError), a Simulation argument (ValueError), an env
argument (TypeError for a non-number), each naming the field."""

import math
from fractions import Fraction

import numpy as np
import pytest

import discgym as dg
from discgym.config import ReactorConfig
from discgym.values import as_float, integer, plain, real

NUMBERS = [(3, 3), (2.5, 2.5), (np.int32(4), 4), (np.float32(0.5), 0.5),
           (np.asarray(7), 7), (np.asarray(1.25), 1.25), (Fraction(1, 4), 0.25),
           (10**400, 10**400)]
NOT_NUMBERS = [True, np.bool_(False), np.asarray(True), "1", None, [1.0], np.ones(2),
               np.ones((1,)), 1 + 0j, np.complex128(1)]


@pytest.mark.parametrize("value, expected", NUMBERS)
def test_real_numbers_are_the_python_numbers_they_are(value, expected):
    x = real(value)
    assert x == expected and type(x) in (int, float)
    assert type(x) is type(expected) or isinstance(value, Fraction)


@pytest.mark.parametrize("value", NOT_NUMBERS)
def test_bools_strings_and_arrays_are_not_numbers(value):
    assert real(value) is None and integer(value) is None


def test_integers_and_integral_floats():
    assert integer(np.int64(5)) == 5 and type(integer(np.int64(5))) is int
    assert integer(5.0) is None and integer(5.0, integral_float=True) == 5
    for v in (5.5, math.inf, math.nan):
        assert integer(v, integral_float=True) is None
    assert integer(np.asarray(3)) == 3


def test_an_int_beyond_the_float_range_is_infinite():
    assert as_float(10**400) == math.inf and as_float(-10**400) == -math.inf
    assert as_float(3) == 3.0 and type(as_float(3)) is float
    assert type(plain(np.float32(0.5))) is float and plain("x") == "x"


@pytest.mark.parametrize("bad", [True, "0.3", np.ones(2)])
def test_each_family_refuses_a_non_number_naming_the_field(bad):
    with pytest.raises(dg.SceneError, match="radius") as e:
        dg.Species("A", bad, 1.0)
    assert e.value.field == "radius"
    sim = dg.Simulation("ideal_gas", seed=0)
    with pytest.raises(ValueError, match=r"advance\(duration\)|duration"):
        sim.advance(bad)
    with pytest.raises(TypeError, match="step_time"):
        ReactorConfig.from_kwargs(step_time=bad)


def test_each_family_takes_a_zero_dimensional_array():
    assert dg.Species("A", np.asarray(0.3), 1.0) == dg.Species("A", 0.3, 1.0)
    assert ReactorConfig.from_kwargs(step_time=np.asarray(0.5)).steps_per_action == \
        ReactorConfig.from_kwargs(step_time=0.5).steps_per_action


def test_a_real_beyond_the_float_range_is_refused_by_each_family_with_its_own_error():
    huge = Fraction(10**400)
    assert real(huge) == math.inf
    with pytest.raises(dg.SceneError) as e:
        dg.Species("A", huge, 1.0)
    assert e.value.field == "radius"
    with pytest.raises(ValueError, match="step_time"):
        ReactorConfig.from_kwargs(step_time=huge)


def test_number_in_reads_a_value_once_against_its_interval():
    from discgym.values import number_in

    assert number_in(np.float32(0.5), 0.0, 1.0) == 0.5
    assert number_in(0, 0.0, 1.0) == 0.0 and number_in(0, 0.0, 1.0, lo_open=True) is None
    assert number_in(1, 0.0, 1.0, hi_open=True) is None and number_in(1, 0.0, 1.0) == 1.0
    for bad in (True, "0.5", math.nan, math.inf, 10**400, 2.0, -0.1):
        assert number_in(bad, 0.0, 1.0) is None, bad
    assert number_in(1e300, 0.0, math.inf) == 1e300
