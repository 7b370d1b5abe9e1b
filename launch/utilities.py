"""``launch.utilities``: helpers launch files call (see ``rosbook.launch.substitutions``)."""

from rosbook.launch.substitutions import (
    normalize_to_list_of_substitutions,
    perform_substitutions,
)

__all__ = ["normalize_to_list_of_substitutions", "perform_substitutions"]
