"""The base of the kinds that write their own files (scenarios.kind_base.FileKind) and the seeds check."""

import importlib

import pytest

from sarnav.errors import ConfigError
from sarnav.scenarios.kind_base import FileKind, one_seed_per_run
from sarnav.scenarios.registry import KINDS, get_kind

FILE_KINDS = sorted(k for k in KINDS if isinstance(get_kind(k), FileKind))


def test_the_kinds_that_write_files_are_file_kinds():
    assert FILE_KINDS == ["bpa-sensitivity", "gpsd-search", "image", "quality-sweep"]


@pytest.mark.parametrize("kind", FILE_KINDS)
def test_a_file_kind_names_its_writer_and_validates_its_default(kind):
    k = get_kind(kind)
    cfg = k.default_config()
    k.validate(cfg)
    assert k.state_names(cfg) == [] and k.meas_names(cfg) == []
    with pytest.raises(ConfigError) as err:
        k.simulate(cfg, [0], [0])
    assert err.value.field == "scenario.kind"
    path = err.value.message.rsplit("(", 1)[1].rstrip(")")  # the writer, importable under the name given
    module, _, name = path.rpartition(".")
    assert getattr(importlib.import_module(module), name) is type(k).write


def test_run_scenario_passes_only_the_options_the_writer_takes():
    calls = []

    def writer(cfg, out, overwrite=False, quiet=True):
        calls.append((cfg, out, overwrite, quiet))
        return "done"

    class Toy(FileKind):
        kind = "toy-file"
        config, check, write = staticmethod(dict), staticmethod(lambda cfg: None), staticmethod(writer)
        options = ("overwrite", "quiet")

    assert Toy().run_scenario({"a": 1}, "out", figures=False, overwrite=True, quiet=False, workers=4) == "done"
    assert calls == [({"a": 1}, "out", True, False)]


def test_one_seed_per_run():
    one_seed_per_run([0, 1], [5, 6])
    with pytest.raises(ConfigError, match=r"^seeds: need one seed per run, got 1 for 2 runs$"):
        one_seed_per_run([0, 1], [5])
