"""Command line: ``python -m autograder {grade,labs,check} ...``."""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from autograder.config import LABS, lab_ids


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m autograder", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    g = sub.add_parser("grade", help="grade a folder of submissions")
    g.add_argument("submissions", type=Path, help="SUBMISSIONS/<student>/<lab>/<lab>.ipynb")
    g.add_argument("--assignment", help="grade only this lab (default: every lab found)")
    g.add_argument("--workers", type=int, default=2, help="submissions graded at once")
    g.add_argument("--out", type=Path, default=Path("grading"), help="where results go")
    g.add_argument(
        "--timeout", type=int, default=30, help="seconds one cell may run before it is interrupted"
    )
    g.add_argument(
        "--submission-timeout",
        type=float,
        default=600.0,
        help="seconds one submission may take in all before it is stopped",
    )

    labs = sub.add_parser("labs", help="regenerate labs/ from solutions/")
    labs.add_argument("ids", nargs="*", help="labs to regenerate (default: all)")

    c = sub.add_parser("check", help="run a lab notebook's visible checks")
    c.add_argument("notebook", type=Path, help="a lab notebook, or a lab id")
    c.add_argument("--timeout", type=int, default=30, help="seconds per cell")

    args = parser.parse_args(argv)
    if args.command == "grade":
        from autograder.grade import STATUSES, GradingError, grade_class

        try:
            rows = grade_class(
                args.submissions,
                args.out,
                args.assignment,
                args.workers,
                args.timeout,
                args.submission_timeout,
            )
        except GradingError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        for row in rows:
            print(
                f"{row.student_id:<20} {row.assignment_id:<24} "
                f"{row.score:g}/{row.max_score:g}  {row.status}"
            )
        counts = ", ".join(f"{sum(r.status == s for r in rows)} {s}" for s in STATUSES)
        print(f"{len(rows)} submissions graded ({counts}); see {args.out / 'grades.csv'}")
        return 0
    if args.command == "labs":
        from autograder.course import release_lab

        for lab in args.ids or lab_ids():
            with tempfile.TemporaryDirectory() as tmp:
                print(f"generated {release_lab(lab, Path(tmp)).relative_to(LABS.parent)}")
        return 0
    from autograder.check import check, report

    path = args.notebook
    if not path.exists() and (LABS / str(path) / f"{path}.ipynb").exists():
        path = LABS / str(path) / f"{path}.ipynb"
    if not path.is_file():
        print(f"error: no notebook at {path}", file=sys.stderr)
        return 2
    results, changed, flagged = check(path.resolve(), args.timeout)
    print(report(path, results, changed, flagged))
    return 0 if results and all(r.passed for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
