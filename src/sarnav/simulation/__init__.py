"""sarnav.simulation: the flights that Monte Carlo kinds run, between the library and the scenarios.

- ``flight``: the error-state flight spine (truth, truth IMU, INS and covariance with the filter's IMU model,
  feedback, the error / sigma / NEES record) shared by ``telemetry`` and ``rda-nav``
- ``spacecraft``: the batched open-loop Monte Carlo of the spacecraft SAR terrain-relative navigation (Pogorelsky et
  al. §VI.B): RK4 truth, the filter's orbital mechanization, MEKF updates from geolocated centre pixels
- ``multi_imu``: the multi-IMU / particle-filter experiments of Sun (2022): path 1, 3 x ADIS vs NovAtel, the UPF
  flight, per-pulse positions of every navigation source
"""
