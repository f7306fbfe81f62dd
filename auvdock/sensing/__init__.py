"""Sensors: one definition of each measurement and the simulated sources that read the truth."""
