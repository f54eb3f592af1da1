import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.scenarios import fields

CFG = {"imu": {"rate_hz": 100.0, "bad": -1.0, "v": [1, 2, 3], "flag": True, "one": 1}}


def test_reads_and_errors_name_the_field():
    assert fields.positive(CFG, "imu", "rate_hz") == 100.0
    np.testing.assert_array_equal(fields.vector(CFG, "imu", "v", positive=True), [1.0, 2.0, 3.0])
    assert fields.boolean(CFG, "imu", "flag") is True
    for call, field in ((lambda: fields.table(CFG, "radar"), "radar"),
                        (lambda: fields.get(CFG, "imu", "tau"), "imu.tau"),
                        (lambda: fields.positive(CFG, "imu", "bad"), "imu.bad"),
                        (lambda: fields.vector(CFG, "imu", "v", n=2), "imu.v"),
                        (lambda: fields.boolean(CFG, "imu", "one"), "imu.one")):
        with pytest.raises(ConfigError) as err:
            call()
        assert err.value.field == field


TYPED = {"t": {"n": 7, "f": 2.5, "b": True, "s": "grid", "v": [1.0, -2.0, 3.0], "ints": [3, 1, 2], "dup": [1, 1],
               "names": ["a", "b"], "nums": [0.5, 1.5]}}


@pytest.mark.parametrize("call,expected", [
    (lambda: fields.integer(TYPED, "t", "n", 0, 10), 7),
    (lambda: fields.number(TYPED, "t", "f", 0.0, 3.0, "m"), 2.5),
    (lambda: fields.number(TYPED, "t", "n", None, None), 7.0),
    (lambda: fields.choice(TYPED, "t", "s", ("grid", "brent")), "grid"),
    (lambda: fields.bounded_vector(TYPED, "t", "v", -5.0, 5.0, unit="m"), (1.0, -2.0, 3.0)),
    (lambda: fields.number_list(TYPED, "t", "nums", 0.0, 2.0, "m"), (0.5, 1.5)),
    (lambda: fields.int_list(TYPED, "t", "ints", 1, 3), [3, 1, 2]),
    (lambda: fields.name_list(TYPED, "t", "names", ("a", "b", "c")), ["a", "b"]),
])
def test_typed_readers_return_the_value(call, expected):
    assert call() == expected


@pytest.mark.parametrize("call,field,message", [
    (lambda: fields.integer(TYPED, "t", "n", 0, 5), "t.n", "must be an integer in [0, 5], got 7"),
    (lambda: fields.integer(TYPED, "t", "f", 0, 5), "t.f", "must be an integer in [0, 5], got 2.5"),
    (lambda: fields.integer(TYPED, "t", "b", 0, 5), "t.b", "must be an integer in [0, 5], got True"),
    (lambda: fields.integer(TYPED, "t", "n", 0, 5, " (0: every update)"), "t.n",
     "must be an integer in [0, 5] (0: every update), got 7"),
    (lambda: fields.number(TYPED, "t", "f", 3.0, 4.0, "m"), "t.f", "must be in [3, 4] m, got 2.5"),
    (lambda: fields.number(TYPED, "t", "s", 3.0, 4.0), "t.s", "must be a number, got 'grid'"),
    (lambda: fields.number(TYPED, "t", "x", 3.0, 4.0), "t.x", "missing"),
    (lambda: fields.choice(TYPED, "t", "s", ("brent",)), "t.s", "must be one of ['brent'], got 'grid'"),
    (lambda: fields.bounded_vector(TYPED, "t", "v", 0.0, 5.0), "t.v[1]", "must be in [0, 5], got -2.0"),
    (lambda: fields.bounded_vector(TYPED, "t", "v", 0.0, 5.0, n=2), "t.v", "must be a list of 2 numbers"),
    (lambda: fields.number_list(TYPED, "t", "nums", 1.0, 2.0), "t.nums[0]", "must be in [1, 2], got 0.5"),
    (lambda: fields.number_list(TYPED, "t", "nums", 0.0, 2.0, max_len=1), "t.nums", "must be a list of 1 to 1"),
    (lambda: fields.int_list(TYPED, "t", "ints", 1, 2), "t.ints[0]", "must be an integer in [1, 2], got 3"),
    (lambda: fields.int_list(TYPED, "t", "dup", 1, 2), "t.dup", "must not repeat a value"),
    (lambda: fields.int_list(TYPED, "t", "n", 1, 2), "t.n", "must be a list of 1 to 16 integers"),
    (lambda: fields.name_list(TYPED, "t", "names", ("a",)), "t.names[1]", "must be one of ['a'], got 'b'"),
    (lambda: fields.name_list({"t": {"e": []}}, "t", "e", ("a",)), "t.e", "must be a list of names"),
])
def test_typed_readers_name_the_key_and_the_range(call, field, message):
    with pytest.raises(ConfigError) as err:
        call()
    assert err.value.field == field and err.value.message.startswith(message), str(err.value)
    assert fields.name_list({"t": {"e": []}}, "t", "e", ("a",), allow_empty=True) == []
