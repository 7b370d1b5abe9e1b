"""nbgrader configuration of the course (the one place it is set).

The grader and ``make labs`` load this file. nbgrader run by hand reads
``nbgrader_config.py`` from its working folder: run it from a course root that holds
a copy of this file (``solutions/`` and ``labs/`` are then relative to that root).
"""

c = get_config()  # type: ignore[name-defined]  # noqa: F821 (provided by traitlets)

# solutions/<lab>/<lab>.ipynb is the instructor's source, labs/<lab>/<lab>.ipynb the release.
c.CourseDirectory.source_directory = "solutions"
c.CourseDirectory.release_directory = "labs"
c.CourseDirectory.course_id = "ros2-course-book"

c.ClearSolutions.code_stub = {"python": "# YOUR CODE HERE\nraise NotImplementedError()"}
c.ClearSolutions.text_stub = "YOUR ANSWER HERE"

# A student cell that never returns is interrupted after this many seconds; the
# notebook goes on with the next cell (the grader's --timeout overrides it).
c.Execute.timeout = 30
c.Execute.interrupt_on_timeout = True
c.Execute.allow_errors = True
# A cell's last output may come late (a flood of output, an interrupted cell stopping:
# a spin that waits for its next event, a launch shutting down): keep grading the next
# cells instead of abandoning the notebook (nbgrader's default raises after 4 s). An
# interrupted cell is given the cell limit once more to stop, and a cell still running
# then is the last one run (autograder.kernels.CappedExecute).
c.Execute.raise_on_iopub_timeout = False
c.Execute.iopub_timeout = 10

# A test cell the student deleted is put back (and the submission marked tampered).
c.OverwriteCells.add_missing_cells = True

# Feedback never shows hidden tests: their source is removed, and a failing test
# cell shows only its error message, not a traceback through hidden lines.
c.GenerateFeedback.preprocessors = [
    "nbgrader.preprocessors.GetGrades",
    "nbgrader.preprocessors.ClearHiddenTests",
    "autograder.feedback.ShortenTestTracebacks",
    "nbconvert.preprocessors.CSSHTMLHeaderPreprocessor",
]

# Kernels talk to the grader over Unix sockets, not TCP ports on localhost: two kernels
# starting at once cannot race for a port, and ipykernel does not warn about
# unencrypted TCP (autograder/kernels.py).
c.Execute.kernel_manager_class = "autograder.kernels.IpcKernelManager"

# Autograding runs every kernel sandboxed (the manager above) and keeps a bounded
# amount of each cell's output (autograder/kernels.py: CappedExecute).
c.Autograde.autograde_preprocessors = [
    "autograder.kernels.CappedExecute",
    "nbgrader.preprocessors.IgnorePattern",
    "nbconvert.preprocessors.ClearMetadataPreprocessor",
    "nbgrader.preprocessors.LimitOutput",
    "nbgrader.preprocessors.SaveAutoGrades",
    "nbgrader.preprocessors.AssignLatePenalties",
    "nbgrader.preprocessors.CheckCellMetadata",
]
