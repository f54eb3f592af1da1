"""sarnav.simulation: the flights that Monte Carlo kinds run, between the library and the scenarios.

- ``flight``: the error-state flight spine (truth, truth IMU, INS and covariance with the filter's IMU model,
  feedback, the error / sigma / NEES record) shared by ``telemetry`` and ``rda-nav``
"""
