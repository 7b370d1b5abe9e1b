"""The course's grader: isolated, parallel nbgrader autograding of real rclpy code."""
