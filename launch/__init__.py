"""``launch`` as a full ROS 2 install has it: a launch file that imports it runs here and
there unchanged.

The implementation is ``rosbook.launch`` (``launcher``, ``substitutions``, ``events``,
``frontend``); these modules only give its names under upstream's.
"""

from launch import (
    actions,
    conditions,
    descriptions,
    event_handlers,
    events,
    frontend,
    launch_description_sources,
    logging,
    substitutions,
    utilities,
)
from rosbook.launch.events import BaseEventHandler, Event, EventHandler
from rosbook.launch.launcher import (
    Action,
    InvalidLaunchFileError,
    LaunchDescription,
    LaunchDescriptionEntity,
    LaunchDescriptionSource,
    LaunchIntrospector,
    LaunchService,
    SomeEntitiesType,
    SomeEntitiesType_types_tuple,
)
from rosbook.launch.substitutions import (
    Condition,
    LaunchContext,
    SomeSubstitutionsType,
    SomeSubstitutionsType_types_tuple,
    Substitution,
)

__all__ = [
    "Action",
    "BaseEventHandler",
    "Condition",
    "Event",
    "EventHandler",
    "InvalidLaunchFileError",
    "LaunchContext",
    "LaunchDescription",
    "LaunchDescriptionEntity",
    "LaunchDescriptionSource",
    "LaunchIntrospector",
    "LaunchService",
    "SomeEntitiesType",
    "SomeEntitiesType_types_tuple",
    "SomeSubstitutionsType",
    "SomeSubstitutionsType_types_tuple",
    "Substitution",
    "actions",
    "conditions",
    "descriptions",
    "event_handlers",
    "events",
    "frontend",
    "launch_description_sources",
    "logging",
    "substitutions",
    "utilities",
]
