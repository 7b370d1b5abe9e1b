"""The course server: JupyterHub with each student's JupyterLab sandboxed (``make hub``).

Hosting, apart from grading: ``coursehub`` uses the grader's sandbox and course settings
(``autograder.sandbox``, ``autograder.cgroups``, ``autograder/nbgrader_config.py``);
nothing of ``autograder`` imports ``coursehub``.
"""
