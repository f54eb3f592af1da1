"""Simulation of whole experiments: truth, sensors and filters wired together, batched over Monte Carlo runs.

- ``multi_imu``: the experiments of Sun (2022) (multi-IMU SIR fusion, up-sampled filters) as library
  functions returning position errors per navigation source.
"""
