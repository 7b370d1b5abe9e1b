"""The chapters' experiments (``qos``) and demo nodes to try the ``ros2`` verbs on (``nodes``)."""
