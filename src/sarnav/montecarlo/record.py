"""The run record, re-exported for the campaign engine: :class:`sarnav.record.RunRecord` (it lives at the bottom of
the package so that the experiments of ``sarnav.simulation`` can return it)."""

from sarnav.record import RunRecord

__all__ = ["RunRecord"]
