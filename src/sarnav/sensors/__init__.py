"""Sensor error models: IMU grades and white noise + FOGM biases."""

from sarnav.sensors.gauss_markov import fogm_coefficients, fogm_path
from sarnav.sensors.imu import IMU_GRADES, ImuGrade, ImuModel, imu_grade

__all__ = ["ImuGrade", "ImuModel", "IMU_GRADES", "imu_grade", "fogm_coefficients", "fogm_path"]
