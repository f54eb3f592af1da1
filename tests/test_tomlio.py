"""sarnav.tomlio: scenario text round-trips, NaN/inf are refused naming the key, malformed text names the line, only
regular files are read."""

import math
import os

import pytest

from sarnav.errors import ConfigError
from sarnav.tomlio import MAX_FILE_BYTES, check_finite, dump_toml, load_toml_file, parse_toml


def test_dump_and_parse_round_trip():
    cfg = {"scenario": {"name": "x", "kind": "telemetry"}, "imu": {"rate_hz": 100.0, "grade": "tactical"},
           "initial": {"p_3sigma": [1.0, 1.0, 3.0]}, "cases": [{"label": "a", "set": {"imu.grade": "consumer"}}],
           "campaign": {"runs": 3, "seed": 2**63 - 1}}
    assert parse_toml(dump_toml(cfg)) == cfg


@pytest.mark.parametrize("text, field", [("[imu]\nrate_hz = nan\n", "imu.rate_hz"),
                                         ("[initial]\np_3sigma = [1.0, inf, 3.0]\n", "initial.p_3sigma[1]"),
                                         ("[[cases]]\nv = -inf\n", "cases[0].v")])
def test_nan_and_inf_are_refused_naming_the_key(text, field):
    # TOML allows nan and inf; a scenario never does
    with pytest.raises(ConfigError) as err:
        check_finite(parse_toml(text))
    assert err.value.field == field and err.value.message.startswith("must be a finite number")
    with pytest.raises(ConfigError):
        dump_toml({"a": {"b": math.nan}})


def test_malformed_text_names_the_origin_and_the_line():
    with pytest.raises(ConfigError) as err:
        parse_toml("[scenario]\nname = \n", origin="my.toml")
    assert err.value.field == "my.toml" and "malformed TOML" in err.value.message and "line 2" in err.value.message


def test_only_regular_utf8_files_of_bounded_size_are_read(tmp_path):
    good = tmp_path / "s.toml"
    good.write_text('[scenario]\nname = "s"\n')
    assert load_toml_file(good) == {"scenario": {"name": "s"}}
    with pytest.raises(ConfigError, match="is not a regular file"):
        load_toml_file(tmp_path)  # a folder
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe.toml")
        with pytest.raises(ConfigError, match="is not a regular file"):
            load_toml_file(tmp_path / "pipe.toml")  # never opened: it would block
    (tmp_path / "latin.toml").write_bytes(b'name = "caf\xe9"\n')
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_toml_file(tmp_path / "latin.toml")
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(MAX_FILE_BYTES + 1)
    with pytest.raises(ConfigError, match=f"at most {MAX_FILE_BYTES} bytes"):
        load_toml_file(big)
    with pytest.raises(ConfigError, match="cannot read scenario file"):
        load_toml_file(tmp_path / "missing.toml")
