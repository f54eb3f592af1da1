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
