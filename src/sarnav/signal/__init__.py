"""sarnav.signal: containers and 1-D tools shared by ``radar`` and ``imaging`` (the layer both depend down on).

- ``data``: :class:`PulseData` (raw or range-compressed pulses with their axes and antenna positions),
  :class:`SarImage` (complex image with both axes in metres)
- ``windows``: spectral weighting windows (:class:`Window`, :func:`as_window`, :func:`frequency_weights`)
- ``metrics``: impulse-response measurement (peak, IRW, PSLR, ISLR) and the theoretical figures of a window
"""
