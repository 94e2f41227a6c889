"""The least data an estimate of the indicators needs: readings for a spread, axes for a prior.

Plain constants: the monitor stores them with every baseline without importing the readings.
"""

__all__ = ["MIN_AXES", "MIN_READINGS"]

#: Least readings for a spread; least axes for a fleet prior.
MIN_READINGS = 3

#: Least axes for a fleet prior.
MIN_AXES = 3
