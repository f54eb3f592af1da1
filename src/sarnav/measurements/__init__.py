"""sarnav.measurements: the one measurement contract and the models and extractors that make measurements.

- ``base``: :class:`Measurement` (``predict(nav) -> Prediction``, ``simulate(truth, rngs, noise)``),
  :class:`ScalarBiasedMeasurement` (h(p, v) + FOGM bias + white noise)
- ``telemetry``: altimeter, range and range rate to a known target (thesis eqs. 3.13-3.17)
- ``sar``: SAR range and cross-range of a geolocated reference target at its time of closest approach
  (NAVIGATION paper eqs. 47-56)
- ``sar_image``: the extractor that makes the SAR measurements from echoes (RDA, mapdrift, chip registration)

This is the only place where an image meets a state estimate.
"""
