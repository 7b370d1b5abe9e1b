"""``launch.conditions`` (see ``rosbook.launch.substitutions``)."""

from rosbook.launch.substitutions import (
    IfCondition,
    InvalidConditionExpressionError,
    UnlessCondition,
)

__all__ = ["IfCondition", "InvalidConditionExpressionError", "UnlessCondition"]
