"""Simulation spines: truth, sensors or simulated measurements, and the filter between updates, batched over runs."""
