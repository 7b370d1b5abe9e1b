"""The ROS runtime: the notebook session, executors, domain isolation, the graph,
interfaces, services, actions and parameters. It imports nothing else of rosbook."""
