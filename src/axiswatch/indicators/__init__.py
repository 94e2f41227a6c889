"""The product default: physical indicators of an axis, scored in spreads of its own and its fleet."""

from axiswatch.indicators._readings import INDICATORS as _READ

__all__ = ["INDICATORS"]

#: What the product default reads of every capture it can (with a profile's kinematics also
#: ``tooth_lines:<stage>`` and ``bearing_lines:<bearing>``; ``order_lines`` on request).
INDICATORS: tuple[str, ...] = tuple(indicator.name for indicator in _READ)
