"""The product default: physical indicators of an axis, scored in spreads of its own and its fleet."""

from typing import Any as _Any

__all__ = ["INDICATORS"]

#: INDICATORS: what the product default reads of every capture it can (with a profile's
#: kinematics also ``tooth_lines:<stage>`` and ``bearing_lines:<bearing>``; ``order_lines`` on
#: request). Built on first use (PEP 562): importing a submodule does not import the readings.


def __getattr__(name: str) -> _Any:
    """``INDICATORS``, from the readings on first use."""
    if name != "INDICATORS":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from axiswatch.indicators._readings import INDICATORS as READ

    value = tuple(indicator.name for indicator in READ)
    globals()[name] = value
    return value
