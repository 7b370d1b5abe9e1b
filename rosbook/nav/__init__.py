"""Finding the way on the 2D simulator: a map from ``scan`` and ``odom`` (``grid``), a
planner on it (``planner``), what a run measured (``metrics``) and the nodes (``nodes``)."""
