"""``ros2 pkg create | list | executables | prefix``: packages of the ament index.

``create`` scaffolds an ``ament_python`` package with the same files as the real
command; the other sub-verbs read the ament index on ``AMENT_PREFIX_PATH`` (and the
venv, which plays ``/opt/ros/jazzy`` here).
"""

from __future__ import annotations

import argparse

from rosbook.cli.reporting import fail
from rosbook.launch import workspace

#: What upstream's ``ros2 pkg`` verbs answer for a package not in the ament index.
PACKAGE_NOT_FOUND = "Package not found"


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("pkg", help="Various package related sub-commands")
    sub = parser.add_subparsers(dest="pkg_verb", required=True, metavar="VERB")

    create = sub.add_parser("create", help="Create a new ROS 2 package")
    create.add_argument("package_name", help="The package name")
    create.add_argument("--package-format", default="3", choices=["3"])
    create.add_argument("--description", default="TODO: Package description")
    create.add_argument("--license", default="TODO: License declaration")
    create.add_argument("--destination-directory", default=".")
    create.add_argument("--build-type", default="ament_cmake")
    create.add_argument("--dependencies", nargs="+", default=[])
    create.add_argument("--maintainer-email")
    create.add_argument("--maintainer-name")
    create.add_argument("--node-name")
    create.set_defaults(func=create_main)

    listing = sub.add_parser("list", help="Output a list of available packages")
    listing.set_defaults(func=list_main)

    exes = sub.add_parser("executables", help="Output a list of package specific executables")
    exes.add_argument("package_name", nargs="?", help="The package name")
    exes.add_argument("--full-path", action="store_true", help="Output the full path")
    exes.set_defaults(func=executables_main)

    prefix = sub.add_parser("prefix", help="Output the prefix path of a package")
    prefix.add_argument("package_name", help="The package name")
    prefix.set_defaults(func=prefix_main)


def create_main(args: argparse.Namespace) -> int:
    try:
        workspace.create_package(
            args.package_name,
            args.destination_directory,
            build_type=args.build_type,
            dependencies=args.dependencies,
            node_name=args.node_name,
            description=args.description,
            license=args.license,
            maintainer_name=args.maintainer_name,
            maintainer_email=args.maintainer_email,
        )
    except (ValueError, FileExistsError) as error:
        return fail(str(error))
    return 0


def list_main(args: argparse.Namespace) -> int:
    for name in sorted(workspace.packages()):
        print(name)
    return 0


def executables_main(args: argparse.Namespace) -> int:
    names = [args.package_name] if args.package_name else sorted(workspace.packages())
    for package in names:
        try:
            found = workspace.executables(package)
            prefix = workspace.package_prefix(package)
        except LookupError:
            return fail(PACKAGE_NOT_FOUND)
        for exe in found:
            print(prefix / "lib" / package / exe if args.full_path else f"{package} {exe}")
    return 0


def prefix_main(args: argparse.Namespace) -> int:
    try:
        print(workspace.package_prefix(args.package_name))
    except LookupError:
        return fail(PACKAGE_NOT_FOUND)
    return 0
