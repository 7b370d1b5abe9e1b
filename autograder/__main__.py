"""Command line: ``python -m autograder {grade,labs,check} ...``."""

from __future__ import annotations

import argparse
import shlex
import signal
import sys
import tempfile
from pathlib import Path

from autograder.config import CELL_TIMEOUT_S, LABS, SOLUTIONS, lab_ids


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m autograder", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    g = sub.add_parser(
        "grade",
        help="grade a folder of submissions",
        description="Grade a folder of submissions into OUT/grades.csv. Before the first "
        "submission it checks that a sandboxed kernel starts here and imports the project "
        "(`python -m autograder preflight`), and stops with the cause and the fix if not. "
        "A row's status: ok, timeout, error (the notebook failed: the student's), missing, "
        "tampered, or grader_error (the grader failed before any cell ran, e.g. its "
        "sandbox did not start: never the student's; --resume grades it again).",
    )
    g.add_argument("submissions", type=Path, help="SUBMISSIONS/<student>/<lab>/<lab>.ipynb")
    g.add_argument("--assignment", help="grade only this lab (default: every lab found)")
    g.add_argument("--workers", type=int, default=2, help="submissions graded at once")
    g.add_argument("--out", type=Path, default=Path("grading"), help="where results go")
    g.add_argument(
        "--timeout",
        type=int,
        default=CELL_TIMEOUT_S,
        help="seconds one cell may run before it is interrupted",
    )
    g.add_argument(
        "--submission-timeout",
        type=float,
        default=600.0,
        help="seconds one submission may take in all before it is stopped",
    )
    g.add_argument(
        "--resume",
        action="store_true",
        help="keep the rows already in OUT whose notebook is unchanged; grade the rest",
    )
    g.add_argument(
        "--student",
        action="append",
        metavar="ID[,ID...]",
        help="regrade only these students (repeatable, or a comma list); other rows are kept",
    )
    g.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="grade on the workers of this Dask scheduler (tcp://host:8786) instead of here "
        "(--workers is then ignored: each Dask worker grades --nthreads at once)",
    )

    labs = sub.add_parser("labs", help="regenerate labs/ from solutions/")
    labs.add_argument("ids", nargs="*", help="labs to regenerate (default: all)")
    labs.add_argument(
        "--solutions",
        type=Path,
        default=SOLUTIONS,
        help="the instructor's source folder (default: solutions/)",
    )

    c = sub.add_parser("check", help="run a lab notebook's visible checks")
    c.add_argument("notebook", type=Path, help="a lab notebook, or a lab id")
    c.add_argument("--timeout", type=int, default=CELL_TIMEOUT_S, help="seconds per cell")
    c.add_argument("--log", type=Path, help="where the nodes' log lines go")

    pre = sub.add_parser(
        "preflight", help="check that a sandboxed kernel can start here and import the project"
    )
    pre.add_argument(
        "--unsandboxed", action="store_true", help="check an unsandboxed kernel (make lab's)"
    )

    args = parser.parse_args(argv)
    if args.command == "preflight":
        seconds = ready(sandboxed=not args.unsandboxed)
        if seconds is None:
            return 2
        print(f"preflight: kernels can start here and import the project ({seconds:.1f} s)")
        return 0
    if args.command == "grade":
        return grade(args, argv if argv is not None else sys.argv[1:])
    if args.command == "labs":
        return labs_command(args.ids or lab_ids(args.solutions), args.solutions)
    from autograder.check import check, report

    path = args.notebook
    if not path.exists() and (LABS / str(path) / f"{path}.ipynb").exists():
        path = LABS / str(path) / f"{path}.ipynb"
    if not path.is_file():
        print(f"error: no notebook at {path}", file=sys.stderr)
        return 2
    # The preflight (a sandboxed probe) runs only when the kernel could not run the
    # notebook: it then says why (the machine's, never the student's), and make check,
    # the student's edit loop, is not slowed by a probe on every run.
    try:
        run = check(path.resolve(), args.timeout, args.log)
    except Exception:
        if ready() is None:
            return 2
        raise
    if run.died and ready() is None:
        return 2
    print(report(path, run))
    return 0 if run.passed else 1


def ready(sandboxed: bool = True) -> float | None:
    """Run the preflight (``autograder.preflight``): its seconds, or None once its one
    message is printed."""
    from autograder import preflight

    try:
        return preflight.check(sandboxed=sandboxed)
    except preflight.NotReady as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None


def labs_command(ids: list[str], solutions: Path) -> int:
    """Regenerate ``labs/`` for ``ids``; none is released if a test cell of any of them
    has no check in the judge (each such cell is named, with why)."""
    from autograder.course import UnjudgedLab, refuse_unjudged, release_lab

    refused = []
    for lab in ids:
        try:
            refuse_unjudged(lab, solutions)
        except UnjudgedLab as exc:
            refused += str(exc).splitlines()
        except FileNotFoundError:
            refused.append(f"{lab}: no notebook {solutions / lab / (lab + '.ipynb')}")
    if refused:
        for line in refused:
            print(f"error: {line}", file=sys.stderr)
        print(
            "error: a test cell the judge cannot decide would score nothing when graded; "
            "add its check (CONTRIBUTING.md: Adding a lab). Nothing was generated.",
            file=sys.stderr,
        )
        return 1
    for lab in ids:
        with tempfile.TemporaryDirectory() as tmp:
            released = release_lab(lab, Path(tmp), solutions=solutions)
            print(f"generated {released.relative_to(LABS.parent)}")
    return 0


def grade(args: argparse.Namespace, argv: list[str]) -> int:
    from autograder.grade import STATUSES, GradingError, Interrupted, grade_class
    from autograder.preflight import NotReady

    students = [s for value in args.student or [] for s in value.split(",") if s.strip()]
    # Ctrl-C, and SIGTERM (a scheduler, a closed session), stop cleanly, rows kept; also
    # when started from a shell that had SIGINT ignored (a background job in a script).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        rows = grade_class(
            args.submissions,
            args.out,
            args.assignment,
            args.workers,
            args.timeout,
            args.submission_timeout,
            resume=args.resume,
            students=[s.strip() for s in students],
            scheduler=args.scheduler,
        )
    except (GradingError, NotReady) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except Interrupted as exc:
        again = ["python", "-m", "autograder", *argv]
        if "--resume" not in again:
            again.append("--resume")
        print(
            f"\nstopped: {exc.done} of {exc.total} submission(s) graded in this run; every "
            f"finished row is saved in {args.out}. To grade the rest:\n  {shlex.join(again)}",
            file=sys.stderr,
        )
        return 130
    for row in rows:
        if row.status != "ok":
            print(
                f"{row.student_id:<20} {row.assignment_id:<24} "
                f"{row.score:g}/{row.max_score:g}  {row.status}"
            )
    counts = ", ".join(f"{sum(r.status == s for r in rows)} {s}" for s in STATUSES)
    print(f"{len(rows)} submissions graded ({counts}); see {args.out / 'grades.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
