"""``ros2 interface show | list | packages | package | proto``, worded as upstream's
(ros2cli jazzy)."""

from __future__ import annotations

import argparse
import sys

from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import interfaces

#: The kinds of interface, each with the option that asks for it alone and its title.
KINDS = (
    ("msg", "only_msgs", "Messages"),
    ("srv", "only_srvs", "Services"),
    ("action", "only_actions", "Actions"),
)


class ReadStdinPipe(argparse.Action):
    """A positional that reads its value from stdin's first line when given as ``-``
    (``ros2 topic type /chatter | ros2 interface show -``), as upstream's."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        text = str(values)
        if text == "-":
            if sys.stdin.isatty():
                parser.error("expected stdin pipe")
            text = sys.stdin.readline().strip()
        if not text:
            parser.error("the passed value is empty")
        setattr(namespace, self.dest, text)


def _add_kind_options(parser: argparse.ArgumentParser, action: str = "store_true") -> None:
    for flag, kind in (("-m", "msgs"), ("-s", "srvs"), ("-a", "actions")):
        parser.add_argument(
            flag, f"--only-{kind}", action=action, help=f"Print out only the {kind}"
        )


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("interface", help="Message, service and action definitions")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = commands.add_parser("show", help="Output the interface definition")
    comments = p.add_mutually_exclusive_group()
    comments.add_argument(
        "--all-comments",
        action="store_true",
        help="Show all comments, including for nested interface definitions",
    )
    comments.add_argument(
        "--no-comments", action="store_true", help="Show no comments or whitespace"
    )
    p.add_argument(
        "type",
        action=ReadStdinPipe,
        help="Show an interface definition (e.g. 'example_interfaces/msg/String'). Passing "
        "'-' reads the argument from stdin (e.g. 'ros2 topic type /chatter | ros2 interface "
        "show -').",
    )
    p.set_defaults(func=show)

    p = commands.add_parser("list", help="List all interface types available")
    _add_kind_options(p)
    p.set_defaults(func=list_interfaces)

    p = commands.add_parser("packages", help="Output a list of packages that provide interfaces")
    _add_kind_options(p, action="count")
    p.set_defaults(func=list_packages)

    p = commands.add_parser(
        "package", help="Output a list of available interface types within one package"
    )
    _add_kind_options(p)
    p.add_argument("package_name", help="Package name")
    p.set_defaults(func=package)

    p = commands.add_parser("proto", help="Output an interface prototype")
    p.add_argument(
        "type", help="Show an interface definition (e.g. 'example_interfaces/msg/String')"
    )
    p.add_argument("--no-quotes", action="store_true", help="if true output has no outer quotes.")
    p.set_defaults(func=proto)


def _wanted(args: argparse.Namespace) -> list[str]:
    """The kinds asked for by ``-m``/``-s``/``-a``; all three when none is given."""
    asked = [kind for kind, option, _ in KINDS if getattr(args, option)]
    return asked or [kind for kind, _, _ in KINDS]


def _of_kind(package: str, kind: str) -> list[str]:
    return [name for name in interfaces.interfaces(package) if name.split("/")[1] == kind]


@reports_errors
def show(args: argparse.Namespace) -> int:
    package, kind, name = interfaces.split_type(args.type)  # or a one-line error
    prefix = interfaces.package_prefix(package)
    if prefix is None:
        return fail(f"Unknown package '{package}'")
    try:
        text = interfaces.show(
            args.type, comments=not args.no_comments, nested_comments=args.all_comments
        )
    except interfaces.InterfaceError:
        idl = prefix / "share" / package / kind / f"{name}.idl"
        return fail(f"Could not find the interface '{idl}'")
    print(text)
    return 0


def list_interfaces(args: argparse.Namespace) -> int:
    """Upstream's blocks: ``Messages:``, ``Services:``, ``Actions:``, one indented name a line."""
    packages = interfaces.packages()
    for kind, _, title in KINDS:
        if kind in _wanted(args):
            print(f"{title}:")
            for package in packages:
                for name in _of_kind(package, kind):
                    print(f"    {name}")
    return 0


def list_packages(args: argparse.Namespace) -> int:
    """The packages that provide interfaces (of the first kind asked for, as upstream)."""
    kind = _wanted(args)[0] if len(_wanted(args)) < len(KINDS) else None
    for package in interfaces.packages():
        if kind is None or _of_kind(package, kind):
            print(package)
    return 0


@reports_errors
def package(args: argparse.Namespace) -> int:
    if interfaces.package_prefix(args.package_name) is None:
        return fail(f"Unknown package '{args.package_name}'")
    wanted = _wanted(args)
    found = [n for n in interfaces.interfaces(args.package_name) if n.split("/")[1] in wanted]
    print(*found, sep="\n")
    return 0


@reports_errors
def proto(args: argparse.Namespace) -> int:
    """A default instance as YAML (a service's request, an action's goal), quoted unless
    ``--no-quotes``, as upstream prints it."""
    interface = interfaces.message_class(args.type)
    for part in ("Goal", "Request"):
        interface = getattr(interface, part, interface)
    text = interfaces.to_yaml(interface()) + "\n"
    print(text if args.no_quotes else f'"{text}"')
    return 0
