"""The course's grader: isolated, parallel nbgrader autograding of real rclpy code."""

import sys

# jsonschema (under nbformat and nbgrader) imports rfc3987_syntax when it is installed
# (JupyterLab's jupyter-events asks for it), and that compiles a Lark grammar at import:
# 1.2 s of every grading process's start, for IRI format checks the grader never makes.
# A missing module is what jsonschema expects without it (its format checker skips them).
sys.modules.setdefault("rfc3987_syntax", None)  # type: ignore[arg-type]
