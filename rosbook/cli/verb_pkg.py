"""``ros2 pkg create | list | executables | prefix | xml``: packages of the ament index.

``create`` scaffolds an ``ament_python`` or ``ament_cmake`` package with the same files as
the real command; the other sub-verbs read the ament index on ``AMENT_PREFIX_PATH`` (and the
venv, which plays ``/opt/ros/jazzy`` here).
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET

from rosbook.cli.reporting import fail
from rosbook.launch import workspace

#: What upstream's ``ros2 pkg`` verbs answer for a package not in the ament index.
PACKAGE_NOT_FOUND = "Package not found"


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("pkg", help="Various package related sub-commands")
    sub = parser.add_subparsers(dest="pkg_verb", required=True, metavar="VERB")

    create = sub.add_parser("create", help="Create a new ROS 2 package")
    create.add_argument("package_name", help="The package name")
    create.add_argument(
        "--package-format",
        "--package_format",
        default="3",
        choices=["3"],
        help="The package.xml format (upstream also writes format 2)",
    )
    create.add_argument("--description", default="TODO: Package description")
    create.add_argument("--license", default="TODO: License declaration")
    create.add_argument("--destination-directory", default=".")
    create.add_argument("--build-type", default="ament_cmake")
    create.add_argument("--dependencies", nargs="+", default=[])
    create.add_argument("--maintainer-email")
    create.add_argument("--maintainer-name")
    create.add_argument("--node-name", help="name of the empty executable")
    create.add_argument(
        "--library-name",
        help="name of the empty library (a C++ build type's: a Python package has none)",
    )
    create.set_defaults(func=create_main)

    listing = sub.add_parser("list", help="Output a list of available packages")
    listing.set_defaults(func=list_main)

    exes = sub.add_parser("executables", help="Output a list of package specific executables")
    exes.add_argument("package_name", nargs="?", help="The package name")
    exes.add_argument("--full-path", action="store_true", help="Output the full path")
    exes.set_defaults(func=executables_main)

    prefix = sub.add_parser("prefix", help="Output the prefix path of a package")
    prefix.add_argument("package_name", help="The package name")
    prefix.add_argument("--share", action="store_true", help="Show share directory for the package")
    prefix.set_defaults(func=prefix_main)

    xml = sub.add_parser("xml", help="Output the XML of the package manifest or a specific tag")
    xml.add_argument("package_name", help="The package name")
    xml.add_argument("-t", "--tag", help="The XML tag to output (e.g. 'version')")
    xml.set_defaults(func=xml_main)


def create_main(args: argparse.Namespace) -> int:
    node_name = args.node_name
    if node_name and node_name == args.library_name:  # as upstream
        node_name += "_node"
        print("[WARNING] node name can not be equal to the library name", file=sys.stderr)
        print(f"[WARNING] renaming node to {node_name}", file=sys.stderr)
    try:
        workspace.create_package(
            args.package_name,
            args.destination_directory,
            build_type=args.build_type,
            dependencies=args.dependencies,
            node_name=node_name,
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
        prefix = workspace.package_prefix(args.package_name)
    except LookupError:
        return fail(PACKAGE_NOT_FOUND)
    print(prefix / "share" / args.package_name if args.share else prefix)
    return 0


def xml_main(args: argparse.Namespace) -> int:
    """The package's ``package.xml`` as the XML parser reads it (no comments), or the
    text of each ``--tag`` element under its root; upstream's words when absent."""
    try:
        manifest = workspace.package_prefix(args.package_name) / "share" / args.package_name
    except LookupError:
        return fail(PACKAGE_NOT_FOUND)
    manifest /= "package.xml"
    if not manifest.is_file():
        return fail("Package XML manifest not found")
    try:
        tree = ET.parse(manifest)
    except ET.ParseError as error:
        return fail(f"{manifest}: {error}")
    if args.tag is None:
        ET.dump(tree)
        return 0
    elements = tree.getroot().findall(args.tag)
    if not elements:
        return fail("XML tag not found")
    for element in elements:
        print(element.text)
    return 0
